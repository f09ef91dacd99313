//! Rebuilding a joint hierarchy: some rigs store every joint as a sibling under one node (the
//! WebXR hand profile assets do), which leaves nothing for kinematics to chain. The tree is
//! inferred (from the WebXR hand joint names) and the rig rebuilt around it, keeping every
//! joint's world transform, so skinning and output are unchanged.

use crate::animation::Animation;
use crate::math::Matrix4;
use crate::rig::Rig;
use crate::skeleton::{Joint, Pose, Skeleton};

/// The WebXR hand joints: each finger from its metacarpal to its tip, all on the wrist.
const WEBXR_FINGERS: &[&[&str]] = &[
    &[
        "thumb-metacarpal",
        "thumb-phalanx-proximal",
        "thumb-phalanx-distal",
        "thumb-tip",
    ],
    &[
        "index-finger-metacarpal",
        "index-finger-phalanx-proximal",
        "index-finger-phalanx-intermediate",
        "index-finger-phalanx-distal",
        "index-finger-tip",
    ],
    &[
        "middle-finger-metacarpal",
        "middle-finger-phalanx-proximal",
        "middle-finger-phalanx-intermediate",
        "middle-finger-phalanx-distal",
        "middle-finger-tip",
    ],
    &[
        "ring-finger-metacarpal",
        "ring-finger-phalanx-proximal",
        "ring-finger-phalanx-intermediate",
        "ring-finger-phalanx-distal",
        "ring-finger-tip",
    ],
    &[
        "pinky-finger-metacarpal",
        "pinky-finger-phalanx-proximal",
        "pinky-finger-phalanx-intermediate",
        "pinky-finger-phalanx-distal",
        "pinky-finger-tip",
    ],
];

/// For a skeleton whose WebXR hand joints are all siblings, the parent each joint should
/// have (wrist -> metacarpal -> ... -> tip); `None` when the skeleton is not such a hand.
pub fn webxr_hand_parents(skeleton: &Skeleton) -> Option<Vec<Option<usize>>> {
    let wrist = skeleton.find("wrist")?;
    let flat_parent = skeleton.joint(wrist).parent;
    let mut parents: Vec<Option<usize>> = skeleton.joints().iter().map(|j| j.parent).collect();
    let mut changed = false;
    for finger in WEBXR_FINGERS {
        let mut previous = wrist;
        for name in *finger {
            let j = skeleton.find(name)?;
            if skeleton.joint(j).parent != flat_parent && skeleton.joint(j).parent != Some(previous)
            {
                return None; // some other hierarchy: leave it alone
            }
            if parents[j] != Some(previous) {
                parents[j] = Some(previous);
                changed = true;
            }
            previous = j;
        }
    }
    changed.then_some(parents)
}

/// A rig rebuilt with new parents (indices into the current joints). Returns the rig and,
/// for each new joint index, the old one. World transforms of the stored pose and of the
/// rest pose are kept; animation channels of joints whose parent changed are dropped (their
/// keys were relative to the old parent).
pub fn reparent(rig: &Rig, parents: &[Option<usize>]) -> Option<(Rig, Vec<usize>)> {
    let old = &rig.skeleton;
    let rest_world = old.world_matrices(&old.rest_pose());
    let pose_world = old.world_matrices(&rig.pose);
    let joints: Vec<Joint> = old
        .joints()
        .iter()
        .enumerate()
        .map(|(i, j)| Joint {
            parent: parents[i],
            ..j.clone()
        })
        .collect();
    let (skeleton, new_index) = Skeleton::from_unordered(joints).ok()?;
    let n = skeleton.len();
    let mut old_index = vec![0; n];
    for (o, &nw) in new_index.iter().enumerate() {
        old_index[nw] = o;
    }
    let reorder =
        |world: &[Matrix4]| -> Vec<Matrix4> { old_index.iter().map(|&o| world[o]).collect() };
    let rest = skeleton.pose_from_world(&reorder(&rest_world));
    let pose = skeleton.pose_from_world(&reorder(&pose_world));
    let joints: Vec<Joint> = skeleton
        .joints()
        .iter()
        .zip(&rest.local)
        .map(|(j, r)| Joint {
            rest: *r,
            ..j.clone()
        })
        .collect();
    let mut skeleton = Skeleton::new(joints).ok()?;
    skeleton.set_default_dofs();
    let meshes = rig
        .meshes
        .iter()
        .map(|m| {
            let mut m = m.clone();
            for js in &mut m.joints {
                for j in js.iter_mut() {
                    *j = new_index[*j as usize] as u32;
                }
            }
            m.inverse_bind = old_index.iter().map(|&o| m.inverse_bind[o]).collect();
            m
        })
        .collect();
    let animations = rig
        .animations
        .iter()
        .map(|a| Animation {
            channels: a
                .channels
                .iter()
                .filter(|c| parents[c.joint] == old.joint(c.joint).parent)
                .map(|c| {
                    let mut c = c.clone();
                    c.joint = new_index[c.joint];
                    c
                })
                .collect(),
            ..a.clone()
        })
        .collect();
    Some((
        Rig {
            skeleton,
            pose: Pose { local: pose.local },
            meshes,
            animations,
        },
        old_index,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::{Trs, Vector3};

    #[test]
    fn a_flat_hand_becomes_a_tree_with_the_same_world_transforms() {
        let mut joints = vec![Joint::new("Armature", None, Trs::IDENTITY)];
        let mut x = 0.0;
        for finger in WEBXR_FINGERS {
            for (k, name) in finger.iter().enumerate() {
                joints.push(Joint::new(
                    *name,
                    Some(0),
                    Trs::from_translation(Vector3::new(x, 0.02 * k as f64, 0.0)),
                ));
            }
            x += 0.02;
        }
        joints.push(Joint::new(
            "wrist",
            Some(0),
            Trs::from_translation(Vector3::new(0.04, -0.05, 0.0)),
        ));
        let mut skeleton = Skeleton::new(joints).expect("valid");
        skeleton.set_default_dofs();
        let rig = Rig {
            pose: skeleton.rest_pose(),
            skeleton,
            meshes: vec![],
            animations: vec![],
        };
        let parents = webxr_hand_parents(&rig.skeleton).expect("a WebXR hand");
        let (hand, old_index) = reparent(&rig, &parents).expect("a tree");
        let before = rig.skeleton.joint_positions(&rig.pose);
        let after = hand.skeleton.joint_positions(&hand.pose);
        for (nw, &o) in old_index.iter().enumerate() {
            assert!((before[o] - after[nw]).norm() < 1e-12);
        }
        let tip = hand.skeleton.find("index-finger-tip").expect("tip");
        let distal = hand
            .skeleton
            .find("index-finger-phalanx-distal")
            .expect("distal");
        assert_eq!(hand.skeleton.joint(tip).parent, Some(distal));
        assert!(
            webxr_hand_parents(&hand.skeleton).is_none(),
            "already a tree"
        );
    }
}
