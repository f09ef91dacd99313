//! From glTF JSON and buffers to a [`Rig`].

use base64::Engine as _;
use nalgebra::Quaternion;
use rigfit_core::{
    Animation, AnimationChannel, ChannelTarget, Interpolation, Joint, JointKind, Matrix4, Point3,
    Quat, Rig, Skeleton, SkinnedMesh, Trs, Vector3,
};
use serde_json::Value;

use super::accessor::{element, index_field, read_accessor_as, required_index};
use super::container::{is_glb, split_glb};
use super::{GltfDocument, LoadUri, MeshSummary};
use crate::error::{ParseError, coordinate_problem};

pub(super) fn parse(
    bytes: &[u8],
    load_uri: &mut LoadUri<'_>,
    skin_name: Option<&str>,
) -> Result<GltfDocument, ParseError> {
    let (json_bytes, bin) = if is_glb(bytes) {
        split_glb(bytes)?
    } else {
        (bytes, None)
    };
    // The node count first, by a pass that builds nothing: a JSON tree costs about a
    // kilobyte a node, so a file of millions of nodes is refused before it is built.
    #[derive(serde::Deserialize)]
    struct Shape {
        #[serde(default)]
        nodes: Vec<serde::de::IgnoredAny>,
    }
    if let Ok(shape) = serde_json::from_slice::<Shape>(json_bytes) {
        if shape.nodes.len() > crate::error::MAX_JOINTS {
            return Err(ParseError::new(
                "nodes",
                format!(
                    "{} nodes is too many (rigfit reads glTF files of at most {} nodes)",
                    shape.nodes.len(),
                    crate::error::MAX_JOINTS
                ),
            ));
        }
    }
    let json: Value = serde_json::from_slice(json_bytes).map_err(|e| {
        ParseError::new(
            format!("JSON line {} column {}", e.line(), e.column()),
            format!("invalid JSON: {e}"),
        )
    })?;
    if !json.is_object() {
        return Err(ParseError::new("JSON", "the top level is not an object"));
    }
    let version = json
        .pointer("/asset/version")
        .and_then(Value::as_str)
        .unwrap_or("");
    if !version.starts_with('2') {
        return Err(ParseError::new(
            "asset.version",
            format!("glTF version '{version}' is not supported (only 2.x)"),
        ));
    }
    let buffers = resolve_buffers(&json, bin, load_uri)?;
    let mut doc = GltfDocument {
        json,
        buffers,
        rig: None,
        joint_nodes: Vec::new(),
        skin: None,
        source_dir: None,
        external_files: Vec::new(),
    };
    let skins = doc
        .json
        .get("skins")
        .and_then(Value::as_array)
        .map_or(0, Vec::len);
    let skin = match skin_name {
        Some(name) => Some(
            (0..skins)
                .find(|&i| doc.json["skins"][i].get("name").and_then(Value::as_str) == Some(name))
                .ok_or_else(|| ParseError::new("skins", format!("no skin named '{name}'")))?,
        ),
        None => (skins > 0).then_some(0),
    };
    if let Some(skin) = skin {
        let (rig, joint_nodes) = build_rig(&doc.json, &doc.buffers, skin)?;
        doc.rig = Some(rig);
        doc.joint_nodes = joint_nodes;
        doc.skin = Some(skin);
    }
    Ok(doc)
}

