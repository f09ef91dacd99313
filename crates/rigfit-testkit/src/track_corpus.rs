//! Tracking takes from where they really start (issue 23), on the tracking suites and on
//! the rigs of the posing corpus: each sequence is moved as a whole by a random rigid motion
//! (any turn about the rig's up axis, a shift anywhere in a 4 m square scaled by the
//! height / 1.75) and tracked by [`Take`] from the rig's stored (rest or bind) pose, the
//! take choosing the first frame's start and searching again on collapsed frames.
//!
//! A corpus rig's sequence ([`corpus_sequence`]): the rig read as the corpus reads it, its
//! start pose stored, the joint model `rigfit track` uses ([`tracked_rig`]); 60 frames at
//! 30 fps of its own clip ([`clip_motion`]: its longest stretch without a jump) or, without
//! a clip, a smooth synthetic motion ([`synthetic_motion`]: every joint turned from the
//! start pose through three random far poses while the body travels and turns). Points are
//! drawn by [`make_sequence`] with the rig stood upright (its up axis turned onto y, where
//! `make_sequence` puts its floor and lifts its cameras; a flat rig, whose height is not
//! along its up axis, as it lies) and turned back.
//! The suites' sequences ([`suite_sequence`]) are `track_init`'s: the suite's own frames
//! moved by the same rigid motions.
//!
//! Errors ([`track_sequence`]): mean joint distance over the reported joints per frame, a
//! fraction of the height (the corpus's height along its up axis; the model's for the
//! suites). The bounds of issue 23 ([`TakeOutcome::ok`]): mean below 3% from frame 5 on and
//! no frame above 10% from frame 5 on.
//!
//! Up to the rig's own symmetries ([`crate::symmetry::rig_symmetries`] of its stored pose):
//! a body that a rotation maps onto itself with its joints relabelled (a box character
//! turned half round, left and right swapped; a quadruped with four like legs) gives the
//! same points as its twin, so no tracker can tell the twin from the truth. The errors
//! take, for the whole sequence, the relabelling with the lowest mean from frame [`FROM`]
//! on ([`TakeOutcome::twin`] when it is not the identity); the identity's errors are kept
//! too ([`TakeOutcome::strict_errors`], [`TakeOutcome::strict_ok`]), and both counts are
//! reported.
//!
//! `cargo run --release -p rigfit-testkit --example track_corpus` prints the table.

use std::time::Instant;

use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use rigfit_core::track::parts::PartModel;
use rigfit_core::track::{
    ArticulatedModel, FrameStart, Take, TakeFrame, TakeOptions, TrackOptions, Tracker,
};
use rigfit_core::{Pose, Quat, Rig, Trs, Vector3};

use crate::corpus::{Corpus, CorpusRig};
use crate::symmetry;
use crate::targets::{FarPoseOptions, far_pose};
use crate::track_cases::{SequenceFrame, SequenceOptions, make_sequence};
use crate::track_suites::{self, FRAMES, joint_error, tracked_rig};

/// Frames per second of every sequence.
pub const FPS: f64 = 30.0;
/// The error bounds of issue 23, as fractions of the height.
pub const MEAN_BOUND: f64 = 0.03;
pub const FRAME_BOUND: f64 = 0.10;
/// Frames before this one may still be settling.
pub const FROM: usize = 5;
/// The suites and the corpus rigs they are.
pub const SUITES: [(&str, &str); 4] = [
    ("hand", "webxr-hand-left"),
    ("01_01", "cmu-01_01"),
    ("BCN_Epileptic", "assimp-bcn_epileptic"),
    ("Testwuson", "assimp-testwuson"),
];

/// The corpus rigs tracked besides the suites (three seeds each in `examples/track_corpus`
/// and in the whole-corpus test): bodies, hands, quadrupeds, robots and a creature.
pub const CORPUS_RIGS: [&str; 11] = [
    "assimp-boxing_toes",
    "bvhtoolbox-mocapbank",
    "bvhtoolbox-freebvh",
    "minetest-character",
    "gymr-shadow_hand",
    "gymr-adroit_hand",
    "dmc-dog",
    "dmc-quadruped",
    "gymr-fetch",
    "minetest-maidroid",
    "assimp-mrfixit",
];

