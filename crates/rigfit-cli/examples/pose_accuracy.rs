//! Pose-from-strokes accuracy on the real assets: ground-truth cases drawn from the rigs'
//! own animations, solved by the paper's method and by rigfit's improvements.
//!
//! `cargo run --release -p rigfit-cli --example pose_accuracy [-- --quick]`

use std::path::PathBuf;
use std::time::Instant;

use rand::SeedableRng;
use rigfit_core::pose::cases::{CaseOptions, limb_motion, make_case, mean_joint_error};
use rigfit_core::pose::{PoseOptions, PoseProblem, solve_pose};
use rigfit_core::{Pose, Rig};
use rigfit_formats::rig_file::{RigOptions, StartFrame, read_rig};

fn data(rel: &str) -> PathBuf {
    let root = std::env::var("RIGFIT_DATA").unwrap_or_else(|_| {
        concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/data").to_string()
    });
    PathBuf::from(root).join(rel)
}

/// (name, rig, start pose, true poses)
fn suites() -> Vec<(String, Rig, Pose, Vec<Pose>)> {
    let mut out = Vec::new();
    let bvh = read_rig(
        &data("cmu/01_01.bvh"),
        &RigOptions {
            start_frame: StartFrame::Rest,
            ..Default::default()
        },
    )
    .expect("01_01.bvh");
    let anim = &bvh.rig.animations[0];
    let frames = anim.frame_count();
    let dt = anim.frame_time.unwrap_or(1.0 / 120.0);
    let truths: Vec<Pose> = (0..10)
        .map(|i| anim.sample(&bvh.rig.pose, (i * (frames - 1) / 9) as f64 * dt))
        .collect();
    out.push((
        "01_01.bvh".to_string(),
        bvh.rig.clone(),
        bvh.rig.pose.clone(),
        truths,
    ));
    for file in ["assimp/BCN_Epileptic.glb", "assimp/Testwuson.glb"] {
        let r = read_rig(&data(file), &RigOptions::default()).expect("rig");
        let anim = &r.rig.animations[0];
        let (s, e) = (anim.start(), anim.end());
        let truths = (0..5)
            .map(|i| anim.sample(&r.rig.pose, s + (e - s) * (i as f64 + 0.5) / 5.0))
            .collect();
        out.push((file.to_string(), r.rig.clone(), r.rig.pose.clone(), truths));
    }
    // The WebXR hand (rest pose only): fingers curled by poses set here.
    let hand = read_rig(&data("webxr_hand/left.glb"), &RigOptions::default()).expect("hand");
    let mut truths = Vec::new();
    for i in 0..5u64 {
        let mut pose = hand.rig.pose.clone();
        let mut state = 99 + i * 7919;
        let mut random = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        for (j, joint) in hand.rig.skeleton.joints().iter().enumerate() {
            let curl = if joint.name.contains("metacarpal") {
                0.15
            } else {
                1.1
            };
            if joint.name.contains("phalanx") || joint.name.contains("metacarpal") {
                let bend = rigfit_core::Quat::from_euler_angles(
                    curl * random(),
                    0.0,
                    0.3 * (random() - 0.5),
                );
                pose.local[j].rotation *= bend;
            }
        }
        truths.push(pose);
    }
    out.push((
        "webxr_hand/left.glb".to_string(),
        hand.rig.clone(),
        hand.rig.pose.clone(),
        truths,
    ));
    out
}

fn main() {
    let methods: Vec<(&str, PoseOptions)> = vec![
        ("paper (softassign + annealing)", PoseOptions::paper()),
        (
            "+ beautify",
            PoseOptions {
                beautify: true,
                ..PoseOptions::paper()
            },
        ),
        (
            "+ rigid init",
            PoseOptions {
                beautify: true,
                rigid_init: true,
                ..PoseOptions::paper()
            },
        ),
        (
            "+ geometric beta",
            PoseOptions {
                chain_assignment: false,
                ..PoseOptions::default()
            },
        ),
        ("rigfit (+ chain step)", PoseOptions::default()),
    ];
    let scenarios: Vec<(&str, CaseOptions)> = vec![
        ("1% noise", CaseOptions::default()),
        (
            "one limb undrawn",
            CaseOptions {
                drop_limbs: 1,
                ..Default::default()
            },
        ),
        (
            "one stray stroke",
            CaseOptions {
                stray_strokes: 1,
                ..Default::default()
            },
        ),
    ];
    let suites = suites();
    println!(
        "| method | scenario | cases | mean error (% height) | cases < 2% | worst | undrawn limb motion (max % h) | ms/solve |"
    );
    println!("|---|---|---|---|---|---|---|---|");
    for (mname, mopts) in &methods {
        for (sname, copts) in &scenarios {
            let mut errors = Vec::new();
            let mut motion: f64 = 0.0;
            let mut time = 0.0;
            let mut n = 0;
            for (suite, rig, start, truths) in &suites {
                let height = rig.height();
                for (t, truth) in truths.iter().enumerate() {
                    let mut rng = rand::rngs::StdRng::seed_from_u64(1000 + t as u64);
                    let case = make_case(&rig.skeleton, truth, height, copts, &mut rng);
                    let problem = PoseProblem {
                        skeleton: &rig.skeleton,
                        start,
                        strokes: &case.strokes,
                        movable: None,
                        height,
                    };
                    let t0 = Instant::now();
                    let result = solve_pose(&problem, mopts).expect("solves");
                    time += t0.elapsed().as_secs_f64();
                    n += 1;
                    let err = mean_joint_error(
                        &rig.skeleton,
                        &result.pose,
                        truth,
                        &case.drawn_joints,
                        height,
                    );
                    if std::env::var("VERBOSE").is_ok() {
                        eprintln!(
                            "{suite} #{t} {mname} / {sname}: {:.2}% ({} iterations)",
                            err * 100.0,
                            result.iterations
                        );
                    }
                    errors.push(err);
                    for chain in &case.dropped_chains {
                        let m = limb_motion(&rig.skeleton, start, &result.pose, chain, height);
                        if std::env::var("VERBOSE").is_ok() {
                            let names: Vec<&str> = chain
                                .iter()
                                .map(|&j| rig.skeleton.joint(j).name.as_str())
                                .collect();
                            eprintln!("   undrawn {names:?} moved {:.2}%", m * 100.0);
                        }
                        motion = motion.max(m);
                    }
                }
            }
            let mean = errors.iter().sum::<f64>() / errors.len() as f64;
            let ok = errors.iter().filter(|&&e| e < 0.02).count();
            let worst = errors.iter().copied().fold(0.0, f64::max);
            let motion = if copts.drop_limbs > 0 {
                format!("{:.2}", motion * 100.0)
            } else {
                "-".into()
            };
            println!(
                "| {mname} | {sname} | {} | {:.2} | {}/{} | {:.1} | {motion} | {:.1} |",
                errors.len(),
                mean * 100.0,
                ok,
                errors.len(),
                worst * 100.0,
                time / n as f64 * 1000.0
            );
        }
    }
}