fn resolve_buffers(
    json: &Value,
    bin: Option<&[u8]>,
    load_uri: &mut LoadUri<'_>,
) -> Result<Vec<Vec<u8>>, ParseError> {
    let Some(buffers) = json.get("buffers").and_then(Value::as_array) else {
        return Ok(Vec::new());
    };
    let mut out = Vec::with_capacity(buffers.len());
    for (i, b) in buffers.iter().enumerate() {
        let path = format!("buffers[{i}]");
        let length = required_index(b, "byteLength", &path)?;
        let data = match b.get("uri").and_then(Value::as_str) {
            None => match (i, bin) {
                (0, Some(bin)) => bin.to_vec(),
                _ => {
                    return Err(ParseError::new(
                        &path,
                        "has no uri and there is no GLB binary chunk",
                    ));
                }
            },
            Some(uri) if uri.starts_with("data:") => {
                let comma = uri
                    .find(',')
                    .ok_or_else(|| ParseError::new(&path, "data URI has no ','"))?;
                if !uri[..comma].ends_with(";base64") {
                    return Err(ParseError::new(
                        &path,
                        "only base64 data URIs are supported",
                    ));
                }
                base64::engine::general_purpose::STANDARD
                    .decode(uri[comma + 1..].trim())
                    .map_err(|e| ParseError::new(&path, format!("bad base64 data: {e}")))?
            }
            Some(uri) => load_uri(uri, length).map_err(|e| ParseError::new(&path, e))?,
        };
        if data.len() < length {
            return Err(ParseError::new(
                &path,
                format!(
                    "byteLength is {length} but only {} bytes are there (truncated?)",
                    data.len()
                ),
            ));
        }
        out.push(data);
    }
    Ok(out)
}

fn numbers<const N: usize>(
    node: &Value,
    key: &str,
    path: &str,
) -> Result<Option<[f64; N]>, ParseError> {
    let out = finite_numbers::<N>(node, key, path)?;
    if key != "rotation" {
        if let Some(problem) = out.iter().flatten().find_map(|&x| coordinate_problem(x)) {
            return Err(ParseError::new(format!("{path}.{key}"), problem));
        }
    }
    Ok(out)
}

fn finite_numbers<const N: usize>(
    node: &Value,
    key: &str,
    path: &str,
) -> Result<Option<[f64; N]>, ParseError> {
    let Some(v) = node.get(key) else {
        return Ok(None);
    };
    let arr = v
        .as_array()
        .filter(|a| a.len() == N)
        .ok_or_else(|| ParseError::new(format!("{path}.{key}"), format!("expected {N} numbers")))?;
    let mut out = [0.0; N];
    for (o, x) in out.iter_mut().zip(arr) {
        *o = x
            .as_f64()
            .filter(|f| f.is_finite())
            .ok_or_else(|| ParseError::new(format!("{path}.{key}"), "expected finite numbers"))?;
    }
    Ok(Some(out))
}

/// A node's local transform.
fn node_trs(node: &Value, path: &str) -> Result<Trs, ParseError> {
    if let Some(m) = numbers::<16>(node, "matrix", path)? {
        return Ok(Trs::from_matrix(&Matrix4::from_column_slice(&m)));
    }
    let t = numbers::<3>(node, "translation", path)?.unwrap_or([0.0; 3]);
    let r = numbers::<4>(node, "rotation", path)?.unwrap_or([0.0, 0.0, 0.0, 1.0]);
    let s = numbers::<3>(node, "scale", path)?.unwrap_or([1.0; 3]);
    let rotation = unit_quaternion(r).ok_or_else(|| {
        ParseError::new(
            format!("{path}.rotation"),
            "rotation quaternion has zero length",
        )
    })?;
    Ok(Trs {
        translation: Vector3::from(t),
        rotation,
        scale: Vector3::from(s),
    })
}

/// The unit quaternion of `[x, y, z, w]`, normalised after scaling by the largest component
/// (so that huge components do not overflow the norm, nor tiny ones underflow it); `None`
/// for a zero (or non-finite) quaternion.
pub(crate) fn unit_quaternion(r: [f64; 4]) -> Option<Quat> {
    let largest = r.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    if !(largest > 0.0 && largest.is_finite()) {
        return None;
    }
    let q = Quaternion::new(
        r[3] / largest,
        r[0] / largest,
        r[1] / largest,
        r[2] / largest,
    );
    Some(Quat::new_normalize(q))
}

