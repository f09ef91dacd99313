//! The paper's matching (Cannavò et al. 2020, eq. 1): softassign between model points and
//! stroke samples with an outlier row and column, Sinkhorn normalisation, and a match scale
//! lowered step by step (deterministic annealing), each match followed by a fit.

use super::fitting::Fitter;
use super::setup::Setup;
use crate::engine::fitting_loop::{
    EmModel, Ending, Expectation, Maximisation, Schedule, Stage, Widths, run_em,
};
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

/// The paper's matching and fitting as a model of the engine's fitting loop: the E-step is
/// softassign at the loop's scale, the M-step aligns to its matches.
struct MatchAndAlign<'s, 'a, 'f> {
    setup: &'s Setup<'a>,
    fitter: &'f mut Fitter,
    layout: &'s DofLayout,
    allowed: AllowedBones<'s>,
    /// Alignment steps per match.
    aligns: usize,
    /// With `settling`, the E-step ends the loop once the matches stop changing.
    settling: bool,
    matches: MatchMatrix,
    /// Whether the pose moved since the last match (or nothing was matched yet).
    stale: bool,
}

impl<'s, 'a, 'f> MatchAndAlign<'s, 'a, 'f> {
    /// Nothing matched yet; `aligns` alignment steps per match.
    fn new(
        setup: &'s Setup<'a>,
        fitter: &'f mut Fitter,
        layout: &'s DofLayout,
        allowed: AllowedBones<'s>,
        aligns: usize,
        settling: bool,
    ) -> Self {
        Self {
            setup,
            fitter,
            layout,
            allowed,
            aligns,
            settling,
            matches: MatchMatrix::default(),
            stale: true,
        }
    }
}

impl EmModel for MatchAndAlign<'_, '_, '_> {
    type Error = std::convert::Infallible;

    fn interrupted(&self) -> bool {
        self.setup.interrupt.is_set()
    }

    fn e_step(&mut self, stage: &Stage) -> Result<Expectation, Self::Error> {
        let next = match_now(self.setup, self.fitter, stage.sigma, self.allowed);
        let first = stage.iteration == 1;
        let change = (self.settling && !first).then(|| next.change_from(&self.matches));
        self.matches = next;
        self.stale = false;
        Ok(match change {
            Some(change) if change < 1e-3 => Expectation::Settled,
            _ => Expectation::Ready,
        })
    }

    fn m_step(&mut self, _stage: &Stage) -> Result<Maximisation, Self::Error> {
        for _ in 0..self.aligns {
            align(self.setup, self.fitter, self.layout, &self.matches);
        }
        self.fitter.iterations += 1;
        self.stale = true;
        Ok(Maximisation::moved(f64::INFINITY))
    }
}

/// Runs the fitting loop on the paper's matching; the matches at the final pose.
fn match_and_align(mut model: MatchAndAlign, schedule: &Schedule) -> MatchMatrix {
    let Ok(report) = run_em(&mut model, schedule);
    // Settling ends on a match of the final pose; a pass through every scale or an
    // interrupt after an alignment matches once more (annealing keeps its last scale's).
    if model.settling && model.stale && report.ending != Ending::Settled {
        model.matches = match_now(model.setup, model.fitter, report.sigma, model.allowed);
    }
    model.matches
}

/// One annealing pass: for each scale, match then align.
pub(super) fn anneal(
    setup: &Setup,
    fitter: &mut Fitter,
    layout: &DofLayout,
    sigmas: &[f64],
    allowed: AllowedBones,
) -> MatchMatrix {
    let schedule = Schedule {
        widths: Widths::List(sigmas.to_vec()),
        rounds: 1,
        final_rounds: 1,
        tolerance: None,
    };
    let model = MatchAndAlign::new(
        setup,
        fitter,
        layout,
        allowed,
        setup.options.gauss_newton_steps,
        false,
    );
    match_and_align(model, &schedule)
}

/// Iterates at the final scale until the match stops changing.
pub(super) fn settle(
    setup: &Setup,
    fitter: &mut Fitter,
    layout: &DofLayout,
    sigma: f64,
    allowed: AllowedBones,
) -> MatchMatrix {
    let schedule = Schedule {
        widths: Widths::List(vec![sigma]),
        rounds: 0,
        final_rounds: setup.options.max_final_iterations,
        tolerance: None,
    };
    let model = MatchAndAlign::new(setup, fitter, layout, allowed, 1, true);
    match_and_align(model, &schedule)
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
