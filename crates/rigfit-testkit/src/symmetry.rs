//! A rig's own geometric symmetries: the proper rotations that map its body (joints and
//! surface) onto itself with its joints relabelled, such as a box character turned half
//! round about the vertical (left and right arms and legs swapped) or a quadruped with four
//! identical legs turned half round about its up axis. Points alone cannot tell such a
//! twin from the truth, so tracking is judged up to them ([`crate::track_corpus`]).
//!
//! [`rig_symmetries`] tries quarter, half and three-quarter turns about the three world
//! axes and the three principal axes of the surface points, all through the surface points'
//! centroid, and keeps those that map every joint near a joint (a bijection that respects
//! the hierarchy) and the surface near itself. [`relabelled_errors`] and
//! [`best_labelling`] measure a fit against the truth under such a relabelling.

use std::collections::HashSet;

use nalgebra::{Rotation3, Unit};
use rigfit_core::engine::spatial::PointTree;
use rigfit_core::{Point3, Pose, Rig, Skeleton, Vector3};

/// A joint must map within this share of the height of its image joint.
pub const JOINT_TOLERANCE: f64 = 0.015;
/// The surface's mapped points: mean and largest distance to the surface, shares of the
/// height.
pub const SURFACE_MEAN_TOLERANCE: f64 = 0.01;
pub const SURFACE_MAX_TOLERANCE: f64 = 0.04;
/// The surface check looks at most this many points (every k-th).
pub const SURFACE_SAMPLES: usize = 2000;

/// The joint permutations (index `i` -> `P[i]`, over every joint of the skeleton) of the
/// proper rotations that map the rig in `pose` onto itself, the identity first, each
/// permutation once. A rotation counts when every joint maps within [`JOINT_TOLERANCE`] of
/// `height` of its image joint, the map is a bijection that keeps the hierarchy (parents
/// map to their images' parents, roots to roots), and, for a rig with a skinned mesh, the
/// mesh's vertices map near the mesh (mean distance below [`SURFACE_MEAN_TOLERANCE`], none
/// beyond [`SURFACE_MAX_TOLERANCE`], over at most [`SURFACE_SAMPLES`] of them). A rig with
/// no mesh is judged by its joints alone.
pub fn rig_symmetries(rig: &Rig, pose: &Pose, height: f64) -> Vec<Vec<usize>> {
    let skeleton = &rig.skeleton;
    let n = skeleton.len();
    let mut found: Vec<Vec<usize>> = vec![(0..n).collect()];
    let joints = skeleton.joint_positions(pose);
    let has_mesh = rig.meshes.iter().any(|m| !m.positions.is_empty());
    let surface = if has_mesh {
        rig.extent_points(pose)
    } else {
        joints.clone()
    };
    if n == 0 || surface.is_empty() || height <= 0.0 {
        return found;
    }
    let centroid = centroid(&surface);
    let tree = has_mesh.then(|| {
        let coords: Vec<[f64; 3]> = surface.iter().map(|p| [p.x, p.y, p.z]).collect();
        PointTree::new(&coords)
    });
    let stride = surface.len().div_ceil(SURFACE_SAMPLES).max(1);
    let samples: Vec<Point3> = surface.iter().step_by(stride).copied().collect();
    let mut seen: HashSet<Vec<usize>> = found.iter().cloned().collect();
    for rotation in candidate_rotations(&surface, &centroid) {
        let map = |p: &Point3| centroid + rotation * (p - centroid);
        let mapped: Vec<Point3> = joints.iter().map(map).collect();
        let Some(permutation) =
            joint_permutation(skeleton, &joints, &mapped, JOINT_TOLERANCE * height)
        else {
            continue;
        };
        if permutation.iter().enumerate().all(|(i, &p)| i == p) || seen.contains(&permutation) {
            continue;
        }
        if let Some(tree) = &tree {
            let (mut sum, mut worst) = (0.0, 0.0f64);
            for p in &samples {
                let q = map(p);
                let d = (surface[tree.nearest(&q)] - q).norm();
                sum += d;
                worst = worst.max(d);
            }
            let mean = sum / samples.len() as f64;
            if mean >= SURFACE_MEAN_TOLERANCE * height || worst >= SURFACE_MAX_TOLERANCE * height {
                continue;
            }
        }
        seen.insert(permutation.clone());
        found.push(permutation);
    }
    found
}

