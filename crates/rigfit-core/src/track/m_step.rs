//! The M-step: Levenberg-Marquardt on the weighted pulls of eq. (20) (or eq. 21) plus a
//! prior toward the frame's start pose (rotations, and the places of free joints below the
//! root), the ties of IK goals and the joints' soft limits.

use super::Tracker;
use super::texture::TexturePoint;
use crate::engine::{ChainCrossMoments, NormalSink, SkeletonNormalEquations, SubtreeMoments};
use crate::joint_model::{Ties, limit_residuals, translation_limit_residuals};
use crate::kinematics::{DofLayout, ForwardKinematics};
use crate::math::{Point3, Vector3};
use crate::skeleton::{JointDof, Pose, Skeleton};

/// A point pulled toward a target with a weight.
#[derive(Clone, Copy, Debug)]
pub(super) struct Pull {
    pub(super) point: TexturePoint,
    pub(super) target: Point3,
    pub(super) weight: f64,
}

/// Texture points blended with weights in this range get their exact Jacobian (eq. 3);
/// outside it, the dominant joint's (an error of at most 5% in the other's columns).
const EXACT_BLEND_MIN: f64 = 0.05;
const EXACT_BLEND_MAX: f64 = 0.95;

impl Tracker {
    /// Levenberg-Marquardt steps on `sum w |x(theta) - target|^2` (eq. 20 or 21) plus the
    /// rotation prior toward `start` and each limited joint's excess over its limits.
    /// With `exact_blend`, blended points get their exact Jacobian; otherwise their
    /// dominant joint's (cheaper, slightly biased: for the annealing levels above the
    /// noise level).
    /// `relax` scales each step (over-relaxed EM: with the M-step's cost quadratic, any
    /// factor below 2 still lowers it, and EM's slow directions converge faster).
    pub(super) fn fit(
        &mut self,
        pulls: &[Pull],
        start: &Pose,
        steps: usize,
        exact_blend: bool,
        relax: f64,
    ) {
        let mut relaxed: Vec<f64> = Vec::new();
        if pulls.is_empty() {
            return;
        }
        let skeleton = &self.model.skeleton;
        let parent = |j: usize| skeleton.joint(j).parent;
        let mut ne = match self.normal.take() {
            Some(ne) => ne,
            None => SkeletonNormalEquations::new(&self.layout, parent),
        };
        let inv_h = 1.0 / self.model.height;
        let prior = self.options.prior_weight;
        let held = if self.options.hold_free_joints {
            held_free_joints(&self.layout, skeleton)
        } else {
            Vec::new()
        };
        let limits = self.options.limit_weight;
        let layout = &self.layout;
        let mut ties = Ties::new(layout, skeleton, 0.0);
        if !ties.is_empty() {
            ties.weight = Ties::WEIGHT * pulls.iter().map(|p| p.weight).sum::<f64>();
        }
        // A tie couples two branches of the tree: the dense form holds it.
        ne.set_allow_tree(ties.is_empty());
        // The prior toward the frame's start, for either form of the objective below.
        let prior_at = |pose: &Pose, add: &mut dyn FnMut(f64, f64, usize, f64)| {
            prior_toward_start(layout, &held, start, pose, prior, inv_h, add)
        };
        let objective = |pose: &Pose,
                         fk: &ForwardKinematics,
                         ne: Option<(&mut SubtreeMoments, &mut SkeletonNormalEquations)>|
         -> f64 {
            let mut cost = 0.0;
            match ne {
                Some((moments, ne)) => {
                    ne.clear();
                    moments.reset(skeleton.len());
                    let mut blended = Vec::new();
                    let mut split = Vec::new();
                    let mut lower: Vec<(usize, Vector3)> = Vec::new();
                    for pull in pulls {
                        let x = pull.point.world(fk);
                        let r = (x - pull.target) * inv_h;
                        let w = pull.point.weight;
                        if !exact_blend || !(EXACT_BLEND_MIN..=EXACT_BLEND_MAX).contains(&w) {
                            // Nearly rigid: the dominant joint's Jacobian.
                            let j = pull.point.joints[usize::from(w < 0.5)];
                            moments.add_point(fk, j, &x, &r, pull.weight);
                            continue;
                        }
                        // Blended on one chain (eq. 3): rigid on the upper joint (summarised
                        // by its moments), plus the columns only the lower part moves.
                        let from = lower.len();
                        match pull.point.chain_split(fk, layout, inv_h, &mut lower) {
                            Some(upper) => {
                                moments.add_point(fk, upper, &x, &r, pull.weight);
                                split.push((pull.weight, r, upper, x, from..lower.len()));
                            }
                            None => blended.push((pull, r)),
                        }
                    }
                    // Blended points need the tree or dense form for their Jacobian, the
                    // weighted sum of both parts' (exact, not summarised by moments).
                    ne.set_allow_articulated(
                        blended.is_empty() && split.is_empty() && ties.is_empty(),
                    );
                    ne.assemble_points(moments, fk, inv_h);
                    let mut cols: Vec<(usize, Vector3)> = Vec::new();
                    for (pull, r) in blended {
                        cols.clear();
                        pull.point.jacobian(fk, layout, inv_h, &mut cols);
                        ne.add_point_columns(&r, pull.weight, &cols);
                    }
                    // The split points' lower columns: their own block, their share of
                    // `J^T r`, and their products with the upper chain's columns (summed
                    // by their moments).
                    let mut cross = ChainCrossMoments::new(layout.len());
                    for (w, r, upper, x, range) in split {
                        let low = &lower[range];
                        for (a, &(ca, va)) in low.iter().enumerate() {
                            let wa = va * w;
                            ne.add_jtr(ca, wa.dot(&r));
                            for &(cb, vb) in &low[a..] {
                                ne.add_jtj(ca, cb, wa.dot(&vb));
                            }
                            cross.add(fk, ca, upper, &x, &wa);
                        }
                    }
                    cross.assemble(fk, layout, inv_h, ne);
                    // The ties: each tied joint at its place in the other's frame.
                    ties.each(layout, fk, inv_h, &mut cols, |r, w, c| {
                        ne.add_point_columns(r, w, c)
                    });
                    prior_at(pose, &mut |r, w, col, d| ne.add_scalar(r, w, col, d));
                    // Only the axes outside their limits: inside, the hinge-shaped cost is
                    // flat and a zero row would only damp the joint.
                    all_limit_residuals(
                        layout,
                        skeleton,
                        pose,
                        limits,
                        inv_h,
                        &mut |r, w, col, d| {
                            if r != 0.0 {
                                ne.add_scalar(r, w, col, d)
                            }
                        },
                    );
                    ne.cost()
                }
                None => {
                    for pull in pulls {
                        let r = (pull.point.world(fk) - pull.target) * inv_h;
                        cost += pull.weight * r.norm_squared();
                    }
                    let mut cols = Vec::new();
                    ties.each(layout, fk, inv_h, &mut cols, |r, w, _| {
                        cost += w * r.norm_squared()
                    });
                    prior_at(pose, &mut |r, w, _, _| cost += w * r * r);
                    all_limit_residuals(
                        layout,
                        skeleton,
                        pose,
                        limits,
                        inv_h,
                        &mut |r, w, _, _| cost += w * r * r,
                    );
                    cost
                }
            }
        };
        let mut fk = ForwardKinematics::new(skeleton, &self.pose);
        let mut trial_fk = fk.clone();
        let mut trial = self.pose.clone();
        for _ in 0..steps {
            let cost = objective(&self.pose, &fk, Some((&mut self.moments, &mut ne)));
            let mut improved = false;
            for _ in 0..6 {
                let Some(step) = ne.solve(self.lambda) else {
                    self.lambda *= 10.0;
                    continue;
                };
                trial.clone_from(&self.pose);
                if relax == 1.0 {
                    layout.apply(&mut trial, step);
                } else {
                    relaxed.clear();
                    relaxed.extend(step.iter().map(|d| d * relax));
                    layout.apply(&mut trial, &relaxed);
                }
                trial_fk.update(skeleton, &trial);
                let trial_cost = objective(&trial, &trial_fk, None);
                if trial_cost <= cost {
                    std::mem::swap(&mut self.pose, &mut trial);
                    std::mem::swap(&mut fk, &mut trial_fk);
                    self.lambda = (self.lambda / 3.0).max(1e-7);
                    improved = true;
                    break;
                }
                self.lambda *= 10.0;
            }
            if !improved {
                break;
            }
        }
        self.normal = Some(ne);
    }
}

