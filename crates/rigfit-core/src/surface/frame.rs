//! Fitting one frame: the patches start from their last motion continued, then EM through
//! the engine's fitting loop: the E-step of eq. (7)-(8) over the blended predictions, one
//! Gauss-Newton step on eq. (15) per M-step, and `sigma` set by the M-step (eq. 15), falling
//! no faster than the annealing rate.

use super::carry::carry_unseen;
use super::estep::{Observations, VertexTargets, e_step_predicted};
use super::model::Predictions;
use super::solve::{StepWeights, gauss_newton_step, patch_support};
use super::{FrameFit, SurfaceError, SurfaceTracker};
use crate::engine::fitting_loop::{
    EmModel, Expectation, Maximisation, Schedule, Stage, Widths, continued_rotation, run_em,
};
use crate::math::{Point3, Vector3, rotation_quat, rotation_toward};

/// Every iteration's thinning (`SurfaceOptions::points_per_vertex`) keeps at least this many
/// points a patch on average: a rigid fit among 15% outliers (at eight, two spheres of 370
/// vertices each against 3,500 points lost their track).
const THINNED_POINTS_PER_PATCH: usize = 24;

impl SurfaceTracker {
    pub(super) fn track_in_pool(&mut self, data: &Observations) -> Result<FrameFit, SurfaceError> {
        data.check()?;
        self.cache.clear();
        let last = self.pose.clone();
        let piece_steps = self
            .piece_tree
            .as_mut()
            .and_then(|tree| tree.track(&data.points));
        match &piece_steps {
            // Each patch moved as its piece moved in the pieces' tree.
            Some(steps) => {
                super::piece_tree::PieceTree::move_patches(&self.model, &mut self.pose, steps)
            }
            None if self.options.extrapolate => self.continue_motion(&last),
            None => {}
        }
        // Where the patches short of data are held and carried from: the last frame's pose,
        // but a part found again where it came back into view (it was not where it was
        // lost).
        let returned = self
            .piece_tree
            .as_ref()
            .map(|tree| tree.returned_pieces())
            .unwrap_or_default();
        let moved_last = match &piece_steps {
            Some(steps) if !returned.is_empty() => {
                let mut held = last.clone();
                super::piece_tree::PieceTree::move_some_patches(
                    &self.model,
                    &mut held,
                    steps,
                    &returned,
                );
                Some(held)
            }
            _ => None,
        };
        let held_from = moved_last.as_ref().unwrap_or(&last);
        // After the pieces' tree took up most of the motion, a narrower first kernel.
        let first_sigma = match (&piece_steps, &self.options.piece_tree) {
            (Some(_), Some(tree)) => tree.initial_sigma,
            _ => self.options.initial_sigma,
        };
        let diagonal = self.model.diagonal;
        let min_sigma = self.options.min_sigma * diagonal;
        let merged = (self.options.merge_cell > 0.0).then(|| {
            // The points' mean spacing were they all on the reference's surface.
            let area: f64 = self.model.area.iter().sum();
            let spacing = (area / data.points.len() as f64).sqrt();
            data.merged(self.options.merge_cell * spacing)
        });
        let data = merged.as_ref().unwrap_or(data);
        let coarse_iterations = self
            .options
            .coarse_iterations
            .min(self.options.max_iterations.saturating_sub(1));
        // An object of rigid pieces (tracked with its pieces' tree) is thinned in every
        // iteration to about `points_per_vertex` points a vertex, while each patch keeps
        // enough points for its rigid fit among outliers. A skin that bends is not: thinned
        // so, BCN's error rose from 0.579% to 0.604% of the diagonal (BENCHMARKS.md).
        let per_vertex = self.options.points_per_vertex;
        let everywhere = if per_vertex > 0.0 && self.piece_tree.is_some() {
            let wanted = per_vertex * self.model.rest.len() as f64;
            let stride = (data.points.len() as f64 / wanted).floor() as usize;
            let fewest = THINNED_POINTS_PER_PATCH * self.model.patch_count();
            stride.min(data.points.len() / fewest.max(1)).max(1)
        } else {
            1
        };
        // Thinned only while each patch keeps a few points on average.
        let thinned = self.options.coarse_stride > 1
            && coarse_iterations > 0
            && data.points.len() / self.options.coarse_stride >= 8 * self.model.patch_count();
        // After fast motion the first width covers part of the last frame's largest step of
        // a well-seen patch: the motion continued misses by about as much as it changes.
        let fast = match (&self.previous, self.options.fast_start > 0.0) {
            (Some(previous), true) => {
                let radius = self.options.patches.radius * diagonal;
                (0..self.model.patch_count())
                    .filter(|&k| self.support.get(k).is_some_and(|&s| s >= 0.5))
                    .map(|k| {
                        let turn =
                            rotation_quat(&(last.rotation[k] * previous.rotation[k].transpose()));
                        (last.centre[k] - previous.centre[k]).norm() + turn.angle() * radius
                    })
                    .fold(0.0, f64::max)
                    * self.options.fast_start
            }
            _ => 0.0,
        };
        let schedule = Schedule {
            widths: Widths::Estimated {
                start: (first_sigma * diagonal).max(fast).max(min_sigma),
                floor: min_sigma,
                fall: self.options.anneal,
                preliminary: if thinned { coarse_iterations } else { 0 },
                hold: self.options.hold_while_moving,
            },
            rounds: 0,
            final_rounds: self.options.max_iterations,
            // The move measured is the Gauss-Newton step's, before relaxation.
            tolerance: Some(self.options.tolerance * diagonal),
        };
        let FrameScratch {
            mut predictions,
            mut normals,
            mut spare_positions,
        } = std::mem::take(&mut self.scratch);
        self.model.predictions_into(&self.pose, &mut predictions);
        self.model.blended_normals_into(&predictions, &mut normals);
        self.model
            .blended_positions_into(&predictions, &mut spare_positions);
        let mut frame = FrameEm {
            positions: spare_positions,
            normals,
            predictions,
            spare_positions: Vec::new(),
            targets: VertexTargets::default(),
            total: 0.0,
            anchor: (self.options.anchor > 0.0).then_some(held_from),
            stride: everywhere,
            tracker: self,
            data,
        };
        let report = run_em(&mut frame, &schedule)?;
        let FrameEm {
            mut positions,
            targets,
            predictions,
            normals,
            spare_positions,
            ..
        } = frame;
        self.scratch = FrameScratch {
            predictions,
            normals,
            spare_positions,
        };
        let support = patch_support(&self.model, &targets);
        if self.options.carry_unseen && support.iter().any(|&s| s < 1.0) {
            carry_unseen(&self.model, held_from, &mut self.pose, &support);
            positions = self.model.positions(&self.pose);
        }
        let laid = self.lay_pieces_rigidly(&mut positions);
        if positions.iter().any(|p| p.iter().any(|x| !x.is_finite())) {
            // Never hand out a broken mesh: the next frame starts again from this one's start.
            self.pose = last;
            return Err(SurfaceError::Diverged);
        }
        if let Some(tree) = self.piece_tree.as_mut() {
            tree.sync(&self.model, &self.pose, &support, laid.as_deref());
        }
        self.previous = Some(last);
        self.support = support;
        let total = targets.total_weight();
        let rms = if total > 0.0 {
            (targets.weighted_residual / total).sqrt()
        } else {
            0.0
        };
        Ok(FrameFit {
            positions,
            inliers: targets.inliers,
            rms,
            iterations: report.iterations,
            sigma: report.sigma,
        })
    }

