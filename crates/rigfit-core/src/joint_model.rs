//! The joint model of a rig: which joints turn about one axis only (hinges) and the range
//! each joint turns through. A rig file rarely says; its clips do. A joint its clips only
//! ever turn about one axis becomes a hinge (as the knees and finger joints of the 27-DOF
//! hand of Dewaele et al. are), and every joint the clips turn gets the range they show,
//! widened by a margin. A joints file (read by `rigfit-formats`) may give or override the
//! model joint by joint. Posing keeps every joint's DOF unless a joints file says otherwise
//! and uses limits only to choose among poses that explain the strokes alike. Joints the
//! clips tie to another joint (an IK goal at the end of an arm, [`crate::Rig::tie_goals`])
//! are held there by the tracker (`Ties`).

use crate::animation::{Animation, ChannelTarget, Interpolation, quat_from_xyzw};
use crate::kinematics::{DofLayout, ForwardKinematics};
use crate::math::{Matrix3, Vector3};
use crate::skeleton::{JointDof, JointKind, JointLimits, JointTie, Pose, Skeleton};

/// What one joint may do: its degrees of freedom and the limits of its rotation, and for a
/// joint that translates, the box its translation keeps to (from its rest translation, the
/// rig's units).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct JointSpec {
    pub dof: JointDof,
    pub limits: Option<JointLimits>,
    pub translation: Option<JointLimits>,
}

/// How a joint model is learnt from clips.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ClipModelOptions {
    /// Radians added on each side of the range the clips show.
    pub margin: f64,
    /// A further share of the shown range added on each side.
    pub margin_share: f64,
    /// A joint is a hinge when its rotations' spread off their main axis is at most this
    /// share of the spread along it.
    pub hinge_off_axis: f64,
    /// A joint whose rotations stay within this angle (radians, RMS) of rest is not
    /// modelled (the clips say nothing about it).
    pub min_motion: f64,
    /// Fewest distinct keys a joint needs to be modelled.
    pub min_keys: usize,
}

impl Default for ClipModelOptions {
    fn default() -> Self {
        Self {
            margin: 0.35,
            margin_share: 0.25,
            hinge_off_axis: 0.15,
            min_motion: 0.05,
            min_keys: 8,
        }
    }
}

/// The rotation keys of every joint over all clips, as rotation vectors relative to the
/// joint's rest rotation (`rest^-1 * rotation`, axis times angle).
fn relative_rotations(skeleton: &Skeleton, animations: &[Animation]) -> Vec<Vec<Vector3>> {
    let mut keys: Vec<Vec<Vector3>> = vec![Vec::new(); skeleton.len()];
    for channel in animations.iter().flat_map(|a| &a.channels) {
        if channel.target != ChannelTarget::Rotation || channel.joint >= skeleton.len() {
            continue;
        }
        let rest = skeleton.joint(channel.joint).rest.rotation;
        let values = match channel.interpolation {
            Interpolation::CubicSpline => channel.values.iter().skip(1).step_by(3).collect(),
            _ => channel.values.iter().collect::<Vec<_>>(),
        };
        keys[channel.joint].extend(
            values
                .into_iter()
                .map(|v| (rest.inverse() * quat_from_xyzw(*v)).scaled_axis()),
        );
    }
    keys
}

/// The joint model the clips show (`None` for joints they do not turn, the character's
/// root, tips, helpers and joints that translate).
pub fn joint_model_from_clips(
    skeleton: &Skeleton,
    animations: &[Animation],
    options: &ClipModelOptions,
) -> Vec<Option<JointSpec>> {
    let root = skeleton.skin_root();
    relative_rotations(skeleton, animations)
        .into_iter()
        .enumerate()
        .map(|(j, keys)| {
            let joint = skeleton.joint(j);
            let modelled = Some(j) != root
                && joint.parent.is_some()
                && joint.kind == JointKind::Skin
                && joint.dof == JointDof::Ball;
            if !modelled || keys.len() < options.min_keys {
                return None;
            }
            spec_from_keys(&keys, options)
        })
        .collect()
}