/// Where a sequence's motion came from.
#[derive(Clone, Debug, PartialEq)]
pub enum Motion {
    /// The suite's own motion.
    Suite,
    /// The rig's clip from `offset` seconds in, `length` seconds of it used (played back
    /// and forth when `bounced`).
    Clip {
        offset: f64,
        length: f64,
        bounced: bool,
    },
    /// Slerped through random far poses, with a root travel.
    Synthetic,
}

/// A generated, rigidly moved sequence and what is needed to track and judge it.
#[derive(Debug)]
pub struct MovedSequence {
    /// The corpus id (or the suite's name).
    pub id: String,
    /// The corpus half and kind (`None` when the corpus does not list the rig).
    pub half: Option<crate::Half>,
    pub kind: String,
    pub seed: u64,
    /// The rig the errors are measured on, and the model the take fits.
    pub rig: Rig,
    pub model: ArticulatedModel,
    /// Errors are fractions of this.
    pub height: f64,
    pub up: Vector3,
    /// The up axis the first-frame search turns about (the model's, from its surface's
    /// box as `Rig::height` decides): a search about another axis than `up` cannot undo
    /// the turn.
    pub search_up: Vector3,
    /// The rigid motion's turn about `up` (radians) and shift.
    pub turn: f64,
    pub shift: Vector3,
    pub motion: Motion,
    /// The largest step of the true motion between two frames: mean joint distance,
    /// fraction of the height.
    pub max_step: f64,
    pub frames: Vec<SequenceFrame>,
}

/// How a take did on a sequence.
#[derive(Clone, Debug)]
pub struct TakeOutcome {
    /// How the first frame started.
    pub start: FrameStart,
    /// Mean joint error per frame, fraction of the height, under the rig's symmetry (the
    /// joint relabelling) that suits the whole take best.
    pub errors: Vec<f64>,
    /// The errors without relabelling (the identity's).
    pub strict_errors: Vec<f64>,
    /// The relabelling chosen is not the identity: the take tracked the rig's twin.
    pub twin: bool,
    /// Frames found collapsed, and of those the ones the search recovered.
    pub collapsed: Vec<usize>,
    pub recovered: usize,
    pub seconds: Vec<f64>,
    /// The search's score (the share of the first frame's points explained, eq. 17) of the
    /// first frame's true pose: a take that lands elsewhere with as good a score met an
    /// ambiguity, one with a lower score a search that missed.
    pub truth_score: f64,
    /// Per frame, the angle between the fitted and the true world rotation of the
    /// character's root (radians): a wrong heading shows here, wrong limbs do not.
    pub root_angles: Vec<f64>,
    /// Per reported joint (index, mean distance from frame [`FROM`] on to its fitted image
    /// under the chosen relabelling, fraction of the height), worst first.
    pub joint_means: Vec<(usize, f64)>,
}

/// The errors from frame [`FROM`] on.
fn later(errors: &[f64]) -> &[f64] {
    &errors[FROM.min(errors.len())..]
}

/// Within issue 23's bounds: mean below [`MEAN_BOUND`], no frame above [`FRAME_BOUND`].
fn within_bounds(errors: &[f64]) -> bool {
    let later = later(errors);
    let mean = later.iter().sum::<f64>() / later.len().max(1) as f64;
    mean < MEAN_BOUND && !later.iter().any(|&e| e > FRAME_BOUND)
}

