//! One frame of the surface bench, tracked `N` times (default 5), for profilers and
//! CPU-time comparisons: the torus (5,000 vertices, 10,000 points) after two warm-up frames,
//! or with `adroit` the many-part Adroit hand of the surface corpus (frame 6 after frames
//! 0-5, as the bench):
//!
//! `RAYON_NUM_THREADS=1 valgrind --tool=callgrind target/release/examples/surface_frame 1`
//! `target/release/examples/surface_frame 20 adroit`

use std::time::Instant;

use rigfit_core::surface::{Observations, SurfaceOptions, SurfaceTracker};
use rigfit_testkit::surface_cases::{bend, mean_distance, warmed_torus_tracker};
use rigfit_testkit::surface_corpus::{self, PartsOptions};

fn main() {
    let repeats: usize = std::env::args()
        .nth(1)
        .and_then(|a| a.parse().ok())
        .unwrap_or(5);
    if std::env::args().nth(2).as_deref() == Some("adroit") {
        adroit(repeats);
        return;
    }
    let (reference, frames, tracker) = warmed_torus_tracker();
    let diagonal = reference.bounds().expect("bounds").diagonal();
    let truth = bend(&reference, 0.3);
    for _ in 0..repeats {
        let mut t = tracker.clone();
        let start = Instant::now();
        let fit = t.track(&frames[2]).expect("frame 2");
        let error = mean_distance(&fit.positions, &truth) / diagonal;
        println!(
            "{:.1} ms, {} iterations, mean error {:.4}% of the diagonal",
            start.elapsed().as_secs_f64() * 1e3,
            fit.iterations,
            100.0 * error
        );
    }
}

/// The bench's many-part frame: the Adroit hand's tracker after frames 0-5, frame 6.
fn adroit(repeats: usize) {
    let corpus = surface_corpus::load().expect("the surface corpus (scripts/fetch-data.sh)");
    let entry = corpus.entry("gymr-adroit_hand").expect("the Adroit hand");
    let case = surface_corpus::parts_case(&corpus, entry, 0, &PartsOptions::default())
        .expect("its sequence");
    let sequence = &case.sequence;
    let mut tracker =
        SurfaceTracker::new(&sequence.reference, &SurfaceOptions::default()).expect("tracker");
    let frames: Vec<Observations> = sequence.frames[..7]
        .iter()
        .map(|f| Observations::from_mesh(f).expect("frame"))
        .collect();
    for frame in &frames[..6] {
        tracker.track(frame).expect("frame");
    }
    let mut times = Vec::new();
    for _ in 0..repeats {
        let mut t = tracker.clone();
        let start = Instant::now();
        let fit = t.track(&frames[6]).expect("frame 6");
        let ms = start.elapsed().as_secs_f64() * 1e3;
        times.push(ms);
        println!(
            "{ms:.1} ms, {} iterations, sigma {:.5}",
            fit.iterations, fit.sigma
        );
    }
    times.sort_by(f64::total_cmp);
    println!("median {:.1} ms", times[times.len() / 2]);
}
