//! The M-step's normal equations summed vertex by vertex, as before the moment form, and the
//! test that the moment form takes the same step.
#![allow(clippy::all)]

use rayon::prelude::*;

use super::block_moments::add_jtr;
use super::gauss_newton::anchor_weights;
use super::gauss_newton::{damp_solve_and_apply, data_terms};
use super::patch_system::{BlendPair, DiagonalEntry, RigidityPair};
use super::{PatchSystem, SolveError, StepWeights, gauss_newton_step};
use crate::engine::linear_algebra::{Block6 as Block, NormalSink};
use crate::geometry::TriMesh;
use crate::math::{Matrix3, Point3, Vector3, exp_rotation, skew};
use crate::surface::estep::VertexTargets;
use crate::surface::model::{PatchModel, PatchOptions, PatchPose};
use crate::surface::test_meshes::torus;
use rand::{Rng, SeedableRng};

/// The rigidity term of one pair of neighbouring patches `k < l`, summed vertex by vertex:
/// its blocks `(k,k)`, `(l,l)`, `(k,l)` and its gradient, patch `k`'s then `l`'s.
struct PairTerms {
    k: usize,
    l: usize,
    blocks: [Block; 3],
    gradient: [f64; 12],
}

/// Adds `w * J_a^T J_b` for `J = [-[q]x, I]` (the Jacobian of a prediction with respect to
/// its patch's rotation increment and centre shift).
#[inline]
pub fn add_jtj(block: &mut Block, w: f64, qa: &Vector3, qb: &Vector3) {
    let sa = skew(qa);
    let sb = skew(qb);
    // J_a^T J_b = [[-[qa]x [qb]x, [qa]x], [-[qb]x, I]].
    let tl = -(sa * sb);
    for r in 0..3 {
        for c in 0..3 {
            block[6 * r + c] += w * tl[(r, c)];
            block[6 * r + c + 3] += w * sa[(r, c)];
            block[6 * (r + 3) + c] -= w * sb[(r, c)];
        }
        block[6 * (r + 3) + r + 3] += w;
    }
}

/// Adds `J_a^T P J_b` for `J = [-[q]x, I]` and a symmetric metric `P` (already weighted).
#[inline]
pub fn add_jtpj(block: &mut Block, p: &Matrix3, qa: &Vector3, qb: &Vector3) {
    let sa = skew(qa);
    let sb = skew(qb);
    // J_a^T P J_b = [[-[qa]x P [qb]x, [qa]x P], [-P [qb]x, P]].
    let sap = sa * p;
    let tl = -(sap * sb);
    let bl = -(p * sb);
    for r in 0..3 {
        for c in 0..3 {
            block[6 * r + c] += tl[(r, c)];
            block[6 * r + c + 3] += sap[(r, c)];
            block[6 * (r + 3) + c] += bl[(r, c)];
            block[6 * (r + 3) + c + 3] += p[(r, c)];
        }
    }
}

