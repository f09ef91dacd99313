//! Surface tracking speed: one frame of a 5,000-vertex reference (a torus, 100 x 50) against
//! 10,000 points (1% noise, 15% clutter), starting from the previous frame's fit; and the
//! E-step and M-step alone.
//!
//! `cargo bench -p rigfit-core --bench surface`

use criterion::{Criterion, criterion_group, criterion_main};
use rigfit_core::surface::{SurfaceOptions, SurfaceTracker, e_step};
use rigfit_testkit::surface_cases::warmed_torus_tracker;

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
    group.finish();
}

criterion_group!(benches, surface);
criterion_main!(benches);
