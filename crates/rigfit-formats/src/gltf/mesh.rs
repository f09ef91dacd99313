//! glTF meshes: a skinned mesh's primitives read to a [`SkinnedMesh`], and the vertex and
//! triangle counts of every mesh for `rigfit info`.

use rigfit_core::{Point3, SkinnedMesh, Vector3};
use serde_json::Value;

use super::MeshSummary;
use super::accessor::{element, index_field, read_accessor_as};
use crate::error::{ParseError, coordinate_problem};

pub(super) fn read_skinned_mesh(
    json: &Value,
    buffers: &[Vec<u8>],
    mesh_index: usize,
    skeleton_of_skin_joint: &[usize],
    from: &str,
) -> Result<SkinnedMesh, ParseError> {
    let mesh_path = format!("meshes[{mesh_index}]");
    let mesh_json = element(json, "meshes", mesh_index, from)?;
    let mut mesh = SkinnedMesh::default();
    let primitives = mesh_json
        .get("primitives")
        .and_then(Value::as_array)
        .map(Vec::as_slice)
        .unwrap_or(&[]);
    let mut all_normals = true;
    let mut normals = Vec::new();
    for (p, prim) in primitives.iter().enumerate() {
        let path = format!("{mesh_path}.primitives[{p}]");
        let mode = index_field(prim, "mode", &path)?.unwrap_or(4);
        if !(4..=6).contains(&mode) {
            continue; // points and lines carry no surface
        }
        let attrs = prim
            .get("attributes")
            .ok_or_else(|| ParseError::new(&path, "missing 'attributes'"))?;
        let attr = |name: &str| index_field(attrs, name, &format!("{path}.attributes"));
        let position =
            attr("POSITION")?.ok_or_else(|| ParseError::new(&path, "missing POSITION"))?;
        let pos = read_accessor_as(
            json,
            buffers,
            position,
            3,
            &format!("{path}.attributes.POSITION"),
        )?;
        let count = pos.len() / 3;
        let base = mesh.positions.len() as u32;
        for (i, c) in pos.chunks(3).enumerate() {
            if let Some(problem) = c.iter().find_map(|&v| coordinate_problem(v)) {
                return Err(ParseError::new(
                    format!("accessors[{position}]"),
                    format!("vertex {i}: {problem}"),
                ));
            }
            mesh.positions.push(Point3::new(c[0], c[1], c[2]));
        }
        match attr("NORMAL")? {
            Some(a) if all_normals => {
                let nrm =
                    read_accessor_as(json, buffers, a, 3, &format!("{path}.attributes.NORMAL"))?;
                if nrm.len() != pos.len() {
                    return Err(ParseError::new(
                        format!("accessors[{a}]"),
                        "NORMAL count differs from POSITION count",
                    ));
                }
                if let Some((i, problem)) = nrm.chunks(3).enumerate().find_map(|(i, c)| {
                    c.iter()
                        .find_map(|&v| coordinate_problem(v))
                        .map(|p| (i, p))
                }) {
                    return Err(ParseError::new(
                        format!("accessors[{a}]"),
                        format!("normal {i}: {problem}"),
                    ));
                }
                normals.extend(nrm.chunks(3).map(|c| Vector3::new(c[0], c[1], c[2])));
            }
            _ => all_normals = false,
        }
        let (joints_acc, weights_acc) = match (attr("JOINTS_0")?, attr("WEIGHTS_0")?) {
            (Some(j), Some(w)) => (j, w),
            _ => {
                return Err(ParseError::new(
                    &path,
                    "skinned primitive without JOINTS_0 and WEIGHTS_0",
                ));
            }
        };
        let jv = read_accessor_as(
            json,
            buffers,
            joints_acc,
            4,
            &format!("{path}.attributes.JOINTS_0"),
        )?;
        let wv = read_accessor_as(
            json,
            buffers,
            weights_acc,
            4,
            &format!("{path}.attributes.WEIGHTS_0"),
        )?;
        if jv.len() != pos.len() / 3 * 4 || wv.len() != jv.len() {
            return Err(ParseError::new(
                &path,
                "JOINTS_0 / WEIGHTS_0 counts differ from POSITION count",
            ));
        }
        for (v, (j, w)) in jv.chunks(4).zip(wv.chunks(4)).enumerate() {
            let mut ji = [0u32; 4];
            let mut wi = [0f32; 4];
            for k in 0..4 {
                let weight = w[k];
                if !weight.is_finite() || weight < 0.0 {
                    return Err(ParseError::new(
                        format!("accessors[{weights_acc}]"),
                        format!("vertex {v} has a bad weight"),
                    ));
                }
                if weight == 0.0 {
                    continue;
                }
                let skin_joint = j[k] as usize;
                let joint = skeleton_of_skin_joint.get(skin_joint).ok_or_else(|| {
                    ParseError::new(
                        format!("accessors[{joints_acc}]"),
                        format!(
                            "vertex {v} uses joint {skin_joint}, but the skin has {} joints",
                            skeleton_of_skin_joint.len()
                        ),
                    )
                })?;
                ji[k] = *joint as u32;
                wi[k] = weight as f32;
            }
            let sum: f32 = wi.iter().sum();
            if sum > 0.0 {
                wi.iter_mut().for_each(|x| *x /= sum);
            }
            mesh.joints.push(ji);
            mesh.weights.push(wi);
        }
        let indices: Vec<u32> = match index_field(prim, "indices", &path)? {
            Some(a) => read_accessor_as(json, buffers, a, 1, &format!("{path}.indices"))?
                .into_iter()
                .map(|i| i as u32)
                .collect(),
            None => (0..count as u32).collect(),
        };
        if let Some(bad) = indices.iter().find(|&&i| i as usize >= count) {
            return Err(ParseError::new(
                format!("{path}.indices"),
                format!("index {bad} is out of range ({count} vertices)"),
            ));
        }
        let tri = |a: u32, b: u32, c: u32| [base + a, base + b, base + c];
        match mode {
            4 => mesh
                .triangles
                .extend(indices.chunks_exact(3).map(|t| tri(t[0], t[1], t[2]))),
            5 => mesh
                .triangles
                .extend(indices.windows(3).enumerate().map(|(i, t)| {
                    if i % 2 == 0 {
                        tri(t[0], t[1], t[2])
                    } else {
                        tri(t[1], t[0], t[2])
                    }
                })),
            _ => {
                if let Some((&first, rest)) = indices.split_first() {
                    mesh.triangles
                        .extend(rest.windows(2).map(|t| tri(first, t[0], t[1])));
                }
            }
        }
    }
    mesh.normals = (all_normals && !normals.is_empty()).then_some(normals);
    Ok(mesh)
}

