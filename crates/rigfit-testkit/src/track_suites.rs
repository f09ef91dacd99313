//! The tracking ground-truth sequences on the real assets, shared by the accuracy test, the
//! accuracy table example and the bench: BCN_Epileptic.glb (its clip) and Testwuson.glb
//! (its run clip) at 30 frames per second, the WebXR hand with a scripted finger motion,
//! and 01_01.bvh every fourth frame (30 per second) with ellipsoids sized from bone
//! lengths, from 1 s in (its frame 0 is a calibration T-pose). Each: 60 frames, about 2,000 points a frame seen from two cameras, 1% noise,
//! 25% outliers. Tracking starts from the first frame's true pose.

use std::path::{Path, PathBuf};
use std::time::Instant;

use crate::track_cases::{SequenceFrame, SequenceOptions, clip_poses, hand_motion, make_sequence};
use rigfit_core::Pose;
use rigfit_core::Rig;
use rigfit_core::joint_model::{with_clip_model, with_clip_ranges};
use rigfit_core::track::{ArticulatedModel, TrackOptions, Tracker};
use rigfit_formats::rig_file::{RigOptions, read_rig};

use crate::assets::asset;

/// A rig and a generated sequence.
#[derive(Debug)]
pub struct TrackSuite {
    pub name: &'static str,
    pub rig: Rig,
    pub model: ArticulatedModel,
    pub frames: Vec<SequenceFrame>,
}

/// Frames per sequence.
pub const FRAMES: usize = 60;

/// Loads one suite with `frames` frames.
pub fn suite(name: &'static str, frames: usize, options: &SequenceOptions) -> TrackSuite {
    let (file, clip) = match name {
        "BCN_Epileptic" => ("assimp/BCN_Epileptic.glb", Some(0)),
        "Testwuson" => ("assimp/Testwuson.glb", Some(0)),
        "hand" => ("webxr_hand/left.glb", None),
        "01_01" => ("cmu/01_01.bvh", Some(0)),
        _ => panic!("unknown suite {name}"),
    };
    let rig = read_rig(&asset(file), &RigOptions::default())
        .expect("asset loads")
        .rig;
    let poses = match clip {
        // The CMU conversions hold a calibration T-pose at frame 0: start 1 s in.
        Some(c) => clip_poses(
            &rig,
            c,
            frames,
            30.0,
            if name == "01_01" { 1.0 } else { 0.0 },
        ),
        None => hand_motion(&rig, frames),
    };
    let count = std::env::var("MP")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(TrackOptions::default().model_points);
    let model = ArticulatedModel::from_rig(&tracked_rig(&rig), count).expect("model");
    let frames = make_sequence(&rig, &model.parts, &poses, options);
    TrackSuite {
        name,
        rig,
        model,
        frames,
    }
}

/// `rig` with the joint model `rigfit track` fits: the clips' hinges and soft limits
/// ([`with_clip_model`]). `JOINT_MODEL=none` keeps every joint a free ball, `ranges` keeps
/// them balls with the clips' ranges (for comparing the three).
pub fn tracked_rig(rig: &Rig) -> Rig {
    let mut modelled = rig.clone();
    match std::env::var("JOINT_MODEL").as_deref() {
        Ok("none") => {}
        Ok("ranges") => modelled.skeleton = with_clip_ranges(&rig.skeleton, &rig.animations),
        _ => modelled.skeleton = with_clip_model(&rig.skeleton, &rig.animations),
    }
    modelled
}

/// The four suites.
pub fn suites(frames: usize) -> Vec<TrackSuite> {
    ["BCN_Epileptic", "Testwuson", "hand", "01_01"]
        .into_iter()
        .map(|n| suite(n, frames, &SequenceOptions::default()))
        .collect()
}

/// How a tracker did on a sequence.
#[derive(Debug, Clone)]
pub struct TrackOutcome {
    /// Mean joint error per frame, fraction of the height.
    pub frame_errors: Vec<f64>,
    pub seconds: Vec<f64>,
    /// Per frame: (true inliers kept, outliers kept).
    pub inliers: Vec<usize>,
}

impl TrackOutcome {
    pub fn mean(&self) -> f64 {
        self.frame_errors.iter().sum::<f64>() / self.frame_errors.len().max(1) as f64
    }
    pub fn worst(&self) -> f64 {
        self.frame_errors.iter().copied().fold(0.0, f64::max)
    }
    pub fn ms_per_frame(&self) -> f64 {
        1000.0 * self.seconds.iter().sum::<f64>() / self.seconds.len().max(1) as f64
    }
}

/// Mean distance between the joints of two poses over the reported joints, fraction of
/// the height.
pub fn joint_error(rig: &Rig, a: &Pose, b: &Pose, height: f64) -> f64 {
    let pa = rig.skeleton.joint_positions(a);
    let pb = rig.skeleton.joint_positions(b);
    let joints: Vec<usize> = rig.reported_joints().collect();
    joints.iter().map(|&j| (pa[j] - pb[j]).norm()).sum::<f64>()
        / joints.len().max(1) as f64
        / height
}

/// Tracks a suite's sequence with `options`, from the first frame's true pose.
pub fn track(suite: &TrackSuite, options: &TrackOptions) -> TrackOutcome {
    let mut tracker = Tracker::new(suite.model.clone(), options.clone()).expect("tracker");
    tracker.set_pose(&suite.frames[0].truth);
    let h = suite.model.height;
    let mut out = TrackOutcome {
        frame_errors: Vec::new(),
        seconds: Vec::new(),
        inliers: Vec::new(),
    };
    for frame in &suite.frames {
        let t0 = Instant::now();
        let fit = tracker.track(&frame.points).expect("frame tracks");
        out.seconds.push(t0.elapsed().as_secs_f64());
        out.frame_errors
            .push(joint_error(&suite.rig, &fit.pose, &frame.truth, h));
        out.inliers.push(fit.inliers);
    }
    out
}

/// Writes a suite's first `n` frames as PLY clouds and its first true pose as the start
/// rig (`start.glb` / `start.bvh`). Returns the start rig and the frame files.
pub fn write_sequence(
    dir: &Path,
    name: &'static str,
    n: usize,
) -> (PathBuf, Vec<PathBuf>, TrackSuite) {
    // The full 60-frame motion (the scripted hand's speed depends on it), first n frames.
    let mut suite = suite(name, FRAMES, &SequenceOptions::default());
    suite.frames.truncate(n);
    let source = match name {
        "01_01" => "cmu/01_01.bvh",
        "hand" => "webxr_hand/left.glb",
        _ => "assimp/BCN_Epileptic.glb",
    };
    let rig_file = read_rig(&asset(source), &RigOptions::default()).expect("rig");
    let start = dir.join(if source.ends_with(".bvh") {
        "start.bvh"
    } else {
        "start.glb"
    });
    rig_file
        .write_pose(&start, &suite.frames[0].truth, None)
        .expect("start rig written");
    let files = suite
        .frames
        .iter()
        .enumerate()
        .map(|(k, f)| {
            let path = dir.join(format!("frame_{k:04}.ply"));
            let cloud = rigfit_core::TriMesh {
                vertices: f.points.clone(),
                ..rigfit_core::TriMesh::default()
            };
            rigfit_formats::ply::write_ply(&path, &cloud).expect("frame written");
            path
        })
        .collect();
    (start, files, suite)
}
