// Shared by the browser tests: start `rigfit serve` (or the mock), launch Debian's Chromium
// through playwright-core, open the page, and small helpers over window.rigfit.

import { spawn } from 'node:child_process';
import { existsSync, mkdirSync, mkdtempSync, readFileSync, rmSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { join } from 'node:path';
import { fileURLToPath } from 'node:url';
import { chromium } from 'playwright-core';

export const root = fileURLToPath(new URL('../..', import.meta.url));
export const artifacts = join(root, 'target', 'web-artifacts');
mkdirSync(artifacts, { recursive: true });
export const rigfitBinary = process.env.RIGFIT_BIN ?? join(root, 'target', 'debug', 'rigfit');
export const dataDir = process.env.RIGFIT_DATA ?? join(root, '..', 'shared', 'data');

/**
 * Starts `rigfit serve --port 0` (RIGFIT_MOCK=1: the node mock instead) and reads its address
 * from the first stdout line. Returns { url, stop() }.
 */
export async function startServer(args = []) {
  const command = process.env.RIGFIT_MOCK
    ? [process.execPath, [join(root, 'web', 'tests', 'mock-server.mjs'), '--port', '0']]
    : [rigfitBinary, ['serve', ...args, '--port', '0']];
  const child = spawn(command[0], command[1], { stdio: ['ignore', 'pipe', 'pipe'] });
  let stderr = '';
  child.stderr.on('data', (d) => {
    stderr += d;
  });
  const url = await new Promise((resolve, reject) => {
    let out = '';
    const timer = setTimeout(() => reject(new Error(`rigfit serve printed no address in 30 s: ${stderr}`)), 30000);
    child.stdout.on('data', (d) => {
      out += d;
      const line = out.split('\n')[0];
      if (out.includes('\n')) {
        clearTimeout(timer);
        const m = /^rigfit serve: (http:\/\/[^ ]+\/)$/.exec(line.trim());
        if (m) resolve(m[1]);
        else reject(new Error(`unexpected first line: ${line}`));
      }
    });
    child.on('exit', (code) => {
      clearTimeout(timer);
      reject(new Error(`rigfit serve exited with ${code}: ${stderr}`));
    });
  });
  return {
    url,
    stderr: () => stderr,
    stop: () =>
      new Promise((resolve) => {
        if (child.exitCode !== null) return resolve();
        child.once('exit', resolve);
        child.kill('SIGTERM');
      }),
  };
}

/** Headless Debian Chromium with a software WebGL (SwiftShader), loopback only. */
export async function launchBrowser() {
  const executablePath = process.env.CHROMIUM ?? '/usr/bin/chromium';
  if (!existsSync(executablePath)) throw new Error(`no Chromium at ${executablePath} (scripts/test-web.sh installs it)`);
  const userDataDir = mkdtempSync(join(tmpdir(), 'rigfit-chromium-'));
  const context = await chromium.launchPersistentContext(userDataDir, {
    executablePath,
    headless: true,
    viewport: { width: 1280, height: 800 },
    acceptDownloads: true,
    args: [
      '--headless',
      '--no-sandbox',
      '--disable-gpu',
      '--disable-quic',
      '--no-first-run',
      '--disable-background-networking',
      '--disable-component-update',
      '--disable-sync',
      '--use-gl=angle',
      '--use-angle=swiftshader',
      '--enable-unsafe-swiftshader',
    ],
  });
  // Closing the browser also removes its profile folder.
  const close = context.close.bind(context);
  context.close = async (...args) => {
    try {
      await close(...args);
    } finally {
      rmSync(userDataDir, { recursive: true, force: true });
    }
  };
  return context;
}

/**
 * Opens the page in a new tab; fails on page errors. `init`: scripts run before the page's
 * own (e.g. the WebXR emulator). Returns { page, errors }.
 */
export async function openPage(context, url, { init = [] } = {}) {
  const page = await context.newPage();
  const errors = [];
  page.on('pageerror', (e) => errors.push(`page error: ${e.message}`));
  page.on('console', (m) => {
    if (m.type() === 'error') errors.push(`console: ${m.text()}`);
  });
  // Only the serving origin: anything else is a bug (the page must not fetch from the network).
  const origin = new URL(url).origin;
  await page.route('**/*', (route) => {
    const u = route.request().url();
    const path = u.startsWith(origin) ? new URL(u).pathname : null;
    if (process.env.RIGFIT_WEB_FROM_DISK && path !== null && (path === '/' || path.startsWith('/app/'))) {
      // Working on the page: its files from web/ rather than those built into the binary.
      const file = join(root, 'web', path === '/' ? 'index.html' : path);
      const type = { html: 'text/html', css: 'text/css', js: 'text/javascript' }[file.split('.').pop()];
      return route.fulfill({ body: readFileSync(file), contentType: type });
    }
    if (u.startsWith(origin) || u.startsWith('data:') || u.startsWith('blob:')) return route.continue();
    errors.push(`network request off the origin: ${u}`);
    return route.abort();
  });
  for (const script of init) await page.addInitScript(script);
  await page.goto(url);
  await page.waitForFunction(() => window.rigfit && document.body.dataset.ready === 'true', null, {
    timeout: 60000,
  });
  return { page, errors };
}

export const distance = (a, b) => Math.hypot(a[0] - b[0], a[1] - b[1], a[2] - b[2]);

/** Waits until the page has no solve in flight and is idle. */
export async function settle(page) {
  await page.evaluate(() => window.rigfit.idle());
  await page.waitForFunction(() => window.rigfit.status === 'idle');
}

/** Canvas pixel of a page-space point, as page.mouse coordinates. */
export async function screenOf(page, point) {
  return page.evaluate((p) => {
    const [x, y] = window.rigfit.project(p);
    const r = window.rigfit.canvasRect();
    return [r.left + x, r.top + y];
  }, point);
}

/** Draws a stroke with real mouse events through page-space points (projected by the page). */
export async function drawStroke(page, points, steps = 2) {
  const screen = [];
  for (const p of points) screen.push(await screenOf(page, p));
  await page.mouse.move(screen[0][0], screen[0][1]);
  await page.mouse.down();
  for (const s of screen.slice(1)) await page.mouse.move(s[0], s[1], { steps });
  await page.mouse.up();
  await settle(page);
}