/// The parent of every node (checking each node has at most one).
fn node_parents(json: &Value) -> Result<Vec<Option<usize>>, ParseError> {
    let nodes = json
        .get("nodes")
        .and_then(Value::as_array)
        .map(Vec::as_slice)
        .unwrap_or(&[]);
    let mut parents = vec![None; nodes.len()];
    for (i, node) in nodes.iter().enumerate() {
        let Some(children) = node.get("children").and_then(Value::as_array) else {
            continue;
        };
        for (k, c) in children.iter().enumerate() {
            let place = format!("nodes[{i}].children[{k}]");
            let c = c
                .as_u64()
                .map(|c| c as usize)
                .filter(|&c| c < nodes.len())
                .ok_or_else(|| ParseError::new(&place, "not a valid node index"))?;
            if c == i {
                return Err(ParseError::new(
                    &place,
                    format!("joint cycle: node {c} lists itself as a child"),
                ));
            }
            if parents[c].is_some() {
                return Err(ParseError::new(
                    &place,
                    format!("node {c} has more than one parent"),
                ));
            }
            parents[c] = Some(i);
        }
    }
    // A joint cycle (every node of it has one parent, so no root above it): found by
    // walking up from every node once, marking the nodes whose ancestry is known.
    // 0: not visited, 1: on the current walk, 2: known to reach a root.
    let mut state = vec![0u8; nodes.len()];
    let mut walk = Vec::new();
    for start in 0..nodes.len() {
        let mut cur = Some(start);
        while let Some(n) = cur {
            match state[n] {
                2 => break,
                1 => {
                    return Err(ParseError::new(
                        format!("nodes[{n}]"),
                        "joint cycle: the node is its own ancestor (the hierarchy must be a tree)",
                    ));
                }
                _ => {
                    state[n] = 1;
                    walk.push(n);
                    cur = parents[n];
                }
            }
        }
        for n in walk.drain(..) {
            state[n] = 2;
        }
    }
    Ok(parents)
}

