//! Limb swings for the first frame's search: once the body is placed, a limb the EM left
//! far from its data (an arm held out in the rig's T-pose while the person's hangs down: at a
//! wide `sigma` the torso's points pull it as much as its own) is tried pointing in each of
//! a few directions about its root joint, and kept where the data's explained share (one
//! E-step of eq. 17, with the outlier class) is highest. Limbs are tried parents first, so
//! an elbow is swung after its shoulder.

use super::Tracker;
use crate::joint_model::limit_excess;
use crate::math::{Point3, Quat, Vector3};
use crate::skeleton::{JointDof, Pose, Skeleton};

/// A joint whose one bone is shorter than this share of the next is a short link (a
/// clavicle): not swung itself, its child is.
const SHORT_LINK: f64 = 0.6;

/// How limbs are swung. Lengths are fractions of the height.
#[derive(Clone, Debug, PartialEq)]
pub struct LimbSwingOptions {
    /// A limb: a joint whose descendants reach at least this far from it and that carries
    /// at most `max_share` of the skeleton's joints (an arm, not the trunk).
    pub reach: f64,
    pub max_share: f64,
    /// The width of the E-step that scores a swing: wide enough to credit a limb pointing
    /// roughly the right way.
    pub sigma: f64,
    /// A swing replaces the limb's pose only when it explains this much more of the data.
    pub margin: f64,
    /// A swing whose rotation lies further than this (radians) outside the joint's limits
    /// is not tried.
    pub limit_slack: f64,
    /// The data points a swing is scored on (evenly strided): at most this many.
    pub points: usize,
    /// Try the eight diagonals between the world axes too (else the six axes alone).
    pub diagonals: bool,
}

impl Default for LimbSwingOptions {
    fn default() -> Self {
        Self {
            reach: 0.12,
            max_share: 0.4,
            sigma: 0.05,
            margin: 0.003,
            limit_slack: 0.2,
            points: 500,
            diagonals: true,
        }
    }
}

/// The directions a limb is tried in: the world axes, and the diagonals between them.
fn directions(diagonals: bool) -> Vec<Vector3> {
    let mut out = Vec::new();
    for a in 0..3 {
        for s in [-1.0, 1.0] {
            out.push(Vector3::from_fn(|i, _| if i == a { s } else { 0.0 }));
        }
    }
    if diagonals {
        for x in [-1.0, 1.0] {
            for y in [-1.0, 1.0] {
                for z in [-1.0, 1.0] {
                    out.push(Vector3::new(x, y, z).normalize());
                }
            }
        }
    }
    out
}

/// The limbs of `skeleton` in `pose`: joints that turn, are not a root, reach far enough
/// and carry few enough joints (see [`LimbSwingOptions`]); parents first.
fn limbs(skeleton: &Skeleton, pose: &Pose, height: f64, options: &LimbSwingOptions) -> Vec<usize> {
    let positions = skeleton.joint_positions(pose);
    (0..skeleton.len())
        .filter(|&j| {
            let joint = skeleton.joint(j);
            if joint.parent.is_none() || matches!(joint.dof, JointDof::Fixed) {
                return false;
            }
            let subtree = skeleton.subtree_mask(j);
            let count = subtree.iter().filter(|&&m| m).count();
            let reach = (0..skeleton.len())
                .filter(|&k| subtree[k])
                .map(|k| (positions[k] - positions[j]).norm())
                .fold(0.0, f64::max);
            // A short link (a clavicle, a hip joint): its limb turns at the next joint.
            let children = skeleton.children(j);
            let short_link = children.len() == 1 && {
                let child = children[0];
                let link = (positions[child] - positions[j]).norm();
                let next = skeleton
                    .children(child)
                    .iter()
                    .map(|&g| (positions[g] - positions[child]).norm())
                    .fold(0.0, f64::max);
                link < SHORT_LINK * next
            };
            count > 1
                && !short_link
                && (count as f64) <= options.max_share * skeleton.len() as f64
                && reach >= options.reach * height
        })
        .collect()
}

/// `pose` with each limb swung where the data are explained best; the tracker's pose is
/// left at the result. Returns the pose and how many limbs moved.
pub(super) fn swing_limbs(
    tracker: &mut Tracker,
    pose: &Pose,
    data: &[Point3],
    options: &LimbSwingOptions,
) -> (Pose, usize) {
    let skeleton = tracker.model.skeleton.clone();
    let h = tracker.model.height;
    // Every few points of the frame: a share is measured as well on a few hundred.
    let stride = data.len().div_ceil(options.points.max(1)).max(1);
    let data: Vec<Point3> = data.iter().step_by(stride).copied().collect();
    let data = &data[..];
    let sigma = options.sigma * h;
    let mut best = pose.clone();
    tracker.set_pose(&best);
    let mut best_score = tracker.explained_share(data, sigma);
    let mut moved = 0;
    for j in limbs(&skeleton, pose, h, options) {
        let positions = skeleton.joint_positions(&best);
        let subtree = skeleton.subtree_mask(j);
        let below: Vec<Point3> = (0..skeleton.len())
            .filter(|&k| subtree[k] && k != j)
            .map(|k| positions[k])
            .collect();
        let direction = crate::geometry::centroid(&below) - positions[j];
        if direction.norm() < 1e-9 * h {
            continue;
        }
        let world = skeleton.world_rotations(&best);
        let joint = skeleton.joint(j);
        let mut chosen: Option<(Pose, f64)> = None;
        for target in directions(options.diagonals) {
            let Some(swing) = Quat::rotation_between(&direction, &target) else {
                continue;
            };
            let local = skeleton.turned_in_world(&best, &world, j, &swing);
            let local = match joint.dof {
                // A hinge keeps only the swing's turn about its axis.
                JointDof::Hinge { axis } => {
                    let relative = (best.local[j].rotation.inverse() * local).scaled_axis();
                    let axis = axis.normalize();
                    best.local[j].rotation * Quat::from_scaled_axis(axis * relative.dot(&axis))
                }
                _ => local,
            };
            if let Some(limits) = &joint.limits {
                let relative = (joint.rest.rotation.inverse() * local).scaled_axis();
                if limit_excess(&joint.dof, limits, &relative).norm() > options.limit_slack {
                    continue;
                }
            }
            let mut candidate = best.clone();
            candidate.local[j].rotation = local;
            tracker.set_pose(&candidate);
            let score = tracker.explained_share(data, sigma);
            if chosen.as_ref().is_none_or(|c| score > c.1) {
                chosen = Some((candidate, score));
            }
        }
        if let Some((candidate, score)) = chosen
            && score > best_score + options.margin
        {
            best = candidate;
            best_score = score;
            moved += 1;
        }
    }
    tracker.set_pose(&best);
    (best, moved)
}
