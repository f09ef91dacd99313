//! One frame's observed data: its points and normals (estimated from the points when the
//! frame has none), and the points merged by cubes and normal direction.

use rayon::prelude::*;

use crate::engine::spatial::PointTree;
use crate::geometry::Aabb;
use crate::math::{Matrix3, Point3, Vector3};

/// Normals of a point cloud by principal component analysis of each point's `k` nearest
/// neighbours. Their sign is unknown (see [`Observations::oriented`]).
pub fn estimate_normals(points: &[Point3], k: usize) -> Vec<Vector3> {
    let coords: Vec<[f64; 3]> = points.iter().map(|p| [p.x, p.y, p.z]).collect();
    let tree = PointTree::new(&coords);
    points
        .par_iter()
        .map(|p| {
            let near = tree.nearest_n(p, k);
            if near.len() < 3 {
                return Vector3::z();
            }
            let mean = near.iter().map(|&i| points[i].coords).sum::<Vector3>() / near.len() as f64;
            let mut cov = Matrix3::zeros();
            for &i in &near {
                let d = points[i].coords - mean;
                cov += d * d.transpose();
            }
            let eig = cov.symmetric_eigen();
            let smallest = (0..3)
                .min_by(|&a, &b| eig.eigenvalues[a].total_cmp(&eig.eigenvalues[b]))
                .unwrap_or(0);
            eig.eigenvectors
                .column(smallest)
                .into_owned()
                .try_normalize(1e-12)
                .unwrap_or_else(Vector3::z)
        })
        .collect()
}

/// One frame of observed data: points and normals.
#[derive(Clone, Debug, Default)]
pub struct Observations {
    pub points: Vec<Point3>,
    pub normals: Vec<Vector3>,
    /// False when the normals' signs are unknown (estimated from the points): a normal is
    /// then compatible with its opposite too.
    pub oriented: bool,
    /// How many observed points each point stands for (see [`Observations::merged`]); empty
    /// when each stands for itself.
    pub counts: Vec<u32>,
}

impl Observations {
    /// How many observed points point `i` stands for.
    #[inline]
    pub fn count(&self, i: usize) -> u32 {
        self.counts.get(i).copied().unwrap_or(1)
    }

    /// The points merged by cubes of side `cell` and by normal direction (the axis the normal
    /// is closest to, and its sign when normals are oriented, so that the two sides of a
    /// thin part stay apart): one point per group at the mean of its points, with their
    /// mean normal, standing for all of them. The E-step counts each merged point as many
    /// times, so the data term is the full cloud's with every point moved to its group's
    /// mean (which also averages the sensor's noise), while the search and the posteriors
    /// cost a fraction. Cubes of about two point spacings keep the means within a small
    /// fraction of a spacing of a curved surface.
    pub fn merged(&self, cell: f64) -> Observations {
        if !(cell > 0.0 && cell.is_finite()) || self.points.len() < 2 {
            return self.clone();
        }
        let Some(bounds) = Aabb::from_points(&self.points) else {
            return self.clone();
        };
        const SIDE: u64 = (1 << 20) - 1;
        let cube = |x: f64, low: f64| (((x - low) / cell) as u64).min(SIDE);
        let mut keyed: Vec<(u64, u32)> = self
            .points
            .iter()
            .zip(&self.normals)
            .enumerate()
            .map(|(i, (p, n))| {
                let axis = (0..3)
                    .max_by(|&a, &b| n[a].abs().total_cmp(&n[b].abs()))
                    .unwrap_or(0);
                let side = if self.oriented && n[axis] < 0.0 { 3 } else { 0 };
                let key = cube(p.x, bounds.min.x)
                    | (cube(p.y, bounds.min.y) << 20)
                    | (cube(p.z, bounds.min.z) << 40)
                    | (((axis + side) as u64) << 60);
                (key, i as u32)
            })
            .collect();
        keyed.sort_unstable();
        let mut merged = Observations {
            oriented: self.oriented,
            ..Observations::default()
        };
        for group in keyed.chunk_by(|a, b| a.0 == b.0) {
            let first = self.normals[group[0].1 as usize];
            let (mut sum, mut normal, mut count) = (Vector3::zeros(), Vector3::zeros(), 0u32);
            for &(_, i) in group {
                let (i, c) = (i as usize, self.count(i as usize));
                sum += self.points[i].coords * c as f64;
                let n = self.normals[i];
                // Unoriented normals: turned to agree with the group's first.
                normal += if n.dot(&first) < 0.0 { -n } else { n } * c as f64;
                count += c;
            }
            merged.points.push(Point3::from(sum / count.max(1) as f64));
            merged
                .normals
                .push(normal.try_normalize(1e-12).unwrap_or(first));
            merged.counts.push(count);
        }
        merged
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Merging keeps every point counted and the two sides of a thin part apart.
    #[test]
    fn merging_counts_every_point_and_keeps_sides_apart() {
        let (mut points, mut normals) = (Vec::new(), Vec::new());
        for i in 0..10 {
            for j in 0..10 {
                for (z, side) in [(0.0, 1.0), (0.001, -1.0)] {
                    points.push(Point3::new(i as f64 * 0.01, j as f64 * 0.01, z));
                    normals.push(Vector3::new(0.0, 0.0, side));
                }
            }
        }
        let data = Observations {
            points,
            normals,
            oriented: true,
            counts: Vec::new(),
        };
        let merged = data.merged(0.025);
        assert_eq!(merged.counts.iter().sum::<u32>(), 200);
        assert!(merged.points.len() <= 2 * 16, "{}", merged.points.len());
        for (p, n) in merged.points.iter().zip(&merged.normals) {
            // Each merged point is one sheet's, with that sheet's normal.
            let sheet = if n.z > 0.0 { 0.0 } else { 0.001 };
            assert!((p.z - sheet).abs() < 1e-12 && (n.z.abs() - 1.0).abs() < 1e-12);
        }
        let again = merged.merged(0.05);
        assert_eq!(again.counts.iter().sum::<u32>(), 200);
        assert_eq!(data.merged(0.0).points.len(), 200);
    }
}
