//! The first frame's pose found from the model's start pose, wherever the person stands and
//! whichever way they face: hypotheses of position and heading about the model's up axis,
//! each refined by the tracker's own EM (eq. 17, M-step eq. 20) with only the root free at a
//! wide `sigma`; then the best few refined with every joint free, `sigma` annealed from wide
//! to the noise level; the hypothesis whose final E-step explains the most data wins.

use super::{ArticulatedModel, TrackError, TrackOptions, Tracker, check_cloud};
use crate::engine::{WeightedPoints, em_step};
use crate::geometry::{Aabb, centroid};
use crate::kinematics::DofLayout;
use crate::math::{Point3, Quat, Vector3};
use crate::rig::z_is_up;
use crate::skeleton::{JointDof, Pose};

/// Two root-only fits are one hypothesis when their roots are this close (fraction of the
/// height) and turned less than this (radians) from each other.
const SAME_PLACE: f64 = 0.05;
const SAME_TURN: f64 = 0.35;

/// The initialisation's settings. Lengths are fractions of the character's height.
#[derive(Clone, Debug, PartialEq)]
pub struct InitialiseOptions {
    /// Headings tried about the up axis (evenly spaced): the root-only EM at a wide `sigma`
    /// brings a start within half the spacing to the right heading.
    pub headings: usize,
    /// Root-only EM: `sigma` from `root_sigma` down to `root_floor` in `root_steps`
    /// geometric steps.
    pub root_sigma: f64,
    pub root_floor: f64,
    pub root_steps: usize,
    /// Hypotheses (distinct root placements) carried on to the fit of every joint.
    pub keep: usize,
    /// Every-joint EM: `sigma` from `full_sigma` down to the tracker's noise level in
    /// `full_steps` geometric steps, with this weight on the rotation prior toward the
    /// start pose.
    pub full_sigma: f64,
    pub full_steps: usize,
    pub full_prior_weight: f64,
    /// Every-joint passes in all: after the first (which chooses the winner), the winner's
    /// further passes each start from the last one's pose, `sigma` from `refine_sigma` in
    /// `refine_steps` steps, with the tracker's own prior weight.
    pub full_passes: usize,
    pub refine_sigma: f64,
    pub refine_steps: usize,
    /// The width at which hypotheses are compared: the data's summed inlier posteriors of
    /// one E-step (eq. 17) at this `sigma`, over every texture point.
    pub score_sigma: f64,
}

impl Default for InitialiseOptions {
    fn default() -> Self {
        Self {
            headings: 8,
            root_sigma: 0.3,
            root_floor: 0.03,
            root_steps: 5,
            keep: 3,
            full_sigma: 0.12,
            full_steps: 6,
            full_prior_weight: 0.3,
            full_passes: 3,
            refine_sigma: 0.06,
            refine_steps: 4,
            score_sigma: 0.03,
        }
    }
}

/// What [`initialise`] found.
#[derive(Clone, Debug)]
pub struct Initialisation {
    /// The first frame's pose.
    pub pose: Pose,
    /// The winner's score: the data's summed inlier posteriors (eq. 17) at the noise level,
    /// as a fraction of the data points.
    pub score: f64,
    /// The winner's heading about the up axis (radians) before refinement.
    pub heading: f64,
    /// Every hypothesis tried, best root-only score first.
    pub tried: Vec<Tried>,
}

/// One hypothesis [`initialise`] tried.
#[derive(Clone, Debug, PartialEq)]
pub struct Tried {
    /// Its heading about the up axis (radians) and which centre of the data it started on
    /// (0: the median, 1: the mean near it).
    pub heading: f64,
    pub centre: usize,
    /// Its score after the root-only EM, and after the every-joint EM when it got there.
    pub root_score: f64,
    pub full_score: Option<f64>,
    /// The pose it ended in.
    pub pose: Pose,
}

/// One hypothesis: where it starts, where EM took it, and how well it explains the data.
#[derive(Clone, Debug)]
struct Hypothesis {
    heading: f64,
    centre: usize,
    pose: Pose,
    score: f64,
}

/// The pose of a first frame `data` from `model`'s start pose, by EM from several
/// placements (see the module's documentation), with the default [`InitialiseOptions`].
/// `options` are the tracker's: its noise level, outlier term (eq. 17), bending exponent
/// (eq. 3) and M-step settings.
pub fn initialise(
    model: &ArticulatedModel,
    options: &TrackOptions,
    data: &[Point3],
) -> Result<Initialisation, TrackError> {
    initialise_with(model, options, &InitialiseOptions::default(), data)
}

