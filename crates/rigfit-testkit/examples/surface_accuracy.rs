//! The surface-tracking accuracy table of BENCHMARKS.md: ground-truth scan sequences drawn
//! from the real assets' own clips (30 frames at the clip's rate, 10,000 points a frame, 1%
//! noise, 15% outliers, a limb missing in frames 10-12), tracked frame to frame by the
//! paper's method and by rigfit's additions one by one.
//!
//! `cargo run --release -p rigfit-testkit --example surface_accuracy` (`VERBOSE=1` for every
//! frame; `METHOD=rigfit` for the rows whose label starts so)

use std::time::Instant;

use rand::SeedableRng;
use rand::rngs::StdRng;
use rigfit_core::surface::{Observations, SurfaceOptions, SurfaceTracker};
use rigfit_formats::rig_file::{RigOptions, read_rig};
use rigfit_testkit::surface_cases::{
    SequenceOptions, SurfaceSequence, find_animation, make_sequence, mean_and_p95, vertex_errors,
};

use rigfit_testkit::assets::asset as data;

/// Tracks a sequence: (mean, p95, mean over the missing limb in its hole frames, ms/frame,
/// iterations/frame, patches).
fn track(seq: &SurfaceSequence, options: &SurfaceOptions, label: &str) -> [f64; 6] {
    let mut tracker = SurfaceTracker::new(&seq.reference, options).expect("tracker");
    let mut fitted = Vec::new();
    let (mut seconds, mut iterations) = (0.0, 0);
    for (f, frame) in seq.frames.iter().enumerate() {
        let obs = Observations::from_mesh(frame).expect("frame");
        let t0 = Instant::now();
        let fit = tracker.track(&obs).expect("track");
        seconds += t0.elapsed().as_secs_f64();
        iterations += fit.iterations;
        if std::env::var("VERBOSE").is_ok() {
            let (m, p) = mean_and_p95(&vertex_errors(
                std::slice::from_ref(&fit.positions),
                &seq.truth[f..f + 1],
                seq.diagonal,
            ));
            eprintln!(
                "{label} frame {f}: mean {:.3}% p95 {:.3}%, {} iterations, sigma {:.4}, {} inliers",
                m * 100.0,
                p * 100.0,
                fit.iterations,
                fit.sigma / seq.diagonal,
                fit.inliers
            );
        }
        fitted.push(fit.positions);
    }
    let (mean, p95) = mean_and_p95(&vertex_errors(&fitted, &seq.truth, seq.diagonal));
    let hole_frames = SequenceOptions::default().hole_frames;
    let hole: Vec<f64> = hole_frames
        .flat_map(|f| seq.hole_vertices.iter().map(move |&v| (f, v)))
        .filter(|&(f, _)| f < fitted.len())
        .map(|(f, v)| (fitted[f][v] - seq.truth[f][v]).norm() / seq.diagonal)
        .collect();
    let n = seq.frames.len() as f64;
    [
        mean,
        p95,
        mean_and_p95(&hole).0,
        seconds / n * 1000.0,
        iterations as f64 / n,
        tracker.model.patch_count() as f64,
    ]
}

fn main() {
    // Every addition but the last, each frame starting from the previous fit with the
    // published first kernel.
    let previous_start = SurfaceOptions {
        initial_sigma: SurfaceOptions::paper().initial_sigma,
        extrapolate: false,
        ..SurfaceOptions::default()
    };
    let methods: Vec<(&str, SurfaceOptions)> = vec![
        ("paper (point-to-point, EM sigma)", SurfaceOptions::paper()),
        (
            "+ small parts follow",
            SurfaceOptions {
                tangential: 1.0,
                anneal: 0.0,
                ..previous_start.clone()
            },
        ),
        (
            "+ across-surface weighting",
            SurfaceOptions {
                anneal: 0.0,
                ..previous_start.clone()
            },
        ),
        ("+ annealed sigma", previous_start),
        (
            "rigfit (+ motion continued, narrower first kernel)",
            SurfaceOptions::default(),
        ),
        ("rigfit --fast-motion", SurfaceOptions::fast_motion()),
        (
            "rigfit, every point in every iteration",
            SurfaceOptions {
                coarse_stride: 1,
                ..SurfaceOptions::default()
            },
        ),
        (
            "rigfit --merge 2 (points merged by cubes of two spacings)",
            SurfaceOptions {
                merge_cell: 2.0,
                ..SurfaceOptions::default()
            },
        ),
    ];
    println!(
        "| method | asset (clip) | vertices | patches | mean error (% diag) | p95 (% diag) | missing limb, hole frames (% diag) | ms/frame | EM iterations/frame |"
    );
    println!("|---|---|---|---|---|---|---|---|---|");
    for (file, clip) in [
        ("assimp/BCN_Epileptic.glb", "jump"),
        ("assimp/Testwuson.glb", "run"),
    ] {
        let rig = read_rig(&data(file), &RigOptions::default())
            .expect("asset")
            .rig;
        let anim = find_animation(&rig, clip);
        let mut rng = StdRng::seed_from_u64(5);
        let seq = make_sequence(&rig, anim, &SequenceOptions::default(), &mut rng);
        let clip_name = rig
            .animations
            .get(anim)
            .map(|a| a.name.as_str())
            .unwrap_or("-");
        let only = std::env::var("METHOD").unwrap_or_default();
        for (label, options) in methods.iter().filter(|(l, _)| l.starts_with(&only)) {
            let [mean, p95, hole, ms, iterations, patches] = track(&seq, options, label);
            println!(
                "| {label} | {file} ({clip_name}) | {} | {patches} | {:.3} | {:.3} | {:.3} | {ms:.1} | {iterations:.1} |",
                seq.reference.vertices.len(),
                mean * 100.0,
                p95 * 100.0,
                hole * 100.0,
            );
        }
    }
}
