//! The volumetric parts of the articulated surface model (Dewaele et al. 2006, section 2):
//! an ellipsoid per bone, carried rigidly by a joint, and their fusion into one surface by
//! field functions (eq. 1-2) summed only over the dominant part and its neighbours in the
//! kinematic chain, so touching fingers are not glued together.

use nalgebra::SymmetricEigen;

use crate::geometry::TriMesh;
use crate::kinematics::ForwardKinematics;
use crate::math::{Matrix3, Point3, Vector3, linear_part, transform_point};
use crate::skeleton::{JointDof, JointKind, Pose, Skeleton};
use crate::skinning::SkinnedMesh;

/// An ellipsoid carried by a joint: `{ center + shape * u : |u| = 1 }` in the joint's frame.
#[derive(Clone, Debug, PartialEq)]
pub struct EllipsoidPart {
    pub joint: usize,
    pub center: Point3,
    /// Maps the unit sphere onto the ellipsoid (columns: semi-axes), in the joint's frame.
    pub shape: Matrix3,
}

/// The parts of a model, which of them fuse, and the fusion coefficient `nu` of eq. (1).
#[derive(Clone, Debug, PartialEq)]
pub struct PartModel {
    pub parts: Vec<EllipsoidPart>,
    /// For each part, the parts it fuses with: those on the same joint and on the nearest
    /// part-carrying joint above or below it.
    pub adjacent: Vec<Vec<usize>>,
    /// `nu` of eq. (1), in world units.
    pub fusion: f64,
}

/// The parts placed in world space for one pose.
#[derive(Clone, Debug, Default)]
pub struct PlacedParts {
    pub center: Vec<Point3>,
    /// `L^-1` with `L` the world shape matrix: `u = L^-1 (X - c)` is on the unit sphere
    /// exactly when `X` is on the ellipsoid.
    pub inv_shape: Vec<Matrix3>,
    /// The largest semi-axis of each part (for culling).
    pub reach: Vec<f64>,
}

/// A point's distance to the fused surface (eq. 2) and where it comes from.
#[derive(Clone, Copy, Debug)]
pub struct SurfaceDistance {
    /// Pseudo-Euclidean signed distance (negative inside).
    pub distance: f64,
    /// Its gradient with respect to the point.
    pub gradient: Vector3,
    /// The part with the largest field (eq. 1) at the point.
    pub dominant: usize,
}

/// Pseudo-Euclidean distance from `x` to one ellipsoid and its gradient: the distance along
/// the ray from the centre, `|v| (1 - 1/|u|)` with `v = x - c`, `u = L^-1 v`.
pub fn ellipsoid_distance(center: &Point3, inv_shape: &Matrix3, x: &Point3) -> (f64, Vector3) {
    let v = x - center;
    let u = inv_shape * v;
    let (vn, un) = (v.norm(), u.norm());
    if un < 1e-12 || vn < 1e-300 {
        // At the centre: as deep as the smallest semi-axis, no preferred direction.
        let smallest = 1.0 / inv_shape.norm().max(1e-300);
        return (-smallest, Vector3::zeros());
    }
    let d = vn * (1.0 - 1.0 / un);
    // grad = v/|v| (1 - 1/|u|) + |v| / |u|^3 L^-T u.
    let grad = v / vn * (1.0 - 1.0 / un) + inv_shape.transpose() * u * (vn / (un * un * un));
    (d, grad)
}

impl PartModel {
    /// Parts with the fusion coefficient `fusion`, computing their adjacency.
    pub fn new(skeleton: &Skeleton, parts: Vec<EllipsoidPart>, fusion: f64) -> Self {
        let mut carries = vec![false; skeleton.len()];
        for p in &parts {
            carries[p.joint] = true;
        }
        // The nearest proper ancestor that carries a part.
        let above = |j: usize| {
            let mut cur = skeleton.joint(j).parent;
            while let Some(a) = cur {
                if carries[a] {
                    return Some(a);
                }
                cur = skeleton.joint(a).parent;
            }
            None
        };
        let adjacent = (0..parts.len())
            .map(|p| {
                (0..parts.len())
                    .filter(|&q| {
                        let (a, b) = (parts[p].joint, parts[q].joint);
                        q != p && (a == b || above(a) == Some(b) || above(b) == Some(a))
                    })
                    .collect()
            })
            .collect();
        Self {
            parts,
            adjacent,
            fusion,
        }
    }

