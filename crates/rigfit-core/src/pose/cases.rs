//! Ground-truth posing cases from real rigs: pose the rig (a frame of its own animation),
//! draw one polyline per limb chain through the true joint positions, resample densely,
//! add Gaussian noise, shuffle stroke order and direction, optionally drop limbs and add
//! stray strokes. Used by tests and benchmarks.

use rand::Rng;
use rand::seq::SliceRandom;
use rand_distr::{Distribution, Normal};

use super::beautify::resample;
use crate::math::{Point3, Vector3};
use crate::skeleton::{JointKind, Pose, Skeleton};
use crate::strokes::Stroke;

/// How to draw a case.
#[derive(Clone, Debug)]
pub struct CaseOptions {
    /// Gaussian noise per coordinate, as a fraction of the height.
    pub noise: f64,
    /// Spacing of the drawn samples (dense, like a controller), fraction of the height.
    pub sample_spacing: f64,
    /// Chains shorter than this (fraction of height) are not drawn.
    pub min_chain_length: f64,
    /// How many limb chains to leave undrawn.
    pub drop_limbs: usize,
    /// How many stray strokes to add.
    pub stray_strokes: usize,
}

impl Default for CaseOptions {
    fn default() -> Self {
        Self {
            noise: 0.01,
            sample_spacing: 0.004,
            min_chain_length: 0.1,
            drop_limbs: 0,
            stray_strokes: 0,
        }
    }
}

/// A generated case.
#[derive(Clone, Debug)]
pub struct Case {
    pub strokes: Vec<Stroke>,
    /// Joints on drawn chains: the ones whose error is measured.
    pub drawn_joints: Vec<usize>,
    /// The chains left undrawn (joint sequences; the first joint is where they attach).
    pub dropped_chains: Vec<Vec<usize>>,
    /// For each stroke, the joint sequence it was drawn through (empty for strays).
    pub stroke_chains: Vec<Vec<usize>>,
}

/// The limb chains of a skeleton: from the character's root or a branching joint, through
/// joints with one child, to a leaf or the next branching joint. Helpers above the root and
/// zero-length links are skipped as the posing model skips them.
pub fn limb_chains(skeleton: &Skeleton) -> Vec<Vec<usize>> {
    let root = skeleton.skin_root();
    let included = |j: usize| skeleton.joint(j).kind != JointKind::Helper;
    let children = |j: usize| -> Vec<usize> {
        skeleton
            .children(j)
            .iter()
            .copied()
            .filter(|&c| included(c))
            .collect()
    };
    let starts: Vec<usize> = (0..skeleton.len())
        .filter(|&j| {
            let under = root.is_none_or(|r| skeleton.is_ancestor_or_self(r, j));
            under
                && (Some(j) == root
                    || children(j).len() > 1
                    || (skeleton.joint(j).parent.is_none() && root.is_none()))
        })
        .collect();
    let mut chains = Vec::new();
    for s in starts {
        for c in children(s) {
            let mut chain = vec![s, c];
            let mut cur = c;
            loop {
                let next = children(cur);
                if next.len() != 1 {
                    break;
                }
                cur = next[0];
                chain.push(cur);
            }
            chains.push(chain);
        }
    }
    chains
}

fn chain_length(points: &[Point3], chain: &[usize]) -> f64 {
    chain
        .windows(2)
        .map(|w| (points[w[1]] - points[w[0]]).norm())
        .sum()
}

