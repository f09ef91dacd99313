//! One torus frame of the surface bench (5,000 vertices, 10,000 points), tracked `N` times
//! (default 5) after two warm-up frames, for profilers and CPU-time comparisons:
//!
//! `RAYON_NUM_THREADS=1 valgrind --tool=callgrind target/release/examples/surface_frame 1`

use std::time::Instant;

use rigfit_testkit::surface_cases::{bend, warmed_torus_tracker};

fn main() {
    let repeats: usize = std::env::args()
        .nth(1)
        .and_then(|a| a.parse().ok())
        .unwrap_or(5);
    let (reference, frames, tracker) = warmed_torus_tracker();
    let diagonal = reference.bounds().expect("bounds").diagonal();
    let truth = bend(&reference, 0.3);
    for _ in 0..repeats {
        let mut t = tracker.clone();
        let start = Instant::now();
        let fit = t.track(&frames[2]).expect("frame 2");
        let error = fit
            .positions
            .iter()
            .zip(&truth)
            .map(|(p, q)| (p - q).norm())
            .sum::<f64>()
            / truth.len() as f64
            / diagonal;
        println!(
            "{:.1} ms, {} iterations, mean error {:.4}% of the diagonal",
            start.elapsed().as_secs_f64() * 1e3,
            fit.iterations,
            100.0 * error
        );
    }
}
