//! The posing ground-truth suites on the real assets, shared by the accuracy test and the
//! accuracy table example: 01_01.bvh at 10 frames spread over the clip from its rest pose;
//! BCN_Epileptic.glb and Testwuson.glb at 5 times of their first clip from their stored pose;
//! the WebXR hand with 5 finger poses set here.

use crate::sweep::limb_motion;
use rand::SeedableRng;
use rigfit_core::humanoid::humanoid;
use rigfit_core::pose::beautify::resample;
use rigfit_core::pose::sketch::{Case, CaseOptions, make_case, mean_joint_error};
use rigfit_core::pose::{PoseOptions, PoseProblem, solve_pose};
use rigfit_core::{Joint, Pose, Quat, Rig, Skeleton, Stroke, Trs, Vector3};
use rigfit_formats::rig_file::{RigOptions, StartFrame, read_rig};

use crate::assets::asset;

/// One suite: a rig, the pose the solver starts from, and the true poses to recover.
#[derive(Debug)]
pub struct Suite {
    pub name: String,
    pub rig: Rig,
    pub start: Pose,
    pub truths: Vec<Pose>,
}

/// Finger poses for the hand: every phalanx curled by a seeded random angle.
fn hand_poses(rig: &Rig, count: u64) -> Vec<Pose> {
    (0..count)
        .map(|i| {
            let mut pose = rig.pose.clone();
            let mut state = 99 + i * 7919;
            let mut random = || {
                state = state
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                (state >> 11) as f64 / (1u64 << 53) as f64
            };
            for (j, joint) in rig.skeleton.joints().iter().enumerate() {
                let curl = if joint.name.contains("metacarpal") {
                    0.15
                } else {
                    1.1
                };
                if joint.name.contains("phalanx") || joint.name.contains("metacarpal") {
                    pose.local[j].rotation *=
                        Quat::from_euler_angles(curl * random(), 0.0, 0.3 * (random() - 0.5));
                }
            }
            pose
        })
        .collect()
}

/// All suites.
pub fn suites() -> Vec<Suite> {
    let mut out = Vec::new();
    let bvh = read_rig(
        &asset("cmu/01_01.bvh"),
        &RigOptions {
            start_frame: StartFrame::Rest,
            ..Default::default()
        },
    )
    .expect("01_01.bvh");
    let anim = &bvh.rig.animations[0];
    let frames = anim.frame_count();
    let dt = anim.frame_time.unwrap_or(1.0 / 120.0);
    let truths = (0..10)
        .map(|i| anim.sample(&bvh.rig.pose, (i * (frames - 1) / 9) as f64 * dt))
        .collect();
    out.push(Suite {
        name: "01_01.bvh".into(),
        start: bvh.rig.pose.clone(),
        rig: bvh.rig,
        truths,
    });
    for file in ["assimp/BCN_Epileptic.glb", "assimp/Testwuson.glb"] {
        let r = read_rig(&asset(file), &RigOptions::default()).expect("rig");
        let anim = &r.rig.animations[0];
        let (s, e) = (anim.start(), anim.end());
        let truths = (0..5)
            .map(|i| anim.sample(&r.rig.pose, s + (e - s) * (i as f64 + 0.5) / 5.0))
            .collect();
        out.push(Suite {
            name: file.into(),
            start: r.rig.pose.clone(),
            rig: r.rig,
            truths,
        });
    }
    let hand = read_rig(&asset("webxr_hand/left.glb"), &RigOptions::default()).expect("hand");
    let truths = hand_poses(&hand.rig, 5);
    out.push(Suite {
        name: "webxr_hand/left.glb".into(),
        start: hand.rig.pose.clone(),
        rig: hand.rig,
        truths,
    });
    out
}

/// What one case gave.
#[derive(Debug, Clone, Copy)]
pub struct Outcome {
    /// Mean error over drawn joints, as a fraction of the height.
    pub error: f64,
    /// How far undrawn limbs moved from their start pose (fraction of the height; 0 when
    /// every limb was drawn).
    pub undrawn_motion: f64,
    pub seconds: f64,
    pub iterations: usize,
}