impl TakeOutcome {
    fn later(&self) -> &[f64] {
        later(&self.errors)
    }
    /// The first frame's error.
    pub fn init_error(&self) -> f64 {
        self.errors.first().copied().unwrap_or(f64::NAN)
    }
    /// Mean error from frame [`FROM`] on.
    pub fn mean_from(&self) -> f64 {
        let later = self.later();
        later.iter().sum::<f64>() / later.len().max(1) as f64
    }
    /// Worst error from frame [`FROM`] on.
    pub fn worst_from(&self) -> f64 {
        self.later().iter().copied().fold(0.0, f64::max)
    }
    /// Frames above [`FRAME_BOUND`] from frame [`FROM`] on.
    pub fn lost(&self) -> usize {
        self.later().iter().filter(|&&e| e > FRAME_BOUND).count()
    }
    /// Within issue 23's bounds.
    pub fn ok(&self) -> bool {
        within_bounds(&self.errors)
    }
    /// Within the bounds without relabelling ([`TakeOutcome::strict_errors`]).
    pub fn strict_ok(&self) -> bool {
        within_bounds(&self.strict_errors)
    }
    pub fn ms_per_frame(&self) -> f64 {
        1000.0 * self.seconds.iter().sum::<f64>() / self.seconds.len().max(1) as f64
    }
    /// The first frame's start and scores in a few words: `searched 0.70 (stored 0.21;
    /// truth 0.70)`.
    pub fn start_label(&self) -> String {
        let truth = format!("truth {:.2}", self.truth_score);
        match self.start {
            FrameStart::Stored {
                score,
                searched: Some(s),
            } => format!("stored {score:.2} (search {s:.2}; {truth})"),
            FrameStart::Stored { score, .. } => format!("stored {score:.2} ({truth})"),
            FrameStart::Searched {
                score,
                stored: Some(s),
            } => format!("searched {score:.2} (stored {s:.2}; {truth})"),
            FrameStart::Searched { score, .. } => format!("searched {score:.2} ({truth})"),
            other => format!("{other:?} ({truth})"),
        }
    }
}

/// A turn by any angle about `up` and a shift anywhere in a 4 m square across it (scaled by
/// `height / 1.75`), drawn from `rng` as `track_init` draws them.
fn rigid_motion(up: &Vector3, height: f64, rng: &mut impl Rng) -> (f64, Quat, Vector3) {
    let angle = rng.random_range(0.0..std::f64::consts::TAU);
    let axis = nalgebra::Unit::new_normalize(*up);
    let turn = Quat::from_axis_angle(&axis, angle);
    let [a, b] = across(up);
    let scale = height / 1.75;
    let shift = (a * rng.random_range(-2.0..2.0) + b * rng.random_range(-2.0..2.0)) * scale;
    (angle, turn, shift)
}

/// Two unit axes across `up`: x and z for y-up, x and y for z-up (as `track_init`).
pub fn across(up: &Vector3) -> [Vector3; 2] {
    let up = up.normalize();
    if up.y.abs() > 0.99 {
        return [Vector3::x(), Vector3::z()];
    }
    if up.z.abs() > 0.99 {
        return [Vector3::x(), Vector3::y()];
    }
    let a = (Vector3::x() - up * up.x)
        .try_normalize(1e-9)
        .unwrap_or_else(Vector3::y);
    [a, up.cross(&a)]
}

/// Moves every frame (points and true pose) by the rigid motion.
fn move_frames(rig: &Rig, frames: &mut [SequenceFrame], turn: &Quat, shift: &Vector3) {
    for frame in frames {
        for p in &mut frame.points {
            *p = turn * *p + shift;
        }
        frame.truth = rig.skeleton.moved_rigidly(&frame.truth, turn, shift);
    }
}

/// [`make_sequence`] with the rig stood upright: `up` turned onto y (where the floor and
/// the cameras' lift are) for drawing, the points turned back, the truth left as given.
pub fn upright_sequence(
    rig: &Rig,
    parts: &PartModel,
    poses: &[Pose],
    up: &Vector3,
    options: &SequenceOptions,
) -> Vec<SequenceFrame> {
    let to_y = Quat::rotation_between(up, &Vector3::y())
        .unwrap_or_else(|| Quat::from_axis_angle(&Vector3::x_axis(), std::f64::consts::PI));
    if to_y.angle() < 1e-12 {
        return make_sequence(rig, parts, poses, options);
    }
    let zero = Vector3::zeros();
    let mut upright = rig.clone();
    upright.pose = rig.skeleton.moved_rigidly(&rig.pose, &to_y, &zero);
    let turned: Vec<Pose> = poses
        .iter()
        .map(|p| rig.skeleton.moved_rigidly(p, &to_y, &zero))
        .collect();
    let mut frames = make_sequence(&upright, parts, &turned, options);
    let back = to_y.inverse();
    for (frame, pose) in frames.iter_mut().zip(poses) {
        for p in &mut frame.points {
            *p = back * *p;
        }
        frame.truth = pose.clone();
    }
    frames
}