    /// Constant velocity: apply the last frame's motion of each patch once more, in
    /// proportion to how well the patch was seen (a patch no point explained keeps still
    /// rather than flying on at the speed it had when it was lost).
    fn continue_motion(&mut self, last: &super::PatchPose) {
        let Some(previous) = &self.previous else {
            return;
        };
        for k in 0..self.model.patch_count() {
            let support = self.support.get(k).copied().unwrap_or(1.0);
            let continued = continued_rotation(&previous.rotation[k], &last.rotation[k]);
            self.pose.rotation[k] = if support >= 1.0 {
                continued
            } else {
                rotation_toward(&last.rotation[k], &continued, support)
            };
            self.pose.centre[k] = last.centre[k] + (last.centre[k] - previous.centre[k]) * support;
        }
    }
}

/// Buffers a frame writes over and hands to the next ([`SurfaceTracker`] keeps them).
#[derive(Clone, Debug, Default)]
pub(super) struct FrameScratch {
    predictions: Predictions,
    normals: Vec<Vector3>,
    spare_positions: Vec<Point3>,
}

/// One frame's EM as a model of the engine's fitting loop.
struct FrameEm<'t, 'd> {
    tracker: &'t mut SurfaceTracker,
    data: &'d Observations,
    /// Each patch's prediction of its vertices at the current pose (eq. 1), and their blend
    /// (eq. 2) with its normals.
    predictions: Predictions,
    positions: Vec<Point3>,
    normals: Vec<Vector3>,
    /// The positions before the last M-step: a buffer the next one writes over.
    spare_positions: Vec<Point3>,
    /// The last E-step's per-vertex targets and their total weight.
    targets: VertexTargets,
    total: f64,
    /// The last frame's pose, when patches short of data are pulled toward it
    /// (`SurfaceOptions::anchor`).
    anchor: Option<&'d super::PatchPose>,
    /// Every iteration's stride along the E-step's spatial order
    /// (`SurfaceOptions::points_per_vertex`).
    stride: usize,
}

