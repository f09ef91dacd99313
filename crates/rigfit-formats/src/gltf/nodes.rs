//! The glTF scene graph: node transforms (their number arrays and unit quaternions) and
//! the parent of every node, checked to form a tree.

use nalgebra::Quaternion;
use rigfit_core::{Matrix4, Quat, Trs, Vector3};
use serde_json::Value;

use crate::error::{ParseError, coordinate_problem};

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
pub(super) fn node_trs(node: &Value, path: &str) -> Result<Trs, ParseError> {
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
pub(super) fn node_parents(json: &Value) -> Result<Vec<Option<usize>>, ParseError> {
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
