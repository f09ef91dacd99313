// One character on the page: its joints and poses (from the server), its model and skeleton as
// drawn, its strokes and keys. Everything below `placement` is in the character's file space
// (glTF scene world space / BVH file space); `placement` puts it on the page (move, rotate, and
// a uniform scale that shows every character at the same height).

import * as THREE from 'three';
import { clonePose, poseFromCharacter } from './pose.js';

/** Every character is shown this tall on the page, whatever its file's units. */
export const PAGE_HEIGHT = 1.75;

const SIDE_COLOURS = { left: 0x4fa3ff, right: 0xff6b5e, centre: 0xf2d45c, helper: 0x9aa0a8 };
const STROKE_COLOUR = 0x38e1a0;
const DRAWING_COLOUR = 0xffffff;

/** A Blender-like octahedral bone, from its head at the origin to its tail at (0, 1, 0). */
function boneGeometry() {
  const w = 0.09;
  const h = 0.18;
  const v = [
    [0, 0, 0],
    [w, h, 0],
    [0, h, w],
    [-w, h, 0],
    [0, h, -w],
    [0, 1, 0],
  ];
  const faces = [
    [0, 2, 1], [0, 3, 2], [0, 4, 3], [0, 1, 4],
    [5, 1, 2], [5, 2, 3], [5, 3, 4], [5, 4, 1],
  ];
  const g = new THREE.BufferGeometry();
  g.setAttribute('position', new THREE.Float32BufferAttribute(faces.flat().flatMap((i) => v[i]), 3));
  g.computeVertexNormals();
  return g;
}

/**
 * How a character's mesh is shown. A file without materials gets a grey clay (glTF's default
 * material is fully metallic, which is black without an environment map); a material without
 * a metalness texture is made non-metallic for the same reason.
 */
function displayMaterial(material, json) {
  if (!json.materials?.length) {
    return new THREE.MeshStandardMaterial({ color: 0xb4b8c0, roughness: 0.7, metalness: 0 });
  }
  for (const m of Array.isArray(material) ? material : [material]) {
    if (m.isMeshStandardMaterial && !m.metalnessMap) m.metalness = Math.min(m.metalness, 0.1);
  }
  return material;
}

function sideOf(joint) {
  if (joint.kind === 'helper') return 'helper';
  if (/left|(^|[^a-z])l([^a-z]|$)/i.test(joint.name)) return 'left';
  if (/right|(^|[^a-z])r([^a-z]|$)/i.test(joint.name)) return 'right';
  return 'centre';
}

export class Character {
  /** `info`: the server's CHARACTER. */
  constructor(info) {
    this.id = info.id;
    this.name = info.name;
    this.format = info.format;
    this.joints = info.joints;
    this.restPose = poseFromCharacter(info.joints, 'rest');
    this.storedPose = poseFromCharacter(info.joints, 'pose');
    this.pose = clonePose(this.storedPose);
    /** The pose the current strokes were drawn on: every solve starts from it. */
    this.strokeBasePose = null;
    /** [{ points: [[x, y, z], ...] }] in file space, oldest first. */
    this.strokes = [];
    /** [{ frame, pose }] sorted by frame. */
    this.keys = [];
    /** Bumped whenever strokes or pose change under a solve in flight (its answer is then dropped). */
    this.generation = 0;

    const stored = info.joints.map((j) => new THREE.Vector3(...j.position));
    const box = new THREE.Box3().setFromPoints(stored);
    this.height = info.height > 0 ? info.height : Math.max(box.max.y - box.min.y, 1e-6);
    this.filePositions = stored;
    /** Without a model (or for joints without a node): where the root's parent frame is. */
    this.rootFrame = new THREE.Matrix4();
    const root = info.joints.findIndex((j) => j.parent === null);
    if (root >= 0) {
      const t = this.storedPose[root].translation;
      this.rootFrame.makeTranslation(stored[root].x - t[0], stored[root].y - t[1], stored[root].z - t[2]);
    }

    this.placement = new THREE.Group();
    this.placement.name = `character ${this.id}`;
    this.placement.scale.setScalar(PAGE_HEIGHT / this.height);
    this.model = null;
    this.nodes = info.joints.map(() => null);
    this.buildSkeletonView();
    this.strokeView = new THREE.Group();
    this.strokeView.name = 'strokes';
    this.placement.add(this.strokeView);
    this.applyPose(this.pose);
  }

  /** Loads the display GLB and finds the node each joint drives (by glTF node index). */
  async loadModel(loader, url) {
    const gltf = await loader.loadAsync(url);
    const byIndex = new Map();
    gltf.scene.traverse((object) => {
      const association = gltf.parser.associations.get(object);
      if (association?.nodes !== undefined && !byIndex.has(association.nodes)) {
        byIndex.set(association.nodes, object);
      }
      if (object.isSkinnedMesh) object.frustumCulled = false;
      if (object.isMesh) object.material = displayMaterial(object.material, gltf.parser.json);
    });
    this.nodes = this.joints.map((j) => (j.node === undefined || j.node === null ? null : (byIndex.get(j.node) ?? null)));
    this.model = gltf.scene;
    this.model.name = 'model';
    this.placement.add(this.model);
    this.applyPose(this.pose);
  }

