//! A rigged character: skeleton, its stored pose, skinned meshes and animations.

use crate::animation::{Animation, ChannelTarget};
use crate::geometry::Aabb;
use crate::math::{Point3, Vector3};
use crate::skeleton::{JointDof, JointKind, Pose, Skeleton};

/// A box whose y side is under this share of its z side is taken to be z-up.
const Z_UP_RATIO: f64 = 0.6;

/// An animated translation further than this share of the height from the joint's rest
/// translation moves the joint.
const TRANSLATION_TOLERANCE: f64 = 1e-4;
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

    /// The character's height: the vertical extent of its bounding box in the stored pose.
    /// Vertical is y (the glTF and BVH up axis), unless the box is well under its z side
    /// along y (and, with a skinned mesh, y is its thinnest side): then the file is z-up
    /// (many mocap, robotics and DCC exports are) and z is vertical. The largest extent if
    /// the box is degenerate.
    pub fn height(&self) -> f64 {
        match self.bounds(&self.pose) {
            Some(b) => {
                let e = b.extent();
                // A skinned mesh's thinnest side is its depth; a bare skeleton's box may be
                // stretched by a root far from the body (a marker rig's origin).
                let bare = !self.meshes.iter().any(|m| !m.positions.is_empty());
                if e.y < Z_UP_RATIO * e.z && (bare || e.y <= e.x) {
                    e.z
                } else if e.y > 1e-9 {
                    e.y
                } else {
                    e.max()
                }
            }
            None => 0.0,
        }
    }

    /// Gives translation degrees of freedom ([`JointDof::Free`]) to every movable joint
    /// below the root whose animations move its translation (markers, IK goals, BVH
    /// position channels that change): posing and tracking must move them as the file
    /// does. Returns how many joints were freed.
    pub fn free_translating_joints(&mut self) -> usize {
        let size = self.height().max(1e-12);
        let mut translates = vec![false; self.skeleton.len()];
        for animation in &self.animations {
            for channel in &animation.channels {
                if channel.target != ChannelTarget::Translation || channel.joint >= translates.len()
                {
                    continue;
                }
                let rest = self.skeleton.joint(channel.joint).rest.translation;
                translates[channel.joint] |= channel.values.iter().any(|v| {
                    (Vector3::new(v[0], v[1], v[2]) - rest).norm() > TRANSLATION_TOLERANCE * size
                });
            }
        }
        let mut freed = 0;
        for (j, &moves) in translates.iter().enumerate() {
            let joint = self.skeleton.joint(j);
            // Helpers above the character (IK goals, sockets) stay fixed: strokes never
            // pull them.
            if moves && joint.kind != JointKind::Helper && joint.dof != JointDof::Free {
                let limits = joint.limits;
                self.skeleton.set_dof(j, JointDof::Free, limits);
                freed += 1;
            }
        }
        freed
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
