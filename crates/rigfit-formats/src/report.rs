//! The JSON reports of `interfaces.md` (`--report`).

use rigfit_core::animation::quat_to_xyzw;
use rigfit_core::{JointKind, Pose, Rig};
use serde_json::{Value, json};

/// For every joint, its nearest ancestor that is reported (not a helper node): one pass,
/// parents before children, so a long run of helpers is not walked once per joint below it.
fn reported_parents(rig: &Rig) -> Vec<Option<usize>> {
    let s = &rig.skeleton;
    let mut out: Vec<Option<usize>> = Vec::with_capacity(s.len());
    for j in 0..s.len() {
        let parent = s.joint(j).parent.and_then(|p| {
            if s.joint(p).kind == JointKind::Helper {
                out[p]
            } else {
                Some(p)
            }
        });
        out.push(parent);
    }
    out
}

/// Every reported joint of `rig` in `pose`: name, parent, world position, local rotation
/// (and `end_site` for BVH End Sites).
pub fn joints_json(rig: &Rig, pose: &Pose) -> Vec<Value> {
    let positions = rig.skeleton.joint_positions(pose);
    let parents = reported_parents(rig);
    rig.reported_joints()
        .map(|j| {
            let joint = rig.skeleton.joint(j);
            let p = positions[j];
            let mut v = json!({
                "name": joint.name,
                "parent": parents[j].map(|p| rig.skeleton.joint(p).name.clone()),
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