fn centroid(points: &[Point3]) -> Point3 {
    let sum = points.iter().fold(Vector3::zeros(), |s, p| s + p.coords);
    Point3::from(sum / points.len().max(1) as f64)
}

/// Quarter, half and three-quarter turns about the world axes and the principal axes of
/// `points` (about `centroid`).
fn candidate_rotations(points: &[Point3], centroid: &Point3) -> Vec<Rotation3<f64>> {
    let mut covariance = nalgebra::Matrix3::<f64>::zeros();
    for p in points {
        let d = p - centroid;
        covariance += d * d.transpose();
    }
    let eigen = covariance.symmetric_eigen();
    let mut axes = vec![Vector3::x(), Vector3::y(), Vector3::z()];
    axes.extend(eigen.eigenvectors.column_iter().map(|c| c.into_owned()));
    let mut rotations = Vec::new();
    for axis in axes {
        let Some(axis) = Unit::try_new(axis, 1e-12) else {
            continue;
        };
        for quarter in 1..=3 {
            let angle = f64::from(quarter) * std::f64::consts::FRAC_PI_2;
            rotations.push(Rotation3::from_axis_angle(&axis, angle));
        }
    }
    rotations
}

/// The joint permutation that sends every joint `i` (at `joints[i]`, mapped to
/// `mapped[i]`) to a joint within `tolerance` of `mapped[i]`, roots to roots and children
/// of a joint to children of its image: a tree isomorphism, found subtree by subtree with a
/// bipartite matching among siblings. `None` when there is none.
pub fn joint_permutation(
    skeleton: &Skeleton,
    joints: &[Point3],
    mapped: &[Point3],
    tolerance: f64,
) -> Option<Vec<usize>> {
    let roots: Vec<usize> = skeleton.roots().collect();
    let matcher = Matcher {
        skeleton,
        joints,
        mapped,
        tolerance,
    };
    let pairs = matcher.match_siblings(&roots, &roots)?;
    let mut permutation = vec![usize::MAX; skeleton.len()];
    for (i, j) in pairs {
        permutation[i] = j;
    }
    permutation
        .iter()
        .all(|&p| p != usize::MAX)
        .then_some(permutation)
}

/// Joint pairs (`i`, its image).
type Pairs = Vec<(usize, usize)>;
/// Per joint of one set and joint of the other: their subtrees' pairs when they match.
type Feasible = Vec<Vec<Option<Pairs>>>;

struct Matcher<'a> {
    skeleton: &'a Skeleton,
    joints: &'a [Point3],
    mapped: &'a [Point3],
    tolerance: f64,
}

impl Matcher<'_> {
    /// The pairs of the subtree of `i` mapped onto the subtree of `j`.
    fn match_subtree(&self, i: usize, j: usize) -> Option<Pairs> {
        if (self.mapped[i] - self.joints[j]).norm() > self.tolerance {
            return None;
        }
        let mut pairs =
            self.match_siblings(self.skeleton.children(i), self.skeleton.children(j))?;
        pairs.push((i, j));
        Some(pairs)
    }

    /// A one-to-one matching of the joints `from` onto the joints `onto` whose subtrees
    /// match (augmenting paths over the feasible pairs), with the subtrees' pairs.
    fn match_siblings(&self, from: &[usize], onto: &[usize]) -> Option<Pairs> {
        if from.len() != onto.len() {
            return None;
        }
        let k = from.len();
        // feasible[a][b]: the subtree of from[a] onto that of onto[b].
        let feasible: Feasible = from
            .iter()
            .map(|&i| onto.iter().map(|&j| self.match_subtree(i, j)).collect())
            .collect();
        let mut owner: Vec<Option<usize>> = vec![None; k];
        for a in 0..k {
            let mut visited = vec![false; k];
            if !augment(a, &feasible, &mut owner, &mut visited) {
                return None;
            }
        }
        let mut pairs = Vec::new();
        for (b, a) in owner.iter().enumerate() {
            let a = (*a)?;
            pairs.extend(feasible[a][b].iter().flatten().copied());
        }
        Some(pairs)
    }
}

