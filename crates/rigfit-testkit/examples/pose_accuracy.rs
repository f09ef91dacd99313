//! The posing accuracy table of BENCHMARKS.md: ground-truth cases drawn from the real
//! assets' own animations (see tests/common/pose_suites.rs), solved by the paper's method and
//! by rigfit's improvements one by one.
//!
//! `cargo run --release -p rigfit-testkit --example pose_accuracy` (`VERBOSE=1` for every case)

use rigfit_testkit::pose_suites;

use pose_suites::solve_cases;
use rigfit_core::pose::PoseOptions;
use rigfit_core::pose::sketch::CaseOptions;

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
        (
            "+ chain step (greedy, by distance)",
            PoseOptions {
                global_assignment: false,
                shape_matching: false,
                ..PoseOptions::default()
            },
        ),
        (
            "+ global assignment",
            PoseOptions {
                shape_matching: false,
                ..PoseOptions::default()
            },
        ),
        ("rigfit (+ shape matching)", PoseOptions::default()),
    ];
    // ONLY=text keeps the methods whose name contains it.
    let only = std::env::var("ONLY").unwrap_or_default();
    let methods: Vec<_> = methods
        .into_iter()
        .filter(|(name, _)| name.contains(only.as_str()))
        .collect();
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
                for (t, outcome) in solve_cases(suite, mopts, copts).iter().enumerate() {
                    if std::env::var("VERBOSE").is_ok() {
                        eprintln!(
                            "{} #{t} {mname} / {sname}: {:.2}% ({} iterations)",
                            suite.name,
                            outcome.error * 100.0,
                            outcome.iterations
                        );
                    }
                    errors.push(outcome.error);
                    motion = motion.max(outcome.undrawn_motion);
                    time += outcome.seconds;
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
