// A stand-in for `rigfit serve` with canned data, for working on the page without the Rust
// server: node web/tests/mock-server.mjs [--port P]. It keeps to docs/serve-api.md closely
// enough for the page (static files, characters, a skeleton-only model.glb, a crude CCD solve,
// an export that returns JSON); the tests run against the real server, not this.

import { createServer } from 'node:http';
import { readFile } from 'node:fs/promises';
import { extname, join, normalize } from 'node:path';
import { fileURLToPath } from 'node:url';
import * as THREE from '../vendor/three/build/three.module.js';

const web = fileURLToPath(new URL('..', import.meta.url));

const HUMANOID = [
  ['Hips', '', [0, 0.95, 0]], ['Spine', 'Hips', [0, 0.1, 0]], ['Chest', 'Spine', [0, 0.18, 0]],
  ['Neck', 'Chest', [0, 0.22, 0]], ['Head', 'Neck', [0, 0.1, 0]], ['HeadTop', 'Head', [0, 0.2, 0]],
  ['LeftShoulder', 'Chest', [0.04, 0.18, 0]], ['LeftArm', 'LeftShoulder', [0.14, 0, 0]],
  ['LeftForeArm', 'LeftArm', [0.28, 0, 0]], ['LeftHand', 'LeftForeArm', [0.25, 0, 0]],
  ['LeftHandTip', 'LeftHand', [0.17, 0, 0]], ['RightShoulder', 'Chest', [-0.04, 0.18, 0]],
  ['RightArm', 'RightShoulder', [-0.14, 0, 0]], ['RightForeArm', 'RightArm', [-0.28, 0, 0]],
  ['RightHand', 'RightForeArm', [-0.25, 0, 0]], ['RightHandTip', 'RightHand', [-0.17, 0, 0]],
  ['LeftUpLeg', 'Hips', [0.09, -0.03, 0]], ['LeftLeg', 'LeftUpLeg', [0, -0.42, 0]],
  ['LeftFoot', 'LeftLeg', [0, -0.42, 0]], ['LeftToeBase', 'LeftFoot', [0, -0.06, 0.12]],
  ['LeftToeTip', 'LeftToeBase', [0, 0, 0.07]], ['RightUpLeg', 'Hips', [-0.09, -0.03, 0]],
  ['RightLeg', 'RightUpLeg', [0, -0.42, 0]], ['RightFoot', 'RightLeg', [0, -0.42, 0]],
  ['RightToeBase', 'RightFoot', [0, -0.06, 0.12]], ['RightToeTip', 'RightToeBase', [0, 0, 0.07]],
];

const trs = (t, r = [0, 0, 0, 1], s = [1, 1, 1]) => ({ translation: t, rotation: r, scale: s });

function worldMatrices(joints, pose) {
  const out = [];
  joints.forEach((j, i) => {
    const local = new THREE.Matrix4().compose(
      new THREE.Vector3(...pose[i].translation),
      new THREE.Quaternion(...pose[i].rotation),
      new THREE.Vector3(...(pose[i].scale ?? [1, 1, 1])),
    );
    out[i] = j.parent === null ? local : out[j.parent].clone().multiply(local);
  });
  return out;
}

function describe(c) {
  const world = worldMatrices(c.joints, c.pose);
  const ys = world.map((m) => m.elements[13]);
  return {
    id: c.id,
    name: c.name,
    format: c.format,
    height: Math.max(...ys) - Math.min(...ys),
    joints: c.joints.map((j, i) => ({
      name: j.name,
      parent: j.parent,
      kind: j.kind,
      node: i,
      rest: c.rest[i],
      pose: c.pose[i],
      position: new THREE.Vector3().setFromMatrixPosition(world[i]).toArray(),
    })),
  };
}

/** A GLB of nodes only (the skeleton), node i = joint i. */
function skeletonGlb(c) {
  const nodes = c.joints.map((j, i) => ({
    name: j.name,
    translation: c.pose[i].translation,
    rotation: c.pose[i].rotation,
    children: c.joints.flatMap((k, n) => (k.parent === i ? [n] : [])),
  }));
  for (const n of nodes) if (n.children.length === 0) delete n.children;
  const json = { asset: { version: '2.0' }, scene: 0, scenes: [{ nodes: [0] }], nodes };
  let text = Buffer.from(JSON.stringify(json));
  text = Buffer.concat([text, Buffer.alloc((4 - (text.length % 4)) % 4, 0x20)]);
  const header = Buffer.alloc(20);
  header.writeUInt32LE(0x46546c67, 0);
  header.writeUInt32LE(2, 4);
  header.writeUInt32LE(20 + text.length, 8);
  header.writeUInt32LE(text.length, 12);
  header.writeUInt32LE(0x4e4f534a, 16);
  return Buffer.concat([header, text]);
}

const characters = [];
function addHumanoid(name = 'humanoid') {
  const joints = HUMANOID.map(([n, parent], i) => ({
    name: n,
    parent: parent ? HUMANOID.findIndex((j) => j[0] === parent) : null,
    kind: /Tip$/.test(n) ? 'end_site' : 'skin',
    index: i,
  }));
  const rest = HUMANOID.map(([, , t]) => trs(t));
  characters.push({ id: `c${characters.length}`, name, format: 'glb', joints, rest, pose: structuredClone(rest) });
}
addHumanoid();