/// Kuhn's augmenting path from `a`: true when `a` gets a partner.
fn augment(
    a: usize,
    feasible: &Feasible,
    owner: &mut [Option<usize>],
    visited: &mut [bool],
) -> bool {
    for b in 0..owner.len() {
        if feasible[a][b].is_none() || visited[b] {
            continue;
        }
        visited[b] = true;
        if owner[b].is_none_or(|other| augment(other, feasible, owner, visited)) {
            owner[b] = Some(a);
            return true;
        }
    }
    false
}

/// Whether `permutation` maps the set `joints` onto itself.
pub fn keeps_set(permutation: &[usize], joints: &[usize]) -> bool {
    let set: HashSet<usize> = joints.iter().copied().collect();
    joints
        .iter()
        .all(|&i| permutation.get(i).is_some_and(|p| set.contains(p)))
}

/// The mean over `reported` joints `i` of `|fit[P(i)] - truth[i]|`, fraction of `height`.
pub fn relabelled_error(
    fit: &[Point3],
    truth: &[Point3],
    reported: &[usize],
    permutation: &[usize],
    height: f64,
) -> f64 {
    reported
        .iter()
        .map(|&i| (fit[permutation[i]] - truth[i]).norm())
        .sum::<f64>()
        / reported.len().max(1) as f64
        / height
}

/// Per frame ([`relabelled_error`]), for fitted and true joint positions frame by frame.
pub fn relabelled_errors(
    fits: &[Vec<Point3>],
    truths: &[Vec<Point3>],
    reported: &[usize],
    permutation: &[usize],
    height: f64,
) -> Vec<f64> {
    fits.iter()
        .zip(truths)
        .map(|(f, t)| relabelled_error(f, t, reported, permutation, height))
        .collect()
}

/// The index into `permutations` whose relabelled errors have the lowest mean from frame
/// `from` on, among those that map `reported` onto itself (the first, the identity, on a
/// tie or when none does).
pub fn best_labelling(
    permutations: &[Vec<usize>],
    fits: &[Vec<Point3>],
    truths: &[Vec<Point3>],
    reported: &[usize],
    height: f64,
    from: usize,
) -> usize {
    let start = from.min(fits.len());
    let mut best = (0, f64::INFINITY);
    for (k, permutation) in permutations.iter().enumerate() {
        if !keeps_set(permutation, reported) {
            continue;
        }
        let errors = relabelled_errors(
            &fits[start..],
            &truths[start..],
            reported,
            permutation,
            height,
        );
        let mean = errors.iter().sum::<f64>() / errors.len().max(1) as f64;
        if mean < best.1 {
            best = (k, mean);
        }
    }
    best.0
}

/// Per `reported` joint `j`: its mean distance to its fitted image `fit[P(j)]` from frame
/// `from` on, fraction of `height`.
pub fn joint_means(
    fits: &[Vec<Point3>],
    truths: &[Vec<Point3>],
    reported: &[usize],
    permutation: &[usize],
    height: f64,
    from: usize,
) -> Vec<(usize, f64)> {
    let start = from.min(fits.len());
    let frames = (fits.len() - start).max(1) as f64;
    reported
        .iter()
        .map(|&j| {
            let sum: f64 = (fits[start..].iter().zip(&truths[start..]))
                .map(|(f, t)| (f[permutation[j]] - t[j]).norm())
                .sum();
            (j, sum / frames / height)
        })
        .collect()
}

/// The rotation part of the turn that maps the joints at `positions` onto their images
/// under `permutation` (joint `i` onto joint `permutation[i]`; Kabsch about the centroid).
pub fn permutation_rotation(positions: &[Point3], permutation: &[usize]) -> rigfit_core::Quat {
    let centroid = centroid(positions);
    let mut covariance = nalgebra::Matrix3::<f64>::zeros();
    for (i, &image) in permutation.iter().enumerate() {
        covariance += (positions[image] - centroid) * (positions[i] - centroid).transpose();
    }
    // Not `UnitQuaternion::from_matrix`: its iteration starts at the identity and stalls at
    // a half turn.
    rigfit_core::math::rotation_quat(&rigfit_core::math::nearest_rotation(&covariance))
}