    /// Ellipsoids fitted to the skinned vertices each joint dominates, in `pose`: centre and
    /// axes from the vertices' mean and principal directions, semi-axes from their spread
    /// (`sqrt(3 var)`, a sphere's surface), scaled so the median vertex lies on the surface.
    /// Joints dominating fewer than 8 vertices get no part.
    pub fn fit_to_skin(
        skeleton: &Skeleton,
        pose: &Pose,
        meshes: &[SkinnedMesh],
        height: f64,
    ) -> Self {
        let world = skeleton.world_matrices(pose);
        let mut groups: Vec<Vec<Point3>> = vec![Vec::new(); skeleton.len()];
        for mesh in meshes {
            let (positions, _) = mesh.skin(&world);
            for (v, j) in mesh.dominant_joint().into_iter().enumerate() {
                if j < groups.len() && positions[v].iter().all(|c| c.is_finite()) {
                    groups[j].push(positions[v]);
                }
            }
        }
        let min_radius = 0.004 * height;
        let mut parts = Vec::new();
        for (j, points) in groups.iter().enumerate() {
            if points.len() < 8 {
                continue;
            }
            let n = points.len() as f64;
            let mean = points.iter().map(|p| p.coords).sum::<Vector3>() / n;
            let cov = points
                .iter()
                .map(|p| (p.coords - mean) * (p.coords - mean).transpose())
                .sum::<Matrix3>()
                / n;
            let eig = SymmetricEigen::new(cov);
            let radii = eig
                .eigenvalues
                .map(|l| (3.0 * l.max(0.0)).sqrt().max(min_radius));
            let mut shape = eig.eigenvectors * Matrix3::from_diagonal(&radii);
            let Some(inv) = shape.try_inverse() else {
                continue;
            };
            let mut norms: Vec<f64> = points
                .iter()
                .map(|p| (inv * (p.coords - mean)).norm())
                .collect();
            norms.sort_by(f64::total_cmp);
            let median = norms[norms.len() / 2];
            if median > 1e-9 {
                shape *= median;
            }
            if let Some(part) = to_joint_frame(&world[j], j, &Point3::from(mean), &shape) {
                parts.push(part);
            }
        }
        Self::new(skeleton, parts, 0.02 * height)
    }

    /// Ellipsoids sized from bone lengths, for a bare skeleton: one per link from a joint to
    /// each child, along the link, 1.1 times its half-length long and a quarter of its length
    /// thick (between 2% and 7% of `height`).
    pub fn from_bone_lengths(skeleton: &Skeleton, pose: &Pose, height: f64) -> Self {
        let world = skeleton.world_matrices(pose);
        let origin = |j: usize| Point3::from(crate::math::translation_part(&world[j]));
        let mut parts = Vec::new();
        for (c, joint) in skeleton.joints().iter().enumerate() {
            let Some(j) = joint.parent else { continue };
            if skeleton.joint(j).kind == JointKind::Helper {
                continue;
            }
            let (a, b) = (origin(j), origin(c));
            if joint.dof == JointDof::Free {
                // A joint that translates (a marker) is not joined to its parent by a limb:
                // it carries a small blob of its own, which follows its translation.
                let radius = 0.02 * height;
                let shape = Matrix3::identity() * radius;
                if let Some(part) = to_joint_frame(&world[c], c, &b, &shape) {
                    parts.push(part);
                }
                continue;
            }
            let length = (b - a).norm();
            if length < 0.01 * height {
                continue;
            }
            let axis = (b - a) / length;
            let thickness = (0.25 * length).clamp(0.02 * height, 0.07 * height);
            let (u, v) = crate::math::perpendicular_basis(&axis);
            let shape =
                Matrix3::from_columns(&[axis * (0.55 * length), u * thickness, v * thickness]);
            let center = Point3::from((a.coords + b.coords) * 0.5);
            if let Some(part) = to_joint_frame(&world[j], j, &center, &shape) {
                parts.push(part);
            }
        }
        Self::new(skeleton, parts, 0.02 * height)
    }

