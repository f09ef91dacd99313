//! Test meshes and scans, shared by core's own unit tests and rigfit-testkit's ground-truth
//! sequences (`rigfit_testkit::surface_cases`), which re-exports them: a torus, bent, and
//! scanned with noise and clutter. Not part of the published API: compiled for core's tests
//! and under the `test-meshes` feature, which only rigfit-testkit turns on.

use rand::Rng;
use rand_distr::{Distribution, Normal};

use crate::geometry::{Aabb, TriMesh};
use crate::math::{Point3, Vector3};

/// The mean distance between corresponding points of `a` and `b` (a fit's vertices and the
/// truth's).
pub fn mean_distance(a: &[Point3], b: &[Point3]) -> f64 {
    a.iter().zip(b).map(|(p, q)| (p - q).norm()).sum::<f64>() / a.len() as f64
}

/// Uniform samples of a triangle mesh's surface, with the faces' normals.
pub fn sample_surface(
    vertices: &[Point3],
    triangles: &[[u32; 3]],
    count: usize,
    rng: &mut impl Rng,
) -> (Vec<Point3>, Vec<Vector3>) {
    crate::geometry::sample_triangles(vertices, triangles, count, rng)
        .into_iter()
        .map(|(p, t)| {
            let [a, b, c] = triangles[t].map(|i| vertices[i as usize]);
            let normal = (b - a)
                .cross(&(c - a))
                .try_normalize(1e-300)
                .unwrap_or_else(Vector3::y);
            (p, normal)
        })
        .unzip()
}

/// A torus of `rings` x `segments` vertices (major radius 1, minor radius 0.35) around the
/// y axis, with face normals: a reference of any size for speed measurements.
pub fn torus(rings: usize, segments: usize) -> TriMesh {
    let mut vertices = Vec::with_capacity(rings * segments);
    for i in 0..rings {
        let u = 2.0 * std::f64::consts::PI * i as f64 / rings as f64;
        for j in 0..segments {
            let v = 2.0 * std::f64::consts::PI * j as f64 / segments as f64;
            let r = 1.0 + 0.35 * v.cos();
            vertices.push(Point3::new(r * u.cos(), 0.35 * v.sin(), r * u.sin()));
        }
    }
    let index = |i: usize, j: usize| ((i % rings) * segments + (j % segments)) as u32;
    let mut triangles = Vec::with_capacity(2 * rings * segments);
    for i in 0..rings {
        for j in 0..segments {
            let (a, b, c, d) = (
                index(i, j),
                index(i + 1, j),
                index(i, j + 1),
                index(i + 1, j + 1),
            );
            triangles.push([a, c, b]);
            triangles.push([b, c, d]);
        }
    }
    let mut mesh = TriMesh {
        vertices,
        normals: None,
        triangles,
    };
    mesh.normals = Some(mesh.vertex_normals_from_faces());
    mesh
}

/// `mesh` bent: every vertex turned about the z axis by an angle growing with its x, and
/// lifted, by `amount` (0: unchanged).
pub fn bend(mesh: &TriMesh, amount: f64) -> Vec<Point3> {
    mesh.vertices
        .iter()
        .map(|p| {
            let angle = amount * (p.x + 1.5) * 0.3;
            let (s, c) = angle.sin_cos();
            Point3::new(c * p.x - s * p.y, s * p.x + c * p.y, p.z)
                + Vector3::new(0.0, amount * 0.2, 0.0)
        })
        .collect()
}

/// A scan of `vertices` (with `triangles`): `count` points, Gaussian noise of `noise` (per
/// coordinate) and a fraction `outlier_ratio` of uniform clutter around it.
pub fn scan(
    vertices: &[Point3],
    triangles: &[[u32; 3]],
    count: usize,
    noise: f64,
    outlier_ratio: f64,
    rng: &mut impl Rng,
) -> TriMesh {
    let outliers = (count as f64 * outlier_ratio).round() as usize;
    let (mut points, mut normals) =
        sample_surface(vertices, triangles, count.saturating_sub(outliers), rng);
    let normal = Normal::new(0.0, noise.max(1e-300)).expect("valid deviation");
    for p in &mut points {
        *p += Vector3::new(normal.sample(rng), normal.sample(rng), normal.sample(rng));
    }
    let bounds = Aabb::from_points(vertices).unwrap_or(Aabb {
        min: Point3::origin(),
        max: Point3::new(1.0, 1.0, 1.0),
    });
    for _ in 0..outliers {
        points.push(Point3::from(Vector3::from_fn(|i, _| {
            rng.random_range(bounds.min[i] - 0.2..bounds.max[i] + 0.2)
        })));
        normals.push(Vector3::y());
    }
    TriMesh {
        vertices: points,
        normals: Some(normals),
        triangles: Vec::new(),
    }
}
