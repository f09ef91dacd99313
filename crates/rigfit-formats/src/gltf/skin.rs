//! A glTF skin to a [`Rig`]: the skeleton (skin joints and the nodes above them), its
//! inverse bind matrices, and the meshes and animations that move it.

use rigfit_core::{Joint, JointKind, Matrix4, Rig, Skeleton};
use serde_json::Value;

use super::accessor::{index_field, read_accessor_as};
use super::animation::read_animations;
use super::mesh::read_skinned_mesh;
use super::nodes::{node_parents, node_trs};
use crate::error::{ParseError, coordinate_problem};

pub(super) fn build_rig(
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
    let mut rig = Rig {
        skeleton,
        pose,
        meshes,
        animations,
    };
    rig.free_translating_joints();
    rig.tie_goals();
    rig.note_clip_places();
    Ok((rig, joint_nodes))
}