fn build_rig(
    json: &Value,
    buffers: &[Vec<u8>],
    skin_index: usize,
) -> Result<(Rig, Vec<usize>), ParseError> {
    let skin_path = format!("skins[{skin_index}]");
    let skin = &json["skins"][skin_index];
    let nodes = json
        .get("nodes")
        .and_then(Value::as_array)
        .map(Vec::as_slice)
        .unwrap_or(&[]);
    let listed = skin
        .get("joints")
        .and_then(Value::as_array)
        .ok_or_else(|| ParseError::new(&skin_path, "missing 'joints'"))?;
    if listed.len() > crate::error::MAX_JOINTS {
        return Err(crate::error::too_many_joints(
            format!("{skin_path}.joints"),
            listed.len(),
        ));
    }
    let skin_joints: Vec<usize> = listed
        .iter()
        .enumerate()
        .map(|(k, j)| {
            j.as_u64()
                .map(|j| j as usize)
                .filter(|&j| j < nodes.len())
                .ok_or_else(|| {
                    ParseError::new(format!("{skin_path}.joints[{k}]"), "not a valid node index")
                })
        })
        .collect::<Result<_, _>>()?;
    if skin_joints.is_empty() {
        return Err(ParseError::new(&skin_path, "the skin has no joints"));
    }
    let parents = node_parents(json)?;
    // The skeleton: skin joints and every node above them.
    let mut in_skeleton = vec![false; nodes.len()];
    for &j in &skin_joints {
        let mut cur = Some(j);
        let mut steps = 0;
        while let Some(n) = cur {
            if in_skeleton[n] {
                break;
            }
            in_skeleton[n] = true;
            cur = parents[n];
            steps += 1;
            if steps > nodes.len() {
                return Err(ParseError::new(
                    format!("nodes[{n}]"),
                    "the node hierarchy has a cycle",
                ));
            }
        }
    }
    let skeleton_nodes: Vec<usize> = (0..nodes.len()).filter(|&n| in_skeleton[n]).collect();
    if skeleton_nodes.len() > crate::error::MAX_JOINTS {
        return Err(crate::error::too_many_joints(
            &skin_path,
            skeleton_nodes.len(),
        ));
    }
    let mut local_of_node = vec![usize::MAX; nodes.len()];
    for (k, &n) in skeleton_nodes.iter().enumerate() {
        local_of_node[n] = k;
    }
    let is_skin_joint: std::collections::HashSet<usize> = skin_joints.iter().copied().collect();
    let mut seen_names = std::collections::HashSet::new();
    let mut joints = Vec::with_capacity(skeleton_nodes.len());
    for &n in &skeleton_nodes {
        let path = format!("nodes[{n}]");
        let mut name = nodes[n]
            .get("name")
            .and_then(Value::as_str)
            .map_or_else(|| format!("node{n}"), str::to_owned);
        if !seen_names.insert(name.clone()) {
            name = format!("{name}#{n}");
            seen_names.insert(name.clone());
        }
        let mut joint = Joint::new(
            name,
            parents[n].map(|p| local_of_node[p]),
            node_trs(&nodes[n], &path)?,
        );
        joint.kind = if is_skin_joint.contains(&n) {
            JointKind::Skin
        } else {
            JointKind::Helper
        };
        joints.push(joint);
    }
    let (mut skeleton, new_index) =
        Skeleton::from_unordered(joints).map_err(|e| ParseError::new(&skin_path, e.to_string()))?;
    skeleton.set_default_dofs();
    let mut joint_nodes = vec![0; skeleton_nodes.len()];
    for (k, &n) in skeleton_nodes.iter().enumerate() {
        joint_nodes[new_index[k]] = n;
    }
    let skeleton_of_skin_joint: Vec<usize> = skin_joints
        .iter()
        .map(|&n| new_index[local_of_node[n]])
        .collect();

    // Inverse bind matrices, indexed by skeleton joint.
    let mut inverse_bind = vec![Matrix4::identity(); skeleton.len()];
    if let Some(acc) = index_field(skin, "inverseBindMatrices", &skin_path)? {
        let m = read_accessor_as(
            json,
            buffers,
            acc,
            16,
            &format!("{skin_path}.inverseBindMatrices"),
        )?;
        if m.len() / 16 < skin_joints.len() {
            return Err(ParseError::new(
                format!("accessors[{acc}]"),
                format!(
                    "has {} inverse bind matrices for {} joints",
                    m.len() / 16,
                    skin_joints.len()
                ),
            ));
        }
        for (k, &j) in skeleton_of_skin_joint.iter().enumerate() {
            let mat = Matrix4::from_column_slice(&m[16 * k..16 * k + 16]);
            if let Some(problem) = mat.iter().find_map(|&v| coordinate_problem(v)) {
                return Err(ParseError::new(
                    format!("accessors[{acc}]"),
                    format!("matrix {k}: {problem}"),
                ));
            }
            inverse_bind[j] = mat;
        }
    }

    let mut meshes = Vec::new();
    for (n, node) in nodes.iter().enumerate() {
        let path = format!("nodes[{n}]");
        if index_field(node, "skin", &path)? != Some(skin_index) {
            continue;
        }
        let Some(mesh_index) = index_field(node, "mesh", &path)? else {
            continue;
        };
        let name = node
            .get("name")
            .and_then(Value::as_str)
            .map_or_else(|| format!("mesh{mesh_index}"), str::to_owned);
        let mut mesh =
            read_skinned_mesh(json, buffers, mesh_index, &skeleton_of_skin_joint, &path)?;
        mesh.name = name;
        mesh.inverse_bind = inverse_bind.clone();
        meshes.push(mesh);
    }

    let animations = read_animations(json, buffers, &local_of_node, &new_index)?;
    let pose = skeleton.rest_pose();
    Ok((
        Rig {
            skeleton,
            pose,
            meshes,
            animations,
        },
        joint_nodes,
    ))
}

