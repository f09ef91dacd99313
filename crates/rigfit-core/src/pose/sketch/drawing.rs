//! The strokes of a case: dense polylines through a chain's joints or stray wobbly lines,
//! with Gaussian noise, and flattened in depth as a user drawing on a screen draws them.

use rand::Rng;
use rand_distr::{Distribution, Normal};

use crate::math::{Point3, Vector3};
use crate::pose::beautify::resample;

/// Length of a stray stroke, as a fraction of the height.
const STRAY_LENGTH: f64 = 0.25;
/// How far a stray stroke bows out of line, as a fraction of the height.
const STRAY_BOW: f64 = 0.1;
/// How far outside the character's joints a stray stroke may start, fraction of the height.
const STRAY_MARGIN: f64 = 0.3;

/// Adds independent Gaussian noise to every coordinate.
fn add_noise(points: &mut [Point3], noise: &Normal<f64>, rng: &mut impl Rng) {
    for p in points {
        *p += Vector3::new(noise.sample(rng), noise.sample(rng), noise.sample(rng));
    }
}

/// A stroke through `chain`'s joints at `positions`, resampled every `spacing` and noisy.
pub(super) fn chain_stroke(
    positions: &[Point3],
    chain: &[usize],
    spacing: f64,
    noise: &Normal<f64>,
    rng: &mut impl Rng,
) -> Vec<Point3> {
    let line: Vec<Point3> = chain.iter().map(|&j| positions[j]).collect();
    let mut points = resample(&line, spacing);
    add_noise(&mut points, noise, rng);
    points
}

/// A stray stroke: a short wobbly line starting anywhere in the box `lo`..`hi` grown by a
/// margin, resampled every `spacing` and noisy.
pub(super) fn stray_stroke(
    (lo, hi): (Vector3, Vector3),
    height: f64,
    spacing: f64,
    noise: &Normal<f64>,
    rng: &mut impl Rng,
) -> Vec<Point3> {
    let margin = STRAY_MARGIN * height;
    let start = Point3::from(Vector3::from_fn(|i, _| {
        rng.random_range(lo[i] - margin..hi[i] + margin)
    }));
    let dir = Vector3::new(noise.sample(rng), noise.sample(rng), noise.sample(rng))
        .try_normalize(1e-12)
        .unwrap_or_else(Vector3::x);
    let bend = Vector3::new(
        rng.random_range(-1.0..1.0),
        rng.random_range(-1.0..1.0),
        rng.random_range(-1.0..1.0),
    );
    let length = STRAY_LENGTH * height;
    let line: Vec<Point3> = (0..6)
        .map(|i| {
            let t = i as f64 / 5.0;
            start
                + dir * (length * t)
                + bend * (STRAY_BOW * height * (t * std::f64::consts::PI).sin())
        })
        .collect();
    let mut points = resample(&line, spacing);
    add_noise(&mut points, noise, rng);
    points
}

/// Flattens a stroke in depth as seen along `view`: every point moves onto the plane through
/// the stroke's mean point perpendicular to `view` (a stroke drawn on a screen lies at one
/// depth). A zero `view` leaves the stroke as it is.
pub fn flatten_stroke(points: &mut [Point3], view: &Vector3) {
    let Some(normal) = view.try_normalize(1e-12) else {
        return;
    };
    if points.is_empty() {
        return;
    }
    let mean = points.iter().map(|p| p.coords).sum::<Vector3>() / points.len() as f64;
    for p in points {
        let depth = (p.coords - mean).dot(&normal);
        *p -= normal * depth;
    }
}

/// A view direction of a user at a desktop: any heading around `up`, tilted up or down by
/// at most `max_elevation` radians.
pub fn desktop_view(up: &Vector3, max_elevation: f64, rng: &mut impl Rng) -> Vector3 {
    let up = up.try_normalize(1e-12).unwrap_or_else(Vector3::y);
    let (across, ahead) = crate::math::perpendicular_basis(&up);
    let heading = rng.random_range(0.0..std::f64::consts::TAU);
    let elevation = if max_elevation > 0.0 {
        rng.random_range(-max_elevation..=max_elevation)
    } else {
        0.0
    };
    (across * heading.cos() + ahead * heading.sin()) * elevation.cos() + up * elevation.sin()
}
