//! The posing benchmarks as plots (docs/img/pose_*.png) and the tables behind them:
//! error against stroke noise and against stray strokes (outliers) for rigfit and the
//! paper's method on the 25 ground-truth cases of `pose_accuracy`, and solve time against
//! the number of stroke points, log-log, on BCN_Epileptic (55 joints, 10 strokes).
//!
//! `cargo run --release -p rigfit-testkit --example pose_plots [OUT_DIR]` (default docs/img)

#[path = "common/plot_file.rs"]
mod plot_file;

use rigfit_testkit::pose_suites;

use std::path::PathBuf;
use std::time::Instant;

use plot_file::write;
use rigfit_core::pose::sketch::CaseOptions;
use rigfit_core::pose::{PoseOptions, PoseProblem, solve_pose};
use rigfit_formats::rig_file::{RigOptions, read_rig};
use rigfit_render::{Chart, Series, line_chart};

fn methods() -> [(&'static str, PoseOptions); 2] {
    [
        ("rigfit", PoseOptions::default()),
        ("paper (softassign + annealing)", PoseOptions::paper()),
    ]
}

/// Mean and median error (% of the height) over every case of every suite.
fn errors(
    suites: &[pose_suites::Suite],
    options: &PoseOptions,
    scenario: &CaseOptions,
) -> (f64, f64) {
    let mut errors: Vec<f64> = suites
        .iter()
        .flat_map(|s| pose_suites::solve_cases(s, options, scenario))
        .map(|o| o.error * 100.0)
        .collect();
    errors.sort_by(f64::total_cmp);
    (
        errors.iter().sum::<f64>() / errors.len() as f64,
        errors[errors.len() / 2],
    )
}

fn main() {
    let dir = PathBuf::from(std::env::args().nth(1).unwrap_or_else(|| "docs/img".into()));
    std::fs::create_dir_all(&dir).expect("output folder");
    let suites = pose_suites::suites();

    // Error against noise.
    let noise_levels = [0.0, 0.5, 1.0, 2.0, 3.0, 4.0];
    let mut chart = Chart::new(
        "Posing error against stroke noise (25 cases)",
        "noise per coordinate (% of height)",
        "mean joint error (% of height)",
    );
    println!(
        "| noise (% height) | rigfit mean / median error (%) | paper mean / median error (%) |\n|---|---|---|"
    );
    let mut rows = vec![Vec::new(); noise_levels.len()];
    let mut rows_of_noise = Vec::new();
    for (name, options) in methods() {
        let points: Vec<(f64, f64)> = noise_levels
            .iter()
            .map(|&n| {
                let scenario = CaseOptions {
                    noise: n / 100.0,
                    ..Default::default()
                };
                let (mean, median) = errors(&suites, &options, &scenario);
                rows_of_noise.push((mean, median));
                (n, mean)
            })
            .collect();
        for (row, p) in rows.iter_mut().zip(rows_of_noise.drain(..)) {
            row.push(p);
        }
        chart.series.push(Series::new(name, points));
    }
    for (n, row) in noise_levels.iter().zip(&rows) {
        println!(
            "| {n} | {:.2} / {:.2} | {:.2} / {:.2} |",
            row[0].0, row[0].1, row[1].0, row[1].1
        );
    }
    write(&line_chart(&chart), &dir, "pose_error_vs_noise.png");

    // Error against stray strokes (the outliers of posing).
    let strays = [0usize, 1, 2, 3, 4];
    let mut chart = Chart::new(
        "Posing error against stray strokes (25 cases)",
        "stray strokes added (outliers)",
        "mean joint error (% of height)",
    );
    println!(
        "\n| stray strokes | rigfit mean / median error (%) | paper mean / median error (%) |\n|---|---|---|"
    );
    let mut rows = vec![Vec::new(); strays.len()];
    let mut rows_of_strays = Vec::new();
    for (name, options) in methods() {
        let points: Vec<(f64, f64)> = strays
            .iter()
            .map(|&k| {
                let scenario = CaseOptions {
                    stray_strokes: k,
                    ..Default::default()
                };
                let (mean, median) = errors(&suites, &options, &scenario);
                rows_of_strays.push((mean, median));
                (k as f64, mean)
            })
            .collect();
        for (row, p) in rows.iter_mut().zip(rows_of_strays.drain(..)) {
            row.push(p);
        }
        chart.series.push(Series::new(name, points));
    }
    for (k, row) in strays.iter().zip(&rows) {
        println!(
            "| {k} | {:.2} / {:.2} | {:.2} / {:.2} |",
            row[0].0, row[0].1, row[1].0, row[1].1
        );
    }
    write(&line_chart(&chart), &dir, "pose_error_vs_strays.png");

    // Time against the number of stroke points, log-log.
    let file = read_rig(
        &rigfit_testkit::assets::asset("assimp/BCN_Epileptic.glb"),
        &RigOptions::default(),
    )
    .expect("rig");
    let rig = &file.rig;
    let truth = rig.animations[0].sample(&rig.pose, 1.5);
    let per_stroke = [10usize, 30, 100, 300, 1000];
    let mut chart = Chart::new(
        "Posing time against stroke points (BCN_Epileptic, 10 strokes)",
        "stroke points",
        "ms per solve",
    );
    chart.x_log = true;
    chart.y_log = true;
    println!("\n| stroke points | rigfit (ms) | paper (ms) |\n|---|---|---|");
    let mut rows = vec![Vec::new(); per_stroke.len()];
    for (name, options) in methods() {
        let points: Vec<(f64, f64)> = per_stroke
            .iter()
            .map(|&n| {
                let drawing = CaseOptions {
                    min_chain_length: 0.03,
                    sample_spacing: 0.0005,
                    ..Default::default()
                };
                let strokes = pose_suites::strokes_of_size(rig, &truth, 10, n, &drawing);
                let total: usize = strokes.iter().map(|s| s.points.len()).sum();
                let problem = PoseProblem {
                    skeleton: &rig.skeleton,
                    start: &rig.pose,
                    strokes: &strokes,
                    movable: None,
                    height: rig.height(),
                };
                // The fastest of five runs.
                let best = (0..5)
                    .map(|_| {
                        let t0 = Instant::now();
                        solve_pose(&problem, &options).expect("solves");
                        t0.elapsed().as_secs_f64()
                    })
                    .fold(f64::INFINITY, f64::min);
                (total as f64, best * 1000.0)
            })
            .collect();
        for (row, p) in rows.iter_mut().zip(&points) {
            row.push(*p);
        }
        chart.series.push(Series::new(name, points));
    }
    for row in &rows {
        println!("| {} | {:.1} | {:.1} |", row[0].0, row[0].1, row[1].1);
    }
    write(&line_chart(&chart), &dir, "pose_time_vs_points.png");
}