/// The prior `Phi`: each rotating joint's rotation vector away from `start`, per axis, handed to
/// `add(residual, weight, column, derivative)`; and each of the `held` free joints'
/// ([`held_free_joints`]) translation away from `start` (in heights, `inv_h` one over the
/// height). A free joint's rotation, like the root's, moves with the data alone (holding it
/// too was measured worse on both halves: BENCHMARKS.md).
fn prior_toward_start(
    layout: &DofLayout,
    held: &[bool],
    start: &Pose,
    pose: &Pose,
    weight: f64,
    inv_h: f64,
    add: &mut dyn FnMut(f64, f64, usize, f64),
) {
    if weight <= 0.0 {
        return;
    }
    for j in 0..layout.joint_count() {
        let Some(o) = layout.offset(j) else { continue };
        let delta = (start.local[j].rotation.inverse() * pose.local[j].rotation).scaled_axis();
        match layout.dof(j) {
            JointDof::Ball => (0..3).for_each(|a| add(delta[a], weight, o + a, 1.0)),
            JointDof::Hinge { axis } => add(delta.dot(&axis.normalize()), weight, o, 1.0),
            JointDof::Free if held.get(j).copied().unwrap_or(false) => {
                let moved = pose.local[j].translation - start.local[j].translation;
                (0..3).for_each(|a| add(moved[a] * inv_h, weight, o + a, inv_h));
            }
            _ => {}
        }
    }
}