/// The largest mean joint step between consecutive poses, fraction of `height`.
fn max_step(rig: &Rig, poses: &[Pose], height: f64) -> f64 {
    poses
        .windows(2)
        .map(|w| joint_error(rig, &w[0], &w[1], height))
        .fold(0.0, f64::max)
}

/// A deterministic number for a rig id (FNV-1a), to seed its sequences.
fn id_seed(id: &str) -> u64 {
    id.bytes().fold(0xcbf2_9ce4_8422_2325, |h, b| {
        (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3)
    })
}

/// A suite's sequence (its own frames and model, [`track_suites::suite`]) moved by
/// `track_init`'s rigid motion of `seed`. `corpus` gives the half and kind when it has the rig.
pub fn suite_sequence(
    name: &'static str,
    seed: u64,
    options: &SequenceOptions,
    corpus: Option<&Corpus>,
) -> MovedSequence {
    let suite = track_suites::suite(name, FRAMES, options);
    let rig = suite.rig;
    let h = suite.model.height;
    // As track_init decides it: z when the height is the box's z side.
    let extent = rig.bounds(&rig.pose).expect("bounds").extent();
    let up = if (rig.height() - extent.z).abs() < 1e-12 && (extent.y - extent.z).abs() > 0.0 {
        Vector3::z()
    } else {
        Vector3::y()
    };
    let mut frames = suite.frames;
    let (angle, turn, shift) = rigid_motion(&up, h, &mut StdRng::seed_from_u64(0x23_0000 + seed));
    move_frames(&rig, &mut frames, &turn, &shift);
    let poses: Vec<Pose> = frames.iter().map(|f| f.truth.clone()).collect();
    let entry = SUITES
        .iter()
        .find(|(n, _)| *n == name)
        .and_then(|(_, id)| corpus?.entry(id));
    MovedSequence {
        id: name.to_string(),
        half: entry.map(|e| e.half),
        kind: entry.map_or_else(|| "suite".into(), |e| kind_name(e.kind)),
        seed,
        max_step: max_step(&rig, &poses, h),
        rig,
        search_up: suite.model.up_axis().into_inner(),
        model: suite.model,
        height: h,
        up,
        turn: angle,
        shift,
        motion: Motion::Suite,
        frames,
    }
}

/// A rig kind's manifest name.
pub fn kind_name(kind: crate::RigKind) -> String {
    let debug = format!("{kind:?}");
    let mut out = String::new();
    for (i, c) in debug.chars().enumerate() {
        if c.is_uppercase() && i > 0 {
            out.push('-');
        }
        out.push(c.to_ascii_lowercase());
    }
    out
}

