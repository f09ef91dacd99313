//! The paper's matching (Cannavò et al. 2020, eq. 1): softassign between model points and
//! stroke samples with an outlier row and column, Sinkhorn normalisation, and a match scale
//! lowered step by step (deterministic annealing), each match followed by a fit.

use super::fitting::Fitter;
use super::setup::Setup;
use crate::engine::{MatchMatrix, SoftassignParams, softassign};
use crate::kinematics::{DofLayout, ForwardKinematics};
use crate::math::Point3;

/// Per stroke, the bones its samples may match (`None` = any); `None` overall = no limit.
pub(super) type AllowedBones<'b> = Option<&'b [Option<Vec<bool>>]>;

/// Match scales from `from` to `to` (fractions of the height) over `steps`: beta grows
/// geometrically, or by a fixed amount as in the paper.
pub(super) fn schedule(height: f64, from: f64, to: f64, steps: usize, additive: bool) -> Vec<f64> {
    let steps = steps.max(2);
    let (b0, b1) = (1.0 / (from * from), 1.0 / (to * to));
    (0..steps)
        .map(|s| {
            let t = s as f64 / (steps - 1) as f64;
            let beta = if additive {
                b0 + (b1 - b0) * t
            } else {
                b0 * (b1 / b0).powf(t)
            };
            height / beta.sqrt()
        })
        .collect()
}

/// Softassign of the model points at `world` against the stroke samples at scale `sigma`.
fn softassign_at(
    setup: &Setup,
    world: &[Point3],
    sigma: f64,
    allowed: AllowedBones,
) -> MatchMatrix {
    let zeta = (setup.options.outlier_distance * setup.height).powi(2);
    let params = SoftassignParams {
        beta: 1.0 / (sigma * sigma),
        zeta,
        sinkhorn_iterations: 30,
        sinkhorn_tolerance: 1e-3,
    };
    let pinned = &setup.strokes.allowed_bones;
    let model = &setup.model;
    let stroke_of = &setup.strokes.stroke_of;
    softassign(world, &setup.strokes.points, &params, |k, i| {
        let s = stroke_of[i];
        let b = model.points[k].bone;
        let ok_pin = pinned[s].as_ref().is_none_or(|a| a[b]);
        let ok_chain = allowed.is_none_or(|a| a[s].as_ref().is_none_or(|a| a[b]));
        ok_pin && ok_chain
    })
}

/// Softassign at the fitter's current pose.
fn match_now(setup: &Setup, fitter: &Fitter, sigma: f64, allowed: AllowedBones) -> MatchMatrix {
    let fk = ForwardKinematics::new(setup.skeleton, &fitter.pose);
    softassign_at(setup, &setup.model.world_points(&fk), sigma, allowed)
}

/// One fit step with `omega` fixed: each model point pulled to the weighted mean of its
/// matches (Dewaele eq. 20 form).
fn align(setup: &Setup, fitter: &mut Fitter, layout: &DofLayout, matches: &MatchMatrix) {
    let targets: Vec<_> = (0..matches.rows())
        .map(|k| matches.target(k, &setup.strokes.points))
        .collect();
    fitter.step(setup, layout, &targets);
}

/// One annealing pass: for each scale, match then align.
pub(super) fn anneal(
    setup: &Setup,
    fitter: &mut Fitter,
    layout: &DofLayout,
    sigmas: &[f64],
    allowed: AllowedBones,
) -> MatchMatrix {
    let mut matches = MatchMatrix::default();
    for &sigma in sigmas {
        if setup.interrupt.is_set() {
            break;
        }
        matches = match_now(setup, fitter, sigma, allowed);
        for _ in 0..setup.options.gauss_newton_steps {
            align(setup, fitter, layout, &matches);
        }
        fitter.iterations += 1;
    }
    matches
}

/// Iterates at the final scale until the match stops changing.
pub(super) fn settle(
    setup: &Setup,
    fitter: &mut Fitter,
    layout: &DofLayout,
    sigma: f64,
    allowed: AllowedBones,
) -> MatchMatrix {
    let mut matches = match_now(setup, fitter, sigma, allowed);
    for _ in 0..setup.options.max_final_iterations {
        if setup.interrupt.is_set() {
            break;
        }
        align(setup, fitter, layout, &matches);
        fitter.iterations += 1;
        let next = match_now(setup, fitter, sigma, allowed);
        let change = next.change_from(&matches);
        matches = next;
        if change < 1e-3 {
            break;
        }
    }
    matches
}

/// Eq. (1) at the fitter's pose: `sum omega |y - v|^2 - zeta sum omega`.
pub(super) fn energy(setup: &Setup, fitter: &Fitter, matches: &MatchMatrix) -> f64 {
    let fk = ForwardKinematics::new(setup.skeleton, &fitter.pose);
    let world = setup.model.world_points(&fk);
    let zeta = (setup.options.outlier_distance * setup.height).powi(2);
    let data = &setup.strokes.points;
    let mut e = 0.0;
    for k in 0..matches.rows() {
        for &(i, w) in matches.row(k) {
            e += w * ((data[i as usize] - world[k]).norm_squared() - zeta);
        }
    }
    e
}

/// For each stroke, the joints of the bones that took a good share of its points, in
/// stroke order (the paper's method has no chains to report).
pub(super) fn bones_by_weight(setup: &Setup, matches: &MatchMatrix) -> Vec<Vec<usize>> {
    let strokes = &setup.strokes;
    // For each sample, its best bone.
    let mut best = vec![(0.0, usize::MAX); strokes.points.len()];
    for k in 0..matches.rows() {
        let b = setup.model.points[k].bone;
        for &(i, w) in matches.row(k) {
            if w > best[i as usize].0 {
                best[i as usize] = (w, b);
            }
        }
    }
    let mut out = vec![Vec::new(); strokes.count()];
    for (i, &(w, b)) in best.iter().enumerate() {
        if w > 0.2 && b != usize::MAX {
            let joint = setup.model.bones[b].joint;
            let list = &mut out[strokes.stroke_of[i]];
            if !list.contains(&joint) {
                list.push(joint);
            }
        }
    }
    out
}
