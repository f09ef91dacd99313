//! From a rig or a posed document back to glTF bytes.

use std::path::Path;

use base64::Engine as _;
use rigfit_core::animation::quat_to_xyzw;
use rigfit_core::{ChannelTarget, Interpolation, JointDof, JointKind, Pose, Rig, Trs};
use serde_json::{Value, json};

use super::accessor::{AccessorWriter, push};
use super::container::join_glb;
use super::{GltfDocument, RIGFIT_ANIMATION};

fn trs_json(node: &mut Value, trs: &Trs) {
    if let Some(obj) = node.as_object_mut() {
        obj.remove("matrix");
    }
    let t = trs.translation;
    let r = quat_to_xyzw(&trs.rotation);
    let s = trs.scale;
    node["translation"] = json!([t.x, t.y, t.z]);
    node["rotation"] = json!(r);
    node["scale"] = json!([s.x, s.y, s.z]);
}

fn data_uri(bytes: &[u8]) -> String {
    format!(
        "data:application/octet-stream;base64,{}",
        base64::engine::general_purpose::STANDARD.encode(bytes)
    )
}

/// Removes an earlier `rigfit` animation, and its data too when that data is the tail of the
/// accessor, buffer-view and buffer arrays (as rigfit writes it), so re-keying a file does not
/// grow it.
fn remove_rigfit_animation(json: &mut Value, buffers: &mut [Vec<u8>]) {
    let Some(anims) = json.get("animations").and_then(Value::as_array) else {
        return;
    };
    let Some(a) = anims
        .iter()
        .position(|x| x.get("name").and_then(Value::as_str) == Some(RIGFIT_ANIMATION))
    else {
        return;
    };
    let mut accessors: Vec<usize> = anims[a]
        .get("samplers")
        .and_then(Value::as_array)
        .map(|s| {
            s.iter()
                .flat_map(|x| [x.get("input"), x.get("output")])
                .flatten()
                .filter_map(Value::as_u64)
                .map(|i| i as usize)
                .collect()
        })
        .unwrap_or_default();
    accessors.sort_unstable();
    accessors.dedup();
    json["animations"]
        .as_array_mut()
        .expect("checked above")
        .remove(a);
    if json["animations"].as_array().is_some_and(Vec::is_empty) {
        json.as_object_mut().map(|o| o.remove("animations"));
    }
    let n_acc = json
        .get("accessors")
        .and_then(Value::as_array)
        .map_or(0, Vec::len);
    let is_tail = |idx: &[usize], len: usize| {
        !idx.is_empty()
            && idx
                .iter()
                .enumerate()
                .all(|(k, &i)| i == len - idx.len() + k)
    };
    if !is_tail(&accessors, n_acc) {
        return;
    }
    let mut views: Vec<usize> = accessors
        .iter()
        .filter_map(|&i| {
            json["accessors"][i]
                .get("bufferView")
                .and_then(Value::as_u64)
        })
        .map(|v| v as usize)
        .collect();
    views.sort_unstable();
    views.dedup();
    let n_views = json
        .get("bufferViews")
        .and_then(Value::as_array)
        .map_or(0, Vec::len);
    if !is_tail(&views, n_views) {
        return;
    }
    // Every view must sit in buffer 0, after all other data.
    let mut cut = usize::MAX;
    for &v in &views {
        let view = &json["bufferViews"][v];
        if view.get("buffer").and_then(Value::as_u64) != Some(0) {
            return;
        }
        cut = cut.min(view.get("byteOffset").and_then(Value::as_u64).unwrap_or(0) as usize);
    }
    json["accessors"]
        .as_array_mut()
        .expect("array")
        .truncate(n_acc - accessors.len());
    json["bufferViews"]
        .as_array_mut()
        .expect("array")
        .truncate(n_views - views.len());
    let max_other_end = json["bufferViews"]
        .as_array()
        .expect("array")
        .iter()
        .filter(|v| v.get("buffer").and_then(Value::as_u64) == Some(0))
        .map(|v| {
            v.get("byteOffset").and_then(Value::as_u64).unwrap_or(0)
                + v.get("byteLength").and_then(Value::as_u64).unwrap_or(0)
        })
        .max()
        .unwrap_or(0) as usize;
    if let Some(b) = buffers.first_mut() {
        if cut >= max_other_end && cut <= b.len() {
            b.truncate(cut);
        }
    }
}

