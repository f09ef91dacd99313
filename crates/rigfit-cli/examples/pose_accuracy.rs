//! The posing accuracy table of BENCHMARKS.md: ground-truth cases drawn from the real
//! assets' own animations (see tests/common/pose_suites.rs), solved by the paper's method and
//! by rigfit's improvements one by one.
//!
//! `cargo run --release -p rigfit-cli --example pose_accuracy` (`VERBOSE=1` for every case)

#[path = "../tests/common/pose_suites.rs"]
mod pose_suites;

use std::time::Instant;

use rand::SeedableRng;
use rigfit_core::pose::cases::{CaseOptions, limb_motion, make_case, mean_joint_error};
use rigfit_core::pose::{PoseOptions, PoseProblem, solve_pose};

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
            "+ rigid multi-start",
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
    let suites = pose_suites::suites();
    println!(
        "| method | scenario | cases | mean error (% height) | cases < 2% | worst (%) | undrawn limb motion (max % h) | ms/solve |"
    );
    println!("|---|---|---|---|---|---|---|---|");
    for (mname, mopts) in &methods {
        for (sname, copts) in &scenarios {
            let mut errors = Vec::new();
            let mut motion: f64 = 0.0;
            let mut time = 0.0;
            for suite in &suites {
                let height = suite.rig.height();
                for (t, truth) in suite.truths.iter().enumerate() {
                    let mut rng = rand::rngs::StdRng::seed_from_u64(1000 + t as u64);
                    let case = make_case(&suite.rig.skeleton, truth, height, copts, &mut rng);
                    let problem = PoseProblem {
                        skeleton: &suite.rig.skeleton,
                        start: &suite.start,
                        strokes: &case.strokes,
                        movable: None,
                        height,
                    };
                    let t0 = Instant::now();
                    let result = solve_pose(&problem, mopts).expect("solves");
                    time += t0.elapsed().as_secs_f64();
                    let err = mean_joint_error(
                        &suite.rig.skeleton,
                        &result.pose,
                        truth,
                        &case.drawn_joints,
                        height,
                    );
                    if std::env::var("VERBOSE").is_ok() {
                        eprintln!(
                            "{} #{t} {mname} / {sname}: {:.2}% ({} iterations)",
                            suite.name,
                            err * 100.0,
                            result.iterations
                        );
                    }
                    errors.push(err);
                    for chain in &case.dropped_chains {
                        motion = motion.max(limb_motion(
                            &suite.rig.skeleton,
                            &suite.start,
                            &result.pose,
                            chain,
                            height,
                        ));
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
                "| {mname} | {sname} | {} | {:.2} | {ok}/{} | {:.1} | {motion} | {:.1} |",
                errors.len(),
                mean * 100.0,
                errors.len(),
                worst * 100.0,
                time / errors.len() as f64 * 1000.0
            );
        }
    }
}
