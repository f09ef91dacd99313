//! The articulated surface model of a rig: ellipsoids fitted to its skin in the bind pose
//! (or sized from its bones) and texture points sampled on that surface; the bind pose and
//! the texture points' count.

use rand::SeedableRng;

use super::parts::{PartModel, PlacedParts};
use super::texture::sample_triangles;
use super::{ArticulatedModel, TrackError};
use crate::geometry::Aabb;
use crate::kinematics::ForwardKinematics;
use crate::math::{Point3, Vector3};
use crate::rig::{Rig, z_is_up};
use crate::skeleton::Pose;

/// The seed of [`ArticulatedModel::from_rig`]'s random draw of texture points.
pub const MODEL_POINTS_SEED: u64 = 0x7ac4;

impl ArticulatedModel {
    /// The model's up axis: y, or z when its surface is much deeper in z than tall in y (as
    /// `Rig::height` decides). The first-frame search turns the body about it.
    pub fn up_axis(&self) -> nalgebra::Unit<Vector3> {
        let bare = self.surface_normals.is_none();
        match Aabb::from_points(&self.surface_samples) {
            Some(bounds) if z_is_up(&bounds.extent(), bare) => Vector3::z_axis(),
            _ => Vector3::y_axis(),
        }
    }

    /// The model of `rig` in its stored pose: ellipsoids fitted to the skinned mesh and
    /// `samples` texture points sampled on it, or, for a bare skeleton, ellipsoids sized from
    /// bone lengths and sampled on their fused surface. `samples == 0` picks the count from
    /// the surface's area (see [`texture_count`]).
    pub fn from_rig(rig: &Rig, samples: usize) -> Result<Self, TrackError> {
        Self::from_rig_drawn(rig, samples, MODEL_POINTS_SEED)
    }

    /// [`ArticulatedModel::from_rig`] with the texture points drawn from `seed`.
    pub fn from_rig_drawn(rig: &Rig, samples: usize, seed: u64) -> Result<Self, TrackError> {
        Self::from_rig_drawn_at(rig, samples, seed, rig.height())
    }

    /// [`ArticulatedModel::from_rig_drawn`] at the scale `height` in place of the rig's
    /// upright height: the parts' least radius, the fused surface's blend and the tracker's
    /// widths are all fractions of it (an object lying down is measured by its largest side).
    pub fn from_rig_drawn_at(
        rig: &Rig,
        samples: usize,
        seed: u64,
        height: f64,
    ) -> Result<Self, TrackError> {
        let height = height.max(1e-9);
        let has_mesh = rig
            .meshes
            .iter()
            .any(|m| !m.positions.is_empty() && !m.triangles.is_empty());
        let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
        // A skinned character is modelled in its bind pose (limbs apart, as it was
        // modelled); a bare skeleton in its stored pose.
        let built = if has_mesh {
            bind_pose(rig)
        } else {
            rig.pose.clone()
        };
        let parts = if has_mesh {
            PartModel::fit_to_skin(&rig.skeleton, &built, &rig.meshes, height)
        } else {
            PartModel::from_bone_lengths(&rig.skeleton, &built, height)
        };
        if parts.parts.is_empty() {
            return Err(TrackError::NoParts);
        }
        let fk = ForwardKinematics::new(&rig.skeleton, &built);
        let (surface_samples, surface_normals) = if has_mesh {
            let world = rig.skeleton.world_matrices(&built);
            let mut vertices = Vec::new();
            let mut triangles = Vec::new();
            for mesh in &rig.meshes {
                let base = vertices.len() as u32;
                vertices.extend(mesh.skin(&world).0);
                triangles.extend(mesh.triangles.iter().map(|t| t.map(|i| i + base)));
            }
            let samples = texture_count(samples, &vertices, &triangles, height);
            let samples = sample_triangles(&vertices, &triangles, samples, &mut rng);
            let normals = samples
                .iter()
                .map(|&(_, t)| {
                    let [a, b, c] = triangles[t].map(|i| vertices[i as usize]);
                    (b - a).cross(&(c - a)).normalize()
                })
                .collect();
            (samples.into_iter().map(|(p, _)| p).collect(), Some(normals))
        } else {
            let mesh = parts.triangulate(&fk, 12, 16);
            let mut placed = PlacedParts::default();
            parts.place(&fk, &mut placed);
            let samples = texture_count(samples, &mesh.vertices, &mesh.triangles, height);
            // On the parts' own surfaces, where no other part covers them: the outer
            // surface of the ellipsoids, the one a scan of them sees. (Projected onto the
            // fused surface instead, points of parts closer than the fusion width, fingers
            // side by side, a toe on its foot, sat on a web between them that no scan of
            // the parts shows: from the true pose the tracker drifted to 3-5% on the hands.)
            let points = sample_triangles(&mesh.vertices, &mesh.triangles, samples * 2, &mut rng)
                .into_iter()
                .filter_map(|(p, _)| on_outer_surface(&placed, &p))
                .take(samples)
                .collect();
            (points, None)
        };
        Ok(Self {
            skeleton: rig.skeleton.clone(),
            parts,
            height,
            start: rig.pose.clone(),
            built,
            surface_samples,
            surface_normals,
        })
    }
}