/// The local rotations of the twin of `pose` under the symmetry `permutation` of the rig in
/// `start` (a [`rig_symmetries`] result): the pose whose joint `permutation[i]` lies where
/// `pose` has joint `i`, drawn by the same points. With `H` the symmetry's turn and `R` the
/// world rotations, the twin's `R[P(i)] = R_pose[i] R_start[i]^-1 H^-1 R_start[P(i)]`, which
/// keeps every bone's offset in its parent's frame.
pub fn twin_local_rotations(
    skeleton: &Skeleton,
    start: &Pose,
    pose: &Pose,
    permutation: &[usize],
) -> Vec<rigfit_core::Quat> {
    let turn = permutation_rotation(&skeleton.joint_positions(start), permutation);
    let (at_start, posed) = (
        skeleton.world_rotations(start),
        skeleton.world_rotations(pose),
    );
    let mut twin = vec![rigfit_core::Quat::identity(); skeleton.len()];
    for (i, &image) in permutation.iter().enumerate() {
        twin[image] = posed[i] * at_start[i].inverse() * turn.inverse() * at_start[image];
    }
    (0..skeleton.len())
        .map(|j| match skeleton.joint(j).parent {
            Some(p) => twin[p].inverse() * twin[j],
            None => twin[j],
        })
        .collect()
}

/// How far the local rotations `local` of `joints` lie outside `skeleton`'s joint model:
/// the summed squared excess over each joint's limits (radians), plus, at a hinge, the
/// squared turn about other axes than its own.
pub fn joint_model_excess(
    skeleton: &Skeleton,
    local: &[rigfit_core::Quat],
    joints: impl Iterator<Item = usize>,
) -> f64 {
    use rigfit_core::skeleton::JointDof;
    joints
        .map(|j| {
            let joint = skeleton.joint(j);
            let relative = (joint.rest.rotation.inverse() * local[j]).scaled_axis();
            let off_axis = match &joint.dof {
                JointDof::Hinge { axis } => {
                    let axis = axis.normalize();
                    (relative - axis * relative.dot(&axis)).norm_squared()
                }
                _ => 0.0,
            };
            let outside = joint.limits.as_ref().map_or(0.0, |limits| {
                rigfit_core::joint_model::limit_excess(&joint.dof, limits, &relative).norm_squared()
            });
            off_axis + outside
        })
        .sum()
}

#[cfg(test)]
mod tests {
    use super::*;
    use rigfit_core::{Joint, Trs};

    /// A root with two arms along +x and -x, each of two bones.
    fn two_armed(right_length: f64) -> Rig {
        let at = |x: f64| Trs {
            translation: Vector3::new(x, 0.0, 0.0),
            ..Trs::default()
        };
        let mut joints = vec![Joint::new("root", None, Trs::default())];
        joints.push(Joint::new("left", Some(0), at(0.5)));
        joints.push(Joint::new("left_end", Some(1), at(0.5)));
        joints.push(Joint::new("right", Some(0), at(-0.5)));
        joints.push(Joint::new("right_end", Some(3), at(-right_length)));
        let skeleton = Skeleton::new(joints).expect("skeleton");
        Rig {
            pose: skeleton.rest_pose(),
            skeleton,
            meshes: Vec::new(),
            animations: Vec::new(),
        }
    }

    #[test]
    fn a_symmetric_bare_skeleton_has_its_half_turn() {
        let rig = two_armed(0.5);
        let found = rig_symmetries(&rig, &rig.pose, 2.0);
        assert_eq!(found[0], vec![0, 1, 2, 3, 4]);
        assert!(found.contains(&vec![0, 3, 4, 1, 2]), "{found:?}");
        // Every symmetry swaps the arms.
        assert_eq!(found.len(), 2, "{found:?}");
    }

    #[test]
    fn an_asymmetric_bare_skeleton_has_only_the_identity() {
        let rig = two_armed(0.8);
        assert_eq!(rig_symmetries(&rig, &rig.pose, 2.0).len(), 1);
    }

    /// [`two_armed`] with a head above the root, so that one turn (half round about the
    /// vertical) maps it onto itself.
    fn headed() -> Rig {
        let mut rig = two_armed(0.5);
        let mut joints = rig.skeleton.joints().to_vec();
        joints.push(Joint::new(
            "head",
            Some(0),
            Trs {
                translation: Vector3::new(0.0, 0.6, 0.0),
                ..Trs::default()
            },
        ));
        rig.skeleton = Skeleton::new(joints).expect("skeleton");
        rig.pose = rig.skeleton.rest_pose();
        rig
    }

