//! Tracking speed, one frame after another on the ground-truth sequences of the accuracy
//! test (tests/common/track_suites.rs): the 25-joint WebXR hand against 1,000 points a
//! frame (goal: 200 frames per second on one core) and the 54-joint BCN_Epileptic body
//! against 3,000 points (goal: 60 per second). Each iteration tracks the next frame; the
//! tracker restarts from the first true pose when the sequence wraps around.
//!
//! `RAYON_NUM_THREADS=1 cargo bench -p rigfit-core --bench track`

use rigfit_testkit::track_suites;

use criterion::{Criterion, criterion_group, criterion_main};
use rigfit_core::track::{TrackOptions, Tracker};
use rigfit_testkit::track_cases::SequenceOptions;

fn bench_suite(c: &mut Criterion, label: &str, name: &'static str, points: usize) {
    let options = SequenceOptions {
        points,
        ..SequenceOptions::default()
    };
    let suite = track_suites::suite(name, track_suites::FRAMES, &options);
    let mut tracker = Tracker::new(suite.model.clone(), TrackOptions::default()).expect("tracker");
    let mut next = 0;
    c.bench_function(label, |b| {
        b.iter(|| {
            if next == 0 {
                tracker.set_pose(&suite.frames[0].truth);
            }
            let fit = tracker
                .track(&suite.frames[next].points)
                .expect("frame tracks");
            next = (next + 1) % suite.frames.len();
            fit.inliers
        })
    });
}

fn bench(c: &mut Criterion) {
    bench_suite(c, "track hand (25 joints), 1000 points", "hand", 1000);
    bench_suite(
        c,
        "track BCN_Epileptic (54 joints), 3000 points",
        "BCN_Epileptic",
        3000,
    );
    bench_suite(
        c,
        "track Testwuson (37 joints), 2000 points",
        "Testwuson",
        2000,
    );
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(30);
    targets = bench
}
criterion_main!(benches);