/// `x`, a point of a part's triangulated ellipsoid (a facet lies a little inside it), moved
/// radially onto that ellipsoid (the part whose surface it is nearest, by the ellipsoid's
/// own scale), unless another part's ellipsoid covers it there.
fn on_outer_surface(placed: &PlacedParts, x: &Point3) -> Option<Point3> {
    let scale = |q: usize| (placed.inv_shape[q] * (x - placed.center[q])).norm();
    let parts = placed.center.len();
    let (own, u) = (0..parts)
        .map(|q| (q, scale(q)))
        .min_by(|a, b| (a.1 - 1.0).abs().total_cmp(&(b.1 - 1.0).abs()))?;
    let c = placed.center[own];
    let on = c + (x - c) / u.max(1e-12);
    let covered = (0..parts)
        .filter(|&q| q != own)
        .any(|q| (placed.inv_shape[q] * (on - placed.center[q])).norm() < 1.0 - 1e-6);
    (!covered).then_some(on)
}

/// The pose in which a skinned rig's meshes were bound: every skin joint's world transform
/// is the inverse of its inverse bind matrix (of the first mesh that uses it); other joints
/// keep their stored local transforms.
pub fn bind_pose(rig: &Rig) -> Pose {
    let skeleton = &rig.skeleton;
    let stored = &rig.pose;
    let mut world: Vec<crate::math::Matrix4> = Vec::with_capacity(skeleton.len());
    for (j, joint) in skeleton.joints().iter().enumerate() {
        let from_bind = rig
            .meshes
            .iter()
            .filter(|m| m.joints.iter().any(|js| js.contains(&(j as u32))))
            .find_map(|m| m.inverse_bind.get(j).and_then(|ib| ib.try_inverse()));
        let local = stored.local[j].to_matrix();
        let w = match (from_bind, joint.parent) {
            (Some(w), _) => w,
            (None, Some(p)) => world[p] * local,
            (None, None) => local,
        };
        world.push(w);
    }
    let pose = skeleton.pose_from_world(&world);
    let finite = pose.local.iter().all(|t| {
        t.translation.iter().all(|c| c.is_finite())
            && t.scale.iter().all(|c| c.is_finite() && *c != 0.0)
    });
    if finite { pose } else { stored.clone() }
}

/// Texture points for a surface: `requested`, or with 0 one per `(2% of the height)^2`
/// of area (a nearest-neighbour spacing near the 1% noise level, so the EM kernel sums
/// stay comparable across characters), between 500 and 5,000.
pub fn texture_count(
    requested: usize,
    vertices: &[Point3],
    triangles: &[[u32; 3]],
    height: f64,
) -> usize {
    if requested > 0 {
        return requested;
    }
    let area: f64 = triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| vertices[i as usize]);
            0.5 * (b - a).cross(&(c - a)).norm()
        })
        .filter(|a| a.is_finite())
        .sum();
    ((area / (0.02 * height).powi(2)).round() as usize).clamp(500, 5000)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Matrix3;

    /// Two unit spheres, centres one apart along x.
    fn two_spheres() -> PlacedParts {
        PlacedParts {
            center: vec![Point3::origin(), Point3::new(1.0, 0.0, 0.0)],
            inv_shape: vec![Matrix3::identity(); 2],
            reach: vec![1.0; 2],
        }
    }

    #[test]
    fn a_point_is_moved_onto_its_own_part_and_dropped_where_another_covers_it() {
        let placed = two_spheres();
        // Just inside the first sphere's far side (a facet point): moved onto it.
        let kept = on_outer_surface(&placed, &Point3::new(-0.98, 0.0, 0.0)).expect("kept");
        assert!(
            (kept - Point3::new(-1.0, 0.0, 0.0)).norm() < 1e-12,
            "{kept}"
        );
        // On the first sphere, inside the second: no scan sees it.
        assert!(on_outer_surface(&placed, &Point3::new(0.99, 0.0, 0.0)).is_none());
        // Where the two spheres meet, outside both interiors: kept.
        let seam = Point3::new(0.5, 0.75f64.sqrt(), 0.0);
        assert!(on_outer_surface(&placed, &seam).is_some());
    }
}