fn read_skinned_mesh(
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

fn read_animations(
    json: &Value,
    buffers: &[Vec<u8>],
    local_of_node: &[usize],
    new_index: &[usize],
) -> Result<Vec<Animation>, ParseError> {
    let anims = json
        .get("animations")
        .and_then(Value::as_array)
        .map(Vec::as_slice)
        .unwrap_or(&[]);
    let mut out = Vec::with_capacity(anims.len());
    for (a, anim) in anims.iter().enumerate() {
        let path = format!("animations[{a}]");
        let samplers = anim
            .get("samplers")
            .and_then(Value::as_array)
            .map(Vec::as_slice)
            .unwrap_or(&[]);
        let mut animation = Animation {
            name: anim
                .get("name")
                .and_then(Value::as_str)
                .map_or_else(|| format!("animation{a}"), str::to_owned),
            ..Default::default()
        };
        let channels = anim
            .get("channels")
            .and_then(Value::as_array)
            .map(Vec::as_slice)
            .unwrap_or(&[]);
        for (c, ch) in channels.iter().enumerate() {
            let cpath = format!("{path}.channels[{c}]");
            let target = ch
                .get("target")
                .ok_or_else(|| ParseError::new(&cpath, "missing 'target'"))?;
            let Some(node) = index_field(target, "node", &format!("{cpath}.target"))? else {
                continue;
            };
            let Some(&local) = local_of_node.get(node).filter(|&&l| l != usize::MAX) else {
                continue;
            };
            let target_kind = match target.get("path").and_then(Value::as_str) {
                Some("translation") => ChannelTarget::Translation,
                Some("rotation") => ChannelTarget::Rotation,
                Some("scale") => ChannelTarget::Scale,
                _ => continue, // morph weights and extensions do not move joints
            };
            let s = required_index(ch, "sampler", &cpath)?;
            let spath = format!("{path}.samplers[{s}]");
            let sampler = samplers
                .get(s)
                .ok_or_else(|| ParseError::new(&cpath, format!("sampler {s} does not exist")))?;
            let interpolation = match sampler
                .get("interpolation")
                .and_then(Value::as_str)
                .unwrap_or("LINEAR")
            {
                "STEP" => Interpolation::Step,
                "CUBICSPLINE" => Interpolation::CubicSpline,
                _ => Interpolation::Linear,
            };
            let times = read_accessor_as(
                json,
                buffers,
                required_index(sampler, "input", &spath)?,
                1,
                &format!("{spath}.input"),
            )?;
            if times.iter().any(|t| !t.is_finite()) || times.windows(2).any(|w| w[1] < w[0]) {
                return Err(ParseError::new(
                    format!("{spath}.input"),
                    "key times must be finite and increasing",
                ));
            }
            let width = if target_kind == ChannelTarget::Rotation {
                4
            } else {
                3
            };
            let raw = read_accessor_as(
                json,
                buffers,
                required_index(sampler, "output", &spath)?,
                width,
                &format!("{spath}.output"),
            )?;
            let per_key = if interpolation == Interpolation::CubicSpline {
                3
            } else {
                1
            };
            if raw.len() != times.len() * per_key * width {
                return Err(ParseError::new(
                    format!("{spath}.output"),
                    format!("has {} values for {} keys", raw.len() / width, times.len()),
                ));
            }
            let problem = if width == 3 {
                raw.iter().find_map(|&v| coordinate_problem(v))
            } else {
                raw.iter()
                    .any(|v| !v.is_finite())
                    .then(|| "values are not finite".to_string())
            };
            if let Some(problem) = problem {
                return Err(ParseError::new(format!("{spath}.output"), problem));
            }
            let values = raw
                .chunks(width)
                .map(|v| {
                    if width == 4 {
                        // Scaled by the largest component, so that normalising it later
                        // cannot overflow (cubic-spline tangents are kept as they are).
                        let largest = v.iter().fold(0.0f64, |m, x| m.max(x.abs()));
                        let k = if per_key == 1 && largest > 1.0 {
                            largest
                        } else {
                            1.0
                        };
                        [v[0] / k, v[1] / k, v[2] / k, v[3] / k]
                    } else {
                        [v[0], v[1], v[2], 0.0]
                    }
                })
                .collect::<Vec<[f64; 4]>>();
            animation.channels.push(AnimationChannel {
                joint: new_index[local],
                target: target_kind,
                interpolation,
                times,
                values,
            });
        }
        out.push(animation);
    }
    Ok(out)
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
