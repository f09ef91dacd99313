//! A rigged character: skeleton, its stored pose, skinned meshes and animations.

use crate::animation::Animation;
use crate::geometry::Aabb;
use crate::math::Point3;
use crate::skeleton::{JointKind, Pose, Skeleton};
use crate::skinning::SkinnedMesh;

/// Everything a rig file holds that rigfit works with.
#[derive(Clone, Debug)]
pub struct Rig {
    pub skeleton: Skeleton,
    /// The pose stored in the file (glTF node transforms; BVH frame 0).
    pub pose: Pose,
    pub meshes: Vec<SkinnedMesh>,
    pub animations: Vec<Animation>,
}

impl Rig {
    /// World points that describe the character's extent for `pose`: skinned mesh
    /// vertices when there is a mesh, otherwise joint positions.
    pub fn extent_points(&self, pose: &Pose) -> Vec<Point3> {
        let world = self.skeleton.world_matrices(pose);
        if self.meshes.iter().any(|m| !m.positions.is_empty()) {
            self.meshes.iter().flat_map(|m| m.skin(&world).0).collect()
        } else {
            self.skeleton
                .joints()
                .iter()
                .zip(&world)
                .filter(|(j, _)| j.kind != JointKind::Helper)
                .map(|(_, m)| Point3::new(m[(0, 3)], m[(1, 3)], m[(2, 3)]))
                .collect()
        }
    }

    /// The bounding box of the character in `pose`.
    pub fn bounds(&self, pose: &Pose) -> Option<Aabb> {
        Aabb::from_points(&self.extent_points(pose))
    }

    /// The character's height: the vertical (y, the glTF and BVH up axis) extent of its
    /// bounding box in the stored pose, or the largest extent if that is degenerate.
    pub fn height(&self) -> f64 {
        match self.bounds(&self.pose) {
            Some(b) => {
                let e = b.extent();
                if e.y > 1e-9 { e.y } else { e.max() }
            }
            None => 0.0,
        }
    }

    /// Indices of joints that are reported to users (skin joints and end sites).
    pub fn reported_joints(&self) -> impl Iterator<Item = usize> + '_ {
        self.skeleton
            .joints()
            .iter()
            .enumerate()
            .filter(|(_, j)| j.kind != JointKind::Helper)
            .map(|(i, _)| i)
    }
}
