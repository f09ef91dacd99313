//! The first frame's pose found from the model's start pose, wherever the person stands and
//! whichever way they face: hypotheses of position and heading about the model's up axis,
//! each refined by the tracker's own EM (eq. 17, M-step eq. 20) with only the root free at a
//! wide `sigma`; then the best few refined with every joint free, `sigma` annealed from wide
//! to the noise level (joints the rig's clips translate tried at the places the clips put
//! them); the hypothesis whose final E-step explains the most data wins, unless the winner
//! turned half about its own up axis explains more.

use super::limb_swings::{LimbSwingOptions, swing_limbs};
use super::{ArticulatedModel, TrackError, TrackOptions, Tracker, check_cloud, explained_share};
use crate::engine::{EmStep, PointGrid};
use crate::geometry::centroid;
use crate::kinematics::DofLayout;
use crate::math::{Point3, Quat, Vector3, linear_part};
use crate::skeleton::{JointDof, Pose};

/// Two root-only fits are one hypothesis when their roots are this close (fraction of the
/// height) and turned less than this (radians) from each other.
const SAME_PLACE: f64 = 0.05;
const SAME_TURN: f64 = 0.35;

/// Laid placements are screened on at most this many data and texture points.
const SCREEN_POINTS: usize = 500;

/// The initialisation's settings. Lengths are fractions of the character's height.
#[derive(Clone, Debug, PartialEq)]
pub struct InitialiseOptions {
    /// Headings tried about the up axis (evenly spaced): the root-only EM at a wide `sigma`
    /// brings a start within half the spacing to the right heading.
    pub headings: usize,
    /// Also try the model laid with its up axis along each world axis (a flat hand, a low
    /// quadruped, a scan whose up is not the rig's): those turns are screened by one E-step
    /// at `screen_sigma` and the best `laid_fits` get the root-alone EM beside the headings.
    pub any_up: bool,
    /// Centres of the data tried (1: the coordinate-wise median; 2: also the mean of the
    /// points near it).
    pub centres: usize,
    pub screen_sigma: f64,
    pub laid_fits: usize,
    /// Laid placements carried on to the every-joint fit beside the `keep` upright ones;
    /// one wins only when it explains `laid_margin` (share of the points) more.
    pub laid_kept: usize,
    pub laid_margin: f64,
    /// Root-only EM: `sigma` from `root_sigma` down to `root_floor` in `root_steps`
    /// geometric steps.
    pub root_sigma: f64,
    pub root_floor: f64,
    pub root_steps: usize,
    /// The root-alone EM runs on at most this many of the data points (evenly strided).
    pub root_points: usize,
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
    /// After the first every-joint pass, the winner turned half about its own up axis
    /// (the model's up axis as its root carries it) is fitted too and wins when it explains
    /// more: a flat hand's palm and back, which the root-alone fit with the limbs at rest
    /// cannot tell apart.
    pub half_turn: bool,
    /// After each hypothesis's first every-joint pass (and the half-turned winner's), each
    /// joint with clip places (a hip node the clips translate,
    /// [`crate::skeleton::Joint::clip_places`]) tried at each of them and kept where it
    /// explains more, before the hypotheses are compared: the refinement passes carry on
    /// from there. A limb the clips drop far (a sit's legs on the floor) is out of the
    /// fit's reach from the rest pose.
    pub clip_places: bool,
    /// After the winner's first every-joint pass, its limbs swung to where they explain
    /// the data best (`None`: not tried, the default: measured in BENCHMARKS.md, they help
    /// some takes and hurt others, and cost up to a second).
    pub limb_swings: Option<LimbSwingOptions>,
}