/// A hinge or a limited ball from one joint's rotation vectors.
fn spec_from_keys(keys: &[Vector3], options: &ClipModelOptions) -> Option<JointSpec> {
    let n = keys.len() as f64;
    // Second moments about rest: their main axis is the hinge axis when there is one.
    let moments: Matrix3 = keys.iter().map(|v| v * v.transpose()).sum::<Matrix3>() / n;
    let eigen = moments.symmetric_eigen();
    let mut order = [0usize, 1, 2];
    order.sort_by(|&a, &b| eigen.eigenvalues[b].total_cmp(&eigen.eigenvalues[a]));
    let along = eigen.eigenvalues[order[0]].max(0.0).sqrt();
    if along < options.min_motion {
        return None;
    }
    let off = eigen.eigenvalues[order[1]].max(0.0).sqrt();
    let widen = |lo: f64, hi: f64| {
        let m = options.margin + options.margin_share * (hi - lo);
        (lo - m, hi + m)
    };
    if off <= options.hinge_off_axis * along {
        let mut axis: Vector3 = eigen.eigenvectors.column(order[0]).into_owned();
        // The axis the joint mostly turns positively about.
        if keys.iter().map(|v| v.dot(&axis)).sum::<f64>() < 0.0 {
            axis = -axis;
        }
        let angles = keys.iter().map(|v| v.dot(&axis));
        let lo = angles.clone().fold(f64::INFINITY, f64::min).min(0.0);
        let hi = angles.fold(f64::NEG_INFINITY, f64::max).max(0.0);
        let (lo, hi) = widen(lo, hi);
        return Some(JointSpec {
            dof: JointDof::Hinge { axis },
            limits: Some(JointLimits {
                min: Vector3::new(lo.max(-std::f64::consts::PI), 0.0, 0.0),
                max: Vector3::new(hi.min(std::f64::consts::PI), 0.0, 0.0),
            }),
            translation: None,
        });
    }
    // The rest pose is one the rig can take: the range always holds it.
    let mut min = Vector3::zeros();
    let mut max = Vector3::zeros();
    for v in keys {
        min = min.inf(v);
        max = max.sup(v);
    }
    let pi = std::f64::consts::PI;
    for a in 0..3 {
        let (lo, hi) = widen(min[a], max[a]);
        min[a] = lo.max(-pi);
        max[a] = hi.min(pi);
    }
    Some(JointSpec {
        dof: JointDof::Ball,
        limits: Some(JointLimits { min, max }),
        translation: None,
    })
}

impl JointSpec {
    /// The same joint as a ball bounded per axis (a hinge's range spread onto the axes its
    /// axis has components along): what a solver that turns every joint as a ball may use.
    pub fn as_ball(&self) -> JointSpec {
        match (self.dof, self.limits) {
            (JointDof::Hinge { axis }, limits) => {
                let axis = axis.normalize();
                let (lo, hi) = limits.map_or((-std::f64::consts::PI, std::f64::consts::PI), |l| {
                    (l.min.x, l.max.x)
                });
                let a = axis * lo;
                let b = axis * hi;
                JointSpec {
                    dof: JointDof::Ball,
                    limits: Some(JointLimits {
                        min: a.inf(&b),
                        max: a.sup(&b),
                    }),
                    translation: None,
                }
            }
            _ => *self,
        }
    }
}

/// `skeleton` with the limits its clips show, every joint kept a ball (hinges spread onto
/// the axes, see [`JointSpec::as_ball`]): the skeleton posing solves with by default
/// (`rigfit pose`, `rigfit serve`), its limits choosing among poses that explain the strokes
/// alike without changing what any joint can do.
pub fn with_clip_ranges(skeleton: &Skeleton, animations: &[Animation]) -> Skeleton {
    let ranges: Vec<Option<JointSpec>> =
        joint_model_from_clips(skeleton, animations, &ClipModelOptions::default())
            .into_iter()
            .map(|spec| spec.map(|s| s.as_ball()))
            .collect();
    let mut ranged = skeleton.clone();
    apply_joint_model(&mut ranged, &ranges);
    ranged
}

