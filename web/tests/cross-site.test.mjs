// Another site's page, open in the same browser as the sketching page, cannot drive the local
// `rigfit serve`: its requests without a preflight (a text/plain upload, a no-cors solve) are
// refused by the server's Origin and Content-Type checks, and those that need a preflight are
// never sent. Both sites are on 127.0.0.1, on different ports (different origins).

import { after, before, describe, test } from 'node:test';
import assert from 'node:assert/strict';
import { createServer } from 'node:http';
import { launchBrowser, startServer } from './support.mjs';

const BVH = [
  'HIERARCHY',
  'ROOT Hips',
  '{',
  ' OFFSET 0 0 0',
  ' CHANNELS 3 Zrotation Xrotation Yrotation',
  ' End Site',
  ' {',
  '  OFFSET 0 -1 0',
  ' }',
  '}',
  'MOTION',
  'Frames: 1',
  'Frame Time: 0.04',
  '0 0 0',
  '',
].join('\n');

describe('another site cannot drive the server', () => {
  let server;
  let browser;
  let evil;

  before(async () => {
    server = await startServer();
    browser = await launchBrowser();
    evil = createServer((req, res) => {
      res.writeHead(200, { 'Content-Type': 'text/html' });
      res.end('<!doctype html><title>another site</title><p>nothing to see</p>');
    });
    await new Promise((resolve) => evil.listen(0, '127.0.0.1', resolve));
  });

  after(async () => {
    await browser?.close();
    await server?.stop();
    await new Promise((resolve) => evil?.close(resolve));
  });

  test('simple and preflighted requests from another origin change nothing', async () => {
    const page = await browser.newPage();
    await page.goto(`http://127.0.0.1:${evil.address().port}/`);
    const outcome = await page.evaluate(
      async ({ target, bvh }) => {
        const tried = async (url, init) => {
          try {
            const response = await fetch(url, init);
            return response.type === 'opaque' ? 'sent' : `answered ${response.status}`;
          } catch {
            return 'blocked';
          }
        };
        return {
          // Simple requests: the browser sends them without asking.
          plainUpload: await tried(`${target}api/characters?name=evil.bvh`, {
            method: 'POST',
            mode: 'no-cors',
            body: bvh,
          }),
          plainSolve: await tried(`${target}api/characters/c0/solve`, {
            method: 'POST',
            mode: 'no-cors',
            body: JSON.stringify({ strokes: [{ points: [[0, 1, 0], [0.3, 1, 0]] }] }),
          }),
          plainDelete: await tried(`${target}api/characters/c0`, { method: 'DELETE', mode: 'no-cors' }),
          // A request with the server's content type needs a preflight, which is not granted.
          upload: await tried(`${target}api/characters?name=evil.bvh`, {
            method: 'POST',
            headers: { 'Content-Type': 'application/octet-stream' },
            body: bvh,
          }),
          read: await tried(`${target}api/characters`, {}),
        };
      },
      { target: server.url, bvh: BVH },
    );
    assert.equal(outcome.upload, 'blocked', JSON.stringify(outcome));
    assert.equal(outcome.read, 'blocked', JSON.stringify(outcome));
    // Nothing was uploaded or deleted: the server holds only the humanoid, as it started.
    const list = await (await fetch(`${server.url}api/characters`)).json();
    assert.deepEqual(
      list.characters.map((c) => c.id),
      ['c0'],
      JSON.stringify(outcome),
    );
    // The same upload from a script with no Origin (curl-like) and the right type works.
    const direct = await fetch(`${server.url}api/characters?name=direct.bvh`, {
      method: 'POST',
      headers: { 'Content-Type': 'application/octet-stream' },
      body: BVH,
    });
    assert.equal(direct.status, 201);
    await page.close();
  });
});
