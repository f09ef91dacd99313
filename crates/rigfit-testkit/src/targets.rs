//! Target poses for cases: a frame of the rig's own clips, a random pose far from the start
//! (limbs turned up to half a turn, other joints bent), and a mirror-symmetric one.

use rand::Rng;
use rand_distr::{Distribution, UnitSphere};

use rigfit_core::animation::{Animation, ChannelTarget, Interpolation};
use rigfit_core::joint_model::limit_excess;
use rigfit_core::math::{Quat, Vector3};
use rigfit_core::mirror::mirror_pairs;
use rigfit_core::pose::sketch::{chain_length, limb_chains, outer_limbs};
use rigfit_core::skeleton::{Joint, JointDof, JointKind, JointLimits, Pose, Skeleton};

/// A limb's first bone counts as a short link (a clavicle, a hip joint) and the limb turns
/// at the next joint when it is shorter than this fraction of the next bone.
const SHORT_LINK_RATIO: f64 = 0.75;

/// A chain of up to this many turning joints bends each by up to the full `bend`; in a
/// longer one (a spine of many vertebrae, a tail) the joints share that budget, so a
/// 30-vertebra tail curls about as far as a 4-joint one instead of tying a knot.
const BEND_SHARED_JOINTS: f64 = 4.0;

/// How far random target poses go from the start pose. Angles are in radians, lengths
/// fractions of the height.
#[derive(Clone, Debug, PartialEq)]
pub struct FarPoseOptions {
    /// The largest turn of the joint at the root of each limb (an arm at the shoulder, a
    /// leg at the hip): arms cross and legs rise from these.
    pub limb_turn: f64,
    /// The largest bend of every other joint that rotates.
    pub bend: f64,
    /// The largest turn of the whole character about `up`.
    pub heading: f64,
    /// The world's vertical axis.
    pub up: Vector3,
    /// The shortest limb.
    pub limb_length: f64,
    /// Joints that translate and that no clip gives a range for move up to this far along
    /// each axis.
    pub translation: f64,
}

impl Default for FarPoseOptions {
    fn default() -> Self {
        Self {
            limb_turn: std::f64::consts::PI,
            bend: 60f64.to_radians(),
            heading: std::f64::consts::PI,
            up: Vector3::y(),
            limb_length: 0.1,
            translation: 0.05,
        }
    }
}

/// A pose from one of `animations` (chosen at random among those that last) at a random
/// time, over `start`. `None` when no clip lasts.
pub fn clip_pose(animations: &[Animation], start: &Pose, rng: &mut impl Rng) -> Option<Pose> {
    let clips: Vec<&Animation> = animations.iter().filter(|a| a.duration() > 0.0).collect();
    if clips.is_empty() {
        return None;
    }
    let clip = clips[rng.random_range(0..clips.len())];
    let time = rng.random_range(clip.start()..=clip.end());
    Some(clip.sample(start, time))
}

/// The joint at the root of each limb (each chain at least `limb_length` long, with no such
/// chain hanging below it, of three joints or more): the chain's second joint, or its third
/// when the second turns only a short link (a clavicle, a hip joint).
pub fn limb_roots(skeleton: &Skeleton, start: &Pose, limb_length: f64) -> Vec<usize> {
    let positions = skeleton.joint_positions(start);
    let chains = limb_chains(skeleton);
    let lengths: Vec<f64> = chains.iter().map(|c| chain_length(&positions, c)).collect();
    let bone = |a: usize, b: usize| (positions[b] - positions[a]).norm();
    outer_limbs(skeleton, &chains, &lengths, limb_length)
        .into_iter()
        .filter(|&c| chains[c].len() >= 3)
        .map(|c| {
            let chain = &chains[c];
            let short_link = chain.len() >= 4
                && bone(chain[1], chain[2]) < SHORT_LINK_RATIO * bone(chain[2], chain[3]);
            if short_link { chain[2] } else { chain[1] }
        })
        .collect()
}

/// A random pose far from `start`: each limb root turned by up to `limb_turn` and every
/// other ball or free joint below the character's root bent by up to `bend` (about random
/// axes, within the joint's limits), joints that translate moved within their clips' range
/// (or `translation`), and the whole character turned about `up` by up to `heading`.
pub fn far_pose(
    skeleton: &Skeleton,
    start: &Pose,
    animations: &[Animation],
    height: f64,
    options: &FarPoseOptions,
    rng: &mut impl Rng,
) -> Pose {
    let mut pose = random_bends(skeleton, start, animations, height, options, rng);
    // An IK goal stays at the end of its arm, as the rig's clips keep it.
    skeleton.apply_ties(&mut pose);
    turn_heading(skeleton, &mut pose, options, rng);
    pose
}