/// `skeleton` with the joint model its clips show ([`joint_model_from_clips`]): hinges where
/// the clips turn a joint about one axis only, and every turned joint's range as its limits.
/// The skeleton tracking fits (`rigfit track`), the limits soft in its M-step.
pub fn with_clip_model(skeleton: &Skeleton, animations: &[Animation]) -> Skeleton {
    let model = joint_model_from_clips(skeleton, animations, &ClipModelOptions::default());
    let mut modelled = skeleton.clone();
    apply_joint_model(&mut modelled, &model);
    modelled
}

/// Gives each joint its `model` entry (`None` leaves a joint as it is); returns how many
/// joints changed.
pub fn apply_joint_model(skeleton: &mut Skeleton, model: &[Option<JointSpec>]) -> usize {
    let mut changed = 0;
    for (j, spec) in model.iter().enumerate().take(skeleton.len()) {
        if let Some(spec) = spec {
            skeleton.set_dof(j, spec.dof, spec.limits);
            let rest = skeleton.joint(j).rest.translation;
            let translation = spec
                .translation
                .filter(|_| spec.dof == JointDof::Free)
                .map(|t| JointLimits {
                    min: rest + t.min,
                    max: rest + t.max,
                });
            skeleton.set_translation_limits(j, translation);
            changed += 1;
        }
    }
    changed
}

/// The soft translation-limit residuals of `pose`: for each joint `layout` moves that
/// translates and has [`crate::skeleton::Joint::translation_limits`], its local
/// translation's excess over them in heights (`scale`: one over the height), per
/// translation parameter, handed to `add(residual, weight, column, derivative)`.
pub fn translation_limit_residuals(
    layout: &DofLayout,
    skeleton: &Skeleton,
    pose: &Pose,
    weight: f64,
    scale: f64,
    add: &mut dyn FnMut(f64, f64, usize, f64),
) {
    if weight <= 0.0 {
        return;
    }
    for j in 0..layout.joint_count() {
        let (Some(o), Some(limits)) = (layout.offset(j), &skeleton.joint(j).translation_limits)
        else {
            continue;
        };
        if layout.dof(j) != JointDof::Free {
            continue;
        }
        let t = pose.local[j].translation;
        for a in 0..3 {
            let excess = (t[a] - limits.max[a]).max(0.0) + (t[a] - limits.min[a]).min(0.0);
            add(excess * scale, weight, o + a, scale);
        }
    }
}

/// How far a joint's rotation vector relative to rest (`rest^-1 * rotation`) lies outside
/// `limits` (radians, per axis; zero inside). For a hinge, only the signed angle about its
/// axis counts.
pub fn limit_excess(dof: &JointDof, limits: &JointLimits, relative: &Vector3) -> Vector3 {
    let clamp_excess = |v: f64, lo: f64, hi: f64| (v - hi).max(0.0) + (v - lo).min(0.0);
    match dof {
        JointDof::Hinge { axis } => {
            let angle = relative.dot(&axis.normalize());
            Vector3::new(clamp_excess(angle, limits.min.x, limits.max.x), 0.0, 0.0)
        }
        _ => Vector3::from_fn(|a, _| clamp_excess(relative[a], limits.min[a], limits.max[a])),
    }
}

/// The soft joint-limit residuals of `pose`: for each joint `layout` moves that has limits,
/// its rotation's excess over them (relative to rest, [`limit_excess`]) per rotation
/// parameter, handed to `add(residual, weight, column)` with derivative 1 (the excess moves
/// with the joint's own rotation increment to first order). Shared by posing's fit and the
/// tracker's M-step.
pub fn limit_residuals(
    layout: &DofLayout,
    skeleton: &Skeleton,
    pose: &Pose,
    weight: f64,
    add: &mut dyn FnMut(f64, f64, usize),
) {
    if weight <= 0.0 {
        return;
    }
    for j in 0..layout.joint_count() {
        joint_limit_residuals(layout, skeleton, pose, j, weight, add);
    }
}

