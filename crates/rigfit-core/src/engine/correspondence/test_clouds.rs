//! Clouds and thread pools the correspondence tests share.

use crate::math::Point3;

/// `count` points on a square grid in the plane z = 0, `per_row` a row, 0.01 apart.
pub(super) fn square_grid(count: usize, per_row: usize) -> Vec<Point3> {
    (0..count)
        .map(|i| {
            Point3::new(
                (i % per_row) as f64 * 0.01,
                (i / per_row) as f64 * 0.01,
                0.0,
            )
        })
        .collect()
}

/// `count` points along a curve winding over the grid: point `i` at
/// `(a sin(f_x i) + a, b cos(f_y i) + b, z)` for `turns = (f_x, f_y)` and `reach = (a, b)`.
pub(super) fn winding_cloud(
    count: usize,
    turns: (f64, f64),
    reach: (f64, f64),
    z: f64,
) -> Vec<Point3> {
    (0..count)
        .map(|i| {
            let t = i as f64;
            Point3::new(
                (t * turns.0).sin() * reach.0 + reach.0,
                (t * turns.1).cos() * reach.1 + reach.1,
                z,
            )
        })
        .collect()
}

/// `work`'s answer on a pool of `threads` threads.
pub(super) fn on_threads<T: Send>(threads: usize, work: impl FnOnce() -> T + Send) -> T {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("pool")
        .install(work)
}
