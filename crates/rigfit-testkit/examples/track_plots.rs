//! The tracking benchmarks as plots (docs/img/track_*.png) and the tables behind them:
//! mean joint error against data noise and against the outlier ratio, rigfit and the EM as
//! published on the same axes (the 60-frame sequences of the hand and BCN_Epileptic of the
//! accuracy table), and time per frame against points per frame, log-log, on the
//! hand and BCN_Epileptic.
//!
//! `cargo run --release -p rigfit-testkit --example track_plots [OUT_DIR]` (default docs/img)

#[path = "common/plot_file.rs"]
mod plot_file;

use rigfit_testkit::track_suites;

use std::path::{Path, PathBuf};

use plot_file::write;
use rigfit_core::track::TrackOptions;
use rigfit_render::{Chart, Series, line_chart};
use rigfit_testkit::track_cases::SequenceOptions;

const FRAMES: usize = track_suites::FRAMES;
const SUITES: [&str; 2] = ["hand", "BCN_Epileptic"];

/// Mean over the suites of each sequence's mean joint error (% of the height), and the
/// worst frame.
fn error(options: &TrackOptions, sequence: &SequenceOptions) -> (f64, f64) {
    let outcomes: Vec<_> = SUITES
        .iter()
        .map(|n| track_suites::track(&track_suites::suite(n, FRAMES, sequence), options))
        .collect();
    let mean = outcomes.iter().map(|o| o.mean()).sum::<f64>() / outcomes.len() as f64;
    let worst = outcomes.iter().map(|o| o.worst()).fold(0.0, f64::max);
    (100.0 * mean, 100.0 * worst)
}

/// One chart of error against a sequence setting, with its table printed.
fn sweep(
    dir: &Path,
    name: &str,
    title: &str,
    x_label: &str,
    values: &[f64],
    sequence: impl Fn(f64) -> SequenceOptions,
) {
    let methods = [
        ("rigfit", TrackOptions::default()),
        ("EM as published", TrackOptions::paper()),
    ];
    let mut chart = Chart::new(title, x_label, "mean joint error (% of height)");
    let mut rows = vec![Vec::new(); values.len()];
    for (label, options) in &methods {
        let points: Vec<(f64, f64)> = values
            .iter()
            .zip(rows.iter_mut())
            .map(|(&x, row)| {
                let (mean, worst) = error(options, &sequence(x));
                row.push((mean, worst));
                (x, mean)
            })
            .collect();
        chart.series.push(Series::new(*label, points));
    }
    println!(
        "| {x_label} | rigfit mean / worst frame (%) | EM as published mean / worst frame (%) |"
    );
    println!("|---|---|---|");
    for (x, row) in values.iter().zip(&rows) {
        println!(
            "| {x} | {:.2} / {:.2} | {:.2} / {:.2} |",
            row[0].0, row[0].1, row[1].0, row[1].1
        );
    }
    write(&line_chart(&chart), dir, name);
}

fn main() {
    let dir = PathBuf::from(std::env::args().nth(1).unwrap_or_else(|| "docs/img".into()));
    std::fs::create_dir_all(&dir).expect("output folder");
    sweep(
        &dir,
        "track_error_vs_noise.png",
        "Tracking error against data noise (hand, BCN_Epileptic; 25% outliers)",
        "noise per coordinate (% of height)",
        &[0.5, 1.0, 2.0, 3.0],
        |n| SequenceOptions {
            noise: n / 100.0,
            ..SequenceOptions::default()
        },
    );
    sweep(
        &dir,
        "track_error_vs_outliers.png",
        "Tracking error against outliers (hand, BCN_Epileptic; 1% noise)",
        "outliers (% of the points)",
        &[0.0, 25.0, 50.0, 75.0],
        |o| SequenceOptions {
            outliers: o / 100.0,
            ..SequenceOptions::default()
        },
    );

    // Time per frame against points per frame, log-log.
    let sizes = [500usize, 1000, 2000, 4000, 8000, 16000];
    let mut chart = Chart::new(
        "Tracking time against points per frame",
        "points per frame",
        "ms per frame",
    );
    chart.x_log = true;
    chart.y_log = true;
    println!("| points per frame | hand (ms) | BCN_Epileptic (ms) |");
    println!("|---|---|---|");
    let mut rows = vec![Vec::new(); sizes.len()];
    for name in SUITES {
        let points: Vec<(f64, f64)> = sizes
            .iter()
            .zip(rows.iter_mut())
            .map(|(&n, row)| {
                let sequence = SequenceOptions {
                    points: n,
                    ..SequenceOptions::default()
                };
                let suite = track_suites::suite(name, FRAMES, &sequence);
                let ms = track_suites::track(&suite, &TrackOptions::default()).ms_per_frame();
                row.push(ms);
                (n as f64, ms)
            })
            .collect();
        chart.series.push(Series::new(name, points));
    }
    for (n, row) in sizes.iter().zip(&rows) {
        println!("| {n} | {:.2} | {:.2} |", row[0], row[1]);
    }
    write(&line_chart(&chart), &dir, "track_time_vs_points.png");
}
