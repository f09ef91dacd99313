//! The score that chooses among hypotheses: how well a pose explains the strokes under an
//! assignment, and the preferences that choose among equal explanations.

use super::chains::{Assignment, stroke_length, stroke_residuals};
use super::setup::Setup;
use super::solver::Solver;
use crate::joint_model::limit_excess;
use crate::kinematics::DofLayout;
use crate::skeleton::Pose;

/// Weight of the mean joint rotation (radians) against the mean squared stroke residual
/// (heights) when choosing among hypotheses (measured on the tuning half: 5e-4 against 2e-3
/// and 1e-4 when the rotations were squared, and against 2.5e-4 and 1e-3 unsquared; at 2e-3
/// bending a small rig's limbs far cost more than setting their strokes aside; since
/// session 17's search, 7e-4 against 3.5e-4, 5e-4 and 1e-3).
pub(super) const HYPOTHESIS_BEND_WEIGHT: f64 = 7e-4;

/// Weight of the mean squared excess of the joints over their limits (radians) when
/// choosing among hypotheses (measured on the tuning half: 1e-3 against 3e-4, 3e-3, 1e-2).
const HYPOTHESIS_LIMIT_WEIGHT: f64 = 1e-3;

/// A joint above the drawn chains bends at this many times the price of one on them
/// (measured: 2 keeps a single arm stroke on its arm rather than twisting the spine to hand
/// it to the other arm, at no cost on the corpus's held-out half).
const ABOVE_CHAIN_BEND_FACTOR: f64 = 2.0;

/// Weight of the squared turn (radians) and move (heights) of the character's root away
/// from the start pose when choosing among hypotheses: a tie-break. Measured against 1e-5
/// to 1e-3: larger weights keep far-turned bodies from turning (tuning half), and from 1e-5
/// on a hypothesis with a stroke on the wrong limb wins on the accuracy suite.
const HYPOTHESIS_ROOT_WEIGHT: f64 = 1e-6;

/// Weight of a stroke's squared length mismatch with its chain (heights) in the score.
const LENGTH_SCORE_WEIGHT: f64 = 0.05;

impl Solver<'_> {
    /// How well the current pose explains the strokes under `assignment`: the mean squared
    /// stroke residual (strays counted at the stray distance, more for longer strokes) plus
    /// a small preference for bending less.
    pub fn score(&self, assignment: &[Assignment], layout: &DofLayout) -> f64 {
        let (data, preference) = self.score_parts(&self.fitter.pose, assignment, layout);
        data + preference
    }

    /// [`Solver::score`] of `pose` in its two parts: how well the strokes are explained,
    /// and the preferences that choose among explanations (bending less, within the limits,
    /// the body where it stood).
    pub fn score_parts(
        &self,
        pose: &Pose,
        assignment: &[Assignment],
        layout: &DofLayout,
    ) -> (f64, f64) {
        let setup = &self.setup;
        let stray = setup.options.stray_distance;
        let strokes = assignment.len();
        let residuals = stroke_residuals(setup, pose, assignment);
        let bones = &setup.model.bones;
        // A stroke set aside costs by its length: a long stroke left unexplained (a neck
        // drawn whole) costs more than a short squiggle. Measured: this against no weight
        // and against weighting every stroke's residual by its length (better on the tuning
        // half, but then a leg's stroke took the undrawn leg on the accuracy suite).
        let mean_length =
            (0..strokes).map(|s| stroke_length(setup, s)).sum::<f64>() / strokes.max(1) as f64;
        let data = (0..strokes)
            .map(|s| match &assignment[s] {
                // Arclength matching stretches a chain over its stroke: a chain shorter or
                // longer than the stroke fits as well unless its length is counted too.
                Some((chain, _)) if !chain.iter().any(|&b| bones[b].tip_translates) => {
                    let length: f64 = chain.iter().map(|&b| bones[b].length).sum();
                    let mismatch = (stroke_length(setup, s) - length) / setup.height;
                    residuals[s].powi(2) + LENGTH_SCORE_WEIGHT * mismatch * mismatch
                }
                Some(_) => residuals[s].powi(2),
                None => {
                    stray * stray * stroke_length(setup, s) / mean_length.max(f64::MIN_POSITIVE)
                }
            })
            .sum::<f64>()
            / strokes.max(1) as f64;
        // Strokes alone cannot always tell a body from its mirror image turned around (ball
        // joints bend either way), so among fits that explain the strokes equally, the one
        // that bends the joints least away from the start pose wins. A joint that turns a
        // drawn bone bends for its stroke; one above the drawn chains (a spine twisted so the
        // other arm takes an arm's stroke) costs more. A joint's bend costs its angle, not
        // its square: the preference then favours bending the few joints the strokes ask
        // for over spreading a bend across many, and a limb drawn far may bend far (squared,
        // raising one leg to the side cost a small rig more than setting the leg's stroke
        // aside; BENCHMARKS.md).
        let covered = covered_joints(setup, assignment);
        // And the one the rig's joints can take: limits (from the rig's clips or a joints
        // file) never hold a limb back in the fit, they choose among explanations. Both are
        // means over the joints that move.
        let (mut bend, mut outside, mut moved) = (0.0, 0.0, 0usize);
        for j in (0..setup.skeleton.len())
            .filter(|&j| Some(j) != setup.root && layout.offset(j).is_some())
        {
            let joint = setup.skeleton.joint(j);
            let rotation = &pose.local[j].rotation;
            let angle = (setup.start.local[j].rotation.inverse() * rotation).angle();
            let factor = if covered[j] {
                1.0
            } else {
                ABOVE_CHAIN_BEND_FACTOR
            };
            bend += factor * angle;
            if let Some(limits) = &joint.limits {
                let relative = (joint.rest.rotation.inverse() * rotation).scaled_axis();
                outside += limit_excess(&joint.dof, limits, &relative).norm_squared();
            }
            moved += 1;
        }
        let bend = bend / moved.max(1) as f64;
        let outside = outside / moved.max(1) as f64;
        // And the one that keeps the body where it stood: a few strokes on limbs say little
        // about where the body is, and what was not drawn keeps its pose.
        let turned = setup.root.map_or(0.0, |r| {
            let (start, now) = (&setup.start.local[r], &pose.local[r]);
            (start.rotation.inverse() * now.rotation).angle().powi(2)
                + ((now.translation - start.translation) / setup.height).norm_squared()
        });
        let preference = HYPOTHESIS_BEND_WEIGHT * bend
            + HYPOTHESIS_ROOT_WEIGHT * turned
            + HYPOTHESIS_LIMIT_WEIGHT * outside;
        (data, preference)
    }
}

/// Which joints turn a bone some stroke covers under `assignment`.
fn covered_joints(setup: &Setup, assignment: &[Assignment]) -> Vec<bool> {
    let mut covered = vec![false; setup.skeleton.len()];
    for (chain, _) in assignment.iter().flatten() {
        chain
            .iter()
            .for_each(|&b| covered[setup.model.bones[b].joint] = true);
    }
    covered
}
