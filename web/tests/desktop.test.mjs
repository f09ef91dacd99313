// The page on the desktop, in headless Chromium against the real `rigfit serve`: draw with the
// mouse, undo, clear, reset, keys and playback, export, and open a second character.

import { after, before, describe, test } from 'node:test';
import assert from 'node:assert/strict';
import { execFileSync } from 'node:child_process';
import { existsSync, mkdtempSync, readFileSync, rmSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { join } from 'node:path';
import {
  artifacts,
  dataDir,
  distance,
  drawStroke,
  launchBrowser,
  openPage,
  rigfitBinary,
  screenOf,
  settle,
} from './support.mjs';
import { startServer } from './support.mjs';

/** Page-space points of a stroke from `from` along `direction` (page units), `n` segments. */
function line(from, direction, n = 16) {
  return Array.from({ length: n + 1 }, (_, i) => from.map((x, k) => x + (direction[k] * i) / n));
}

const joints = (page, id) => page.evaluate((id) => window.rigfit.joints(id), id);
const maxJointMove = (a, b) => Math.max(...Object.keys(a).map((name) => distance(a[name], b[name])));

describe('the page on the desktop', () => {
  let server;
  let browser;
  let page;
  let errors;
  let rest;
  let scale; // page units per file unit of the humanoid
  let raised; // joints after the raised-arm stroke
  let armStroke;

  before(async () => {
    server = await startServer();
    browser = await launchBrowser();
    ({ page, errors } = await openPage(browser, server.url));
  });

  after(async () => {
    await browser?.close();
    await server?.stop();
  });

  test('loads the built-in humanoid: model, skeleton, status line, no error', async () => {
    const characters = await page.evaluate(() => window.rigfit.characters);
    assert.equal(characters.length, 1);
    assert.equal(characters[0].id, 'c0');
    assert.ok(characters[0].hasModel, 'model.glb loaded');
    assert.ok(characters[0].joints.includes('LeftHand'));
    assert.equal(await page.evaluate(() => window.rigfit.selected), 'c0');
    assert.equal(await page.evaluate(() => window.rigfit.status), 'idle');
    assert.match(await page.textContent('#status'), /idle.*humanoid.*frame 0/);
    // No Enter VR button without WebXR.
    assert.equal(await page.isVisible('#enter-vr'), false);
    rest = await joints(page);
    scale = characters[0].placement.scale;
    // WebGL really draws: the canvas is not one flat colour.
    const shot = await page.locator('#view').screenshot({ path: join(artifacts, 'desktop-before.png') });
    assert.ok(shot.length > 20000, `screenshot of ${shot.length} bytes looks empty`);
    assert.deepEqual(errors, []);
  });

  test('a mouse stroke over the raised-arm line poses the arm live, and on release', async () => {
    // Up and out from the left shoulder: the arm raised about 70 degrees.
    armStroke = line(rest.LeftArm, [0.2 * scale, 0.65 * scale, 0]);
    const end = armStroke[armStroke.length - 1];
    const screen = [];
    for (const p of armStroke) screen.push(await screenOf(page, p));
    await page.mouse.move(...screen[0]);
    await page.mouse.down();
    for (const s of screen.slice(1, 10)) await page.mouse.move(s[0], s[1], { steps: 2 });
    assert.equal(await page.evaluate(() => window.rigfit.status), 'drawing');
    // Live: the pose follows while the button is still down.
    await page.waitForFunction(
      ([hand]) => {
        const h = window.rigfit.joints().LeftHand;
        return Math.hypot(h[0] - hand[0], h[1] - hand[1], h[2] - hand[2]) > 0.05;
      },
      [rest.LeftHand],
      { timeout: 20000 },
    );
    assert.equal(await page.evaluate(() => window.rigfit.status), 'drawing');
    for (const s of screen.slice(10)) await page.mouse.move(s[0], s[1], { steps: 2 });
    await page.mouse.up();
    await settle(page);
    raised = await joints(page);
    const strokes = await page.evaluate(() => window.rigfit.strokes());
    assert.equal(strokes.length, 1);
    assert.ok(strokes[0].length >= 10, `${strokes[0].length} stroke points`);
    const before = distance(rest.LeftHand, end);
    const afterDrawing = distance(raised.LeftHand, end);
    assert.ok(afterDrawing < 0.4 * before, `hand to stroke end: ${before} -> ${afterDrawing}`);
    assert.ok(raised.LeftHand[1] > rest.LeftArm[1] + 0.3 * scale, 'the hand is above the shoulder');
    // The root stays (solves leave it fixed by default), so do the legs.
    for (const name of ['Hips', 'LeftFoot', 'RightFoot']) {
      assert.ok(distance(raised[name], rest[name]) < 0.01 * scale, `${name} moved`);
    }
    // The cursor marker shows where the next stroke lands.
    await page.mouse.move(screen[4][0] + 60, screen[4][1]);
    await page.locator('#view').screenshot({ path: join(artifacts, 'desktop-after-drawing.png') });
  });

  test('undo removes the last stroke and solves again; the first undo returns the pose', async () => {
    // A second stroke: the right arm raised forward.
    await drawStroke(page, line(rest.RightArm, [-0.3 * scale, 0.5 * scale, 0.3 * scale]));
    const two = await joints(page);
    assert.equal((await page.evaluate(() => window.rigfit.strokes())).length, 2);
    assert.ok(distance(two.RightHand, rest.RightHand) > 0.15 * scale, 'the right arm moved');
    await page.keyboard.press('z');
    await settle(page);
    const one = await joints(page);
    assert.equal((await page.evaluate(() => window.rigfit.strokes())).length, 1);
    assert.ok(maxJointMove(one, raised) < 0.02 * scale, `undo: pose of one stroke back (${maxJointMove(one, raised)})`);
    await page.click('button[data-command="undo"]');
    await settle(page);
    assert.equal((await page.evaluate(() => window.rigfit.strokes())).length, 0);
    assert.ok(maxJointMove(await joints(page), rest) < 1e-6, 'undoing every stroke: the pose they were drawn on');
  });

  test('clear removes the strokes and keeps the pose; reset brings the rest pose back', async () => {
    await drawStroke(page, armStroke);
    const posed = await joints(page);
    assert.ok(distance(posed.LeftHand, rest.LeftHand) > 0.2 * scale);
    await page.keyboard.press('c');
    assert.equal((await page.evaluate(() => window.rigfit.strokes())).length, 0);
    assert.ok(maxJointMove(await joints(page), posed) < 1e-9, 'clear keeps the pose');
    await page.click('button[data-command="reset"]');
    assert.ok(maxJointMove(await joints(page), rest) < 1e-6, 'reset: the rest pose');
  });

  test('keys at two frames, stepping between them interpolates, play and stop', async () => {
    await page.keyboard.press('i'); // key frame 0: rest
    for (let i = 0; i < 12; i++) await page.keyboard.press('ArrowRight');
    assert.equal(await page.evaluate(() => window.rigfit.frame), 12);
    assert.match(await page.textContent('#status'), /frame 12.*not keyed/);
    await drawStroke(page, armStroke);
    const keyed = await joints(page);
    await page.click('button[data-command="key"]');
    assert.deepEqual(await page.evaluate(() => window.rigfit.keys()), [0, 12]);
    assert.match(await page.textContent('#status'), /frame 12.*◆ keyed/);
    assert.equal(await page.locator('#timeline .key').count(), 2);

    for (let i = 0; i < 6; i++) await page.keyboard.press('ArrowLeft');
    assert.equal(await page.evaluate(() => window.rigfit.frame), 6);
    const middle = await joints(page);
    const span = distance(rest.LeftHand, keyed.LeftHand);
    assert.ok(distance(middle.LeftHand, rest.LeftHand) > 0.2 * span, 'frame 6 is not frame 0');
    assert.ok(distance(middle.LeftHand, keyed.LeftHand) > 0.2 * span, 'frame 6 is not frame 12');
    await page.keyboard.press('Shift+ArrowLeft');
    assert.equal(await page.evaluate(() => window.rigfit.frame), 0);
    assert.ok(maxJointMove(await joints(page), rest) < 1e-6, 'frame 0: the first key');

    await page.keyboard.press('Space');
    assert.equal(await page.evaluate(() => window.rigfit.playing), true);
    const seen = new Set();
    for (let i = 0; i < 20; i++) {
      seen.add(await page.evaluate(() => window.rigfit.frame));
      await page.waitForTimeout(40);
    }
    assert.ok(seen.size >= 4, `playback visited frames ${[...seen]}`);
    await page.click('button[data-command="play"]');
    assert.equal(await page.evaluate(() => window.rigfit.playing), false);
    await page.keyboard.press('Shift+ArrowRight');
    await page.keyboard.press('Shift+ArrowRight');
    assert.equal(await page.evaluate(() => window.rigfit.frame), 12);
    await page.locator('body').screenshot({ path: join(artifacts, 'desktop-keyed.png') });
  });

  test('exports the posed, keyed character as .glb and .bvh; rigfit info reads them back', async () => {
    const dir = mkdtempSync(join(tmpdir(), 'rigfit-web-export-'));
    try {
      for (const [button, ext] of [
        ['export-glb', 'glb'],
        ['export-bvh', 'bvh'],
      ]) {
        const [download] = await Promise.all([
          page.waitForEvent('download', { timeout: 30000 }),
          page.click(`button[data-command="${button}"]`),
        ]);
        assert.match(download.suggestedFilename(), new RegExp(`\\.${ext}$`));
        const file = join(dir, `exported.${ext}`);
        await download.saveAs(file);
        assert.ok(readFileSync(file).length > 100);
        const info = execFileSync(rigfitBinary, ['info', file], { encoding: 'utf8' });
        if (ext === 'glb') {
          assert.match(info, /^\s*rigfit: 0\.500 s, 2 frames/m, info);
        } else {
          assert.match(info, /13 frames/, info);
        }
      }
    } finally {
      rmSync(dir, { recursive: true, force: true });
    }
    assert.match(await page.textContent('#status'), /exported/);
  });

  test('opens a real asset through the file picker: two characters side by side', async () => {
    const asset = join(dataDir, 'assimp', 'BCN_Epileptic.glb');
    assert.ok(existsSync(asset), `${asset} (set RIGFIT_DATA)`);
    const [chooser] = await Promise.all([
      page.waitForEvent('filechooser'),
      page.click('button[data-command="open"]'),
    ]);
    await chooser.setFiles(asset);
    await page.waitForFunction(() => window.rigfit.characters.length === 2, null, { timeout: 60000 });
    const characters = await page.evaluate(() => window.rigfit.characters);
    assert.equal(characters[1].name.replace(/\.glb$/, ''), 'BCN_Epileptic');
    assert.ok(characters[1].hasModel);
    assert.equal(await page.evaluate(() => window.rigfit.selected), characters[1].id);
    const [a, b] = [await joints(page, 'c0'), await joints(page, characters[1].id)];
    const right = (j) => Math.min(...Object.values(j).map((p) => p[0]));
    const left = (j) => Math.max(...Object.values(j).map((p) => p[0]));
    assert.ok(right(b) > left(a), 'the new character stands to the right of the first');

    // Strokes are per character: the new one has none, the humanoid keeps its keys.
    assert.deepEqual(await page.evaluate((id) => window.rigfit.strokes(id), characters[1].id), []);
    assert.deepEqual(await page.evaluate(() => window.rigfit.keys('c0')), [0, 12]);

    // Pose the new character too: raise its left arm.
    const arm = Object.keys(b).find((n) => /upper_?arm_?l|left_?(upper_?)?arm/i.test(n));
    assert.ok(arm, `a left arm among ${Object.keys(b)}`);
    const height = Math.max(...Object.values(b).map((p) => p[1])) - Math.min(...Object.values(b).map((p) => p[1]));
    // (Longer than the whole arm: rigfit's solver leaves a stroke shorter than the chain it
    // would match unmatched.)
    const answers = [];
    const onSolve = (r) => {
      if (r.url().endsWith('/solve')) answers.push(r.json());
    };
    page.on('response', onSolve);
    await drawStroke(page, line(b[arm], [0.15 * height, 0.42 * height, 0]));
    page.off('response', onSolve);
    const answer = await answers.at(-1);
    // What the page shows is the solver's pose: joints where the server's report puts them.
    const shown = await page.evaluate((id) => window.rigfit.joints(id, 'file'), characters[1].id);
    for (const j of answer.joints) {
      assert.ok(distance(j.position, shown[j.name]) < 1e-6, `${j.name}: ${j.position} shown at ${shown[j.name]}`);
    }
    const posed = await joints(page, characters[1].id);
    assert.ok(
      maxJointMove(posed, b) > 0.05 * height,
      'the new character moved',
    );
    for (const [name, p] of Object.entries(posed)) {
      if (/hip|knee|ankle|toe|pelvis|foot|leg/i.test(name)) assert.ok(distance(p, b[name]) < 0.02 * height, `${name} moved`);
    }
    assert.equal((await page.evaluate((id) => window.rigfit.strokes(id), characters[1].id)).length, 1);

    // Select with Tab and by clicking the other character.
    await page.keyboard.press('Tab');
    assert.equal(await page.evaluate(() => window.rigfit.selected), 'c0');
    await page.mouse.click(...(await screenOf(page, b[arm])));
    assert.equal(await page.evaluate(() => window.rigfit.selected), characters[1].id);
    await page.locator('#view').screenshot({ path: join(artifacts, 'desktop-two-characters.png') });
    assert.deepEqual(errors, []);
  });

  test('the move gizmo drags the selected character without drawing a stroke', async () => {
    await page.keyboard.press('Tab'); // back to the humanoid
    assert.equal(await page.evaluate(() => window.rigfit.selected), 'c0');
    const strokes = (await page.evaluate(() => window.rigfit.strokes())).length;
    await page.keyboard.press('g');
    const placement = () => page.evaluate(() => window.rigfit.characters[0].placement.position);
    const before = await placement();
    const at = await screenOf(page, before);
    await page.mouse.move(at[0], at[1]);
    await page.mouse.down();
    for (let i = 1; i <= 10; i++) await page.mouse.move(at[0] + 8 * i, at[1]);
    await page.mouse.up();
    const after = await placement();
    assert.ok(after[0] > before[0] + 0.1, `placement x ${before[0]} -> ${after[0]}`);
    assert.equal((await page.evaluate(() => window.rigfit.strokes())).length, strokes, 'no stroke drawn');
    await page.keyboard.press('Escape');
    assert.deepEqual(errors, []);
  });

  test('a pen and a finger draw too (pointer events of every kind)', async () => {
    const cdp = await page.context().newCDPSession(page);
    const strokes = async () => (await page.evaluate(() => window.rigfit.strokes())).length;
    const start = await strokes();
    const arm = (await joints(page)).LeftArm;
    const screen = [];
    for (const p of line(arm, [0.2 * scale, 0.65 * scale, 0], 8)) screen.push(await screenOf(page, p));

    const pen = (type, [x, y]) =>
      cdp.send('Input.dispatchMouseEvent', {
        type,
        x,
        y,
        button: 'left',
        buttons: type === 'mouseReleased' ? 0 : 1,
        clickCount: 1,
        pointerType: 'pen',
      });
    await pen('mousePressed', screen[0]);
    for (const s of screen.slice(1)) await pen('mouseMoved', s);
    await pen('mouseReleased', screen.at(-1));
    await settle(page);
    assert.equal(await strokes(), start + 1, 'pen stroke');

    const touch = (type, [x, y]) =>
      cdp.send('Input.dispatchTouchEvent', { type, touchPoints: type === 'touchEnd' ? [] : [{ x, y, id: 1 }] });
    await touch('touchStart', screen[0]);
    for (const s of screen.slice(1)) await touch('touchMove', s);
    await touch('touchEnd', screen.at(-1));
    await settle(page);
    assert.equal(await strokes(), start + 2, 'touch stroke');
    assert.ok((await page.evaluate(() => window.rigfit.lastActions)).includes('strokeEnd'));
    await cdp.detach();
    assert.deepEqual(errors, []);
  });
});