/// A random mirror-symmetric pose: [`far_pose`]'s bends on the left side, mirrored onto the
/// right (pairs by name, [`mirror_pairs`]), joints on neither side bending only within the
/// plane of symmetry, then the whole character turned. The plane is the start pose's
/// (through the root, across the pairs), so the pose is symmetric when the start pose is.
/// Translated joints are not mirrored. `None` when the skeleton has no left-right pairs.
pub fn mirror_pose(
    skeleton: &Skeleton,
    start: &Pose,
    animations: &[Animation],
    height: f64,
    options: &FarPoseOptions,
    rng: &mut impl Rng,
) -> Option<Pose> {
    let pairs = mirror_pairs(skeleton);
    let positions = skeleton.joint_positions(start);
    let across: Vector3 = pairs
        .iter()
        .map(|&(left, right)| positions[left] - positions[right])
        .sum();
    let normal = across.try_normalize(1e-12 * height.max(1e-300))?;
    let base = random_bends(skeleton, start, animations, height, options, rng);
    let start_world = skeleton.world_rotations(start);
    let base_world = skeleton.world_rotations(&base);
    let mut left_of = vec![None; skeleton.len()];
    let mut is_left = vec![false; skeleton.len()];
    for &(left, right) in &pairs {
        left_of[right] = Some(left);
        is_left[left] = true;
    }
    // Each joint's change of world rotation from the start pose.
    let change = |j: usize| base_world[j] * start_world[j].inverse();
    let mut pose = base.clone();
    let mut world = start_world.clone();
    for j in 0..skeleton.len() {
        let delta = match left_of[j] {
            Some(left) => mirrored(&change(left), &normal),
            None if is_left[j] => change(j),
            None => twist(&change(j), &normal),
        };
        world[j] = delta * start_world[j];
        let parent = skeleton
            .joint(j)
            .parent
            .map_or_else(Quat::identity, |p| world[p]);
        pose.local[j].rotation = parent.inverse() * world[j];
    }
    skeleton.apply_ties(&mut pose);
    turn_heading(skeleton, &mut pose, options, rng);
    Some(pose)
}

/// The mirror image of a rotation through the plane with unit normal `normal`.
fn mirrored(rotation: &Quat, normal: &Vector3) -> Quat {
    let v = rotation.vector();
    let image = normal * (2.0 * v.dot(normal)) - v;
    Quat::new_normalize(nalgebra::Quaternion::new(
        rotation.scalar(),
        image.x,
        image.y,
        image.z,
    ))
}

/// The part of a rotation about `axis` (its twist): the rotations a plane of symmetry
/// with normal `axis` maps onto themselves.
fn twist(rotation: &Quat, axis: &Vector3) -> Quat {
    let along = axis * rotation.vector().dot(axis);
    let q = nalgebra::Quaternion::new(rotation.scalar(), along.x, along.y, along.z);
    if q.norm() < 1e-12 {
        Quat::identity()
    } else {
        Quat::new_normalize(q)
    }
}

/// A rotation about a uniformly random axis by a uniformly random angle up to `max_angle`.
fn random_rotation(max_angle: f64, rng: &mut impl Rng) -> Quat {
    let [x, y, z]: [f64; 3] = UnitSphere.sample(rng);
    let angle = if max_angle > 0.0 {
        rng.random_range(0.0..=max_angle)
    } else {
        0.0
    };
    Quat::from_scaled_axis(Vector3::new(x, y, z) * angle)
}

/// The range of each joint's translation over the keys of `animations` (`None` for joints
/// no clip translates).
fn translation_ranges(animations: &[Animation], joints: usize) -> Vec<Option<(Vector3, Vector3)>> {
    let mut ranges: Vec<Option<(Vector3, Vector3)>> = vec![None; joints];
    for channel in animations.iter().flat_map(|a| &a.channels) {
        if channel.target != ChannelTarget::Translation || channel.joint >= joints {
            continue;
        }
        let values: Vec<&[f64; 4]> = match channel.interpolation {
            Interpolation::CubicSpline => channel.values.iter().skip(1).step_by(3).collect(),
            _ => channel.values.iter().collect(),
        };
        for v in values {
            let v = Vector3::new(v[0], v[1], v[2]);
            let range = ranges[channel.joint].get_or_insert((v, v));
            *range = (range.0.inf(&v), range.1.sup(&v));
        }
    }
    ranges
}