/// A corpus rig's sequence of seed `seed` (see the module's documentation), or why the
/// rig cannot be tracked (it does not read, or no model can be built from it).
pub fn corpus_sequence(
    corpus: &Corpus,
    id: &str,
    seed: u64,
    options: &SequenceOptions,
) -> Result<MovedSequence, String> {
    let entry = corpus
        .entry(id)
        .ok_or_else(|| format!("{id} is not in the corpus"))?;
    let read = corpus.read_rig(entry).map_err(|e| e.to_string())?;
    let mut rig = read.rig.clone();
    rig.pose = read.start.clone();
    let model = ArticulatedModel::from_rig(&tracked_rig(&rig), 0)
        .map_err(|e| format!("no tracking model: {e}"))?;
    let mut rng = StdRng::seed_from_u64(id_seed(id) ^ (0x23_0000 + seed));
    let (poses, motion) = match clip_motion(&read, FRAMES) {
        Some((poses, motion)) => (poses, motion),
        None => (synthetic_motion(&read, FRAMES, &mut rng), Motion::Synthetic),
    };
    let sequence = SequenceOptions {
        seed: options.seed ^ seed,
        ..options.clone()
    };
    // A flat character (its height is its largest extent, not along up: a hand lying in
    // the ground plane) is drawn as it lies: the cameras look along z.
    let along = rig
        .extent_points(&rig.pose)
        .iter()
        .map(|p| p.coords.dot(&read.up))
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), h| {
            (lo.min(h), hi.max(h))
        });
    let drawn_up = if along.1 - along.0 >= 0.999 * read.height {
        read.up
    } else {
        Vector3::y()
    };
    let mut frames = upright_sequence(&rig, &model.parts, &poses, &drawn_up, &sequence);
    if frames.len() != poses.len() {
        return Err("the sequence generator drew no frames".into());
    }
    let (angle, turn, shift) = rigid_motion(&read.up, read.height, &mut rng);
    move_frames(&rig, &mut frames, &turn, &shift);
    Ok(MovedSequence {
        id: id.to_string(),
        half: Some(entry.half),
        kind: kind_name(entry.kind),
        seed,
        max_step: max_step(&rig, &poses, read.height),
        rig,
        search_up: model.up_axis().into_inner(),
        model,
        height: read.height,
        up: read.up,
        turn: angle,
        shift,
        motion,
        frames,
    })
}

/// `frames` poses of the rig's first clip that lasts, 1/30 s apart, from its longest
/// stretch without a jump (a step of over 5% of the height and 5 times the median step: a
/// calibration pose at its start, or a cut between the ranges of a clip that strings several
/// motions together), played back and forth when that stretch is shorter than the take.
/// `None` without a clip.
pub fn clip_motion(read: &CorpusRig, frames: usize) -> Option<(Vec<Pose>, Motion)> {
    let clip = read.rig.animations.iter().find(|a| a.duration() > 0.0)?;
    let (start, duration) = (clip.start(), clip.duration());
    let sample = |t: f64| clip.sample(&read.start, start + t);
    let steps = ((duration * FPS).floor() as usize).min(600);
    let poses: Vec<Pose> = (0..=steps).map(|k| sample(k as f64 / FPS)).collect();
    let step: Vec<f64> = poses
        .windows(2)
        .map(|w| joint_error(&read.rig, &w[0], &w[1], read.height))
        .collect();
    let mut sorted = step.clone();
    sorted.sort_by(f64::total_cmp);
    let median = sorted.get(sorted.len() / 2).copied().unwrap_or(0.0);
    // Stretches of samples [first, last] with no jump between them; the longest wins.
    let (mut best, mut first) = ((0, 0), 0);
    for (k, &s) in step.iter().enumerate().chain([(steps, &f64::INFINITY)]) {
        if s > 0.05 && s > 5.0 * median {
            if k - first > best.1 - best.0 {
                best = (first, k);
            }
            first = k + 1;
        }
    }
    let offset = best.0 as f64 / FPS;
    let usable = (best.1 - best.0) as f64 / FPS;
    let bounced = usable < (frames.max(1) - 1) as f64 / FPS;
    let poses = (0..frames)
        .map(|f| {
            let mut t = f as f64 / FPS;
            if bounced {
                t %= (2.0 * usable).max(1e-12);
                if t > usable {
                    t = 2.0 * usable - t;
                }
            }
            sample(offset + t)
        })
        .collect();
    let motion = Motion::Clip {
        offset,
        length: if bounced { usable } else { duration - offset },
        bounced,
    };
    Some((poses, motion))
}

/// Smooth interpolation weight (zero slope at both ends).
fn ease(u: f64) -> f64 {
    let u = u.clamp(0.0, 1.0);
    u * u * (3.0 - 2.0 * u)
}