/// The free joints whose translation the prior holds
/// ([`super::TrackOptions::hold_free_joints`]): those below a moving joint that carry joints
/// of their own (a hip node or an IK goal a clip translates, with a leg or a hand below it).
/// Where the data does not pin such a joint's place (a limb sliding along itself) it would
/// wander from frame to frame. The topmost free joints (the body's root) and free leaves (a
/// marker, pinned by its own points) move with the data alone.
fn held_free_joints(layout: &DofLayout, skeleton: &Skeleton) -> Vec<bool> {
    let n = layout.joint_count();
    // Most rigs have none (their one free joint is the root): nothing to allocate.
    if !(0..n).any(|j| layout.dof(j) == JointDof::Free && skeleton.joint(j).parent.is_some()) {
        return Vec::new();
    }
    (0..n)
        .map(|j| {
            let carries = !skeleton.children(j).is_empty();
            if layout.offset(j).is_none() || layout.dof(j) != JointDof::Free || !carries {
                return false;
            }
            let mut at = skeleton.joint(j).parent;
            while let Some(p) = at {
                if layout.offset(p).is_some() {
                    return true;
                }
                at = skeleton.joint(p).parent;
            }
            false
        })
        .collect()
}

/// The soft limits' residuals of `pose` at `weight`: each limited rotation's excess
/// (radians, [`limit_residuals`]) and each boxed translation's (heights, `inv_h` one over
/// the height, [`translation_limit_residuals`]), handed to `add(residual, weight, column,
/// derivative)`.
fn all_limit_residuals(
    layout: &DofLayout,
    skeleton: &Skeleton,
    pose: &Pose,
    weight: f64,
    inv_h: f64,
    add: &mut dyn FnMut(f64, f64, usize, f64),
) {
    limit_residuals(layout, skeleton, pose, weight, &mut |r, w, col| {
        add(r, w, col, 1.0)
    });
    translation_limit_residuals(layout, skeleton, pose, weight, inv_h, add);
}

#[cfg(test)]
mod tests {
    use rand::{Rng, SeedableRng};