/// `start` with every ball or free joint below the character's root turned (limb roots by
/// up to `limb_turn`, others by up to `bend`), and translating joints moved.
fn random_bends(
    skeleton: &Skeleton,
    start: &Pose,
    animations: &[Animation],
    height: f64,
    options: &FarPoseOptions,
    rng: &mut impl Rng,
) -> Pose {
    let root = skeleton.skin_root();
    let under_root = root.map(|r| skeleton.subtree_mask(r));
    let mut is_limb_root = vec![false; skeleton.len()];
    for j in limb_roots(skeleton, start, options.limb_length * height) {
        is_limb_root[j] = true;
    }
    let ranges = translation_ranges(animations, skeleton.len());
    let bend_share = bend_shares(skeleton);
    let mut pose = start.clone();
    for (j, joint) in skeleton.joints().iter().enumerate() {
        let below_root =
            Some(j) != root && under_root.as_ref().is_none_or(|u| u[j]) && joint.parent.is_some();
        if !below_root || joint.kind == JointKind::Helper {
            continue;
        }
        let max_angle = if is_limb_root[j] {
            options.limb_turn
        } else {
            options.bend * bend_share[j]
        };
        match joint.dof {
            JointDof::Ball | JointDof::Free => {
                pose.local[j].rotation =
                    bent_within_limits(joint, &pose.local[j].rotation, max_angle, rng);
            }
            JointDof::Hinge { axis } => {
                // Anywhere in the hinge's range (or up to the bend either way without one).
                let (lo, hi) = joint
                    .limits
                    .map_or((-max_angle, max_angle), |l| (l.min.x, l.max.x));
                let angle = if hi > lo {
                    rng.random_range(lo..=hi)
                } else {
                    lo
                };
                pose.local[j].rotation =
                    joint.rest.rotation * Quat::from_scaled_axis(axis.normalize() * angle);
            }
            JointDof::Fixed => {}
        }
        let moving = ranges[j].filter(|(lo, hi)| (hi - lo).amax() > 1e-9 * height);
        if let Some((lo, hi)) = moving {
            pose.local[j].translation =
                Vector3::from_fn(|i, _| lo[i] + (hi[i] - lo[i]) * rng.random::<f64>());
        } else if let Some(JointLimits { min, max }) = joint
            .translation_limits
            .filter(|_| joint.dof == JointDof::Free)
        {
            // A slide the rig declares: as far as a free joint moves, within the box its
            // range sweeps.
            let reach = options.translation * height;
            let start = pose.local[j].translation;
            pose.local[j].translation = Vector3::from_fn(|i, _| {
                let lo = (start[i] - reach).max(min[i]);
                let hi = (start[i] + reach).min(max[i]).max(lo);
                lo + (hi - lo) * rng.random::<f64>()
            });
        } else if joint.dof == JointDof::Free {
            let reach = options.translation * height;
            pose.local[j].translation += Vector3::from_fn(|_, _| rng.random_range(-reach..=reach));
        }
    }
    pose
}

/// Tries for a random bend that lands within a joint's limits before the last is clamped.
const LIMITED_BEND_TRIES: usize = 16;

/// `rotation` turned about a random axis by up to `max_angle`, within the joint's limits
/// when it has them (a random turn that lands inside them, else the last one clamped).
fn bent_within_limits(joint: &Joint, rotation: &Quat, max_angle: f64, rng: &mut impl Rng) -> Quat {
    let Some(limits) = &joint.limits else {
        return rotation * random_rotation(max_angle, rng);
    };
    let mut relative = Vector3::zeros();
    for _ in 0..LIMITED_BEND_TRIES {
        let bent = rotation * random_rotation(max_angle, rng);
        relative = (joint.rest.rotation.inverse() * bent).scaled_axis();
        if limit_excess(&joint.dof, limits, &relative) == Vector3::zeros() {
            return bent;
        }
    }
    joint.rest.rotation * Quat::from_scaled_axis(relative.sup(&limits.min).inf(&limits.max))
}

/// Each joint's share of a chain's bend budget: 1 in a chain of at most
/// [`BEND_SHARED_JOINTS`] turning joints, less in longer ones.
fn bend_shares(skeleton: &Skeleton) -> Vec<f64> {
    let mut share = vec![1.0; skeleton.len()];
    for chain in limb_chains(skeleton) {
        let turning: Vec<usize> = chain[1..]
            .iter()
            .copied()
            .filter(|&j| matches!(skeleton.joint(j).dof, JointDof::Ball | JointDof::Free))
            .collect();
        let part = (BEND_SHARED_JOINTS / turning.len().max(1) as f64).min(1.0);
        for j in turning {
            share[j] = part;
        }
    }
    share
}

/// Turns the whole character (its root joint, about itself) by up to `options.heading`
/// about the world's `options.up`.
fn turn_heading(
    skeleton: &Skeleton,
    pose: &mut Pose,
    options: &FarPoseOptions,
    rng: &mut impl Rng,
) {
    let Some(root) = skeleton.skin_root() else {
        return;
    };
    let angle = if options.heading > 0.0 {
        rng.random_range(-options.heading..=options.heading)
    } else {
        0.0
    };
    let up = options.up.try_normalize(1e-12).unwrap_or_else(Vector3::y);
    let world = skeleton.world_rotations(pose);
    let turn = Quat::from_scaled_axis(up * angle);
    pose.local[root].rotation = skeleton.turned_in_world(pose, &world, root, &turn);
}