    #[test]
    fn a_twin_is_drawn_by_the_same_points() {
        let rig = headed();
        let skeleton = &rig.skeleton;
        let found = rig_symmetries(&rig, &rig.pose, 2.0);
        assert_eq!(found.len(), 2, "{found:?}");
        let swap = &found[1];
        // The root turned far and moved, each arm bent its own way.
        let mut pose = rig.pose.clone();
        let turn = |axis: Vector3, degrees: f64| {
            rigfit_core::Quat::from_axis_angle(&Unit::new_normalize(axis), degrees.to_radians())
        };
        pose.local[0].rotation = turn(Vector3::new(0.2, 1.0, 0.1), 150.0);
        pose.local[0].translation = Vector3::new(0.3, -0.1, 0.7);
        pose.local[1].rotation = turn(Vector3::z(), 40.0);
        pose.local[2].rotation = turn(Vector3::new(0.0, 1.0, 1.0), 30.0);
        pose.local[3].rotation = turn(Vector3::new(1.0, 0.0, 1.0), -70.0);
        let mut twin = pose.clone();
        for (j, rotation) in twin_local_rotations(skeleton, &rig.pose, &pose, swap)
            .into_iter()
            .enumerate()
        {
            twin.local[j].rotation = rotation;
        }
        let (at, twin_at) = (
            skeleton.joint_positions(&pose),
            skeleton.joint_positions(&twin),
        );
        for (i, &image) in swap.iter().enumerate() {
            assert!(
                (twin_at[image] - at[i]).norm() < 1e-9,
                "joint {i}: {} vs {} ({swap:?})",
                twin_at[image],
                at[i]
            );
        }
        // The twin of the start turns the root half round; its arms do not bend.
        let start_twin = twin_local_rotations(skeleton, &rig.pose, &rig.pose, swap);
        assert!((start_twin[0].angle() - std::f64::consts::PI).abs() < 1e-9);
        assert!(start_twin[1].angle() < 1e-9 && start_twin[3].angle() < 1e-9);
    }

    #[test]
    fn the_joint_model_excess_counts_limits_and_hinges() {
        use rigfit_core::JointLimits;
        use rigfit_core::skeleton::JointDof;
        let mut rig = headed();
        let mut joints = rig.skeleton.joints().to_vec();
        joints[1].limits = Some(JointLimits {
            min: Vector3::repeat(-0.5),
            max: Vector3::repeat(0.5),
        });
        joints[3].dof = JointDof::Hinge { axis: Vector3::z() };
        rig.skeleton = Skeleton::new(joints).expect("skeleton");
        let skeleton = &rig.skeleton;
        let mut local: Vec<rigfit_core::Quat> = vec![rigfit_core::Quat::identity(); skeleton.len()];
        let all = || 0..skeleton.len();
        assert_eq!(joint_model_excess(skeleton, &local, all()), 0.0);
        local[1] = rigfit_core::Quat::from_axis_angle(&Vector3::z_axis(), 0.8);
        assert!((joint_model_excess(skeleton, &local, all()) - 0.09).abs() < 1e-9);
        // Only the joints asked about count.
        assert_eq!(
            joint_model_excess(skeleton, &local, [0, 2, 3].into_iter()),
            0.0
        );
        // A hinge turned about its own axis is free, about another is not.
        local[3] = rigfit_core::Quat::from_axis_angle(&Vector3::z_axis(), 1.0);
        assert_eq!(joint_model_excess(skeleton, &local, [3].into_iter()), 0.0);
        local[3] = rigfit_core::Quat::from_axis_angle(&Vector3::x_axis(), 0.2);
        assert!((joint_model_excess(skeleton, &local, [3].into_iter()) - 0.04).abs() < 1e-9);
    }

    #[test]
    fn the_best_labelling_undoes_a_swap() {
        let p = |x: f64| Point3::new(x, 0.0, 0.0);
        let truth = vec![vec![p(0.0), p(1.0), p(-1.0)]];
        let fit = vec![vec![p(0.0), p(-1.0), p(1.0)]];
        let perms = vec![vec![0, 1, 2], vec![0, 2, 1]];
        assert_eq!(best_labelling(&perms, &fit, &truth, &[0, 1, 2], 1.0, 0), 1);
        assert_eq!(best_labelling(&perms, &fit, &truth, &[1], 1.0, 0), 0);
    }
}