/// Draws every case of `suite` for `scenario` (seeded per case) and solves it.
pub fn solve_cases(suite: &Suite, options: &PoseOptions, scenario: &CaseOptions) -> Vec<Outcome> {
    let skeleton = &suite.rig.skeleton;
    // As `rigfit pose` does: the ranges the rig's clips show choose among explanations.
    let with_ranges = rigfit_core::joint_model::with_clip_ranges(skeleton, &suite.rig.animations);
    let height = suite.rig.height();
    suite
        .truths
        .iter()
        .enumerate()
        .map(|(t, truth)| {
            let mut rng = rand::rngs::StdRng::seed_from_u64(1000 + t as u64);
            let case = make_case(skeleton, truth, height, scenario, &mut rng);
            let problem = PoseProblem {
                skeleton: &with_ranges,
                start: &suite.start,
                strokes: &case.strokes,
                movable: None,
                height,
            };
            let t0 = std::time::Instant::now();
            let result = solve_pose(&problem, options).expect("solves");
            let seconds = t0.elapsed().as_secs_f64();
            let undrawn_motion = case
                .dropped_chains
                .iter()
                .map(|chain| limb_motion(skeleton, &suite.start, &result.pose, chain, height))
                .fold(0.0, f64::max);
            Outcome {
                error: mean_joint_error(skeleton, &result.pose, truth, &case.drawn_joints, height),
                undrawn_motion,
                seconds,
                iterations: result.iterations,
            }
        })
        .collect()
}

/// The humanoid with extra joints `(name, parent, offset)` that no vertex follows.
pub fn humanoid_with(extra: &[(&str, &str, [f64; 3])]) -> Rig {
    let mut rig = humanoid();
    let mut joints = rig.skeleton.joints().to_vec();
    for &(name, parent, offset) in extra {
        let parent = joints.iter().position(|j| j.name == parent);
        joints.push(Joint::new(
            name,
            parent,
            Trs::from_translation(Vector3::from(offset)),
        ));
    }
    rig.skeleton = Skeleton::new(joints).expect("parents come first");
    rig.skeleton.set_default_dofs();
    rig.pose = rig.skeleton.rest_pose();
    for mesh in &mut rig.meshes {
        mesh.inverse_bind
            .resize(rig.skeleton.len(), rigfit_core::math::Matrix4::identity());
    }
    rig
}

/// The rig's first clip sampled at `time` (seconds), and strokes drawn through that pose as a
/// user would (the default [`CaseOptions`], seeded by `seed`): the true pose and the case.
pub fn case_from_clip(rig: &Rig, time: f64, seed: u64) -> (Pose, Case) {
    let clip = rig.animations.first().expect("the rig has an animation");
    let truth = clip.sample(&rig.pose, time);
    let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
    let case = make_case(
        &rig.skeleton,
        &truth,
        rig.height(),
        &CaseOptions::default(),
        &mut rng,
    );
    (truth, case)
}

/// `count` strokes of exactly `points` points each drawn through `truth` (`options`, seed 3),
/// the longest chains first: the fixed-size inputs of the posing bench and speed plots.
pub fn strokes_of_size(
    rig: &Rig,
    truth: &Pose,
    count: usize,
    points: usize,
    options: &CaseOptions,
) -> Vec<Stroke> {
    let mut rng = rand::rngs::StdRng::seed_from_u64(3);
    let mut strokes = make_case(&rig.skeleton, truth, rig.height(), options, &mut rng).strokes;
    strokes.sort_by(|a, b| b.length().total_cmp(&a.length()));
    strokes.truncate(count);
    for s in &mut strokes {
        let spacing = s.length() / (points - 1) as f64;
        s.points = resample(&s.points, spacing * 0.999);
        s.points.truncate(points);
    }
    strokes
}