/// [`limit_residuals`] of one joint `j` (nothing when it does not move or has no limits).
pub fn joint_limit_residuals(
    layout: &DofLayout,
    skeleton: &Skeleton,
    pose: &Pose,
    j: usize,
    weight: f64,
    add: &mut dyn FnMut(f64, f64, usize),
) {
    let Some(o) = layout.offset(j) else { return };
    let joint = skeleton.joint(j);
    let Some(limits) = joint.limits.as_ref().filter(|_| weight > 0.0) else {
        return;
    };
    let relative = (joint.rest.rotation.inverse() * pose.local[j].rotation).scaled_axis();
    let dof = layout.dof(j);
    let excess = limit_excess(&dof, limits, &relative);
    // A free joint's rotation follows its translation in the layout.
    let (rotation, axes) = match dof {
        JointDof::Ball => (o, 3),
        JointDof::Free => (o + 3, 3),
        JointDof::Hinge { .. } => (o, 1),
        JointDof::Fixed => (o, 0),
    };
    (0..axes).for_each(|a| add(excess[a], weight, rotation + a));
}

/// The tied joints that move ([`crate::skeleton::JointTie`]): each held at its place in the
/// other joint's frame with `weight`.
pub(crate) struct Ties {
    /// (the tied joint, its tie, the deepest joint above both).
    ties: Vec<(usize, JointTie, Option<usize>)>,
    pub(crate) weight: f64,
}

impl Ties {
    /// Weight of a tied joint's squared distance from its place (heights) against the
    /// total weight of a solver's pulls: a tie counts as much as every point off by the
    /// same distance.
    pub(crate) const WEIGHT: f64 = 1.0;

    pub(crate) fn new(layout: &DofLayout, skeleton: &Skeleton, weight: f64) -> Self {
        let ties = (0..layout.joint_count())
            .filter(|&j| layout.offset(j).is_some() && layout.dof(j) == JointDof::Free)
            .filter_map(|j| {
                let tie = skeleton.joint(j).tie?;
                let mut above = skeleton.joint(j).parent;
                while let Some(a) = above {
                    if skeleton.is_ancestor_or_self(a, tie.to) {
                        break;
                    }
                    above = skeleton.joint(a).parent;
                }
                Some((j, tie, above))
            })
            .collect();
        Self { ties, weight }
    }

    pub(crate) fn is_empty(&self) -> bool {
        self.ties.is_empty()
    }