    use super::*;
    use crate::humanoid::humanoid;
    use crate::math::Quat;
    use crate::track::{ArticulatedModel, TrackOptions};

    /// Every texture point of `tracker` pulled to where it is in `truth`, with weight 1.
    fn exact_pulls(
        tracker: &Tracker,
        skeleton: &crate::skeleton::Skeleton,
        truth: &Pose,
    ) -> Vec<Pull> {
        let fk = ForwardKinematics::new(skeleton, truth);
        tracker
            .texture
            .iter()
            .map(|t| Pull {
                point: *t,
                target: t.world(&fk),
                weight: 1.0,
            })
            .collect()
    }

    /// With every texture point pulled to where it is in a known pose, the M-step finds it,
    /// with skin that slides near the joints (bending exponent 2) and with rigid parts.
    #[test]
    fn m_step_recovers_a_pose_from_exact_targets() {
        let rig = humanoid();
        let model = ArticulatedModel::from_rig(&rig, 1500).expect("model");
        for bending_exponent in [2.0, 1e6] {
            let options = TrackOptions {
                bending_exponent,
                ..TrackOptions::default()
            };
            let mut tracker = Tracker::new(model.clone(), options).expect("tracker");
            let mut rng = rand::rngs::StdRng::seed_from_u64(5);
            let mut truth = rig.pose.clone();
            for j in 1..truth.local.len() {
                let w = Vector3::new(rng.random(), rng.random(), rng.random()) * 0.3;
                truth.local[j].rotation *= Quat::from_scaled_axis(w);
            }
            truth.local[0].translation += Vector3::new(0.05, -0.02, 0.03);
            let pulls = exact_pulls(&tracker, &rig.skeleton, &truth);
            let start = rig.pose.clone();
            tracker.options.prior_weight = 0.0;
            tracker.fit(&pulls, &start, 30, true, 1.0);
            let a = rig.skeleton.joint_positions(&tracker.pose);
            let b = rig.skeleton.joint_positions(&truth);
            let err = a
                .iter()
                .zip(&b)
                .map(|(p, q)| (p - q).norm())
                .fold(0.0, f64::max);
            assert!(
                err < 1e-3 * rig.height(),
                "bending exponent {bending_exponent}: largest joint error {err}"
            );
        }
    }

    /// Data pulling a joint far outside its limits: with the soft limits the fit stops near
    /// them; without them it follows the data.
    #[test]
    fn soft_limits_hold_a_joint_the_data_pull_outside() {
        use crate::skeleton::JointLimits;
        let mut rig = humanoid();
        let elbow = rig.skeleton.find("LeftForeArm").expect("elbow");
        let limits = JointLimits {
            min: Vector3::from_element(-0.2),
            max: Vector3::from_element(0.2),
        };
        rig.skeleton.set_dof(elbow, JointDof::Ball, Some(limits));
        let model = ArticulatedModel::from_rig(&rig, 1500).expect("model");
        let mut truth = rig.pose.clone();
        truth.local[elbow].rotation *= Quat::from_scaled_axis(Vector3::new(0.0, 0.0, 1.2));
        let excess = |weight: f64| {
            let options = TrackOptions {
                prior_weight: 0.0,
                limit_weight: weight,
                ..TrackOptions::default()
            };
            let mut tracker = Tracker::new(model.clone(), options).expect("tracker");
            let pulls = exact_pulls(&tracker, &rig.skeleton, &truth);
            tracker.fit(&pulls, &rig.pose, 30, true, 1.0);
            let joint = rig.skeleton.joint(elbow);
            let relative =
                (joint.rest.rotation.inverse() * tracker.pose.local[elbow].rotation).scaled_axis();
            crate::joint_model::limit_excess(&JointDof::Ball, &limits, &relative).norm()
        };
        let (free, held) = (excess(0.0), excess(1000.0));
        assert!(
            free > 0.8,
            "without limits the elbow follows the data: {free}"
        );
        assert!(held < 0.1, "with soft limits it stays near them: {held}");
    }
}