  buildSkeletonView() {
    const n = this.joints.length;
    const boneMaterial = new THREE.MeshBasicMaterial({
      depthTest: false,
      transparent: true,
      opacity: 0.9,
    });
    const jointMaterial = boneMaterial.clone();
    this.bones = new THREE.InstancedMesh(boneGeometry(), boneMaterial, n);
    this.jointBalls = new THREE.InstancedMesh(new THREE.SphereGeometry(1, 12, 8), jointMaterial, n);
    const colour = new THREE.Color();
    this.joints.forEach((j, i) => {
      colour.setHex(SIDE_COLOURS[sideOf(j)]);
      this.bones.setColorAt(i, colour);
      this.jointBalls.setColorAt(i, colour);
    });
    for (const mesh of [this.bones, this.jointBalls]) {
      mesh.renderOrder = 10;
      mesh.frustumCulled = false;
    }
    this.skeletonView = new THREE.Group();
    this.skeletonView.name = 'skeleton';
    this.skeletonView.add(this.bones, this.jointBalls);
    this.placement.add(this.skeletonView);
  }

  /** Shows a pose: moves the model's nodes and the skeleton, recomputes joint positions. */
  applyPose(pose) {
    this.pose = pose;
    const local = this.joints.map((_, i) =>
      new THREE.Matrix4().compose(
        new THREE.Vector3(...pose[i].translation),
        new THREE.Quaternion(...pose[i].rotation),
        new THREE.Vector3(...pose[i].scale),
      ),
    );
    this.joints.forEach((_, i) => {
      const node = this.nodes[i];
      if (!node) return;
      node.position.fromArray(pose[i].translation);
      node.quaternion.fromArray(pose[i].rotation);
      node.scale.fromArray(pose[i].scale);
    });
    if (this.model) this.model.updateMatrixWorld(true);

    // File-space matrix of each joint: its node's matrix up to the model root, or (no node) its
    // parent joint's matrix times its own local transform.
    const fileMatrix = [];
    const relativeToModel = (node) => {
      const m = node.matrix.clone();
      for (let p = node.parent; p && p !== this.model; p = p.parent) m.premultiply(p.matrix);
      return m;
    };
    this.joints.forEach((j, i) => {
      if (this.nodes[i]) {
        fileMatrix[i] = relativeToModel(this.nodes[i]);
      } else {
        const parent = j.parent === null ? this.rootFrame : fileMatrix[j.parent];
        fileMatrix[i] = parent.clone().multiply(local[i]);
      }
      this.filePositions[i] = new THREE.Vector3().setFromMatrixPosition(fileMatrix[i]);
    });
    this.updateSkeletonView();
  }

  updateSkeletonView() {
    const ball = this.height * 0.011;
    const m = new THREE.Matrix4();
    const up = new THREE.Vector3(0, 1, 0);
    const q = new THREE.Quaternion();
    const hidden = new THREE.Matrix4().makeScale(0, 0, 0);
    this.joints.forEach((j, i) => {
      const p = this.filePositions[i];
      const r = j.kind === 'end_site' ? ball * 0.6 : ball;
      this.jointBalls.setMatrixAt(i, m.compose(p, q.identity(), new THREE.Vector3(r, r, r)));
      if (j.parent === null) {
        this.bones.setMatrixAt(i, hidden);
        return;
      }
      const head = this.filePositions[j.parent];
      const along = p.clone().sub(head);
      const length = along.length();
      if (length < 1e-9) {
        this.bones.setMatrixAt(i, hidden);
        return;
      }
      q.setFromUnitVectors(up, along.divideScalar(length));
      this.bones.setMatrixAt(i, m.compose(head, q, new THREE.Vector3(length, length, length)));
    });
    this.bones.instanceMatrix.needsUpdate = true;
    this.jointBalls.instanceMatrix.needsUpdate = true;
  }

  /** Brighter when selected. */
  setSelected(selected) {
    this.bones.material.opacity = selected ? 0.95 : 0.35;
    this.jointBalls.material.opacity = selected ? 0.95 : 0.35;
  }

  /** Page-space positions of the joints at the shown pose. */
  worldPositions() {
    this.placement.updateMatrixWorld(true);
    return this.filePositions.map((p) => p.clone().applyMatrix4(this.placement.matrixWorld));
  }

  /** A page-space point in this character's file space. */
  fileFromPage(point) {
    this.placement.updateMatrixWorld(true);
    const inverse = this.placement.matrixWorld.clone().invert();
    return new THREE.Vector3(...point).applyMatrix4(inverse);
  }

  /** Page-space bounding box of the joints. */
  worldBox() {
    return new THREE.Box3().setFromPoints(this.worldPositions());
  }

  /** Redraws every stroke (file space, as tubes); the last one brighter while it is drawn. */
  updateStrokeView(drawing = false) {
    for (const child of [...this.strokeView.children]) {
      child.geometry.dispose();
      child.material.dispose();
      this.strokeView.remove(child);
    }
    const radius = this.height * 0.005;
    this.strokes.forEach((stroke, k) => {
      const live = drawing && k === this.strokes.length - 1;
      const material = new THREE.MeshBasicMaterial({
        color: live ? DRAWING_COLOUR : STROKE_COLOUR,
        depthTest: false,
        transparent: true,
        opacity: 0.9,
      });
      const points = stroke.points.map((p) => new THREE.Vector3(...p));
      const geometry =
        points.length < 2
          ? new THREE.SphereGeometry(radius * 1.5, 8, 6).translate(points[0].x, points[0].y, points[0].z)
          : new THREE.TubeGeometry(
              new THREE.CatmullRomCurve3(points, false, 'centripetal'),
              Math.min(4 * points.length, 600),
              radius,
              6,
              false,
            );
      const mesh = new THREE.Mesh(geometry, material);
      mesh.renderOrder = 11;
      mesh.frustumCulled = false;
      this.strokeView.add(mesh);
    });
  }
}
