//! Stroke beautification: even resampling and smoothing of oversampled, jittery input.

use crate::math::Point3;

/// The most points one resampling makes.
pub const MAX_SAMPLES: usize = 4096;

/// Points at even arclength spacing along a polyline, including both ends: at least two,
/// and about `length / spacing` + 1 in all.
pub fn resample(points: &[Point3], spacing: f64) -> Vec<Point3> {
    let Some(&first) = points.first() else {
        return Vec::new();
    };
    let cumulative: Vec<f64> = std::iter::once(0.0)
        .chain(points.windows(2).scan(0.0, |acc, w| {
            *acc += (w[1] - w[0]).norm();
            Some(*acc)
        }))
        .collect();
    let length = *cumulative.last().unwrap_or(&0.0);
    if length <= 0.0 || spacing <= 0.0 {
        return vec![first, *points.last().unwrap_or(&first)];
    }
    // At most MAX_SAMPLES points whatever the spacing asked for.
    let n = ((length / spacing).round().min(MAX_SAMPLES as f64) as usize).max(1);
    let mut out = Vec::with_capacity(n + 1);
    let mut seg = 0;
    for s in 0..=n {
        let target = length * s as f64 / n as f64;
        while seg + 2 < cumulative.len() && cumulative[seg + 1] < target {
            seg += 1;
        }
        let (a, b) = (cumulative[seg], cumulative[seg + 1]);
        let t = if b > a {
            ((target - a) / (b - a)).clamp(0.0, 1.0)
        } else {
            0.0
        };
        out.push(points[seg] + (points[seg + 1] - points[seg]) * t);
    }
    out
}

/// Laplacian smoothing with fixed ends: each pass moves every inner point halfway toward
/// the mean of its neighbours.
pub fn smooth(points: &mut [Point3], passes: usize) {
    let n = points.len();
    if n < 3 {
        return;
    }
    let mut next = points.to_vec();
    for _ in 0..passes {
        for i in 1..n - 1 {
            let mean = nalgebra::center(&points[i - 1], &points[i + 1]);
            next[i] = nalgebra::center(&points[i], &mean);
        }
        points.copy_from_slice(&next);
    }
}

/// Per-coordinate jitter of a dense polyline: how far points sit from the midpoint of their
/// neighbours (for a smooth curve sampled densely, almost nothing; for Gaussian noise of
/// deviation `s` per coordinate, a distance whose median is about `1.54 sqrt(1.5) s`).
pub fn jitter(points: &[Point3]) -> f64 {
    if points.len() < 5 {
        return 0.0;
    }
    let mut d: Vec<f64> = points
        .windows(3)
        .map(|w| (w[1] - nalgebra::center(&w[0], &w[2])).norm())
        .collect();
    let middle = d.len() / 2;
    let (_, median, _) = d.select_nth_unstable_by(middle, f64::total_cmp);
    *median / (1.538 * 1.5f64.sqrt())
}

/// Moving average over `2 half + 1` consecutive input points (windows shrink at the ends),
/// from prefix sums: linear in the points whatever the window.
fn average_by_index(points: &[Point3], half: usize) -> Vec<Point3> {
    let n = points.len();
    let prefix: Vec<nalgebra::Vector3<f64>> = std::iter::once(nalgebra::Vector3::zeros())
        .chain(points.iter().scan(nalgebra::Vector3::zeros(), |acc, p| {
            *acc += p.coords;
            Some(*acc)
        }))
        .collect();
    (0..n)
        .map(|i| {
            let r = half.min(i).min(n - 1 - i);
            let sum = prefix[i + r + 1] - prefix[i - r];
            Point3::from(sum / (2 * r + 1) as f64)
        })
        .collect()
}

/// The half-width (in input points) of the average that brings a stroke's jitter `sigma`
/// below a quarter of `spacing` (0 when it is under half of `spacing` already), limited so the window spans at most about 1.5 `spacing`
/// of the stroke. The span is measured by chords with the noise's share taken out
/// (`E |a - b|^2 = L^2 + 6 sigma^2`).
fn denoise_half_width(points: &[Point3], spacing: f64) -> usize {
    let sigma = jitter(points);
    if sigma <= 0.5 * spacing {
        // The windowed average below handles this much.
        return 0;
    }
    let want = (sigma / (0.25 * spacing)).powi(2);
    let mut half = (((want - 1.0) / 2.0).ceil().max(0.0) as usize).min(points.len() / 4);
    let span = |steps: usize| {
        let mut c: Vec<f64> = points
            .iter()
            .zip(points.iter().skip(steps))
            .step_by((points.len() / 64).max(1))
            .map(|(a, b)| (b - a).norm_squared())
            .collect();
        if c.is_empty() {
            return 0.0;
        }
        c.sort_by(f64::total_cmp);
        (c[c.len() / 2] - 6.0 * sigma * sigma).max(0.0).sqrt()
    };
    // Step down one at a time near the wanted width; far above it, halve the gap (the span
    // grows with the window), so the search stays logarithmic on very long strokes.
    let mut steps = 0;
    while half > 0 && span(2 * half) > 1.5 * spacing {
        steps += 1;
        if steps < 64 {
            half -= 1;
            continue;
        }
        let (mut fits, mut too_wide) = (0, half);
        while too_wide - fits > 1 {
            let mid = fits + (too_wide - fits) / 2;
            if span(2 * mid) > 1.5 * spacing {
                too_wide = mid;
            } else {
                fits = mid;
            }
        }
        return fits;
    }
    half
}

