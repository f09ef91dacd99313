//! How much memory a character takes, for the store's budget: an estimate from the sizes of
//! what it holds (every vector's capacity, plus what the allocator adds per allocation), not
//! a measurement. The tests compare it with the process's resident memory.

use std::mem::size_of;

use rigfit_core::{Rig, Skeleton};
use rigfit_formats::rig_file::{RigFile, RigSource};
use serde_json::Value;

/// What the allocator adds to each allocation (glibc: a 16-byte header, rounded up).
const PER_ALLOCATION: usize = 32;

/// The bytes of a vector's storage (none when it has not allocated).
fn vec_bytes<T>(v: &Vec<T>) -> usize {
    if v.capacity() == 0 {
        0
    } else {
        v.capacity() * size_of::<T>() + PER_ALLOCATION
    }
}

fn string_bytes(s: &str) -> usize {
    if s.is_empty() {
        0
    } else {
        s.len() + PER_ALLOCATION
    }
}

/// A skeleton: its joints and their names and children lists.
fn skeleton_bytes(skeleton: &Skeleton) -> usize {
    let joints = skeleton.joints();
    let per_joint = size_of::<rigfit_core::Joint>() + size_of::<Vec<usize>>() + PER_ALLOCATION;
    joints
        .iter()
        .map(|j| per_joint + string_bytes(&j.name))
        .sum::<usize>()
        + 2 * PER_ALLOCATION
}

/// A rig: skeleton, stored pose, meshes and animations.
pub fn rig_bytes(rig: &Rig) -> usize {
    let meshes: usize = rig
        .meshes
        .iter()
        .map(|m| {
            size_of::<rigfit_core::SkinnedMesh>()
                + string_bytes(&m.name)
                + vec_bytes(&m.positions)
                + m.normals.as_ref().map_or(0, vec_bytes)
                + vec_bytes(&m.triangles)
                + vec_bytes(&m.joints)
                + vec_bytes(&m.weights)
                + vec_bytes(&m.inverse_bind)
        })
        .sum();
    let animations: usize = rig
        .animations
        .iter()
        .map(|a| {
            string_bytes(&a.name)
                + vec_bytes(&a.channels)
                + a.channels
                    .iter()
                    .map(|c| vec_bytes(&c.times) + vec_bytes(&c.values))
                    .sum::<usize>()
        })
        .sum();
    skeleton_bytes(&rig.skeleton) + vec_bytes(&rig.pose.local) + meshes + animations
}

/// A JSON document: each value's node plus its strings (a rough count of serde_json's
/// layout with ordered maps).
pub fn json_bytes(value: &Value) -> usize {
    const NODE: usize = size_of::<Value>();
    match value {
        Value::Null | Value::Bool(_) | Value::Number(_) => NODE,
        Value::String(s) => NODE + string_bytes(s),
        Value::Array(list) => NODE + PER_ALLOCATION + list.iter().map(json_bytes).sum::<usize>(),
        Value::Object(map) => {
            // An index map: entries (key, value, hash) plus the index table.
            NODE + 2 * PER_ALLOCATION
                + map
                    .iter()
                    .map(|(k, v)| string_bytes(k) + size_of::<String>() + 16 + json_bytes(v))
                    .sum::<usize>()
        }
    }
}

/// A character's rig file: the rig, and the file's own document kept for export (glTF JSON
/// and buffers, or BVH frames).
pub fn rig_file_bytes(rig_file: &RigFile) -> usize {
    let source = match &rig_file.source {
        RigSource::Gltf(doc) => {
            json_bytes(&doc.json)
                + vec_bytes(&doc.buffers)
                + doc.buffers.iter().map(vec_bytes).sum::<usize>()
                + doc.rig.as_ref().map_or(0, rig_bytes)
                + vec_bytes(&doc.joint_nodes)
        }
        RigSource::Bvh(doc) => {
            vec_bytes(&doc.joints)
                + doc
                    .joints
                    .iter()
                    .map(|j| string_bytes(&j.name) + vec_bytes(&j.channels))
                    .sum::<usize>()
                + vec_bytes(&doc.frames)
                + doc.frames.iter().map(vec_bytes).sum::<usize>()
        }
    };
    size_of::<RigFile>()
        + rig_bytes(&rig_file.rig)
        + source
        + rig_file.file_index.as_ref().map_or(0, vec_bytes)
}

/// How many times its size an upload may take while it is read (the reader's own copies and
/// the document it builds): reserved from the budget before reading. Measured on the real
/// assets and on long BVH files (tests/abuse.rs); rounded up.
pub fn parse_factor(format: rigfit_formats::rig_file::RigFormat) -> usize {
    match format {
        rigfit_formats::rig_file::RigFormat::Bvh => 16,
        _ => 8,
    }
}