pub(super) fn mesh_summaries(json: &Value) -> Vec<MeshSummary> {
    let meshes = json
        .get("meshes")
        .and_then(Value::as_array)
        .map(Vec::as_slice)
        .unwrap_or(&[]);
    let nodes = json
        .get("nodes")
        .and_then(Value::as_array)
        .map(Vec::as_slice)
        .unwrap_or(&[]);
    let mut skinned_meshes = std::collections::HashSet::new();
    for n in nodes {
        if let (Some(m), Some(_)) = (n.get("mesh").and_then(Value::as_u64), n.get("skin")) {
            skinned_meshes.insert(m);
        }
    }
    let count = |acc: Option<u64>| {
        acc.and_then(|a| json.pointer(&format!("/accessors/{a}/count")))
            .and_then(Value::as_u64)
            .unwrap_or(0) as usize
    };
    meshes
        .iter()
        .enumerate()
        .map(|(m, mesh)| {
            let prims = mesh
                .get("primitives")
                .and_then(Value::as_array)
                .map(Vec::as_slice)
                .unwrap_or(&[]);
            let vertices = prims
                .iter()
                .map(|p| count(p.pointer("/attributes/POSITION").and_then(Value::as_u64)))
                .sum();
            let triangles = prims
                .iter()
                .map(|p| match p.get("indices").and_then(Value::as_u64) {
                    Some(i) => count(Some(i)) / 3,
                    None => count(p.pointer("/attributes/POSITION").and_then(Value::as_u64)) / 3,
                })
                .sum();
            MeshSummary {
                name: mesh
                    .get("name")
                    .and_then(Value::as_str)
                    .map_or_else(|| format!("mesh{m}"), str::to_owned),
                vertices,
                triangles,
                skinned: skinned_meshes.contains(&(m as u64)),
            }
        })
        .collect()
}