/// [`initialise`] with its settings.
pub fn initialise_with(
    model: &ArticulatedModel,
    options: &TrackOptions,
    settings: &InitialiseOptions,
    data: &[Point3],
) -> Result<Initialisation, TrackError> {
    check_cloud(data)?;
    let root_options = TrackOptions {
        max_motion: settings.root_sigma,
        noise: settings.root_floor,
        anneal_steps: settings.root_steps,
        em_iterations: 2,
        final_em_iterations: 4,
        prediction: 0.0,
        visible_only: false,
        coarse_to_fine: true,
        prior_weight: 0.0,
        surface_fit_steps: 0,
        texture: super::TextureSource::ModelSurface,
        ..options.clone()
    };
    let mut tracker = Tracker::new(model.clone(), root_options)?;
    let h = model.height;
    let skeleton = &model.skeleton;
    let full_layout = tracker.layout.clone();
    let roots = root_joints(model);
    let root_layout = DofLayout::with_active(
        skeleton,
        &(0..skeleton.len())
            .map(|j| roots.contains(&j))
            .collect::<Vec<_>>(),
    );
    if root_layout.is_empty() {
        return Err(TrackError::NothingMoves);
    }
    let up = up_axis(model);
    let score_sigma = settings.score_sigma * h;
    let model_centre = centroid(&tracker.texture_positions());
    let centres = data_centres(data, h);

    // 1. Position and heading: the root alone, from every heading and centre.
    tracker.layout = root_layout;
    tracker.normal = None;
    let mut root_fits: Vec<Hypothesis> = Vec::new();
    for (c, centre) in centres.iter().enumerate() {
        for k in 0..settings.headings.max(1) {
            let heading = std::f64::consts::TAU * k as f64 / settings.headings.max(1) as f64;
            let turn = Quat::from_axis_angle(&up, heading);
            let shift = centre.coords - turn * model_centre.coords;
            let start = moved(&model.start, skeleton, &turn, &shift);
            let score = fit(&mut tracker, &start, data, score_sigma);
            root_fits.push(Hypothesis {
                heading,
                centre: c,
                pose: tracker.pose.clone(),
                score,
            });
        }
    }
    root_fits.sort_by(|a, b| b.score.total_cmp(&a.score));
    let mut kept: Vec<Hypothesis> = Vec::new();
    for hyp in &root_fits {
        if kept.len() == settings.keep.max(1) {
            break;
        }
        if !kept
            .iter()
            .any(|k| same_place(skeleton, &k.pose, &hyp.pose, &roots, h))
        {
            kept.push(hyp.clone());
        }
    }

    // 2. Every joint, coarse to fine, from the best few.
    tracker.layout = full_layout;
    tracker.normal = None;
    tracker.options = TrackOptions {
        max_motion: settings.full_sigma,
        noise: options.noise,
        anneal_steps: settings.full_steps,
        em_iterations: 2,
        final_em_iterations: 8,
        prior_weight: settings.full_prior_weight,
        ..tracker.options.clone()
    };
    let mut tried: Vec<Tried> = root_fits
        .iter()
        .map(|r| Tried {
            heading: r.heading,
            centre: r.centre,
            root_score: r.score,
            full_score: None,
            pose: r.pose.clone(),
        })
        .collect();
    let mut best: Option<Hypothesis> = None;
    for hyp in kept {
        let score = fit(&mut tracker, &hyp.pose, data, score_sigma);
        tracing::debug!(
            "initialise: heading {:.0} root score {:.3} -> {:.3}",
            hyp.heading.to_degrees(),
            hyp.score,
            score
        );
        if let Some(t) = tried
            .iter_mut()
            .find(|t| t.heading == hyp.heading && t.centre == hyp.centre)
        {
            t.full_score = Some(score);
            t.pose.clone_from(&tracker.pose);
        }
        if best.as_ref().is_none_or(|b| score > b.score) {
            best = Some(Hypothesis {
                heading: hyp.heading,
                centre: hyp.centre,
                pose: tracker.pose.clone(),
                score,
            });
        }
    }
    let mut best = best.ok_or(TrackError::NothingMoves)?;
    // Further passes on the winner from its pose (the prior now toward it, the tracker's
    // weight), from a narrower width: limbs that came only part of the way go on. The
    // choice is made before them: the stronger prior of the first pass keeps a body fitted
    // facing the wrong way from bending its limbs into the data.
    tracker.options.prior_weight = options.prior_weight;
    tracker.options.max_motion = settings.refine_sigma;
    tracker.options.anneal_steps = settings.refine_steps;
    for _ in 1..settings.full_passes.max(1) {
        best.score = fit(&mut tracker, &best.pose, data, score_sigma);
        best.pose.clone_from(&tracker.pose);
    }
    Ok(Initialisation {
        pose: best.pose,
        score: best.score,
        heading: best.heading,
        tried,
    })
}