    /// Hands each tie's residual (the joint's origin minus its place, heights, `inv_h` one
    /// over the height), weight and Jacobian columns (written in `cols`) to `add`. The
    /// columns are those of the joints below the deepest one above both ends (the joints
    /// above move both ends alike).
    pub(crate) fn each(
        &self,
        layout: &DofLayout,
        fk: &ForwardKinematics,
        inv_h: f64,
        cols: &mut Vec<(usize, Vector3)>,
        mut add: impl FnMut(&Vector3, f64, &[(usize, Vector3)]),
    ) {
        for &(joint, tie, above) in &self.ties {
            let at = fk.position(joint);
            let place = fk.point(tie.to, &tie.offset.into());
            let r = (at - place) * inv_h;
            cols.clear();
            fk.point_jacobian_below(layout, joint, above, &at, |i, v| cols.push((i, v * inv_h)));
            fk.point_jacobian_below(layout, tie.to, above, &place, |i, v| {
                cols.push((i, -v * inv_h))
            });
            add(&r, self.weight, cols);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::animation::{AnimationChannel, quat_to_xyzw};
    use crate::math::{Quat, Trs};
    use crate::skeleton::Joint;

    fn chain() -> Skeleton {
        let bone = |y: f64| Trs::new(Vector3::new(0.0, y, 0.0), Quat::identity());
        Skeleton::new(vec![
            Joint::new("root", None, bone(0.0)),
            Joint::new("hip", Some(0), bone(1.0)),
            Joint::new("knee", Some(1), bone(1.0)),
            Joint::new("ankle", Some(2), bone(1.0)),
        ])
        .expect("parents come first")
    }

    fn clip(joint: usize, rotations: &[Quat]) -> AnimationChannel {
        AnimationChannel {
            joint,
            target: ChannelTarget::Rotation,
            interpolation: Interpolation::Linear,
            times: (0..rotations.len()).map(|i| i as f64).collect(),
            values: rotations.iter().map(quat_to_xyzw).collect(),
        }
    }

    #[test]
    fn one_axis_makes_a_hinge_and_many_a_limited_ball() {
        let skeleton = chain();
        let knee: Vec<Quat> = (0..20)
            .map(|i| Quat::from_axis_angle(&Vector3::x_axis(), 0.1 * i as f64))
            .collect();
        let hip: Vec<Quat> = (0..20)
            .map(|i| {
                let t = i as f64 * 0.3;
                Quat::from_scaled_axis(Vector3::new(0.5 * t.sin(), 0.0, 0.4 * t.cos()))
            })
            .collect();
        let animation = Animation {
            name: "walk".into(),
            channels: vec![clip(1, &hip), clip(2, &knee)],
            ..Animation::default()
        };
        let model = joint_model_from_clips(&skeleton, &[animation], &ClipModelOptions::default());
        assert!(model[0].is_none() && model[3].is_none());
        let knee = model[2].expect("the knee is modelled");
        let JointDof::Hinge { axis } = knee.dof else {
            panic!("the knee should be a hinge, got {:?}", knee.dof);
        };
        assert!((axis - Vector3::x()).norm() < 1e-6, "axis {axis}");
        let limits = knee.limits.expect("knee limits");
        // 0 to 1.9 radians shown, widened by 0.35 + a quarter of 1.9.
        assert!((limits.min.x - (-0.35 - 0.475)).abs() < 1e-6, "{limits:?}");
        assert!(
            (limits.max.x - (1.9 + 0.35 + 0.475)).abs() < 1e-6,
            "{limits:?}"
        );
        let hip = model[1].expect("the hip is modelled");
        assert_eq!(hip.dof, JointDof::Ball);
        let limits = hip.limits.expect("hip limits");
        assert!(limits.min.x < -0.5 && limits.max.z > 0.4 && limits.max.y >= 0.35);
    }

    #[test]
    fn excess_is_zero_inside_and_signed_outside() {
        let limits = JointLimits {
            min: Vector3::new(-0.5, -0.2, -0.1),
            max: Vector3::new(1.0, 0.2, 0.1),
        };
        let hinge = JointDof::Hinge { axis: Vector3::x() };
        assert_eq!(
            limit_excess(&hinge, &limits, &Vector3::new(0.3, 9.0, 9.0)),
            Vector3::zeros()
        );
        assert!(
            (limit_excess(&hinge, &limits, &Vector3::new(-0.7, 0.0, 0.0)).x + 0.2).abs() < 1e-12
        );
        let e = limit_excess(&JointDof::Ball, &limits, &Vector3::new(1.5, 0.0, -0.3));
        assert!((e - Vector3::new(0.5, 0.0, -0.2)).norm() < 1e-12);
    }

    #[test]
    fn a_translating_joint_outside_its_box_gets_residuals_in_heights() {
        let mut skeleton = chain();
        skeleton.set_dof(2, JointDof::Free, None);
        skeleton.set_translation_limits(
            2,
            Some(JointLimits {
                min: Vector3::new(0.0, 1.0, 0.0),
                max: Vector3::new(0.0, 1.5, 0.0),
            }),
        );
        let layout = DofLayout::new(&skeleton);
        let mut pose = skeleton.rest_pose();
        pose.local[2].translation = Vector3::new(0.2, 2.0, 0.0);
        let mut got = Vec::new();
        translation_limit_residuals(&layout, &skeleton, &pose, 1.0, 0.5, &mut |r, w, c, d| {
            got.push((r, w, c, d))
        });
        let o = layout.offset(2).expect("moves");
        // 0.2 past x's box and 0.5 past y's, halved (one over a height of 2).
        assert_eq!(
            got,
            vec![
                (0.1, 1.0, o, 0.5),
                (0.25, 1.0, o + 1, 0.5),
                (0.0, 1.0, o + 2, 0.5)
            ]
        );
    }
}