/// One Gauss-Newton step on `data * sum_v W_v |x(v) - ybar_v|_P^2 + rigidity * E_r`, applied
/// to `pose` in place, where `P = n n^T + tangential (I - n n^T)` for the vertex normal `n`.
pub fn reference_step(
    model: &PatchModel,
    system: &PatchSystem,
    pose: &mut PatchPose,
    positions: &[Point3],
    normals: &[Vector3],
    targets: &VertexTargets,
    weights: &StepWeights,
    anchor: Option<&PatchPose>,
) -> Result<(), SolveError> {
    let n = model.patch_count();
    let mut blocks = vec![[0.0; 36]; system.block_count()];
    let mut gradient = vec![0.0; 6 * n];

    // Data term, vertex by vertex: residual x(v) - ybar_v with weight W_v; the Jacobian of
    // x(v) is sum_k alpha_k(v) J_k(v) (eq. 2).
    let data_terms: Vec<(usize, Matrix3, Vector3)> =
        data_terms(positions, normals, targets, weights)
            .into_iter()
            .map(|t| (t.vertex, t.metric, t.residual))
            .collect();
    // Two halves in parallel, each into its own blocks, then summed.
    let half = data_terms.len().div_ceil(2).max(1);
    let partial: Vec<(Vec<Block>, Vec<f64>)> = data_terms
        .par_chunks(half)
        .map(|terms| {
            let mut blocks = vec![[0.0; 36]; system.block_count()];
            let mut gradient = vec![0.0; 6 * n];
            let mut blend: Vec<(usize, f64, Vector3)> = Vec::with_capacity(16);
            for &(v, metric, r) in terms {
                let pr = metric * r;
                blend.clear();
                blend.extend(
                    model
                        .blend(v)
                        .map(|(k, a)| (k, a, model.offset(pose, k, v))),
                );
                let first = model.blend_start[v] as usize;
                for (i, &(k, alpha, q)) in blend.iter().enumerate() {
                    add_jtr(&mut gradient[6 * k..6 * k + 6], alpha, &q, &pr);
                    let DiagonalEntry { block, weight } = system.diagonal[first + i];
                    add_jtpj(&mut blocks[block as usize], &(metric * weight), &q, &q);
                }
                for &BlendPair {
                    first: i,
                    second: j,
                    block,
                    weight,
                } in system.vertex_pairs(v)
                {
                    let (_, _, qa) = blend[i as usize];
                    let (_, _, qb) = blend[j as usize];
                    add_jtpj(&mut blocks[block as usize], &(metric * weight), &qa, &qb);
                }
            }
            (blocks, gradient)
        })
        .collect();
    for (b, g) in partial {
        for (t, s) in blocks.iter_mut().zip(&b) {
            for (x, y) in t.iter_mut().zip(s) {
                *x += y;
            }
        }
        for (x, y) in gradient.iter_mut().zip(&g) {
            *x += y;
        }
    }

    // Rigidity (eq. 4): residual x_k(v) - x_l(v) over v in P_k and P_l, weight
    // alpha_k(v) + alpha_l(v); the Jacobian is J_k(v) for patch k and -J_l(v) for patch l.
    let rigidity: Vec<PairTerms> = system
        .rigidity_pairs
        .par_iter()
        .map(
            |&RigidityPair {
                 k,
                 l,
                 contact,
                 small_piece,
                 ..
             }| {
                let mut b = [[0.0; 36]; 3];
                let mut g = [0.0; 12];
                // A contact link's vertices and weight, or both patches' vertices and weights
                // alpha_k(v) + alpha_l(v).
                let vertices: Vec<(usize, f64)> = match contact {
                    Some(i) => {
                        let link = &model.contacts[i];
                        link.vertices
                            .iter()
                            .map(|&v| (v as usize, link.weight))
                            .collect()
                    }
                    None => model.members[k]
                        .iter()
                        .chain(&model.members[l])
                        .map(|&v| {
                            let v = v as usize;
                            (v, model.alpha(k, v) + model.alpha(l, v))
                        })
                        .collect(),
                };
                let scale = if small_piece {
                    weights.within_pieces
                } else {
                    1.0
                };
                for (v, beta) in vertices {
                    let beta = weights.rigidity * scale * beta;
                    let qk = model.offset(pose, k, v);
                    let ql = model.offset(pose, l, v);
                    let r = (pose.centre[k] + qk) - (pose.centre[l] + ql);
                    add_jtj(&mut b[0], beta, &qk, &qk);
                    add_jtj(&mut b[1], beta, &ql, &ql);
                    add_jtj(&mut b[2], -beta, &qk, &ql);
                    add_jtr(&mut g[..6], beta, &qk, &r);
                    add_jtr(&mut g[6..], -beta, &ql, &r);
                }
                PairTerms {
                    k,
                    l,
                    blocks: b,
                    gradient: g,
                }
            },
        )
        .collect();
    // Pairs are (k, l) with k < l: the cross block is stored as it is.
    for PairTerms {
        k,
        l,
        blocks: b,
        gradient: g,
    } in rigidity
    {
        let ids = [(k, k), (l, l), (k, l)].map(|(a, c)| {
            system
                .pattern
                .block_index(a, c)
                .expect("a pair of the pattern")
        });
        for (&slot, block) in ids.iter().zip(&b) {
            for (t, s) in blocks[slot].iter_mut().zip(block) {
                *t += s;
            }
        }
        for i in 0..6 {
            gradient[6 * k + i] += g[i];
            gradient[6 * l + i] += g[6 + i];
        }
    }

    // The anchor term, vertex by vertex: residual x_k(v) - a_k(v) over v in P_k, weight w_k.
    if let Some(anchor) = anchor {
        let patch_weights = anchor_weights(model, targets, weights);
        for (k, &w) in patch_weights.iter().enumerate() {
            let slot = system.pattern.block_index(k, k).expect("a diagonal block");
            for &v in &model.members[k] {
                let v = v as usize;
                let q = model.offset(pose, k, v);
                let r = model.prediction(pose, k, v) - model.prediction(anchor, k, v);
                add_jtj(&mut blocks[slot], w, &q, &q);
                add_jtr(&mut gradient[6 * k..6 * k + 6], w, &q, &r);
            }
        }
    }

    let mut equations = system.pattern.equations();
    for (block, position) in blocks.iter().zip(system.pattern.block_pairs()) {
        let (a, b) = (position.row as usize, position.column as usize);
        equations.add_jtj_block6(6 * a, 6 * b, block);
    }
    for (i, &g) in gradient.iter().enumerate() {
        equations.add_jtr(i, g);
    }
    damp_solve_and_apply(model, pose, &mut equations, targets, weights)
}

/// The moment form of the normal equations takes the same step as summing vertex by
/// vertex.
#[test]
fn moment_assembly_matches_vertex_by_vertex_sums() {
    let one = torus(30, 15);
    // Two pieces a little apart: contact links join them.
    let mut two = one.clone();
    let count = two.vertices.len() as u32;
    two.vertices.extend(
        one.vertices
            .iter()
            .map(|p| p + Vector3::new(2.75, 0.0, 0.0)),
    );
    two.triangles
        .extend(one.triangles.iter().map(|t| t.map(|i| i + count)));
    two.normals = None;
    for reference in [one, two] {
        check_moment_assembly(&reference);
    }
}