impl Default for InitialiseOptions {
    fn default() -> Self {
        Self {
            headings: 8,
            any_up: true,
            centres: 1,
            screen_sigma: 0.15,
            laid_fits: 8,
            laid_kept: 2,
            laid_margin: 0.01,
            root_sigma: 0.3,
            root_floor: 0.03,
            root_steps: 5,
            root_points: 1000,
            keep: 3,
            full_sigma: 0.12,
            full_steps: 6,
            full_prior_weight: 0.3,
            full_passes: 3,
            refine_sigma: 0.06,
            refine_steps: 4,
            score_sigma: 0.03,
            half_turn: true,
            clip_places: true,
            limb_swings: None,
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
    /// Every hypothesis tried, best root-only score first, then the winner turned half
    /// ([`InitialiseOptions::half_turn`]).
    pub tried: Vec<Tried>,
}

/// One hypothesis [`initialise`] tried.
#[derive(Clone, Debug, PartialEq)]
pub struct Tried {
    /// Its heading about the up axis (radians) and which centre of the data it started on
    /// (0: the median, 1: the mean near it).
    pub heading: f64,
    pub centre: usize,
    /// Its score after the root-only EM (NaN for the winner turned half, which starts
    /// from the every-joint fit), and after the every-joint EM when it got there.
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
    /// The model laid with its up axis along another world axis ([`InitialiseOptions::any_up`]).
    laid: bool,
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
        hold_free_joints: false,
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
    let up = model.up_axis();
    let score_sigma = settings.score_sigma * h;
    let model_centre = centroid(&tracker.texture_positions());
    let mut centres = data_centres(data, h);
    centres.truncate(settings.centres.max(1));

    // 1. Position and orientation: every heading about the model's up axis on every
    // centre, and with `any_up` the best `laid_fits` of the model laid with its up axis
    // along each world axis (screened by one E-step at a wide width); each gets the
    // root-alone EM.
    tracker.layout = root_layout;
    tracker.normal = None;
    let headings = settings.headings.max(1);
    let turns = orientations(&up, headings, settings.any_up);
    let screen_sigma = settings.screen_sigma * h;
    let screen_data: Vec<Point3> = data
        .iter()
        .step_by(data.len().div_ceil(SCREEN_POINTS).max(1))
        .copied()
        .collect();
    let (mut grid, mut em) = (PointGrid::default(), EmStep::default());
    // (heading, centre, start pose, laid)
    let mut placements: Vec<(f64, usize, Pose, bool)> = Vec::new();
    let mut laid: Vec<(f64, usize, Pose, f64)> = Vec::new();
    for (c, centre) in centres.iter().enumerate() {
        for (k, &(heading, turn)) in turns.iter().enumerate() {
            let shift = centre.coords - turn * model_centre.coords;
            let start = skeleton.moved_rigidly(&model.start, &turn, &shift);
            if k < headings {
                placements.push((heading, c, start, false));
            } else {
                tracker.set_pose(&start);
                let screened = screen(&tracker, &screen_data, screen_sigma, &mut grid, &mut em);
                laid.push((heading, c, start, screened));
            }
        }
    }
    laid.sort_by(|a, b| b.3.total_cmp(&a.3));
    placements.extend(
        laid.into_iter()
            .take(settings.laid_fits)
            .map(|(heading, c, start, _)| (heading, c, start, true)),
    );
    let mut root_fits: Vec<Hypothesis> = Vec::new();
    // The root-alone fits see every few points: a body's place and heading need few.
    let root_data: Vec<Point3> = data
        .iter()
        .step_by(data.len().div_ceil(settings.root_points.max(1)).max(1))
        .copied()
        .collect();
    for (heading, c, start, laid) in placements {
        let score = fit(&mut tracker, &start, &root_data, score_sigma);
        root_fits.push(Hypothesis {
            heading,
            centre: c,
            pose: tracker.pose.clone(),
            score,
            laid,
        });
    }
    root_fits.sort_by(|a, b| b.score.total_cmp(&a.score));
    // Indices into `root_fits` of the distinct placements kept: the best `keep` upright
    // and the best `laid_kept` laid (a laid body can explain a floor's clutter better at
    // the root-alone stage than the upright truth does; the every-joint fit decides).
    let mut kept: Vec<usize> = Vec::new();
    for (laid, count) in [(false, settings.keep.max(1)), (true, settings.laid_kept)] {
        let first = kept.len();
        for (i, hyp) in root_fits.iter().enumerate() {
            if kept.len() - first == count {
                break;
            }
            if hyp.laid == laid
                && !kept
                    .iter()
                    .any(|&k| same_place(skeleton, &root_fits[k].pose, &hyp.pose, &roots, h))
            {
                kept.push(i);
            }
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
    for i in kept {
        let hyp = &root_fits[i];
        let mut score = fit(&mut tracker, &hyp.pose, data, score_sigma);
        if settings.clip_places {
            score = at_clip_places(&mut tracker, score, data, score_sigma);
        }
        tracing::debug!(
            "initialise: heading {:.0} root score {:.3} -> {:.3}",
            hyp.heading.to_degrees(),
            hyp.score,
            score
        );
        tried[i].full_score = Some(score);
        tried[i].pose.clone_from(&tracker.pose);
        // A laid body must explain clearly more than an upright one (and an upright one
        // only as much as a laid one) to win: the rig's own up axis is the likelier.
        let handicap = |h: &Hypothesis| if h.laid { settings.laid_margin } else { 0.0 };
        if best
            .as_ref()
            .is_none_or(|b| score - handicap(hyp) > b.score - handicap(b))
        {
            best = Some(Hypothesis {
                heading: hyp.heading,
                centre: hyp.centre,
                pose: tracker.pose.clone(),
                score,
                laid: hyp.laid,
            });
        }
    }
    let mut best = best.ok_or(TrackError::NothingMoves)?;
    if settings.half_turn {
        let turned = half_turned(&mut tracker, &best.pose, &roots, &up);
        let mut score = fit(&mut tracker, &turned, data, score_sigma);
        if settings.clip_places {
            score = at_clip_places(&mut tracker, score, data, score_sigma);
        }
        tracing::debug!(
            "initialise: the winner {:.3}, turned half about its up axis {score:.3}",
            best.score
        );
        tried.push(Tried {
            heading: best.heading + std::f64::consts::PI,
            centre: best.centre,
            root_score: f64::NAN,
            full_score: Some(score),
            pose: tracker.pose.clone(),
        });
        if score > best.score {
            best.pose.clone_from(&tracker.pose);
            best.score = score;
            best.heading += std::f64::consts::PI;
        }
    }
    // Limbs the first pass left far from their data (a T-pose's arms against arms that
    // hang down) swung where they explain it best, before the refinement passes.
    if let Some(swings) = &settings.limb_swings {
        let (pose, moved) = swing_limbs(&mut tracker, &best.pose, data, swings);
        tracing::debug!("initialise: {moved} limbs swung");
        best.pose = pose;
    }
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

/// A laid placement's screening score: the share of `data` one E-step (eq. 17) at `sigma`
/// explains, with at most [`SCREEN_POINTS`] texture points (evenly strided).
fn screen(
    tracker: &Tracker,
    data: &[Point3],
    sigma: f64,
    grid: &mut PointGrid,
    em: &mut EmStep,
) -> f64 {
    let world = tracker.texture_positions();
    let stride = world.len().div_ceil(SCREEN_POINTS).max(1);
    let model: Vec<Point3> = world.into_iter().step_by(stride).collect();
    explained_share(
        data,
        &model,
        sigma,
        tracker.options.outlier_constant,
        grid,
        em,
    )
}

/// One EM run of the tracker (its current layout and options) from `start` on `data`,
/// then its score: the data's summed inlier posteriors (eq. 17) at `sigma`, per data point.
fn fit(tracker: &mut Tracker, start: &Pose, data: &[Point3], sigma: f64) -> f64 {
    tracker.set_pose(start);
    tracker.lambda = 1e-4;
    if tracker.track(data).is_err() {
        return f64::NEG_INFINITY;
    }
    tracker.explained_share(data, sigma)
}

/// Moves each free joint that has clip places ([`crate::skeleton::Joint::clip_places`]; a
/// joints file may have fixed it), with the joints tied to it, to the place that explains
/// `data` most (one E-step at `sigma` each, as [`fit`] scores), and returns the tracker's
/// new share explained; a joint none of whose places explains more than `explained` (the
/// pose's own share) stays where it is.
fn at_clip_places(tracker: &mut Tracker, explained: f64, data: &[Point3], sigma: f64) -> f64 {
    let skeleton = &tracker.model.skeleton;
    // Each joint that leads its places, with the joints tied to it that follow.
    let groups: Vec<Vec<usize>> = (0..skeleton.len())
        .filter(|&j| {
            let joint = skeleton.joint(j);
            !joint.clip_places.is_empty() && joint.tie.is_none() && joint.dof == JointDof::Free
        })
        .map(|j| {
            let count = skeleton.joint(j).clip_places.len();
            std::iter::once(j)
                .chain((0..skeleton.len()).filter(|&f| {
                    let follower = skeleton.joint(f);
                    follower.tie.is_some_and(|t| t.to == j)
                        && follower.clip_places.len() == count
                        && follower.dof == JointDof::Free
                }))
                .collect()
        })
        .collect();
    if groups.is_empty() || !explained.is_finite() {
        return explained;
    }
    let places: Vec<Vec<Vec<crate::math::Trs>>> = groups
        .iter()
        .map(|g| {
            g.iter()
                .map(|&j| skeleton.joint(j).clip_places.clone())
                .collect()
        })
        .collect();
    let mut explained = explained;
    let mut pose = tracker.pose.clone();
    for (group, places) in groups.iter().zip(&places) {
        let mut kept: Vec<_> = group.iter().map(|&j| pose.local[j]).collect();
        for k in 0..places[0].len() {
            for (&j, joint_places) in group.iter().zip(places) {
                pose.local[j] = joint_places[k];
            }
            tracker.set_pose(&pose);
            let share = tracker.explained_share(data, sigma);
            if share > explained {
                explained = share;
                kept = group.iter().map(|&j| pose.local[j]).collect();
            }
        }
        for (&j, local) in group.iter().zip(kept) {
            pose.local[j] = local;
        }
    }
    tracker.set_pose(&pose);
    explained
}

/// `pose` turned half about the model's up axis `up` as the first of `roots` carries it
/// there (from the start pose to `pose`), about the texture's centroid in `pose`.
fn half_turned(
    tracker: &mut Tracker,
    pose: &Pose,
    roots: &[usize],
    up: &nalgebra::Unit<Vector3>,
) -> Pose {
    let skeleton = &tracker.model.skeleton;
    let root = roots.first().copied().unwrap_or(0);
    let at = |p: &Pose| linear_part(&skeleton.world_matrices(p)[root]);
    let carried = at(pose)
        * at(&tracker.model.start)
            .try_inverse()
            .unwrap_or_else(nalgebra::Matrix3::identity);
    let axis = nalgebra::Unit::try_new(carried * up.into_inner(), 1e-12).unwrap_or(*up);
    let turn = Quat::from_axis_angle(&axis, std::f64::consts::PI);
    tracker.set_pose(pose);
    let centre = centroid(&tracker.texture_positions());
    let shift = centre.coords - turn * centre.coords;
    tracker.model.skeleton.moved_rigidly(pose, &turn, &shift)
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

/// The turns tried: `headings` about `up`, and with `any_up` the same about each world axis
/// after the model's up axis is laid along it. Each with its heading (radians).
fn orientations(up: &nalgebra::Unit<Vector3>, headings: usize, any_up: bool) -> Vec<(f64, Quat)> {
    let mut layings = vec![Quat::identity()];
    if any_up {
        for a in 0..3 {
            for sign in [1.0, -1.0] {
                let target = Vector3::from_fn(|i, _| if i == a { sign } else { 0.0 });
                if (target - up.into_inner()).norm() < 1e-9 {
                    continue;
                }
                // Laid from `up` onto `target`: the shortest turn, or half a turn about an
                // axis across `up` when `target` is its opposite.
                let laid = Quat::rotation_between(up, &target).unwrap_or_else(|| {
                    let across = if up.x.abs() < 0.9 {
                        Vector3::x()
                    } else {
                        Vector3::y()
                    };
                    Quat::from_axis_angle(
                        &nalgebra::Unit::new_normalize(up.cross(&across)),
                        std::f64::consts::PI,
                    )
                });
                layings.push(laid);
            }
        }
    }
    let mut out = Vec::new();
    for laid in layings {
        let axis = nalgebra::Unit::new_normalize(laid * up.into_inner());
        for k in 0..headings {
            let heading = std::f64::consts::TAU * k as f64 / headings as f64;
            out.push((heading, Quat::from_axis_angle(&axis, heading) * laid));
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

    /// The half turn is about the model's up axis as the root carries it: a body laid along
    /// x turns about x (every joint keeps its place along x), and twice is the identity.
    #[test]
    fn a_half_turn_is_about_the_carried_up_axis() {
        let model = ArticulatedModel::from_rig(&humanoid(), 500).expect("model");
        let mut tracker = Tracker::new(model.clone(), TrackOptions::default()).expect("tracker");
        let up = model.up_axis();
        assert_eq!(up, Vector3::y_axis());
        let laid = Quat::from_axis_angle(&Vector3::z_axis(), -std::f64::consts::FRAC_PI_2);
        let pose = model
            .skeleton
            .moved_rigidly(&model.start, &laid, &Vector3::new(0.3, 0.1, -0.2));
        let roots = root_joints(&model);
        let once = half_turned(&mut tracker, &pose, &roots, &up);
        let twice = half_turned(&mut tracker, &once, &roots, &up);
        let (p, q, r) = (
            model.skeleton.joint_positions(&pose),
            model.skeleton.joint_positions(&once),
            model.skeleton.joint_positions(&twice),
        );
        let h = model.height;
        let mut moved = 0.0_f64;
        for ((a, b), c) in p.iter().zip(&q).zip(&r) {
            assert!((a.x - b.x).abs() < 1e-9 * h, "{a} -> {b}");
            assert!((a - c).norm() < 1e-9 * h, "{a} -> {c}");
            moved = moved.max((a - b).norm());
        }
        assert!(
            moved > 0.1 * h,
            "the half turn moved joints by at most {moved}"
        );
    }

    /// A leg with clip places (here on the humanoid's thigh, made free): where the data
    /// shows the leg at one of them, the leg is put there; where it shows the leg as it
    /// stands, it stays; a thigh that may only turn is never moved to them.
    #[test]
    fn a_joint_is_put_at_the_clip_place_the_data_shows() {
        let mut rig = humanoid();
        let thigh = rig.skeleton.find("LeftUpLeg").expect("a thigh");
        rig.skeleton.set_dof(thigh, JointDof::Free, None);
        let rest = rig.skeleton.joint(thigh).rest;
        let place = |axis: Vector3, angle: f64, drop: f64| {
            let mut at = rest;
            at.rotation =
                Quat::from_axis_angle(&nalgebra::Unit::new_normalize(axis), angle) * rest.rotation;
            at.translation.y -= drop;
            at
        };
        let places = vec![
            place(Vector3::x(), -1.5, 0.3),
            place(Vector3::z(), 1.0, 0.0),
            place(Vector3::x(), 0.6, 0.1),
        ];
        rig.skeleton.set_clip_places(thigh, places.clone());
        let model = ArticulatedModel::from_rig(&rig, 1500).expect("model");
        let h = model.height;
        let mut tracker = Tracker::new(model.clone(), TrackOptions::default()).expect("tracker");
        let mut turning = model.clone();
        turning.skeleton.set_dof(thigh, JointDof::Ball, None);
        let mut turning = Tracker::new(turning, TrackOptions::default()).expect("tracker");
        for shown in [Some(0), Some(1), None] {
            let mut truth = model.start.clone();
            if let Some(k) = shown {
                truth.local[thigh] = places[k];
            }
            tracker.set_pose(&truth);
            let data = tracker.texture_positions();
            tracker.set_pose(&model.start);
            let before = tracker.explained_share(&data, 0.03 * h);
            let after = at_clip_places(&mut tracker, before, &data, 0.03 * h);
            let at = tracker.pose.local[thigh];
            match shown {
                Some(k) => {
                    assert!(after > before, "{after} against {before}");
                    assert_eq!(at, places[k], "place {k}");
                    turning.set_pose(&model.start);
                    let kept = at_clip_places(&mut turning, before, &data, 0.03 * h);
                    assert_eq!(kept, before, "a turning thigh stays");
                    assert_eq!(turning.pose.local[thigh], model.start.local[thigh]);
                }
                None => {
                    assert_eq!(after, before);
                    assert_eq!(at, model.start.local[thigh]);
                }
            }
        }
    }

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
        let truth = model.skeleton.moved_rigidly(&model.start, &turn, &shift);
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