/// Appends an animation named `name` with one sampler per (joint node, target).
fn append_pose_animation(
    json: &mut Value,
    bytes: &mut Vec<u8>,
    name: &str,
    keyed: &[(usize, ChannelTarget)],
    keys: &[(f64, Pose)],
    joint_nodes: &[usize],
) {
    let mut w = AccessorWriter {
        json,
        buffer_index: 0,
        bytes,
    };
    let times: Vec<f64> = keys.iter().map(|k| k.0).collect();
    let input = w.floats(&times, "SCALAR", true, None);
    let mut samplers = Vec::new();
    let mut channels = Vec::new();
    for &(joint, target) in keyed {
        let (values, ty, path): (Vec<f64>, _, _) = match target {
            ChannelTarget::Rotation => (
                keys.iter()
                    .flat_map(|(_, p)| quat_to_xyzw(&p.local[joint].rotation))
                    .collect(),
                "VEC4",
                "rotation",
            ),
            ChannelTarget::Translation => (
                keys.iter()
                    .flat_map(|(_, p)| {
                        p.local[joint]
                            .translation
                            .iter()
                            .copied()
                            .collect::<Vec<_>>()
                    })
                    .collect(),
                "VEC3",
                "translation",
            ),
            ChannelTarget::Scale => (
                keys.iter()
                    .flat_map(|(_, p)| p.local[joint].scale.iter().copied().collect::<Vec<_>>())
                    .collect(),
                "VEC3",
                "scale",
            ),
        };
        let output = w.floats(&values, ty, false, None);
        channels.push(json!({ "sampler": samplers.len(), "target": { "node": joint_nodes[joint], "path": path } }));
        samplers.push(json!({ "input": input, "output": output, "interpolation": "LINEAR" }));
    }
    push(
        w.json,
        "animations",
        json!({ "name": name, "channels": channels, "samplers": samplers }),
    );
}

pub(super) fn to_bytes(
    doc: &GltfDocument,
    glb: bool,
    pose: &Pose,
    keys: &[(f64, Pose)],
    out_dir: Option<&Path>,
) -> Vec<u8> {
    let mut json = doc.json.clone();
    let mut buffers = doc.buffers.clone();
    remove_rigfit_animation(&mut json, &mut buffers);
    for (joint, &node) in doc.joint_nodes.iter().enumerate() {
        if let Some(trs) = pose.local.get(joint) {
            trs_json(&mut json["nodes"][node], trs);
        }
    }
    if let (Some(rig), false) = (&doc.rig, keys.is_empty()) {
        if buffers.is_empty() {
            buffers.push(Vec::new());
            push(&mut json, "buffers", json!({ "byteLength": 0 }));
        }
        let mut keyed = Vec::new();
        for (j, joint) in rig.skeleton.joints().iter().enumerate() {
            match joint.dof {
                JointDof::Fixed => {}
                JointDof::Free => {
                    keyed.push((j, ChannelTarget::Translation));
                    keyed.push((j, ChannelTarget::Rotation));
                }
                _ => keyed.push((j, ChannelTarget::Rotation)),
            }
        }
        let mut bytes = std::mem::take(&mut buffers[0]);
        append_pose_animation(
            &mut json,
            &mut bytes,
            RIGFIT_ANIMATION,
            &keyed,
            keys,
            &doc.joint_nodes,
        );
        buffers[0] = bytes;
    }
    // Images referenced by relative paths stay reachable from a new directory.
    if let (Some(src), Some(out)) = (&doc.source_dir, out_dir) {
        let same = src.canonicalize().ok() == out.canonicalize().ok();
        if let (false, Some(images)) = (same, json.get_mut("images").and_then(Value::as_array_mut))
        {
            for img in images {
                if let Some(uri) = img.get("uri").and_then(Value::as_str) {
                    if !uri.starts_with("data:") && !uri.contains("://") {
                        let abs = src.canonicalize().unwrap_or_else(|_| src.clone()).join(uri);
                        img["uri"] = json!(abs.to_string_lossy());
                    }
                }
            }
        }
    }
    encode(json, &buffers, glb)
}

/// The bytes of a glTF file from its JSON and the bytes of its buffers: GLB keeps buffer 0
/// in its binary chunk and embeds the others as data URIs; `.gltf` JSON embeds every buffer.
pub(super) fn encode(mut json: Value, buffers: &[Vec<u8>], glb: bool) -> Vec<u8> {
    for (i, b) in buffers.iter().enumerate() {
        let entry = &mut json["buffers"][i];
        entry["byteLength"] = json!(b.len());
        if glb && i == 0 {
            entry.as_object_mut().map(|o| o.remove("uri"));
        } else {
            entry["uri"] = json!(data_uri(b));
        }
    }
    let text = serde_json::to_vec(&json).expect("JSON values always serialise");
    if glb {
        join_glb(&text, buffers.first().map(Vec::as_slice))
    } else {
        text
    }
}

/// A complete `.glb` for a rig: nodes for its joints in their stored pose (node `j` is
/// joint `j`), a skin, its skinned meshes and animations.
pub fn rig_to_glb(rig: &Rig) -> Vec<u8> {
    let (json, bytes) = rig_document(rig);
    encode(json, &[bytes], true)
}

/// [`rig_to_glb`] as `.gltf` JSON with its buffer embedded as a data URI.
pub fn rig_to_gltf(rig: &Rig) -> Vec<u8> {
    let (json, bytes) = rig_document(rig);
    encode(json, &[bytes], false)
}