/// Draws a case for the skeleton in `truth` (the pose the solver should recover).
pub fn make_case(
    skeleton: &Skeleton,
    truth: &Pose,
    height: f64,
    options: &CaseOptions,
    rng: &mut impl Rng,
) -> Case {
    let positions = skeleton.joint_positions(truth);
    let mut chains: Vec<Vec<usize>> = limb_chains(skeleton)
        .into_iter()
        .filter(|c| chain_length(&positions, c) >= options.min_chain_length * height)
        .collect();
    // Drop limbs: chains that end at a leaf, chosen at random.
    let mut dropped_chains = Vec::new();
    for _ in 0..options.drop_limbs {
        let leaves: Vec<usize> = (0..chains.len())
            .filter(|&c| {
                skeleton
                    .children(*chains[c].last().expect("chains have joints"))
                    .is_empty()
            })
            .collect();
        if leaves.len() <= 1 {
            break;
        }
        let pick = leaves[rng.random_range(0..leaves.len())];
        dropped_chains.push(chains.remove(pick));
    }
    let normal = Normal::new(0.0, (options.noise * height).max(1e-300)).expect("valid deviation");
    let mut drawn_joints: Vec<usize> = chains.iter().flatten().copied().collect();
    drawn_joints.sort_unstable();
    drawn_joints.dedup();
    let mut strokes: Vec<(Stroke, Vec<usize>)> = chains
        .iter()
        .map(|chain| {
            let line: Vec<Point3> = chain.iter().map(|&j| positions[j]).collect();
            let mut points = resample(&line, options.sample_spacing * height);
            for p in &mut points {
                *p += Vector3::new(normal.sample(rng), normal.sample(rng), normal.sample(rng));
            }
            let mut chain = chain.clone();
            if rng.random_bool(0.5) {
                points.reverse();
                chain.reverse();
            }
            (
                Stroke {
                    points,
                    bones: None,
                },
                chain,
            )
        })
        .collect();
    // Stray strokes: short wobbly lines near the character.
    let lo = positions
        .iter()
        .fold(Vector3::repeat(f64::INFINITY), |a, p| a.inf(&p.coords));
    let hi = positions
        .iter()
        .fold(Vector3::repeat(f64::NEG_INFINITY), |a, p| a.sup(&p.coords));
    for _ in 0..options.stray_strokes {
        let margin = 0.3 * height;
        let start = Point3::from(Vector3::from_fn(|i, _| {
            rng.random_range(lo[i] - margin..hi[i] + margin)
        }));
        let dir = Vector3::new(normal.sample(rng), normal.sample(rng), normal.sample(rng))
            .try_normalize(1e-12)
            .unwrap_or_else(Vector3::x);
        let bend = Vector3::new(
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
        );
        let length = 0.25 * height;
        let line: Vec<Point3> = (0..6)
            .map(|i| {
                let t = i as f64 / 5.0;
                start
                    + dir * (length * t)
                    + bend * (0.1 * height * (t * std::f64::consts::PI).sin())
            })
            .collect();
        let mut points = resample(&line, options.sample_spacing * height);
        for p in &mut points {
            *p += Vector3::new(normal.sample(rng), normal.sample(rng), normal.sample(rng));
        }
        strokes.push((
            Stroke {
                points,
                bones: None,
            },
            Vec::new(),
        ));
    }
    strokes.shuffle(rng);
    let (strokes, stroke_chains) = strokes.into_iter().unzip();
    Case {
        strokes,
        drawn_joints,
        dropped_chains,
        stroke_chains,
    }
}

/// Mean distance between solved and true joint positions over `joints`, as a fraction of
/// `height`.
pub fn mean_joint_error(
    skeleton: &Skeleton,
    solved: &Pose,
    truth: &Pose,
    joints: &[usize],
    height: f64,
) -> f64 {
    let a = skeleton.joint_positions(solved);
    let b = skeleton.joint_positions(truth);
    joints.iter().map(|&j| (a[j] - b[j]).norm()).sum::<f64>() / joints.len().max(1) as f64 / height
}

/// How far an undrawn chain moved relative to where it attaches: the largest change, between
/// `start` and `solved`, of its joints' positions in the frame of its first joint, as a
/// fraction of `height`. Zero when the limb kept its start pose.
pub fn limb_motion(
    skeleton: &Skeleton,
    start: &Pose,
    solved: &Pose,
    chain: &[usize],
    height: f64,
) -> f64 {
    let ws = skeleton.world_matrices(start);
    let wr = skeleton.world_matrices(solved);
    let anchor = chain[0];
    let (Some(is), Some(ir)) = (ws[anchor].try_inverse(), wr[anchor].try_inverse()) else {
        return f64::INFINITY;
    };
    // Distances measured in the start frame's units.
    let scale = ws[anchor].fixed_view::<3, 3>(0, 0).column(0).norm();
    chain[1..]
        .iter()
        .map(|&j| {
            let p = |w: &crate::math::Matrix4| Point3::new(w[(0, 3)], w[(1, 3)], w[(2, 3)]);
            let a = crate::math::transform_point(&is, &p(&ws[j]));
            let b = crate::math::transform_point(&ir, &p(&wr[j]));
            (a - b).norm() * scale
        })
        .fold(0.0, f64::max)
        / height
}