    /// The parts in world space for the pose of `fk`.
    pub fn place(&self, fk: &ForwardKinematics, out: &mut PlacedParts) {
        out.center.clear();
        out.inv_shape.clear();
        out.reach.clear();
        for part in &self.parts {
            let world = fk.world(part.joint);
            let l = linear_part(world) * part.shape;
            out.center.push(transform_point(world, &part.center));
            out.inv_shape
                .push(l.try_inverse().unwrap_or_else(Matrix3::zeros));
            out.reach
                .push((0..3).map(|k| l.column(k).norm()).fold(0.0, f64::max));
        }
    }

    /// The part nearest to `x` (smallest pseudo-Euclidean distance), or `None` without
    /// parts.
    pub fn nearest_part(&self, placed: &PlacedParts, x: &Point3) -> Option<usize> {
        let mut best: Option<(usize, f64)> = None;
        for p in 0..self.parts.len() {
            // A lower bound of the distance: culls far parts cheaply.
            let lower = (x - placed.center[p]).norm() - placed.reach[p];
            if best.is_some_and(|(_, b)| lower > b) {
                continue;
            }
            let (d, _) = ellipsoid_distance(&placed.center[p], &placed.inv_shape[p], x);
            if best.is_none_or(|(_, b)| d < b) {
                best = Some((p, d));
            }
        }
        best.map(|b| b.0)
    }

    /// Eq. (1)-(2): the distance from `x` to the fused surface, `-nu log sum phi_q`, over
    /// the dominant part and the parts adjacent to it. `hint` is a part known to be near
    /// (its neighbours are searched for the dominant part instead of every part).
    pub fn surface_distance(
        &self,
        placed: &PlacedParts,
        x: &Point3,
        hint: Option<usize>,
    ) -> Option<SurfaceDistance> {
        let dominant = match hint {
            Some(h) => {
                let mut best = (
                    h,
                    ellipsoid_distance(&placed.center[h], &placed.inv_shape[h], x).0,
                );
                for &q in &self.adjacent[h] {
                    let d = ellipsoid_distance(&placed.center[q], &placed.inv_shape[q], x).0;
                    if d < best.1 {
                        best = (q, d);
                    }
                }
                best.0
            }
            None => self.nearest_part(placed, x)?,
        };
        let nu = self.fusion;
        let (d0, g0) = ellipsoid_distance(&placed.center[dominant], &placed.inv_shape[dominant], x);
        // Sum of exp(-(d_q - d0) / nu), so the largest term is 1 (no overflow).
        let mut sum = 1.0;
        let mut grad = g0;
        for &q in &self.adjacent[dominant] {
            let (d, g) = ellipsoid_distance(&placed.center[q], &placed.inv_shape[q], x);
            let e = (-(d - d0) / nu).exp();
            sum += e;
            grad += g * e;
        }
        Some(SurfaceDistance {
            distance: d0 - nu * sum.ln(),
            gradient: grad / sum,
            dominant,
        })
    }

    /// Moves `x` onto the fused surface by a few Newton steps along the gradient.
    pub fn project(&self, placed: &PlacedParts, x: &Point3, hint: Option<usize>) -> Option<Point3> {
        let mut p = *x;
        let mut hint = hint;
        for _ in 0..4 {
            let s = self.surface_distance(placed, &p, hint)?;
            hint = Some(s.dominant);
            let g2 = s.gradient.norm_squared();
            if g2 < 1e-18 {
                return None;
            }
            p -= s.gradient * (s.distance / g2);
        }
        Some(p)
    }