/** Crude CCD: the chain from the joint nearest each stroke's start to a leaf reaches its end. */
function solve(c, request) {
  const pose = c.joints.map((j, i) => {
    const given = request.pose?.joints?.find((p) => p.name === j.name);
    return given ? trs(given.translation, given.rotation) : structuredClone(c.pose[i]);
  });
  for (const stroke of request.strokes ?? []) {
    const pts = stroke.points.map((p) => new THREE.Vector3(...p));
    const world = worldMatrices(c.joints, pose);
    const pos = world.map((m) => new THREE.Vector3().setFromMatrixPosition(m));
    let start = 0;
    pos.forEach((p, i) => {
      if (p.distanceTo(pts[0]) < pos[start].distanceTo(pts[0])) start = i;
    });
    const chain = [start];
    for (;;) {
      const child = c.joints.findIndex((j) => j.parent === chain[chain.length - 1]);
      if (child < 0) break;
      chain.push(child);
    }
    const goal = pts[pts.length - 1];
    for (let iteration = 0; iteration < 10; iteration++) {
      for (let k = chain.length - 2; k >= 0; k--) {
        const w = worldMatrices(c.joints, pose);
        const at = (i) => new THREE.Vector3().setFromMatrixPosition(w[i]);
        const joint = at(chain[k]);
        const a = at(chain[chain.length - 1]).sub(joint).normalize();
        const b = goal.clone().sub(joint).normalize();
        const worldRot = new THREE.Quaternion().setFromUnitVectors(a, b);
        const jointWorld = new THREE.Quaternion().setFromRotationMatrix(w[chain[k]]);
        const local = new THREE.Quaternion(...pose[chain[k]].rotation);
        const next = jointWorld.clone().invert().multiply(worldRot).multiply(jointWorld);
        pose[chain[k]].rotation = local.multiply(next).normalize().toArray();
      }
    }
  }
  const world = worldMatrices(c.joints, pose);
  return {
    joints: c.joints.map((j, i) => ({
      name: j.name,
      parent: j.parent === null ? null : c.joints[j.parent].name,
      position: new THREE.Vector3().setFromMatrixPosition(world[i]).toArray(),
      rotation: pose[i].rotation,
      translation: pose[i].translation,
    })),
    strokes: (request.strokes ?? []).map(() => ({ bones: [] })),
    iterations: 10,
    energy: 0,
    seconds: 0.001,
  };
}

const TYPES = { '.html': 'text/html', '.js': 'text/javascript', '.css': 'text/css', '.json': 'application/json', '.glb': 'model/gltf-binary' };

async function body(req) {
  const chunks = [];
  for await (const chunk of req) chunks.push(chunk);
  return Buffer.concat(chunks);
}

function send(res, status, data, type = 'application/json', headers = {}) {
  res.writeHead(status, { 'Content-Type': type, ...headers });
  res.end(typeof data === 'string' || Buffer.isBuffer(data) ? data : JSON.stringify(data));
}

const server = createServer(async (req, res) => {
  const url = new URL(req.url, 'http://localhost');
  const path = url.pathname;
  try {
    if (req.method === 'GET' && (path === '/' || path.startsWith('/app/') || path.startsWith('/vendor/'))) {
      const file = normalize(join(web, path === '/' ? 'index.html' : path));
      if (!file.startsWith(web)) return send(res, 404, { error: 'not found' });
      return send(res, 200, await readFile(file), TYPES[extname(file)] ?? 'application/octet-stream');
    }
    if (path === '/api/characters' && req.method === 'GET') {
      return send(res, 200, { characters: characters.map(describe) });
    }
    if (path === '/api/characters' && req.method === 'POST') {
      await body(req);
      addHumanoid(url.searchParams.get('name') ?? 'upload');
      return send(res, 201, describe(characters[characters.length - 1]));
    }
    const m = /^\/api\/characters\/([^/]+)(?:\/(model\.glb|solve|export))?$/.exec(path);
    const c = m && characters.find((x) => x.id === m[1]);
    if (!c) return send(res, 404, { error: `no such path ${path}` });
    if (!m[2]) return send(res, 200, describe(c));
    if (m[2] === 'model.glb') return send(res, 200, skeletonGlb(c), 'model/gltf-binary');
    const request = JSON.parse((await body(req)).toString() || '{}');
    if (m[2] === 'solve') {
      if (!request.strokes?.length) return send(res, 422, { error: 'solve: no strokes' });
      return send(res, 200, solve(c, request));
    }
    return send(res, 200, JSON.stringify(request), 'application/octet-stream', {
      'Content-Disposition': `attachment; filename="${c.name}.${request.format}"`,
    });
  } catch (error) {
    send(res, 400, { error: error.message });
  }
});

const portArg = process.argv.indexOf('--port');
server.listen(portArg > 0 ? Number(process.argv[portArg + 1]) : 0, '127.0.0.1', () => {
  console.log(`rigfit serve: http://127.0.0.1:${server.address().port}/`);
});
