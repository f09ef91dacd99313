// Poses: one local transform per joint, in the solver's joint order (parents first).
// A pose is an array of { translation: [x, y, z], rotation: [x, y, z, w], scale: [x, y, z] }.

import * as THREE from 'three';

/** The pose stored under `field` ('rest' or 'pose') of the server's CHARACTER joints. */
export function poseFromCharacter(joints, field) {
  return joints.map((j) => ({
    translation: [...j[field].translation],
    rotation: [...j[field].rotation],
    scale: [...(j[field].scale ?? [1, 1, 1])],
  }));
}

export function clonePose(pose) {
  return pose.map((t) => ({
    translation: [...t.translation],
    rotation: [...t.rotation],
    scale: [...t.scale],
  }));
}

/** The `pose` object of a solve or export request. */
export function poseToRequest(joints, pose) {
  return {
    joints: joints.map((j, i) => ({
      name: j.name,
      translation: pose[i].translation,
      rotation: pose[i].rotation,
    })),
  };
}

/** A solve answer as a pose: its joints by name over `base` (joints it does not list keep theirs). */
export function poseFromSolve(joints, answer, base) {
  // Same joints in the same order (the solver's): match by index, so that repeated names (BVH
  // end sites) stay apart; otherwise by name.
  const sameOrder =
    answer.joints.length === joints.length && answer.joints.every((j, i) => j.name === joints[i].name);
  const byName = new Map(answer.joints.map((j) => [j.name, j]));
  return joints.map((j, i) => {
    const solved = sameOrder ? answer.joints[i] : byName.get(j.name);
    return {
      translation: [...(solved?.translation ?? base[i].translation)],
      rotation: [...(solved?.rotation ?? base[i].rotation)],
      scale: [...base[i].scale],
    };
  });
}

const qa = new THREE.Quaternion();
const qb = new THREE.Quaternion();

/** Between two poses: translations and scales lerped, rotations slerped (shortest arc). */
export function interpolatePoses(a, b, t) {
  const lerp = (u, v) => u.map((x, k) => x + (v[k] - x) * t);
  return a.map((ta, i) => {
    const tb = b[i];
    qa.fromArray(ta.rotation);
    qb.fromArray(tb.rotation);
    qa.slerp(qb, t);
    return {
      translation: lerp(ta.translation, tb.translation),
      rotation: qa.toArray(),
      scale: lerp(ta.scale, tb.scale),
    };
  });
}

/**
 * The pose at `frame` from keys sorted by frame ([{ frame, pose }]): the first key's pose before
 * it, the last one's after it, slerped between the two keys around it. Null without keys.
 */
export function poseAtFrame(keys, frame) {
  if (keys.length === 0) return null;
  if (frame <= keys[0].frame) return clonePose(keys[0].pose);
  const last = keys[keys.length - 1];
  if (frame >= last.frame) return clonePose(last.pose);
  const next = keys.findIndex((k) => k.frame > frame);
  const [a, b] = [keys[next - 1], keys[next]];
  return interpolatePoses(a.pose, b.pose, (frame - a.frame) / (b.frame - a.frame));
}