/// Noisy input is first averaged over consecutive points, as many as its jitter needs
/// (none for clean strokes); dense input is then averaged over windows of about `spacing`,
/// which removes controller jitter without shortening the stroke; then the stroke is
/// resampled evenly and smoothed lightly.
pub fn beautify(points: &[Point3], spacing: f64) -> Vec<Point3> {
    let half = denoise_half_width(points, spacing);
    let denoised;
    let points = if half > 0 {
        denoised = average_by_index(points, half);
        &denoised[..]
    } else {
        points
    };
    let fine = resample(points, spacing / 4.0);
    // A moving average over a window of one spacing (4 fine samples each side -> 9).
    let half = 4usize;
    let n = fine.len();
    let mut averaged = Vec::with_capacity(n);
    for i in 0..n {
        let lo = i.saturating_sub(half);
        let hi = (i + half).min(n - 1);
        // Shrink the window symmetrically near the ends so the end points stay put.
        let r = (i - lo).min(hi - i);
        let sum: nalgebra::Vector3<f64> = fine[i - r..=i + r].iter().map(|p| p.coords).sum();
        averaged.push(Point3::from(sum / (2 * r + 1) as f64));
    }
    let mut out = resample(&averaged, spacing);
    smooth(&mut out, 2);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn resampling_is_even_and_keeps_the_ends() {
        let line = vec![
            Point3::new(0.0, 0.0, 0.0),
            Point3::new(0.1, 0.0, 0.0),
            Point3::new(1.0, 0.0, 0.0),
        ];
        let r = resample(&line, 0.25);
        assert_eq!(r.len(), 5);
        assert!((r[2].x - 0.5).abs() < 1e-12);
        assert!((r[4].x - 1.0).abs() < 1e-12);
    }

    #[test]
    fn beautify_reduces_jitter() {
        let mut state = 7u64;
        let mut noise = || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1);
            ((state >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * 0.02
        };
        let jittery: Vec<Point3> = (0..1000)
            .map(|i| Point3::new(i as f64 / 1000.0, noise(), noise()))
            .collect();
        let clean = beautify(&jittery, 0.05);
        let rms = |p: &[Point3]| {
            (p.iter().map(|p| p.y * p.y + p.z * p.z).sum::<f64>() / p.len() as f64).sqrt()
        };
        // Uniform noise of +-0.01 per axis: RMS about 0.008 off the line before.
        assert!(
            rms(&clean) < 0.35 * rms(&jittery),
            "RMS {} -> {}",
            rms(&jittery),
            rms(&clean)
        );
        assert!((clean.last().expect("points").x - 1.0).abs() < 0.01);
    }
}

#[cfg(test)]
mod noise_tests {
    use super::*;
    use rand::SeedableRng;
    use rand_distr::{Distribution, Normal};

    /// A straight stroke of length 1 sampled every 0.004 with jitter of 0.02 per
    /// coordinate (8% of the spacing asked, five times the sample spacing): the jitter is
    /// found, and the beautified stroke keeps about the true length instead of the
    /// several-fold length of the raw zig-zag.
    #[test]
    fn heavy_jitter_is_averaged_out() {
        let mut rng = rand::rngs::StdRng::seed_from_u64(7);
        let noise = Normal::new(0.0, 0.02).expect("deviation");
        let points: Vec<Point3> = (0..=250)
            .map(|i| {
                Point3::new(
                    i as f64 * 0.004 + noise.sample(&mut rng),
                    noise.sample(&mut rng),
                    noise.sample(&mut rng),
                )
            })
            .collect();
        let estimated = jitter(&points);
        assert!((estimated - 0.02).abs() < 0.005, "jitter {estimated}");
        let length = |p: &[Point3]| p.windows(2).map(|w| (w[1] - w[0]).norm()).sum::<f64>();
        assert!(length(&points) > 4.0);
        let out = beautify(&points, 0.025);
        let l = length(&out);
        assert!(l < 1.4, "beautified length {l}");
    }

    #[test]
    fn clean_strokes_are_not_averaged_by_index() {
        let points: Vec<Point3> = (0..=100)
            .map(|i| Point3::new(i as f64 * 0.01, (i as f64 * 0.05).sin() * 0.1, 0.0))
            .collect();
        assert_eq!(denoise_half_width(&points, 0.025), 0);
    }
}
