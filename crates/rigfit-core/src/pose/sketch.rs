//! Strokes sketched through a pose, as a user would draw them: one polyline per chain
//! through the joint positions (the limbs, every chain, or a few limbs: [`Coverage`]),
//! resampled densely, with Gaussian noise, optionally flattened in depth as seen from one
//! view, in shuffled order and direction, optionally with limbs left undrawn and stray
//! strokes; and how far a solved pose's joints are from the pose drawn ([`joint_errors`]).
//! `rigfit demo` and Python's `draw_strokes` draw their strokes here; rigfit-testkit builds
//! its ground-truth cases on it (the true poses are its `targets`).

mod coverage;
mod drawing;

use rand::Rng;
use rand::seq::SliceRandom;
use rand_distr::Normal;

use crate::math::{Point3, Vector3};
use crate::skeleton::{Pose, Skeleton};
use crate::strokes::Stroke;

pub use coverage::{
    Coverage, EVERY_CHAIN_MIN_LENGTH, FEW_LIMBS, chain_deforms, chain_length, deforming_joints,
    limb_chains, outer_limbs,
};
pub use drawing::{desktop_view, flatten_stroke};

/// How to draw a case.
#[derive(Clone, Debug)]
pub struct CaseOptions {
    /// Gaussian noise per coordinate, as a fraction of the height.
    pub noise: f64,
    /// Spacing of the drawn samples (dense, like a controller), fraction of the height.
    pub sample_spacing: f64,
    /// The shortest limb, as a fraction of the height: [`Coverage::Limbs`] draws no shorter
    /// chain, and only chains this long count as limbs to drop.
    pub min_chain_length: f64,
    /// How many limbs to leave undrawn.
    pub drop_limbs: usize,
    /// How many stray strokes to add.
    pub stray_strokes: usize,
    /// Which chains are drawn.
    pub coverage: Coverage,
    /// The direction a user looks along while drawing: each stroke is flattened onto the
    /// plane through its mean point perpendicular to it (`None`: strokes keep their depth,
    /// as drawn in VR).
    pub flatten: Option<Vector3>,
}

impl Default for CaseOptions {
    fn default() -> Self {
        Self {
            noise: 0.01,
            sample_spacing: 0.004,
            min_chain_length: 0.1,
            drop_limbs: 0,
            stray_strokes: 0,
            coverage: Coverage::Limbs,
            flatten: None,
        }
    }
}

/// A generated case.
#[derive(Clone, Debug)]
pub struct Case {
    pub strokes: Vec<Stroke>,
    /// Joints on drawn chains (each chain's joints, the one it attaches at included): the
    /// ones whose error is measured.
    pub drawn_joints: Vec<usize>,
    /// The chains left undrawn (joint sequences; the first joint is where they attach).
    pub dropped_chains: Vec<Vec<usize>>,
    /// For each stroke, the joint sequence it was drawn through (empty for strays).
    pub stroke_chains: Vec<Vec<usize>>,
}

/// Draws a case for the skeleton in `truth` (the pose the solver should recover), every
/// joint counting as deforming ([`draw_case`] with a rig's own [`deforming_joints`]).
pub fn make_case(
    skeleton: &Skeleton,
    truth: &Pose,
    height: f64,
    options: &CaseOptions,
    rng: &mut impl Rng,
) -> Case {
    draw_case(
        skeleton,
        &vec![true; skeleton.len()],
        truth,
        height,
        options,
        rng,
    )
}

/// Draws a case for the skeleton in `truth`; `deforming` tells which joints carry skin
/// weight (the limbs of [`Coverage::Limbs`] and [`Coverage::FewLimbs`] are chains that do).
pub fn draw_case(
    skeleton: &Skeleton,
    deforming: &[bool],
    truth: &Pose,
    height: f64,
    options: &CaseOptions,
    rng: &mut impl Rng,
) -> Case {
    let positions = skeleton.joint_positions(truth);
    let limb_length = options.min_chain_length * height;
    let mut chains = coverage::covered_chains(
        skeleton,
        deforming,
        &positions,
        options.coverage,
        limb_length,
        height,
        rng,
    );
    let dropped_chains = coverage::drop_limbs(
        skeleton,
        &positions,
        &mut chains,
        options.coverage,
        limb_length,
        options.drop_limbs,
        rng,
    );
    let normal = Normal::new(0.0, (options.noise * height).max(1e-300)).expect("valid deviation");
    let mut drawn_joints: Vec<usize> = chains.iter().flatten().copied().collect();
    drawn_joints.sort_unstable();
    drawn_joints.dedup();
    let spacing = options.sample_spacing * height;
    let mut strokes: Vec<(Vec<Point3>, Vec<usize>)> = chains
        .iter()
        .map(|chain| {
            let mut points = drawing::chain_stroke(&positions, chain, spacing, &normal, rng);
            let mut chain = chain.clone();
            if rng.random_bool(0.5) {
                points.reverse();
                chain.reverse();
            }
            (points, chain)
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
        let points = drawing::stray_stroke((lo, hi), height, spacing, &normal, rng);
        strokes.push((points, Vec::new()));
    }
    if let Some(view) = &options.flatten {
        for (points, _) in &mut strokes {
            flatten_stroke(points, view);
        }
    }
    strokes.shuffle(rng);
    let (strokes, stroke_chains) = strokes
        .into_iter()
        .map(|(points, chain)| {
            let stroke = Stroke {
                points,
                bones: None,
            };
            (stroke, chain)
        })
        .unzip();
    Case {
        strokes,
        drawn_joints,
        dropped_chains,
        stroke_chains,
    }
}

/// How far solved joints are from the truth, as fractions of the height.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct JointErrors {
    /// The mean distance over the joints (0 for none).
    pub mean: f64,
    /// The largest distance (0 for none).
    pub max: f64,
    /// The joint at the largest distance.
    pub worst: Option<usize>,
}

/// The distances between solved and true joint positions over `joints`, as fractions of
/// `height`.
pub fn joint_errors(
    skeleton: &Skeleton,
    solved: &Pose,
    truth: &Pose,
    joints: &[usize],
    height: f64,
) -> JointErrors {
    let a = skeleton.joint_positions(solved);
    let b = skeleton.joint_positions(truth);
    let mut sum = 0.0;
    let mut max = 0.0;
    let mut worst = None;
    for &j in joints {
        let d = (a[j] - b[j]).norm();
        sum += d;
        if worst.is_none() || d > max {
            max = d;
            worst = Some(j);
        }
    }
    JointErrors {
        mean: sum / joints.len().max(1) as f64 / height,
        max: max / height,
        worst,
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
    joint_errors(skeleton, solved, truth, joints, height).mean
}
