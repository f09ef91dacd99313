//! Fitting: Levenberg-Marquardt on eq. (1) of Cannavò et al. with the matches fixed. Each
//! model point is pulled to a target (the weighted mean of its matches, Dewaele eq. 20 form,
//! or the stroke point at the same fraction of arclength), plus `Phi(p)`. Joint limits
//! are not enforced here: they choose among fitted hypotheses (`solver`).
//! [`Fitter`] holds the pose being fitted and the buffers its steps reuse.

use super::chains::{self, Assignment};
use super::setup::Setup;
use crate::engine::{NormalSink, SkeletonNormalEquations, SubtreeMoments};
use crate::joint_model::joint_limit_residuals;
use crate::kinematics::{DofLayout, ForwardKinematics};
use crate::math::Point3;
use crate::skeleton::{JointDof, Pose};

/// Levenberg-Marquardt steps of a full arclength fit.
pub(super) const FULL_FIT_STEPS: usize = 20;

/// A fit stops when a step lowers the cost by less than this fraction.
const CONVERGED_DECREASE: f64 = 1e-3;

/// Per model point, the point it is pulled to and the pull's weight.
type Targets = Vec<Option<(Point3, f64)>>;

/// The pose being fitted, and the Levenberg-Marquardt state.
pub(super) struct Fitter {
    pub pose: Pose,
    /// Levenberg-Marquardt steps and match updates run so far.
    pub iterations: usize,
    /// The weight of `Phi(p)` in force (lowered for the final polish).
    pub prior_weight: f64,
    /// The weight of the joints' excess over their limits (zero: limits are not fitted).
    pub limit_weight: f64,
    /// The damping, adapted from step to step.
    lambda: f64,
    /// Buffers reused from step to step: the model points' subtree moments, the normal
    /// equations of the last layout, the forward kinematics of the last pose reached (with
    /// that pose), and a trial pose with its forward kinematics.
    moments: SubtreeMoments,
    normal: Option<SkeletonNormalEquations>,
    fk: Option<(Pose, ForwardKinematics)>,
    trial: Option<(Pose, ForwardKinematics)>,
    /// The assignment of the last arclength fit and its targets (a trial assignment is
    /// fitted twice when it is accepted; a solve has one setup).
    arclength: Option<(Vec<Assignment>, Targets)>,
}

/// The damping of the first Levenberg-Marquardt step of a fit from a new start.
const INITIAL_DAMPING: f64 = 1e-3;

impl Fitter {
    /// Goes on where `other`, a fitter of the same solve run elsewhere, stopped: its pose
    /// and damping, its steps counted too.
    pub fn continue_after(&mut self, other: &Fitter) {
        self.pose.clone_from(&other.pose);
        self.lambda = other.lambda;
        self.iterations += other.iterations;
    }

    pub fn new(pose: Pose, prior_weight: f64) -> Self {
        Self {
            pose,
            iterations: 0,
            prior_weight,
            limit_weight: 0.0,
            lambda: INITIAL_DAMPING,
            moments: SubtreeMoments::new(),
            normal: None,
            fk: None,
            trial: None,
            arclength: None,
        }
    }

    /// The weighted cost of `pose` (whose forward kinematics is `fk`): model point `k`
    /// pulled to `targets[k]`, plus `Phi(p)`. With `ne`, also
    /// accumulates the normal equations (the points' through their subtree moments).
    fn objective(
        &self,
        setup: &Setup,
        layout: &DofLayout,
        targets: &[Option<(Point3, f64)>],
        pose: &Pose,
        fk: &ForwardKinematics,
        mut ne: Option<(&mut SubtreeMoments, &mut SkeletonNormalEquations)>,
    ) -> f64 {
        let skeleton = setup.skeleton;
        let mut cost = 0.0;
        if let Some((moments, _)) = ne.as_mut() {
            moments.reset(skeleton.len());
        }
        let inv_height = 1.0 / setup.height;
        for (k, mp) in setup.model.points.iter().enumerate() {
            let Some((target, w)) = targets[k] else {
                continue;
            };
            let p = fk.point(mp.joint, &mp.local);
            let r = (p - target) * inv_height;
            match ne.as_mut() {
                Some((moments, _)) => moments.add_point(fk, mp.joint, &p, &r, w),
                None => cost += w * r.norm_squared(),
            }
        }
        if let Some((moments, ne)) = ne.as_mut() {
            ne.assemble_points(moments, fk, inv_height);
        }
        let prior = self.prior_weight;
        // A scalar residual `r` with derivative `d` along parameter `col`.
        let mut scalar = |ne: &mut Option<(&mut SubtreeMoments, &mut SkeletonNormalEquations)>,
                          r: f64,
                          w: f64,
                          col: usize,
                          d: f64| match ne {
            Some((_, ne)) => ne.add_scalar(r, w, col, d),
            None => cost += w * r * r,
        };
        let limit_weight = self.limit_weight;
        for j in 0..skeleton.len() {
            let Some(o) = layout.offset(j) else { continue };
            joint_limit_residuals(layout, skeleton, pose, j, limit_weight, &mut |r, w, col| {
                scalar(&mut ne, r, w, col, 1.0)
            });
            // Phi(p): rotation vectors away from the start pose, per joint and axis.
            let start = &setup.start.local[j];
            let delta = (start.rotation.inverse() * pose.local[j].rotation).scaled_axis();
            match layout.dof(j) {
                JointDof::Ball => (0..3).for_each(|a| scalar(&mut ne, delta[a], prior, o + a, 1.0)),
                JointDof::Hinge { axis } => {
                    scalar(&mut ne, delta.dot(&axis.normalize()), prior, o, 1.0)
                }
                // A joint that translates (other than the character's root, which the
                // multi-start places) also keeps near its start position, in heights.
                JointDof::Free if Some(j) != setup.root => {
                    let moved = (pose.local[j].translation - start.translation) * inv_height;
                    // Translations are in the rig's units, the residual in heights.
                    (0..3).for_each(|a| scalar(&mut ne, moved[a], prior, o + a, inv_height));
                    (0..3).for_each(|a| scalar(&mut ne, delta[a], prior, o + 3 + a, 1.0));
                }
                _ => {}
            }
        }
        match ne {
            Some((_, ne)) => ne.cost(),
            None => cost,
        }
    }

