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
    let mut options = SurfaceOptions::default();
    let env = |name: &str| std::env::var(name).ok().and_then(|v| v.parse::<f64>().ok());
    if let Some(x) = env("RIGIDITY") { options.rigidity = x; }
    if let Some(x) = env("RADIUS") { options.patches.radius = x; }
    if let Some(x) = env("BLEND") { options.patches.blend_width = x; }
    if let Some(x) = env("SIGMA0") { options.initial_sigma = x; }
    if let Some(x) = env("MINSIGMA") { options.min_sigma = x; }
    if let Some(x) = env("ITERS") { options.max_iterations = x as usize; }
    if let Some(x) = env("CUTOFF") { options.data.cutoff_sigmas = x; }
    if let Some(x) = env("CANDIDATES") { options.data.max_candidates = x as usize; }
    if let Some(x) = env("ANGLE") { options.data.normal_angle = x; }
    if let Some(x) = env("OUTLIERS") { options.data.outlier_ratio = x; }
    if let Some(x) = env("DAMPING") { options.damping = x; }
    if let Some(x) = env("COARSE") { options.coarse_points = x as usize; }
    if let Some(x) = env("FINE") { options.fine_iterations = x as usize; }
    if let Some(x) = env("TOL") { options.tolerance = x; }
    if let Some(x) = env("ANNEAL") { options.anneal = x; }
    if let Some(x) = env("TANGENTIAL") { options.tangential = x; }
    if let Some(x) = env("EXTRAP") { options.extrapolate = x > 0.0; }
    let only = std::env::var("ONLY").unwrap_or_default();
    println!("| asset (clip) | vertices | patches | mean error (% diag) | p95 (% diag) | hole-frame limb mean (% diag) | ms/frame | EM iterations/frame |");
    println!("|---|---|---|---|---|---|---|---|");
    for (file, clip) in [("assimp/BCN_Epileptic.glb", "jump"), ("assimp/Testwuson.glb", "run")] {
        if !file.contains(only.as_str()) { continue; }
        let rig = read_rig(&data(file), &RigOptions::default()).expect("asset").rig;
        let anim = find_animation(&rig, clip);
        if std::env::var("VERBOSE").is_ok() {
            for a in &rig.animations { eprintln!("clip {} {:.3}..{:.3} s, {} keys", a.name, a.start(), a.end(), a.frame_count()); }
        }
        let mut rng = StdRng::seed_from_u64(5);
        let mut seq_options = SequenceOptions::default();
        if let Some(x) = env("GEN_NOISE") { seq_options.noise = x; }
        if let Some(x) = env("GEN_OUTLIERS") { seq_options.outlier_ratio = x; }
        if let Some(x) = env("GEN_POINTS") { seq_options.points = x as usize; }
        if let Some(x) = env("GEN_FRAMES") { seq_options.frames = x as usize; }
        if let Some(x) = env("GEN_DT") { seq_options.frame_time = Some(x); }
        if env("GEN_NOHOLE").is_some() { seq_options.hole_frames = 0..0; }
        let seq = make_sequence(&rig, anim, &seq_options, &mut rng);
        if std::env::var("VERBOSE").is_ok() {
            for f in 1..seq.truth.len() {
                let m: f64 = seq.truth[f].iter().zip(&seq.truth[f - 1]).map(|(a, b)| (a - b).norm()).fold(0.0, f64::max);
                eprint!("{:.1} ", m / seq.diagonal * 100.0);
            }
            eprintln!(" <- max motion per frame (% diag)");
        }
        let mut tracker = SurfaceTracker::new(&seq.reference, &options).expect("tracker");
        if std::env::var("VERBOSE").is_ok() {
            let m = &tracker.model;
            let nc = m.component.iter().max().map_or(0, |c| c + 1) as usize;
            let mut verts = vec![0; nc];
            let mut patches = vec![0; nc];
            for (k, &c) in m.component.iter().enumerate() { patches[c as usize] += 1; verts[c as usize] += m.members[k].len(); }
            eprintln!("components (patches, vertices): {:?}", patches.iter().zip(&verts).collect::<Vec<_>>());
        }
        if let Ok(v) = std::env::var("WHICH") {
            let m = &tracker.model;
            let v: usize = v.parse().expect("v");
            let k = m.vertex_patch[v] as usize;
            eprintln!("v{v}: patch {k} comp {} members {} neighbours {:?} blend {:?}", m.component[k], m.members[k].len(), m.neighbours[k], m.blend(v).collect::<Vec<_>>());
        }
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
            if std::env::var("WORST").is_ok() {
                let f = fitted.len();
                let mut idx: Vec<usize> = (0..fit.positions.len()).collect();
                idx.sort_by(|&a, &b| (fit.positions[b] - seq.truth[f][b]).norm().total_cmp(&(fit.positions[a] - seq.truth[f][a]).norm()));
                let b = rigfit_core::Aabb::from_points(&seq.truth[f]).expect("b");
                for &v in idx.iter().take(3) {
                    let t = seq.truth[f][v];
                    eprintln!("  worst v{v}: err {:.3} truth rel ({:.2},{:.2},{:.2}) fitted {:?}", (fit.positions[v] - t).norm() / seq.diagonal, (t.x - b.min.x) / seq.diagonal, (t.y - b.min.y) / seq.diagonal, (t.z - b.min.z) / seq.diagonal, ((fit.positions[v] - t) / seq.diagonal).map(|x| (x * 1000.0).round() / 1000.0));
                }
            }
            fitted.push(fit.positions);
        }
        let errors = vertex_errors(&fitted, &seq.truth, seq.diagonal);
        let (mean, p95) = mean_and_p95(&errors);
        let hole: Vec<f64> = (10..13.min(seq.frames.len()))
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