impl EmModel for FrameEm<'_, '_> {
    type Error = SurfaceError;

    fn e_step(&mut self, stage: &Stage) -> Result<Expectation, SurfaceError> {
        let tracker = &mut *self.tracker;
        // The preliminary iterations run on one point in `coarse_stride` (or fewer).
        tracker.cache.set_stride(if stage.preliminary {
            tracker.options.coarse_stride.max(self.stride)
        } else {
            self.stride
        });
        let spent = std::mem::take(&mut self.targets);
        tracker.cache.recycle(spent);
        self.targets = e_step_predicted(
            &tracker.model,
            &self.predictions,
            &self.positions,
            self.data,
            stage.sigma,
            &tracker.options.data,
            &mut tracker.cache,
        );
        self.total = self.targets.total_weight();
        Ok(if self.total <= 1e-9 {
            Expectation::NoSupport
        } else {
            Expectation::Ready
        })
    }

    fn m_step(&mut self, stage: &Stage) -> Result<Maximisation, SurfaceError> {
        let tracker = &mut *self.tracker;
        let sigma = stage.sigma;
        let radius = tracker.options.patches.radius * tracker.model.diagonal;
        // Eq. 15: data term (1 / sigma^2 per the Gaussian of eq. 7) plus rigidity.
        let weights = StepWeights {
            data: 1.0 / (sigma * sigma),
            rigidity: tracker.options.rigidity / (radius * radius),
            within_pieces: if stage.preliminary {
                tracker.options.coarse_stiffness
            } else {
                1.0
            },
            damping: tracker.options.damping,
            tangential: tracker.options.tangential,
            relaxation: if stage.preliminary {
                tracker.options.coarse_relaxation
            } else {
                tracker.options.relaxation
            },
            anchor: tracker.options.anchor,
        };
        gauss_newton_step(
            &tracker.model,
            &tracker.system,
            &mut tracker.pose,
            &self.positions,
            &self.normals,
            &self.targets,
            &weights,
            self.anchor,
        )?;
        tracker
            .model
            .predictions_into(&tracker.pose, &mut self.predictions);
        let mut moved_to = std::mem::take(&mut self.spare_positions);
        tracker
            .model
            .blended_positions_into(&self.predictions, &mut moved_to);
        // Eq. 15's M-step for sigma: the weighted mean squared residual per coordinate.
        let sigma_em = (self.targets.residual(&moved_to) / (3.0 * self.total)).sqrt();
        // Root mean square displacement of the vertices in this iteration.
        let moved = (moved_to
            .iter()
            .zip(&self.positions)
            .map(|(a, b)| (a - b).norm_squared())
            .sum::<f64>()
            / self.positions.len().max(1) as f64)
            .sqrt();
        self.spare_positions = std::mem::replace(&mut self.positions, moved_to);
        tracker
            .model
            .blended_normals_into(&self.predictions, &mut self.normals);
        Ok(Maximisation {
            moved: moved / weights.relaxation,
            sigma_estimate: Some(sigma_em),
        })
    }
}
