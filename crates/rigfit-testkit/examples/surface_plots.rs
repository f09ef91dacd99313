//! The surface-tracking benchmarks as plots (docs/img/surface_*.png) and the tables behind
//! them: per-vertex error against scan noise and against the outlier ratio (rigfit and the
//! method as published, BCN_Epileptic's jump, 12 frames, a limb missing in frames 10-11),
//! and time per frame against points per frame, log-log, with the PyPI peers on the same
//! axes from `scripts/bench-surface-scaling.sh`'s table.
//!
//! `scripts/bench-surface-scaling.sh > target/surface-scaling.tsv`
//! `cargo run --release -p rigfit-testkit --example surface_plots -- docs/img target/surface-scaling.tsv`

#[path = "common/plot_file.rs"]
mod plot_file;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use plot_file::write;
use rand::SeedableRng;
use rand::rngs::StdRng;
use rigfit_core::surface::{Observations, SurfaceOptions, SurfaceTracker};
use rigfit_render::{Chart, Series, line_chart};
use rigfit_testkit::surface_cases::{
    SequenceOptions, find_animation, make_sequence, mean_and_p95, vertex_errors,
};

/// Mean and p95 per-vertex error (% of the diagonal) of tracking a fresh sequence.
fn error(
    rig: &rigfit_core::Rig,
    options: &SurfaceOptions,
    sequence: &SequenceOptions,
) -> (f64, f64) {
    let anim = find_animation(rig, "jump");
    let seq = make_sequence(rig, anim, sequence, &mut StdRng::seed_from_u64(5));
    let mut tracker = SurfaceTracker::new(&seq.reference, options).expect("tracker");
    let fitted: Vec<_> = seq
        .frames
        .iter()
        .map(|f| {
            let obs = Observations::from_mesh(f).expect("frame");
            tracker.track(&obs).expect("track").positions
        })
        .collect();
    let (mean, p95) = mean_and_p95(&vertex_errors(&fitted, &seq.truth, seq.diagonal));
    (100.0 * mean, 100.0 * p95)
}

fn sweep(
    rig: &rigfit_core::Rig,
    dir: &Path,
    name: &str,
    title: &str,
    x_label: &str,
    values: &[f64],
    sequence: impl Fn(f64) -> SequenceOptions,
) {
    let methods = [
        ("rigfit", SurfaceOptions::default()),
        ("as published", SurfaceOptions::paper()),
    ];
    let mut chart = Chart::new(title, x_label, "mean vertex error (% of diagonal)");
    let mut rows = vec![Vec::new(); values.len()];
    for (label, options) in &methods {
        let points = values
            .iter()
            .zip(rows.iter_mut())
            .map(|(&x, row)| {
                let (mean, p95) = error(rig, options, &sequence(x));
                row.push((mean, p95));
                (x, mean)
            })
            .collect();
        chart.series.push(Series::new(*label, points));
    }
    println!("| {x_label} | rigfit mean / p95 (%) | as published mean / p95 (%) |");
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
    let mut args = std::env::args().skip(1);
    let dir = PathBuf::from(args.next().unwrap_or_else(|| "docs/img".into()));
    let times = args.next().map(PathBuf::from);
    std::fs::create_dir_all(&dir).expect("output folder");
    let rig = rigfit_testkit::assets::asset_rig("assimp/BCN_Epileptic.glb");
    let base = SequenceOptions {
        frames: 12,
        ..SequenceOptions::default()
    };
    sweep(
        &rig,
        &dir,
        "surface_error_vs_noise.png",
        "Surface tracking error against scan noise (BCN_Epileptic; 15% outliers)",
        "noise per coordinate (% of diagonal)",
        &[0.5, 1.0, 2.0, 3.0],
        |n| SequenceOptions {
            noise: n / 100.0,
            ..base.clone()
        },
    );
    sweep(
        &rig,
        &dir,
        "surface_error_vs_outliers.png",
        "Surface tracking error against outliers (BCN_Epileptic; 1% noise)",
        "outliers (% of the points)",
        &[0.0, 15.0, 30.0, 50.0],
        |o| SequenceOptions {
            outlier_ratio: o / 100.0,
            ..base.clone()
        },
    );

    // Time against points, with the peers, from the scaling script's table.
    let Some(times) = times else {
        return;
    };
    let text = std::fs::read_to_string(&times).expect("the scaling table");
    let mut series: BTreeMap<String, Vec<(f64, f64)>> = BTreeMap::new();
    for line in text.lines() {
        let cols: Vec<&str> = line.split('\t').collect();
        if let [n, method, ms] = cols[..]
            && let (Ok(n), Ok(ms)) = (n.parse::<f64>(), ms.parse::<f64>())
        {
            series.entry(method.to_string()).or_default().push((n, ms));
        }
    }
    let mut chart = Chart::new(
        "Surface tracking time against points per frame (BCN_Epileptic)",
        "points per frame",
        "ms per frame",
    );
    chart.x_log = true;
    chart.y_log = true;
    println!("| method | points per frame: ms per frame |");
    println!("|---|---|");
    for (method, points) in series {
        let cells: Vec<String> = points
            .iter()
            .map(|(n, ms)| format!("{n}: {ms:.0}"))
            .collect();
        println!("| {method} | {} |", cells.join(", "));
        chart.series.push(Series::new(method, points));
    }
    write(&line_chart(&chart), &dir, "surface_time_vs_points.png");
}