/// The rotation a share `u` of the way from `p`'s to `q`'s, interpolated as the joints'
/// limits are written: the rotation vector relative to `rest` (a hinge's angle, a ball's
/// axis times angle) moves on a straight line, so that between two keys within a joint's
/// limits the motion stays within them. A slerp takes the short way round: between a wrist
/// bent 2 radians one way and 2 the other it went through the half turn, 0.8 radians past
/// the limits of Fetch's wrist, where no tracker that keeps to them can follow.
fn within_limits(rest: &Quat, p: &Trs, q: &Trs, u: f64) -> Quat {
    let from = (rest.inverse() * p.rotation).scaled_axis();
    let to = (rest.inverse() * q.rotation).scaled_axis();
    rest * Quat::from_scaled_axis(from.lerp(&to, u))
}

/// A smooth synthetic motion of `frames` frames from the rig's start pose through three
/// random far poses (limbs up to 90 degrees, other joints up to 40, no heading), every
/// joint turned between them with eased timing (its rotation vector from rest on a straight
/// line, within its limits), while the whole body travels a third of its height across the
/// up axis and turns up to 40 degrees about it.
pub fn synthetic_motion(read: &CorpusRig, frames: usize, rng: &mut impl Rng) -> Vec<Pose> {
    synthetic_motion_through(read, frames, 3, rng)
}

/// [`synthetic_motion`] through `far_poses` random far poses instead of three (more of them
/// over the same frames: faster motion).
pub fn synthetic_motion_through(
    read: &CorpusRig,
    frames: usize,
    far_poses: usize,
    rng: &mut impl Rng,
) -> Vec<Pose> {
    let rig = &read.rig;
    let far = FarPoseOptions {
        limb_turn: 90f64.to_radians(),
        bend: 40f64.to_radians(),
        heading: 0.0,
        up: read.up,
        ..FarPoseOptions::default()
    };
    let mut keys = vec![read.start.clone()];
    for _ in 0..far_poses.max(1) {
        keys.push(far_pose(
            &rig.skeleton,
            &read.start,
            &rig.animations,
            read.height,
            &far,
            rng,
        ));
    }
    let [a, b] = across(&read.up);
    let direction = rng.random_range(0.0..std::f64::consts::TAU);
    let travel = (a * direction.cos() + b * direction.sin()) * (read.height / 3.0);
    let spin = rng.random_range(-40f64..=40.0).to_radians();
    let axis = nalgebra::Unit::new_normalize(read.up);
    let pivot = rig.skeleton.skin_root().map_or_else(Vector3::zeros, |r| {
        rig.skeleton.joint_positions(&read.start)[r].coords
    });
    (0..frames)
        .map(|f| {
            let s = f as f64 / (frames.max(2) - 1) as f64;
            let along = s * (keys.len() - 1) as f64;
            let k = (along.floor() as usize).min(keys.len() - 2);
            let u = ease(along - k as f64);
            let mut pose = keys[k].clone();
            for (j, local) in pose.local.iter_mut().enumerate() {
                let (p, q) = (&keys[k].local[j], &keys[k + 1].local[j]);
                local.rotation = within_limits(&rig.skeleton.joint(j).rest.rotation, p, q, u);
                local.translation = p.translation.lerp(&q.translation, u);
                local.scale = p.scale.lerp(&q.scale, u);
            }
            // The travel: turn about the root's start position, then shift.
            let w = ease(s);
            let turn = Quat::from_axis_angle(&axis, spin * w);
            let shift = pivot - turn * pivot + travel * w;
            rig.skeleton.moved_rigidly(&pose, &turn, &shift)
        })
        .collect()
}

/// How [`track_sequence`] tracks: the tracker's options, and whether it starts from the
/// first frame's true pose (to tell the tracker's own error from the first frame's search).
#[derive(Clone, Debug, Default)]
pub struct TakeSettings {
    pub track: TrackOptions,
    pub take: TakeOptions,
    pub from_truth: bool,
}

/// What tracks a sequence's frames: a take (its first frame searched or stored), or a
/// tracker put at the first frame's truth.
enum Driver {
    Take(Box<Take>),
    FromTruth(Box<Tracker>),
}