/// The glTF JSON and buffer of [`rig_to_glb`].
fn rig_document(rig: &Rig) -> (Value, Vec<u8>) {
    let skeleton = &rig.skeleton;
    let mut json = json!({ "asset": { "version": "2.0", "generator": "rigfit" }, "buffers": [ { "byteLength": 0 } ] });
    let mut nodes: Vec<Value> = skeleton
        .joints()
        .iter()
        .enumerate()
        .map(|(j, joint)| {
            let mut n = json!({ "name": joint.name });
            trs_json(&mut n, &rig.pose.local[j]);
            let children = skeleton.children(j);
            if !children.is_empty() {
                n["children"] = json!(children);
            }
            n
        })
        .collect();
    let skin_joints: Vec<usize> = (0..skeleton.len())
        .filter(|&j| skeleton.joint(j).kind != JointKind::Helper)
        .collect();
    let mut skin_of_joint = vec![0u16; skeleton.len()];
    for (k, &j) in skin_joints.iter().enumerate() {
        skin_of_joint[j] = k as u16;
    }
    let mut bytes = Vec::new();
    let mut scene_nodes: Vec<usize> = skeleton.roots().collect();
    {
        let mut w = AccessorWriter {
            json: &mut json,
            buffer_index: 0,
            bytes: &mut bytes,
        };
        let inverse_bind: Vec<f64> = skin_joints
            .iter()
            .flat_map(|&j| {
                rig.meshes
                    .first()
                    .and_then(|m| m.inverse_bind.get(j))
                    .copied()
                    .unwrap_or_else(rigfit_core::Matrix4::identity)
                    .as_slice()
                    .to_vec()
            })
            .collect();
        let ibm = w.floats(&inverse_bind, "MAT4", false, None);
        push(
            w.json,
            "skins",
            json!({ "joints": skin_joints, "inverseBindMatrices": ibm }),
        );
        for mesh in &rig.meshes {
            let pos: Vec<f64> = mesh
                .positions
                .iter()
                .flat_map(|p| [p.x, p.y, p.z])
                .collect();
            let mut attributes = json!({ "POSITION": w.floats(&pos, "VEC3", true, Some(34962)) });
            if let Some(normals) = &mesh.normals {
                let n: Vec<f64> = normals.iter().flat_map(|n| [n.x, n.y, n.z]).collect();
                attributes["NORMAL"] = json!(w.floats(&n, "VEC3", false, Some(34962)));
            }
            let joints: Vec<u16> = mesh
                .joints
                .iter()
                .flat_map(|j| j.map(|i| skin_of_joint[i as usize]))
                .collect();
            attributes["JOINTS_0"] = json!(w.u16s(&joints, "VEC4"));
            let weights: Vec<f64> = mesh.weights.iter().flat_map(|w| w.map(f64::from)).collect();
            attributes["WEIGHTS_0"] = json!(w.floats(&weights, "VEC4", false, Some(34962)));
            let indices: Vec<u32> = mesh.triangles.iter().flatten().copied().collect();
            let prim =
                json!({ "attributes": attributes, "indices": w.indices(&indices), "mode": 4 });
            let m = push(
                w.json,
                "meshes",
                json!({ "name": mesh.name, "primitives": [prim] }),
            );
            nodes.push(json!({ "name": mesh.name, "mesh": m, "skin": 0 }));
            scene_nodes.push(nodes.len() - 1);
        }
        for anim in &rig.animations {
            let mut samplers = Vec::new();
            let mut channels = Vec::new();
            for c in &anim.channels {
                let input = w.floats(&c.times, "SCALAR", true, None);
                let (ty, path, width) = match c.target {
                    ChannelTarget::Rotation => ("VEC4", "rotation", 4),
                    ChannelTarget::Translation => ("VEC3", "translation", 3),
                    ChannelTarget::Scale => ("VEC3", "scale", 3),
                };
                let values: Vec<f64> = c.values.iter().flat_map(|v| v[..width].to_vec()).collect();
                let output = w.floats(&values, ty, false, None);
                let interpolation = match c.interpolation {
                    Interpolation::Step => "STEP",
                    Interpolation::Linear => "LINEAR",
                    Interpolation::CubicSpline => "CUBICSPLINE",
                };
                channels.push(json!({ "sampler": samplers.len(), "target": { "node": c.joint, "path": path } }));
                samplers.push(
                    json!({ "input": input, "output": output, "interpolation": interpolation }),
                );
            }
            push(
                w.json,
                "animations",
                json!({ "name": anim.name, "channels": channels, "samplers": samplers }),
            );
        }
    }
    json["nodes"] = json!(nodes);
    json["scenes"] = json!([{ "nodes": scene_nodes }]);
    json["scene"] = json!(0);
    (json, bytes)
}
