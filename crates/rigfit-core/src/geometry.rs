//! Triangle meshes, point clouds and bounding boxes.

use rand::Rng;

use crate::math::{Point3, Vector3};

/// A triangle mesh or, with no triangles, a point cloud.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TriMesh {
    pub vertices: Vec<Point3>,
    /// Per-vertex normals, when the source has them.
    pub normals: Option<Vec<Vector3>>,
    pub triangles: Vec<[u32; 3]>,
}

impl TriMesh {
    /// True when the mesh has no faces (a point cloud).
    pub fn is_point_cloud(&self) -> bool {
        self.triangles.is_empty()
    }

    /// The bounding box of the vertices (`None` when there are none).
    pub fn bounds(&self) -> Option<Aabb> {
        Aabb::from_points(&self.vertices)
    }

    /// Area-weighted vertex normals computed from the faces.
    pub fn vertex_normals_from_faces(&self) -> Vec<Vector3> {
        let mut normals = vec![Vector3::zeros(); self.vertices.len()];
        for t in &self.triangles {
            let [a, b, c] = t.map(|i| self.vertices[i as usize]);
            let n = (b - a).cross(&(c - a));
            for &i in t {
                normals[i as usize] += n;
            }
        }
        for n in &mut normals {
            let len = n.norm();
            if len > 0.0 {
                *n /= len;
            }
        }
        normals
    }
}

/// An axis-aligned bounding box.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    pub min: Point3,
    pub max: Point3,
}

impl Aabb {
    /// The box around `points`, or `None` when there are none.
    pub fn from_points<'a>(points: impl IntoIterator<Item = &'a Point3>) -> Option<Self> {
        let mut it = points.into_iter();
        let first = *it.next()?;
        let mut b = Aabb {
            min: first,
            max: first,
        };
        for p in it {
            b.min = b.min.inf(p);
            b.max = b.max.sup(p);
        }
        Some(b)
    }

    /// The size along each axis.
    pub fn extent(&self) -> Vector3 {
        self.max - self.min
    }

    /// The length of the diagonal.
    pub fn diagonal(&self) -> f64 {
        self.extent().norm()
    }

    pub fn center(&self) -> Point3 {
        nalgebra::center(&self.min, &self.max)
    }
}

/// The mean of `points` (the origin when there are none).
pub fn centroid(points: &[Point3]) -> Point3 {
    let sum: Vector3 = points.iter().map(|p| p.coords).sum();
    Point3::from(sum / points.len().max(1) as f64)
}

/// `count` points spread over the triangles `triangles` of `vertices` uniformly by area,
/// each with the index of its triangle. Empty when the mesh has no area.
pub fn sample_triangles(
    vertices: &[Point3],
    triangles: &[[u32; 3]],
    count: usize,
    rng: &mut impl Rng,
) -> Vec<(Point3, usize)> {
    let mut cumulative = Vec::with_capacity(triangles.len());
    let mut total = 0.0;
    for t in triangles {
        let [a, b, c] = t.map(|i| vertices[i as usize]);
        let area = 0.5 * (b - a).cross(&(c - a)).norm();
        total += if area.is_finite() { area } else { 0.0 };
        cumulative.push(total);
    }
    if total <= 0.0 {
        return Vec::new();
    }
    (0..count)
        .map(|_| {
            let r = rng.random_range(0.0..total);
            let t = cumulative
                .partition_point(|&c| c < r)
                .min(triangles.len() - 1);
            let [a, b, c] = triangles[t].map(|i| vertices[i as usize]);
            let (mut u, mut v) = (rng.random::<f64>(), rng.random::<f64>());
            if u + v > 1.0 {
                u = 1.0 - u;
                v = 1.0 - v;
            }
            (a + (b - a) * u + (c - a) * v, t)
        })
        .collect()
}
