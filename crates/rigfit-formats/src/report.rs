//! The JSON reports of `interfaces.md` (`--report`).

use rigfit_core::animation::quat_to_xyzw;
use rigfit_core::{JointKind, Pose, Rig};
use serde_json::{Value, json};

/// The nearest ancestor of `joint` that is reported (not a helper node).
fn reported_parent(rig: &Rig, joint: usize) -> Option<usize> {
    let mut cur = rig.skeleton.joint(joint).parent;
    while let Some(p) = cur {
        if rig.skeleton.joint(p).kind != JointKind::Helper {
            return Some(p);
        }
        cur = rig.skeleton.joint(p).parent;
    }
    None
}

/// Every reported joint of `rig` in `pose`: name, parent, world position, local rotation
/// (and `end_site` for BVH End Sites).
pub fn joints_json(rig: &Rig, pose: &Pose) -> Vec<Value> {
    let positions = rig.skeleton.joint_positions(pose);
    rig.reported_joints()
        .map(|j| {
            let joint = rig.skeleton.joint(j);
            let p = positions[j];
            let mut v = json!({
                "name": joint.name,
                "parent": reported_parent(rig, j).map(|p| rig.skeleton.joint(p).name.clone()),
                "position": [p.x, p.y, p.z],
                "rotation": quat_to_xyzw(&pose.local[j].rotation),
            });
            if joint.kind == JointKind::EndSite {
                v["end_site"] = json!(true);
            }
            v
        })
        .collect()
}

/// The `pose` report: joints after posing, the bones each stroke was matched to, iterations,
/// energy and seconds.
pub fn pose_report(
    rig: &Rig,
    pose: &Pose,
    stroke_bones: &[Vec<usize>],
    iterations: usize,
    energy: f64,
    seconds: f64,
) -> Value {
    let strokes: Vec<Value> = stroke_bones
        .iter()
        .map(|bones| {
            let names: Vec<&str> = bones
                .iter()
                .map(|&j| rig.skeleton.joint(j).name.as_str())
                .collect();
            json!({ "bones": names })
        })
        .collect();
    json!({
        "joints": joints_json(rig, pose),
        "strokes": strokes,
        "iterations": iterations,
        "energy": energy,
        "seconds": seconds,
    })
}

/// One frame of the `track` report: the frame's file, every reported joint's world
/// position, the inlier count and the seconds it took.
pub fn track_frame_json(rig: &Rig, pose: &Pose, file: &str, inliers: usize, seconds: f64) -> Value {
    let positions = rig.skeleton.joint_positions(pose);
    let joints: Vec<Value> = rig
        .reported_joints()
        .map(|j| {
            let p = positions[j];
            json!({ "name": rig.skeleton.joint(j).name, "position": [p.x, p.y, p.z] })
        })
        .collect();
    json!({ "file": file, "joints": joints, "inliers": inliers, "seconds": seconds })
}

/// Pretty JSON text with a final newline.
pub fn to_text(value: &Value) -> String {
    let mut s = serde_json::to_string_pretty(value).expect("JSON values always serialise");
    s.push('\n');
    s
}