    /// One Levenberg-Marquardt step pulling model point `k` to `targets[k]` (weighted),
    /// plus `Phi(p)`. Returns the relative decrease of the cost.
    pub fn step(
        &mut self,
        setup: &Setup,
        layout: &DofLayout,
        targets: &[Option<(Point3, f64)>],
    ) -> f64 {
        if layout.is_empty() || setup.interrupt.is_set() {
            return 0.0;
        }
        let skeleton = setup.skeleton;
        let parent = |j: usize| skeleton.joint(j).parent;
        let mut ne = match self.normal.take() {
            Some(ne) if ne.is_for(layout) => ne,
            Some(mut ne) => {
                ne.set_layout(layout, parent);
                ne
            }
            None => SkeletonNormalEquations::new(layout, parent),
        };
        ne.clear();
        let (mut fk_pose, mut fk) = match self.fk.take() {
            Some((mut p, mut fk)) => {
                if p != self.pose {
                    fk.update(skeleton, &self.pose);
                    p.clone_from(&self.pose);
                }
                (p, fk)
            }
            None => (
                self.pose.clone(),
                ForwardKinematics::new(skeleton, &self.pose),
            ),
        };
        let (mut trial, mut trial_fk) = self
            .trial
            .take()
            .unwrap_or_else(|| (self.pose.clone(), fk.clone()));
        let mut moments = std::mem::take(&mut self.moments);
        let cost = self.objective(
            setup,
            layout,
            targets,
            &self.pose,
            &fk,
            Some((&mut moments, &mut ne)),
        );
        self.moments = moments;
        let mut decrease = 0.0;
        for _ in 0..8 {
            let Some(step) = ne.solve(self.lambda) else {
                self.lambda *= 10.0;
                continue;
            };
            trial.clone_from(&self.pose);
            layout.apply(&mut trial, step);
            trial_fk.update(skeleton, &trial);
            let trial_cost = self.objective(setup, layout, targets, &trial, &trial_fk, None);
            if trial_cost <= cost {
                fk_pose.clone_from(&trial);
                std::mem::swap(&mut fk, &mut trial_fk);
                std::mem::swap(&mut self.pose, &mut trial);
                self.lambda = (self.lambda / 3.0).max(1e-7);
                decrease = (cost - trial_cost) / cost.max(1e-300);
                break;
            }
            self.lambda *= 10.0;
        }
        self.normal = Some(ne);
        self.fk = Some((fk_pose, fk));
        self.trial = Some((trial, trial_fk));
        decrease
    }

    /// At most `steps` Levenberg-Marquardt steps with every chain point pulled to the stroke
    /// point at the same fraction of arclength, stopping once a step barely helps.
    pub fn fit_arclength(
        &mut self,
        setup: &Setup,
        layout: &DofLayout,
        assignment: &[Assignment],
        steps: usize,
    ) {
        let (fitted, targets) = match self.arclength.take() {
            Some((fitted, targets)) if fitted == assignment => (fitted, targets),
            _ => (
                assignment.to_vec(),
                chains::arclength_targets(setup, assignment),
            ),
        };
        for _ in 0..steps {
            self.iterations += 1;
            if self.step(setup, layout, &targets) < CONVERGED_DECREASE {
                break;
            }
        }
        self.arclength = Some((fitted, targets));
    }

    /// [`Fitter::fit_arclength`] with the joints' excess over their limits fitted too, at
    /// `weight`: where the strokes leave a joint free (a twist), it turns back within its
    /// limits; where they hold it outside, the fit shows what keeping to them costs.
    pub fn fit_within_limits(
        &mut self,
        setup: &Setup,
        layout: &DofLayout,
        assignment: &[Assignment],
        steps: usize,
        weight: f64,
    ) {
        self.limit_weight = weight;
        self.fit_arclength(setup, layout, assignment, steps);
        self.limit_weight = 0.0;
    }

    /// Puts joints with no assigned bone at or below them back to their start transform and
    /// holds them there; returns the layout of the joints that may still move.
    pub fn keep_unexplained_at_start(
        &mut self,
        setup: &Setup,
        assignment: &[Assignment],
    ) -> DofLayout {
        let skeleton = setup.skeleton;
        let mut explained = vec![false; skeleton.len()];
        for (chain, _) in assignment.iter().flatten() {
            for &b in chain {
                explained[setup.model.bones[b].joint] = true;
                // A bone whose tip translates is carried by its tip.
                explained[setup.model.bones[b].child] |= setup.model.bones[b].tip_translates;
            }
        }
        for j in (0..skeleton.len()).rev() {
            if explained[j] {
                if let Some(p) = skeleton.joint(j).parent {
                    explained[p] = true;
                }
            }
        }
        let mut movable = setup.movable.clone();
        for j in 0..skeleton.len() {
            if !explained[j] && Some(j) != setup.root {
                self.pose.local[j].rotation = setup.start.local[j].rotation;
                self.pose.local[j].translation = setup.start.local[j].translation;
                movable[j] = false;
            }
        }
        setup.layout(&movable)
    }
}
