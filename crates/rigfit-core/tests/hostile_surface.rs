//! Hostile surface-tracking input: degenerate clouds (every point at one place), extreme but
//! finite coordinates, odd scales. Each gives a finite result or a clear error quickly; the
//! bounds (seconds) are hang detectors, not speed claims.

use std::time::{Duration, Instant};

use rigfit_core::surface::{Observations, SurfaceOptions, SurfaceTracker};
use rigfit_core::{Point3, TriMesh};

const HANG: Duration = Duration::from_secs(5);

/// A wavy `n` by `n` grid of side 1 scaled by `scale`.
fn grid(n: usize, scale: f64) -> TriMesh {
    let mut vertices = Vec::new();
    for i in 0..n {
        for j in 0..n {
            let (x, z) = (i as f64 / (n - 1) as f64, j as f64 / (n - 1) as f64);
            vertices.push(Point3::new(x, 0.1 * (6.0 * x).sin(), z) * scale);
        }
    }
    let mut triangles = Vec::new();
    for i in 0..n - 1 {
        for j in 0..n - 1 {
            let v = (i * n + j) as u32;
            let n = n as u32;
            triangles.push([v, v + 1, v + n]);
            triangles.push([v + 1, v + n + 1, v + n]);
        }
    }
    TriMesh {
        vertices,
        normals: None,
        triangles,
    }
}

fn cloud(points: Vec<Point3>) -> TriMesh {
    TriMesh {
        vertices: points,
        normals: None,
        triangles: Vec::new(),
    }
}

/// Tracks one frame; the result must be finite or an error, within the bound.
fn track_one(reference: &TriMesh, frame: &TriMesh) -> Result<(), String> {
    let began = Instant::now();
    let outcome = (|| -> Result<(), String> {
        let data = Observations::from_mesh(frame).map_err(|e| e.to_string())?;
        let mut tracker = SurfaceTracker::new(reference, &SurfaceOptions::default())
            .map_err(|e| e.to_string())?;
        let fit = tracker.track(&data).map_err(|e| e.to_string())?;
        assert!(
            fit.positions
                .iter()
                .all(|p| p.iter().all(|v| v.is_finite())),
            "the tracked mesh stays finite: reference {:?}, frame {:?}",
            reference.bounds(),
            frame.bounds()
        );
        Ok(())
    })();
    let took = began.elapsed();
    assert!(took < HANG, "took {took:?}");
    if let Err(e) = &outcome {
        assert!(!e.is_empty() && !e.contains('\n'), "one line: {e:?}");
    }
    outcome
}

#[test]
fn a_cloud_of_copies_of_one_point_is_tracked_in_bounded_time() {
    let reference = grid(30, 1.0);
    for n in [1_000, 100_000, 300_000] {
        let frame = cloud(vec![Point3::new(0.5, 0.0, 0.5); n]);
        let outcome = track_one(&reference, &frame);
        assert!(outcome.is_ok(), "{n} copies: {outcome:?}");
    }
    // Copies of a few points: many ties in every neighbour search.
    let few: Vec<Point3> = (0..200_000)
        .map(|i| Point3::new((i % 7) as f64 / 6.0, 0.0, (i % 5) as f64 / 4.0))
        .collect();
    assert!(track_one(&reference, &cloud(few)).is_ok());
}

#[test]
fn extreme_finite_coordinates_give_a_finite_result_or_an_error() {
    let reference = grid(20, 1.0);
    let near: Vec<Point3> = grid(40, 1.0).vertices;
    for far in [1e30, 1e150, 1e300, f64::MAX] {
        // Clutter at extreme distances among ordinary points.
        let mut points = near.clone();
        points.extend([
            Point3::new(far, 0.0, 0.0),
            Point3::new(-far, far, far),
            Point3::new(0.0, 0.0, -far),
        ]);
        let _ = track_one(&reference, &cloud(points));
        // A frame that is all far away.
        let _ = track_one(&reference, &cloud(vec![Point3::new(far, far, 0.0); 100]));
        // A reference far away or of extreme size.
        let mut shifted = reference.clone();
        for v in &mut shifted.vertices {
            v.x += far;
        }
        let _ = track_one(&shifted, &cloud(near.clone()));
        let _ = track_one(&grid(20, far), &cloud(near.clone()));
    }
    for scale in [1e-300, 1e-30, 1e-7] {
        let reference = grid(20, scale);
        let frame = cloud(grid(40, scale).vertices);
        let outcome = track_one(&reference, &frame);
        if scale >= 1e-30 {
            assert!(outcome.is_ok(), "scale {scale}: {outcome:?}");
        }
    }
}

#[test]
fn a_reference_of_copies_of_one_point_is_refused() {
    let mut reference = grid(10, 1.0);
    for v in &mut reference.vertices {
        *v = Point3::new(1.0, 2.0, 3.0);
    }
    let outcome = track_one(&reference, &cloud(grid(20, 1.0).vertices));
    assert!(outcome.is_err());
}