fn check_moment_assembly(reference: &TriMesh) {
    let model = PatchModel::new(reference, &PatchOptions::default()).expect("model");
    let pieces = model.piece_count();
    assert_eq!(model.contacts.is_empty(), pieces == 1, "{pieces} pieces");
    let system = PatchSystem::new(&model).expect("system");
    let mut rng = rand::rngs::StdRng::seed_from_u64(5);
    let mut pose = model.rest_pose();
    for k in 0..model.patch_count() {
        let w = Vector3::new(rng.random(), rng.random(), rng.random()) * 0.3;
        pose.rotation[k] = exp_rotation(&w).to_rotation_matrix().into_inner();
        pose.centre[k] += Vector3::new(rng.random(), rng.random(), rng.random()) * 0.05;
    }
    let positions = model.positions(&pose);
    let normals = model.normals(&pose);
    let n = model.vertex_count();
    let mut targets = VertexTargets {
        weight: vec![0.0; n],
        weighted_sum: vec![Vector3::zeros(); n],
        weighted_square: vec![0.0; n],
        ..Default::default()
    };
    for v in 0..n {
        if rng.random::<f64>() < 0.8 {
            let w: f64 = rng.random();
            let y =
                positions[v].coords + Vector3::new(rng.random(), rng.random(), rng.random()) * 0.1;
            targets.weight[v] = w;
            targets.weighted_sum[v] = y * w;
            targets.weighted_square[v] = w * y.norm_squared();
        }
    }
    // A patch unseen: the anchor term pulls it.
    for &v in &model.members[0] {
        let v = v as usize;
        targets.weight[v] = 0.0;
        targets.weighted_sum[v] = Vector3::zeros();
        targets.weighted_square[v] = 0.0;
    }
    let anchor = model.rest_pose();
    for (data, rigidity, tangential, anchored, within_pieces) in [
        (40.0, 0.0, 1.0, 0.0, 1.0),
        (40.0, 0.0, 0.0, 0.0, 1.0),
        (0.0, 3.0, 1.0, 0.0, 1.0),
        (40.0, 3.0, 0.3, 0.0, 1.0),
        (40.0, 3.0, 0.3, 0.5, 1.0),
        (40.0, 3.0, 0.3, 0.0, 20.0),
    ] {
        let weights = StepWeights {
            data,
            rigidity,
            within_pieces,
            damping: 1e-3,
            tangential,
            relaxation: 1.0,
            anchor: anchored,
        };
        let anchor = (anchored > 0.0).then_some(&anchor);
        let mut moment_pose = pose.clone();
        gauss_newton_step(
            &model,
            &system,
            &mut moment_pose,
            &positions,
            &normals,
            &targets,
            &weights,
            anchor,
        )
        .expect("step");
        let mut vertex_pose = pose.clone();
        reference_step(
            &model,
            &system,
            &mut vertex_pose,
            &positions,
            &normals,
            &targets,
            &weights,
            anchor,
        )
        .expect("step");
        for k in 0..model.patch_count() {
            let dr = (moment_pose.rotation[k] - vertex_pose.rotation[k])
                .abs()
                .max();
            let dc = (moment_pose.centre[k] - vertex_pose.centre[k]).norm();
            assert!(
                dr < 1e-9 && dc < 1e-9,
                "{data} {rigidity} {tangential} patch {k}: rotation {dr}, centre {dc}"
            );
        }
    }
}

/// A piece at most half the object's diagonal across is a part of it (a link, a limb's
/// capsule), held nearly rigid in the first iterations by `within_pieces`; a piece that
/// spans the object (a skinned body) bends from the start.
#[test]
fn only_the_parts_of_an_object_are_held_rigid_first() {
    let body = torus(30, 15);
    let mut object = body.clone();
    let count = object.vertices.len();
    object.vertices.extend(
        body.vertices
            .iter()
            .map(|p| Point3::from(p.coords * 0.2) + Vector3::new(1.6, 0.0, 0.0)),
    );
    object
        .triangles
        .extend(body.triangles.iter().map(|t| t.map(|i| i + count as u32)));
    object.normals = None;
    let model = PatchModel::new(&object, &PatchOptions::default()).expect("model");
    let system = PatchSystem::new(&model).expect("system");
    let part = model.component[model.vertex_patch[count] as usize];
    let within: Vec<_> = system
        .rigidity_pairs
        .iter()
        .filter(|pair| pair.contact.is_none())
        .collect();
    assert!(within.iter().any(|pair| pair.small_piece));
    assert!(within.iter().any(|pair| !pair.small_piece));
    for pair in within {
        assert_eq!(pair.small_piece, model.component[pair.k] == part);
    }
    // Contact links keep their own weight.
    assert!(
        system
            .rigidity_pairs
            .iter()
            .all(|pair| pair.contact.is_none() || !pair.small_piece)
    );
}
