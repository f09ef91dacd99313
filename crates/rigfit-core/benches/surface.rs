//! Surface tracking speed: one frame of a 5,000-vertex reference (a torus, 100 x 50) against
//! 10,000 points (1% noise, 15% clutter), starting from the previous frame's fit; and the
//! E-step and M-step alone.
//!
//! `cargo bench -p rigfit-core --bench surface`

use criterion::{Criterion, criterion_group, criterion_main};
use rigfit_core::surface::cases::bending_torus_scans;
use rigfit_core::surface::{Observations, SurfaceOptions, SurfaceTracker, e_step};

fn surface(c: &mut Criterion) {
    let (reference, scans) = bending_torus_scans(3, 3);
    let diagonal = reference.bounds().expect("bounds").diagonal();
    let frames: Vec<Observations> = scans
        .iter()
        .map(|cloud| Observations::from_mesh(cloud).expect("frame"))
        .collect();
    let mut tracker = SurfaceTracker::new(&reference, &SurfaceOptions::default()).expect("tracker");
    tracker.track(&frames[0]).expect("frame 0");
    tracker.track(&frames[1]).expect("frame 1");
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