/// Tracks a sequence with [`Take`] from the model's stored pose (or, `from_truth`, with
/// [`Tracker`] from the first frame's true pose).
pub fn track_sequence(
    sequence: &MovedSequence,
    settings: &TakeSettings,
) -> Result<TakeOutcome, String> {
    let mut driver = match (settings.from_truth, sequence.frames.first()) {
        (true, Some(first)) => {
            let mut tracker = Tracker::new(sequence.model.clone(), settings.track.clone())
                .map_err(|e| format!("no tracker: {e}"))?;
            tracker.set_pose(&first.truth);
            Driver::FromTruth(Box::new(tracker))
        }
        _ => Driver::Take(Box::new(
            Take::new(
                sequence.model.clone(),
                settings.track.clone(),
                settings.take.clone(),
            )
            .map_err(|e| format!("no take: {e}"))?,
        )),
    };
    let mut out = TakeOutcome {
        start: FrameStart::Tracked,
        errors: Vec::new(),
        strict_errors: Vec::new(),
        twin: false,
        collapsed: Vec::new(),
        recovered: 0,
        seconds: Vec::new(),
        truth_score: f64::NAN,
        root_angles: Vec::new(),
        joint_means: Vec::new(),
    };
    if let Some(first) = sequence.frames.first() {
        let mut probe = Tracker::new(sequence.model.clone(), TrackOptions::default())
            .map_err(|e| format!("no tracker: {e}"))?;
        probe.set_pose(&first.truth);
        let sigma = TakeOptions::default().search.score_sigma * sequence.model.height;
        out.truth_score = probe.explained_share(&first.points, sigma);
    }
    let rig = &sequence.rig;
    let reported: Vec<usize> = rig.reported_joints().collect();
    let (mut fits, mut truths) = (Vec::new(), Vec::new());
    let root = rig.skeleton.skin_root().unwrap_or(0);
    for (k, frame) in sequence.frames.iter().enumerate() {
        let t0 = Instant::now();
        let fit = match &mut driver {
            Driver::Take(take) => take.track(&frame.points),
            Driver::FromTruth(tracker) => tracker.track(&frame.points).map(|fit| TakeFrame {
                fit,
                start: FrameStart::Tracked,
            }),
        }
        .map_err(|e| format!("frame {k}: {e}"))?;
        out.seconds.push(t0.elapsed().as_secs_f64());
        if k == 0 {
            out.start = fit.start;
        }
        if let FrameStart::Collapsed { recovered, .. } = fit.start {
            out.collapsed.push(k);
            out.recovered += usize::from(recovered);
        }
        let (a, b) = (
            world_rotation(rig, &fit.fit.pose, root),
            world_rotation(rig, &frame.truth, root),
        );
        out.root_angles.push(a.angle_to(&b));
        fits.push(rig.skeleton.joint_positions(&fit.fit.pose));
        truths.push(rig.skeleton.joint_positions(&frame.truth));
    }
    // One relabelling for the whole take: the symmetry that suits it best from frame FROM on.
    let h = sequence.height;
    let labellings = symmetry::rig_symmetries(rig, &rig.pose, h);
    let chosen =
        &labellings[symmetry::best_labelling(&labellings, &fits, &truths, &reported, h, FROM)];
    out.twin = chosen.iter().enumerate().any(|(i, &p)| i != p);
    out.strict_errors = symmetry::relabelled_errors(&fits, &truths, &reported, &labellings[0], h);
    out.errors = symmetry::relabelled_errors(&fits, &truths, &reported, chosen, h);
    out.joint_means = symmetry::joint_means(&fits, &truths, &reported, chosen, h, FROM);
    out.joint_means.sort_by(|a, b| b.1.total_cmp(&a.1));
    Ok(out)
}

/// The world rotation of joint `j` in `pose` (local rotations multiplied up its chain).
fn world_rotation(rig: &Rig, pose: &Pose, j: usize) -> Quat {
    let mut rotation = pose.local[j].rotation;
    let mut at = rig.skeleton.joint(j).parent;
    while let Some(p) = at {
        rotation = pose.local[p].rotation * rotation;
        at = rig.skeleton.joint(p).parent;
    }
    rotation
}
