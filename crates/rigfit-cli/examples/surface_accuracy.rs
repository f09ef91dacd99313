//! The surface-tracking accuracy table of BENCHMARKS.md: ground-truth scan sequences drawn
//! from the real assets' own animations (30 frames, 10,000 points a frame, 1% noise, 15%
//! outliers, a limb missing in frames 10-15), tracked frame to frame.
//!
//! `cargo run --release -p rigfit-cli --example surface_accuracy`

use std::time::Instant;

use rand::SeedableRng;
use rand::rngs::StdRng;
use rigfit_core::surface::cases::{
    SequenceOptions, find_animation, make_sequence, mean_and_p95, vertex_errors,
};
use rigfit_core::surface::{Observations, SurfaceOptions, SurfaceTracker};
use rigfit_formats::rig_file::{RigOptions, read_rig};

fn data(rel: &str) -> std::path::PathBuf {
    let root = std::env::var("RIGFIT_DATA")
        .unwrap_or_else(|_| concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/data").into());
    std::path::Path::new(&root).join(rel)
}

fn main() {
    let options = SurfaceOptions::default();
    println!("| asset (clip) | vertices | patches | mean error (% diag) | p95 (% diag) | hole-frame limb mean (% diag) | ms/frame | EM iterations/frame |");
    println!("|---|---|---|---|---|---|---|---|");
    for (file, clip) in [("assimp/BCN_Epileptic.glb", "jump"), ("assimp/Testwuson.glb", "run")] {
        let rig = read_rig(&data(file), &RigOptions::default()).expect("asset").rig;
        let anim = find_animation(&rig, clip);
        let mut rng = StdRng::seed_from_u64(5);
        let seq = make_sequence(&rig, anim, &SequenceOptions::default(), &mut rng);
        let mut tracker = SurfaceTracker::new(&seq.reference, &options).expect("tracker");
        let mut fitted = Vec::new();
        let mut seconds = 0.0;
        let mut iterations = 0;
        for frame in &seq.frames {
            let obs = Observations::from_mesh(frame).expect("frame");
            let t0 = Instant::now();
            let fit = tracker.track(&obs).expect("track");
            seconds += t0.elapsed().as_secs_f64();
            iterations += fit.iterations;
            if std::env::var("VERBOSE").is_ok() {
                let f = fitted.len();
                let (m, p) = mean_and_p95(&vertex_errors(&[fit.positions.clone()], &seq.truth[f..f + 1], seq.diagonal));
                eprintln!("{file} frame {f}: mean {:.3}% p95 {:.3}% it {} sigma {:.4} inliers {}", m * 100.0, p * 100.0, fit.iterations, fit.sigma / seq.diagonal, fit.inliers);
            }
            fitted.push(fit.positions);
        }
        let errors = vertex_errors(&fitted, &seq.truth, seq.diagonal);
        let (mean, p95) = mean_and_p95(&errors);
        let hole: Vec<f64> = (10..16)
            .flat_map(|f| seq.hole_vertices.iter().map(move |&v| (f, v)))
            .map(|(f, v)| (fitted[f][v] - seq.truth[f][v]).norm() / seq.diagonal)
            .collect();
        let (hole_mean, _) = mean_and_p95(&hole);
        let n = seq.frames.len() as f64;
        println!(
            "| {file} ({}) | {} | {} | {:.3} | {:.3} | {:.3} | {:.1} | {:.1} |",
            rig.animations.get(anim).map(|a| a.name.as_str()).unwrap_or("-"),
            seq.reference.vertices.len(),
            tracker.model.patch_count(),
            mean * 100.0,
            p95 * 100.0,
            hole_mean * 100.0,
            seconds / n * 1000.0,
            iterations as f64 / n
        );
    }
}
