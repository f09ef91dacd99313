// The page in VR, in headless Chromium with the iwer WebXR emulator (a Meta Quest 3 with its
// Touch Plus controllers) against the real `rigfit serve`: a controller trace draws with the
// trigger, the grip moves the character, thumbsticks run commands, and the input layer's own
// recording of it replays through window.rigfit.replay.

import { after, before, describe, test } from 'node:test';
import assert from 'node:assert/strict';
import { readFileSync } from 'node:fs';
import { createRequire } from 'node:module';
import { join } from 'node:path';
import { artifacts, distance, launchBrowser, openPage, settle, startServer } from './support.mjs';

const require = createRequire(import.meta.url);
const trace = JSON.parse(readFileSync(new URL('./fixtures/xr-raise-left-arm.json', import.meta.url)));

/** iwer's browser build, then a Quest 3 installed as navigator.xr before the page's scripts. */
const emulator = [
  { path: require.resolve('iwer/build/iwer.min.js') },
  `window.xrDevice = new IWER.XRDevice(IWER.metaQuest3);
   window.xrDevice.installRuntime({ forceInstall: true });`,
];

const joints = (page) => page.evaluate(() => window.rigfit.joints());
const maxJointMove = (a, b) => Math.max(...Object.keys(a).map((name) => distance(a[name], b[name])));

describe('the page in VR (iwer)', () => {
  let server;
  let browser;
  let page;
  let errors;
  let rest;
  let tipOffset; // page tip position minus the emulated controller's position
  let drawn; // joints after the controller stroke
  let recorded; // the input layer's record of it

  /** Lets the emulated device run a few XR frames. */
  const frames = (n = 2) => page.waitForTimeout(20 * n);
  const controller = (hand, fn, ...args) =>
    page.evaluate(([hand, fn, args]) => window.xrDevice.controllers[hand][fn](...args), [hand, fn, args]);
  /** Puts the `hand` controller's tip at a page-space point. */
  const tipTo = (hand, p) =>
    page.evaluate(([hand, p]) => window.xrDevice.controllers[hand].position.set(...p), [
      hand,
      p.map((x, k) => x - tipOffset[k]),
    ]);

  before(async () => {
    server = await startServer();
    browser = await launchBrowser();
    ({ page, errors } = await openPage(browser, server.url, { init: emulator }));
    rest = await joints(page);
  });

  after(async () => {
    await browser?.close();
    await server?.stop();
  });

  test('offers Enter VR with the emulated headset, enters, draws the controllers from local assets', async () => {
    assert.equal(await page.isVisible('#enter-vr'), true);
    await page.click('#enter-vr');
    await page.waitForFunction(() => window.rigfit.xr.presenting && window.rigfit.xr.tips.right, null, {
      timeout: 30000,
    });
    await page.evaluate(() => window.xrDevice.controllers.right.position.set(0, 1, 0));
    await frames(3);
    const tip = await page.evaluate(() => window.rigfit.xr.tips.right);
    tipOffset = [tip[0], tip[1] - 1, tip[2]];
    // Standing in front of the character, facing it.
    const origin = await page.evaluate(() => window.rigfit.xr.origin);
    assert.ok(origin[2] > rest.Hips[2] + 1, `user at ${origin}`);
    assert.deepEqual(errors, []); // profile assets came from this origin (anything else is an error)
  });

  test('a controller trace with the trigger held poses the arm', async () => {
    const shoulder = rest.LeftArm;
    const end = trace.samples.filter((s) => s.trigger).at(-1).offset.map((x, k) => shoulder[k] + x);
    await page.evaluate(() => window.rigfit.startRecording());
    for (const sample of trace.samples) {
      await tipTo(trace.hand, sample.offset.map((x, k) => shoulder[k] + x));
      await controller(trace.hand, 'updateButtonValue', 'trigger', sample.trigger);
      await frames(1);
    }
    await frames(3);
    await settle(page);
    recorded = await page.evaluate(() => window.rigfit.stopRecording());
    drawn = await joints(page);
    const strokes = await page.evaluate(() => window.rigfit.strokes());
    assert.equal(strokes.length, 1);
    assert.ok(strokes[0].length >= 10, `${strokes[0].length} points`);
    const before = distance(rest.LeftHand, end);
    const after = distance(drawn.LeftHand, end);
    assert.ok(after < 0.4 * before, `hand to stroke end: ${before} -> ${after}`);
    assert.deepEqual(
      [...new Set(recorded.map((a) => a.type))].sort(),
      ['strokeBegin', 'strokeEnd', 'strokePoint'],
    );
    await page.screenshot({ path: join(artifacts, 'xr-view.png') });
  });

  test('right thumbstick left undoes the stroke; replaying the recorded trace draws it again', async () => {
    await controller('right', 'updateAxes', 'thumbstick', -1, 0);
    await frames(3);
    await controller('right', 'updateAxes', 'thumbstick', 0, 0);
    await frames(3);
    await settle(page);
    assert.equal((await page.evaluate(() => window.rigfit.strokes())).length, 0);
    assert.ok(maxJointMove(await joints(page), rest) < 1e-6, 'undo: back to the rest pose');

    // Without its timestamps the trace replays at one point per 16 ms.
    const untimed = recorded.map(({ t, ...action }) => action);
    await page.evaluate((t) => window.rigfit.replay(t), untimed);
    await settle(page);
    assert.equal((await page.evaluate(() => window.rigfit.strokes())).length, 1);
    const again = await joints(page);
    assert.ok(maxJointMove(again, drawn) < 0.01, `replayed pose differs by ${maxJointMove(again, drawn)}`);
  });

  test('left thumbstick keys the pose and steps the frame', async () => {
    await controller('left', 'updateAxes', 'thumbstick', 0, 1); // down: insert key
    await frames(3);
    await controller('left', 'updateAxes', 'thumbstick', 0, 0);
    await frames(3);
    assert.deepEqual(await page.evaluate(() => window.rigfit.keys()), [0]);
    await controller('left', 'updateAxes', 'thumbstick', 1, 0); // right: next frame
    await frames(3);
    await controller('left', 'updateAxes', 'thumbstick', 0, 0);
    await frames(3);
    assert.equal(await page.evaluate(() => window.rigfit.frame), 1);
  });

  test('the grip grabs the character and moves it with the hand', async () => {
    const before = await joints(page);
    const placement = (await page.evaluate(() => window.rigfit.characters))[0].placement.position;
    await tipTo('right', before.Hips);
    await frames(3);
    await controller('right', 'updateButtonValue', 'squeeze', 1);
    await frames(3);
    for (let i = 1; i <= 10; i++) {
      await tipTo('right', [before.Hips[0] + 0.05 * i, before.Hips[1], before.Hips[2] - 0.02 * i]);
      await frames(1);
    }
    await frames(3);
    await controller('right', 'updateButtonValue', 'squeeze', 0);
    await frames(3);
    const moved = (await page.evaluate(() => window.rigfit.characters))[0].placement.position;
    assert.ok(Math.abs(moved[0] - placement[0] - 0.5) < 0.02, `x ${placement[0]} -> ${moved[0]}`);
    assert.ok(Math.abs(moved[2] - placement[2] + 0.2) < 0.02, `z ${placement[2]} -> ${moved[2]}`);
    const after = await joints(page);
    assert.ok(Math.abs(after.LeftHand[0] - before.LeftHand[0] - 0.5) < 0.02, 'the pose moved along');
    await page.screenshot({ path: join(artifacts, 'xr-after-grab.png') });
    assert.deepEqual(errors, []);
  });
});
