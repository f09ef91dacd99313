//! Surface tracking speed: one frame of a 5,000-vertex reference (a torus, 100 x 50) against
//! 10,000 points (1% noise, 15% clutter), starting from the previous frame's fit; and the
//! E-step and M-step alone. Then one frame of a many-part object (issue 22): the Adroit
//! hand of the surface corpus (14,218 vertices in 82 pieces) against 8,000 points, frame 6
//! of its seed-0 sequence after tracking frames 0-5 (skipped without the corpus).
//!
//! `cargo bench -p rigfit-core --bench surface`

use criterion::{Criterion, criterion_group, criterion_main};
use rigfit_core::surface::{Observations, SurfaceOptions, SurfaceTracker, e_step};
use rigfit_testkit::surface_cases::warmed_torus_tracker;
use rigfit_testkit::surface_corpus::{self, PartsOptions};

fn surface(c: &mut Criterion) {
    let (reference, frames, tracker) = warmed_torus_tracker();
    let diagonal = reference.bounds().expect("bounds").diagonal();
    let mut group = c.benchmark_group("surface");
    group.sample_size(20);
    group.bench_function("track_5k_vertices_10k_points", |b| {
        b.iter_batched(
            || tracker.clone(),
            |mut t| t.track(&frames[2]).expect("frame 2"),
            criterion::BatchSize::LargeInput,
        )
    });
    let positions = tracker.positions();
    group.bench_function("e_step_5k_vertices_10k_points", |b| {
        b.iter(|| {
            e_step(
                &tracker.model,
                &tracker.pose,
                &positions,
                &frames[2],
                0.01 * diagonal,
                &tracker.options.data,
            )
        })
    });
    group.bench_function("setup_5k_vertices", |b| {
        b.iter(|| SurfaceTracker::new(&reference, &SurfaceOptions::default()).expect("tracker"))
    });
    match adroit_hand_tracker() {
        Ok((tracker, frame)) => {
            group.bench_function("track_adroit_hand_14k_vertices_8k_points", |b| {
                b.iter_batched(
                    || tracker.clone(),
                    |mut t| t.track(&frame).expect("frame 6"),
                    criterion::BatchSize::LargeInput,
                )
            });
        }
        Err(e) => eprintln!("surface bench: the many-part frame is skipped: {e}"),
    }
    group.finish();
}

/// The Adroit hand's tracker after frames 0-5 of its sequence, and frame 6.
fn adroit_hand_tracker() -> Result<(SurfaceTracker, Observations), String> {
    let corpus = surface_corpus::load().map_err(|e| e.to_string())?;
    let entry = corpus
        .entry("gymr-adroit_hand")
        .ok_or("gymr-adroit_hand is not in the surface corpus")?;
    let case = surface_corpus::parts_case(&corpus, entry, 0, &PartsOptions::default())
        .map_err(|e| e.to_string())?;
    let sequence = &case.sequence;
    let mut tracker = SurfaceTracker::new(&sequence.reference, &SurfaceOptions::default())
        .map_err(|e| e.to_string())?;
    let frames: Vec<Observations> = sequence.frames[..7]
        .iter()
        .map(|f| Observations::from_mesh(f).map_err(|e| e.to_string()))
        .collect::<Result<_, _>>()?;
    for frame in &frames[..6] {
        tracker.track(frame).map_err(|e| e.to_string())?;
    }
    Ok((tracker, frames[6].clone()))
}

criterion_group!(benches, surface);
criterion_main!(benches);