    /// The ellipsoids as one triangle mesh (a UV sphere each), for the pose of `fk`.
    pub fn triangulate(&self, fk: &ForwardKinematics, rings: usize, segments: usize) -> TriMesh {
        let mut mesh = TriMesh::default();
        for part in &self.parts {
            let world = fk.world(part.joint);
            let l = linear_part(world) * part.shape;
            let c = transform_point(world, &part.center);
            let base = mesh.vertices.len() as u32;
            for r in 0..=rings {
                let theta = std::f64::consts::PI * r as f64 / rings as f64;
                for s in 0..segments {
                    let phi = 2.0 * std::f64::consts::PI * s as f64 / segments as f64;
                    let u = Vector3::new(
                        theta.sin() * phi.cos(),
                        theta.sin() * phi.sin(),
                        theta.cos(),
                    );
                    mesh.vertices.push(c + l * u);
                }
            }
            let idx = |r: usize, s: usize| base + (r * segments + s % segments) as u32;
            for r in 0..rings {
                for s in 0..segments {
                    let (a, b, c2, d) =
                        (idx(r, s), idx(r, s + 1), idx(r + 1, s), idx(r + 1, s + 1));
                    if r > 0 {
                        mesh.triangles.push([a, c2, b]);
                    }
                    if r + 1 < rings {
                        mesh.triangles.push([b, c2, d]);
                    }
                }
            }
        }
        // Keep outward orientation whatever the handedness of the shape matrices.
        mesh
    }
}

/// A world-space ellipsoid (centre, shape) expressed in joint `j`'s frame.
fn to_joint_frame(
    world: &crate::math::Matrix4,
    j: usize,
    center: &Point3,
    shape: &Matrix3,
) -> Option<EllipsoidPart> {
    let inv = world.try_inverse()?;
    Some(EllipsoidPart {
        joint: j,
        center: transform_point(&inv, center),
        shape: linear_part(&inv) * shape,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::humanoid::humanoid;

    #[test]
    fn distance_is_zero_on_the_ellipsoid_and_gradient_matches_differences() {
        let l = Matrix3::new(0.3, 0.05, 0.0, 0.0, 0.1, 0.02, 0.0, 0.0, 0.08);
        let inv = l.try_inverse().expect("invertible");
        let c = Point3::new(0.1, -0.2, 0.3);
        let u = Vector3::new(0.3, -0.5, 0.8).normalize();
        let (d, _) = ellipsoid_distance(&c, &inv, &(c + l * u));
        assert!(d.abs() < 1e-12);
        for x in [Point3::new(0.5, 0.1, 0.2), Point3::new(0.12, -0.18, 0.31)] {
            let (_, g) = ellipsoid_distance(&c, &inv, &x);
            let h = 1e-6;
            for k in 0..3 {
                let e = Vector3::ith(k, h);
                let fd = (ellipsoid_distance(&c, &inv, &(x + e)).0
                    - ellipsoid_distance(&c, &inv, &(x - e)).0)
                    / (2.0 * h);
                assert!((fd - g[k]).abs() < 1e-6, "{k}: {fd} vs {}", g[k]);
            }
        }
    }

    #[test]
    fn fitted_parts_hug_the_skin() {
        let rig = humanoid();
        let h = rig.height();
        let model = PartModel::fit_to_skin(&rig.skeleton, &rig.pose, &rig.meshes, h);
        assert!(model.parts.len() >= 15, "{} parts", model.parts.len());
        let fk = ForwardKinematics::new(&rig.skeleton, &rig.pose);
        let mut placed = PlacedParts::default();
        model.place(&fk, &mut placed);
        let world = rig.skeleton.world_matrices(&rig.pose);
        let (verts, _) = rig.meshes[0].skin(&world);
        let mut dists: Vec<f64> = verts
            .iter()
            .map(|v| {
                model
                    .surface_distance(&placed, v, None)
                    .expect("parts")
                    .distance
                    .abs()
                    / h
            })
            .collect();
        dists.sort_by(f64::total_cmp);
        let median = dists[dists.len() / 2];
        assert!(median < 0.02, "median vertex distance {median}");
    }

    #[test]
    fn projection_lands_on_the_surface() {
        let rig = humanoid();
        let h = rig.height();
        let model = PartModel::from_bone_lengths(&rig.skeleton, &rig.pose, h);
        assert!(!model.parts.is_empty());
        let fk = ForwardKinematics::new(&rig.skeleton, &rig.pose);
        let mut placed = PlacedParts::default();
        model.place(&fk, &mut placed);
        let x = placed.center[0] + Vector3::new(0.1, 0.2, 0.05) * h;
        let p = model.project(&placed, &x, None).expect("projects");
        let d = model.surface_distance(&placed, &p, None).expect("parts");
        assert!(d.distance.abs() < 1e-4 * h, "{}", d.distance);
    }
}
