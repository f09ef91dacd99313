//! The many-part sequences of the surface corpus tracked by the *articulated* tracker
//! through each object's own skeleton (the MJCF bodies the sequences are posed through),
//! for comparison with `surface_corpus` (BENCHMARKS.md, issue 22): the same scans (seed by
//! seed), started from the true first pose, the mesh skinned by the pose found and scored
//! vertex by vertex, as fractions of the reference's bounding-box diagonal.
//!
//! `cargo run --release -p rigfit-testkit --example surface_corpus_articulated`
//! (`SEEDS=N` seeds 0..N, default 1; `OBJECTS=id,id` some objects)

#[path = "common/env_knobs.rs"]
mod env_knobs;

use rigfit_core::track::{ArticulatedModel, TrackOptions, Tracker};
use rigfit_testkit::surface_cases::mean_and_p95;
use rigfit_testkit::surface_corpus::{PartsOptions, load, parts_case};

fn main() {
    let corpus = match load() {
        Ok(c) => c,
        Err(e) => {
            eprintln!("surface_corpus_articulated: {e}");
            std::process::exit(2);
        }
    };
    let seeds = env_knobs::count("SEEDS", 1) as u64;
    let chosen = env_knobs::names("OBJECTS");
    println!("| object | half | seed | mean | p95 | worst frame | worst vertex | ms/frame |");
    println!("|---|---|---|---|---|---|---|---|");
    for entry in &corpus.rigs {
        if chosen.as_ref().is_some_and(|c| !c.contains(&entry.id)) {
            continue;
        }
        for seed in 0..seeds {
            let (case, read) = match (
                parts_case(&corpus, entry, seed, &PartsOptions::default()),
                corpus.read_rig(entry),
            ) {
                (Ok(case), Ok(read)) => (case, read),
                (Err(e), _) | (_, Err(e)) => {
                    eprintln!("{}: {e}", entry.id);
                    continue;
                }
            };
            let mut rig = read.rig.clone();
            rig.pose = read.start.clone();
            let tracker = ArticulatedModel::from_rig(&rig, 0)
                .map_err(|e| e.to_string())
                .and_then(|model| {
                    Tracker::new(model, TrackOptions::default()).map_err(|e| e.to_string())
                });
            let mut tracker = match tracker {
                Ok(t) => t,
                Err(e) => {
                    eprintln!("{}: no tracker: {e}", entry.id);
                    continue;
                }
            };
            tracker.set_pose(&read.start);
            let sequence = &case.sequence;
            let (mut all, mut worst_frame, mut seconds) = (Vec::new(), 0f64, Vec::new());
            for (f, (frame, truth)) in sequence.frames.iter().zip(&sequence.truth).enumerate() {
                let t0 = std::time::Instant::now();
                let fit = match tracker.track(&frame.vertices) {
                    Ok(fit) => fit,
                    Err(e) => {
                        eprintln!("{} seed {seed} frame {f}: {e}", entry.id);
                        break;
                    }
                };
                seconds.push(t0.elapsed().as_secs_f64());
                let mesh = rig.skinned_surface(&fit.pose);
                let errors: Vec<f64> = mesh
                    .vertices
                    .iter()
                    .zip(truth)
                    .map(|(p, q)| (p - q).norm() / sequence.diagonal)
                    .collect();
                worst_frame = worst_frame.max(errors.iter().sum::<f64>() / errors.len() as f64);
                all.extend(errors);
            }
            seconds.sort_by(f64::total_cmp);
            let (mean, p95) = mean_and_p95(&all);
            println!(
                "| {} | {} | {seed} | {:.2} | {:.2} | {:.2} | {:.2} | {:.1} |",
                entry.id,
                entry.half.name(),
                mean * 100.0,
                p95 * 100.0,
                worst_frame * 100.0,
                all.iter().copied().fold(0.0, f64::max) * 100.0,
                seconds.get(seconds.len() / 2).copied().unwrap_or(0.0) * 1000.0
            );
        }
    }
}