/// One EM run of the tracker (its current layout and options) from `start` on `data`,
/// then its score: the data's summed inlier posteriors (eq. 17) at `sigma`, per data point.
fn fit(tracker: &mut Tracker, start: &Pose, data: &[Point3], sigma: f64) -> f64 {
    tracker.set_pose(start);
    tracker.lambda = 1e-4;
    if tracker.track(data).is_err() {
        return f64::NEG_INFINITY;
    }
    let world = tracker.texture_positions();
    em_step(
        WeightedPoints::unit(data),
        WeightedPoints::unit(&world),
        sigma,
        tracker.options.outlier_constant,
        &mut tracker.grid,
        &mut tracker.em,
    );
    tracker.em.inlier.iter().sum::<f64>() / data.len() as f64
}

/// The topmost joints that move: a joint with its own degrees of freedom and no moving
/// ancestor (the root of a skeleton, or its hips under a fixed armature node).
fn root_joints(model: &ArticulatedModel) -> Vec<usize> {
    let skeleton = &model.skeleton;
    let moves = |j: usize| skeleton.joint(j).dof != JointDof::Fixed;
    (0..skeleton.len())
        .filter(|&j| {
            if !moves(j) {
                return false;
            }
            let mut p = skeleton.joint(j).parent;
            while let Some(q) = p {
                if moves(q) {
                    return false;
                }
                p = skeleton.joint(q).parent;
            }
            true
        })
        .collect()
}

/// The model's up axis: y, or z when its surface is much deeper in z than tall in y (as
/// `Rig::height` decides).
fn up_axis(model: &ArticulatedModel) -> nalgebra::Unit<Vector3> {
    let bare = model.surface_normals.is_none();
    match Aabb::from_points(&model.surface_samples) {
        Some(bounds) if z_is_up(&bounds.extent(), bare) => Vector3::z_axis(),
        _ => Vector3::y_axis(),
    }
}

/// `pose` with its whole body moved by the rigid motion `x -> turn x + shift`: each joint
/// without a parent carries it.
fn moved(pose: &Pose, skeleton: &crate::skeleton::Skeleton, turn: &Quat, shift: &Vector3) -> Pose {
    let mut out = pose.clone();
    for (j, local) in out.local.iter_mut().enumerate() {
        if skeleton.joint(j).parent.is_none() {
            local.translation = turn * local.translation + shift;
            local.rotation = turn * local.rotation;
        }
    }
    out
}

/// Where the body may stand: the coordinate-wise median of the data, and the mean of the
/// data within a body's height of it (robust to outliers far away).
fn data_centres(data: &[Point3], height: f64) -> Vec<Point3> {
    let median = Point3::from(Vector3::from_fn(|a, _| {
        let mut c: Vec<f64> = data.iter().map(|p| p[a]).collect();
        let mid = c.len() / 2;
        *c.select_nth_unstable_by(mid, f64::total_cmp).1
    }));
    let near: Vec<Point3> = data
        .iter()
        .copied()
        .filter(|p| (p - median).norm() < 0.6 * height)
        .collect();
    if near.is_empty() {
        vec![median]
    } else {
        vec![median, centroid(&near)]
    }
}

/// Whether two poses put their roots at the same place (world) and heading.
fn same_place(
    skeleton: &crate::skeleton::Skeleton,
    a: &Pose,
    b: &Pose,
    roots: &[usize],
    height: f64,
) -> bool {
    let (pa, pb) = (skeleton.joint_positions(a), skeleton.joint_positions(b));
    roots.iter().all(|&j| {
        (pa[j] - pb[j]).norm() < SAME_PLACE * height
            && a.local[j].rotation.angle_to(&b.local[j].rotation) < SAME_TURN
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::humanoid::humanoid;

    /// The humanoid's own surface, turned and moved far from where the model stands, is
    /// found again from the model's start pose.
    #[test]
    fn finds_a_turned_and_moved_body() {
        let rig = humanoid();
        let model = ArticulatedModel::from_rig(&rig, 1500).expect("model");
        let h = model.height;
        let tracker = Tracker::new(model.clone(), TrackOptions::default()).expect("tracker");
        let turn = Quat::from_axis_angle(&Vector3::y_axis(), 2.3);
        let shift = Vector3::new(1.1, 0.0, -0.8) * h;
        let data: Vec<Point3> = tracker
            .texture_positions()
            .iter()
            .map(|p| Point3::from(turn * p.coords + shift))
            .collect();
        let truth = moved(&model.start, &model.skeleton, &turn, &shift);
        let init = initialise(&model, &TrackOptions::default(), &data).expect("initialises");
        let a = model.skeleton.joint_positions(&init.pose);
        let b = model.skeleton.joint_positions(&truth);
        let error = a.iter().zip(&b).map(|(p, q)| (p - q).norm()).sum::<f64>() / a.len() as f64;
        assert!(
            error < 0.02 * h,
            "mean joint error {:.2}%",
            100.0 * error / h
        );
    }
}
