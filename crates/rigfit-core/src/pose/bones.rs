//! The model side of sketch posing: points sampled along the bones of a skeleton, and the
//! chains of bones a single stroke can cover.

use std::ops::Range;

use crate::kinematics::ForwardKinematics;
use crate::math::{Point3, transform_point};
use crate::skeleton::{JointDof, JointKind, Pose, Skeleton};

/// The most points sampled along one bone: a bone far longer than the character is tall
/// (a unit or export mistake) gets points further apart instead of an unbounded number.
pub const MAX_POINTS_PER_BONE: usize = 64;

/// A bone: the segment from a joint to one of its children, carried by the joint.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bone {
    /// The joint whose rotation turns the bone.
    pub joint: usize,
    /// The joint at the bone's tip.
    pub child: usize,
    pub length: f64,
    /// The tip joint translates (a marker, or a joint whose animation moves it): the bone's
    /// points ride on the tip, where the joint's translation moves them.
    pub tip_translates: bool,
}

/// A point rigidly attached to a joint.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ModelPoint {
    pub bone: usize,
    pub joint: usize,
    /// The point in the joint's local frame.
    pub local: Point3,
    /// Where the point lies along its bone, from the bone's joint (0) to its tip (1).
    pub along: f64,
}

/// Bones of a skeleton with points sampled along them (`V` of Cannavò et al. eq. 1).
#[derive(Clone, Debug)]
pub struct BoneModel {
    pub bones: Vec<Bone>,
    pub points: Vec<ModelPoint>,
    /// The points of each bone, ordered from its joint to its child.
    pub bone_points: Vec<Range<usize>>,
    /// The bones that continue each bone (start at its tip, possibly through zero-length
    /// links such as a hip joint placed on the pelvis).
    pub next_bones: Vec<Vec<usize>>,
}

impl BoneModel {
    /// Samples every bone longer than `min_length` with points about `spacing` apart, in the
    /// configuration `pose`. Bones are segments from a joint under the character's root to
    /// a skin joint, an end site or a helper that links skin joints below it.
    pub fn new(skeleton: &Skeleton, pose: &Pose, spacing: f64, min_length: f64) -> Self {
        let fk = ForwardKinematics::new(skeleton, pose);
        let under_root: Vec<bool> = match skeleton.skin_root() {
            Some(r) => skeleton.subtree_mask(r),
            None => (skeleton.joints().iter())
                .map(|j| j.kind != JointKind::Helper)
                .collect(),
        };
        let linking = skeleton.linking_helpers();
        // Each joint's anchor: itself, or the first ancestor reached through zero-length links.
        let mut anchor: Vec<usize> = (0..skeleton.len()).collect();
        for j in 0..skeleton.len() {
            // A joint that translates is a bone's tip however near its parent it rests.
            if let Some(p) = skeleton
                .joint(j)
                .parent
                .filter(|_| skeleton.joint(j).dof != JointDof::Free)
            {
                if (fk.position(j) - fk.position(p)).norm() < min_length {
                    anchor[j] = anchor[p];
                }
            }
        }
        let mut bones = Vec::new();
        let mut points = Vec::new();
        let mut bone_points = Vec::new();
        for c in 0..skeleton.len() {
            let Some(j) = skeleton.joint(c).parent else {
                continue;
            };
            if (skeleton.joint(c).kind == JointKind::Helper && !linking[c]) || !under_root[j] {
                continue;
            }
            let (a, b) = (fk.position(j), fk.position(c));
            let length = (b - a).norm();
            let tip_translates = skeleton.joint(c).dof == JointDof::Free;
            if length < min_length && !tip_translates {
                continue;
            }
            // `as usize` saturates (and maps NaN to 0): the count stays within 1..=MAX.
            let n = ((length / spacing).round() as usize).clamp(1, MAX_POINTS_PER_BONE);
            let start = points.len();
            if tip_translates {
                // Only the ends are known to move with the joints: one point where the bone
                // leaves its joint, the rest of the bone's weight at its tip.
                points.push(ModelPoint {
                    bone: bones.len(),
                    joint: j,
                    local: Point3::origin(),
                    along: 0.0,
                });
                for _ in 0..n.max(2) - 1 {
                    points.push(ModelPoint {
                        bone: bones.len(),
                        joint: c,
                        local: Point3::origin(),
                        along: 1.0,
                    });
                }
            } else {
                let inverse = fk
                    .world(j)
                    .try_inverse()
                    .unwrap_or_else(crate::math::Matrix4::identity);
                for i in 0..n {
                    let t = (i as f64 + 0.5) / n as f64;
                    let p = a + (b - a) * t;
                    points.push(ModelPoint {
                        bone: bones.len(),
                        joint: j,
                        local: transform_point(&inverse, &p),
                        along: t,
                    });
                }
            }
            bone_points.push(start..points.len());
            bones.push(Bone {
                joint: j,
                child: c,
                length,
                tip_translates,
            });
        }
        // The bones leaving each anchor, so that finding a bone's continuations is linear in
        // the bones overall, not quadratic.
        let mut leaving: Vec<Vec<usize>> = vec![Vec::new(); skeleton.len()];
        for (k, bone) in bones.iter().enumerate() {
            leaving[anchor[bone.joint]].push(k);
        }
        let next_bones = bones
            .iter()
            .map(|b| leaving[anchor[b.child]].clone())
            .collect();
        Self {
            bones,
            points,
            bone_points,
            next_bones,
        }
    }

    /// Whether every bone's tip translates: a marker rig, with no shape to place rigidly.
    pub fn is_markers(&self) -> bool {
        self.bones.iter().all(|b| b.tip_translates)
    }

    /// The world position of every model point.
    pub fn world_points(&self, fk: &ForwardKinematics) -> Vec<Point3> {
        self.points
            .iter()
            .map(|p| fk.point(p.joint, &p.local))
            .collect()
    }

    /// Every chain of up to `max_bones` bones that one stroke could cover: sequences of
    /// bones, each continuing the one before; and every longer unbranched run whole (a tail
    /// or a long spine drawn in one stroke), from the joint it leaves to its end or the next
    /// branch.
    pub fn chains(&self, max_bones: usize) -> Vec<Vec<usize>> {
        let mut out = Vec::new();
        let mut stack: Vec<Vec<usize>> = (0..self.bones.len()).map(|b| vec![b]).collect();
        while let Some(chain) = stack.pop() {
            let last = *chain.last().expect("chains are never empty");
            if chain.len() < max_bones {
                for &n in &self.next_bones[last] {
                    let mut longer = chain.clone();
                    longer.push(n);
                    stack.push(longer);
                }
            }
            out.push(chain);
        }
        // A bone continues a run when it is the only continuation of the bone before it.
        let mut continues_run = vec![false; self.bones.len()];
        for next in &self.next_bones {
            if let [only] = next[..] {
                continues_run[only] = true;
            }
        }
        for first in (0..self.bones.len()).filter(|&b| !continues_run[b]) {
            let mut run = vec![first];
            // Bounded: bones never loop, but a malformed model must not hang.
            while let ([only], true) = (
                &self.next_bones[*run.last().expect("runs are never empty")][..],
                run.len() <= self.bones.len(),
            ) {
                run.push(*only);
            }
            if run.len() > max_bones {
                out.push(run);
            }
        }
        out
    }

    /// [`SAMPLES`](super::chains::SAMPLES) points evenly spaced in arclength along `chain`
    /// at `fk` (from the joint that turns its first bone through each bone's tip), and its
    /// length.
    pub(super) fn chain_samples(
        &self,
        chain: &[usize],
        fk: &ForwardKinematics,
    ) -> ([Point3; super::chains::SAMPLES], f64) {
        let joints = || {
            let first = chain.first().map(|&b| self.bones[b].joint);
            first
                .into_iter()
                .chain(chain.iter().map(|&b| self.bones[b].child))
                .map(|j| fk.position(j))
        };
        super::chains::arclength_samples_along(joints)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::{Trs, Vector3};
    use crate::skeleton::Joint;

    /// A root with a 3-bone arm and a 40-bone tail.
    fn tailed() -> Skeleton {
        let mut joints = vec![Joint::new(
            "root",
            None,
            Trs::from_translation(Vector3::zeros()),
        )];
        for i in 0..3 {
            let parent = if i == 0 { 0 } else { joints.len() - 1 };
            let offset = Trs::from_translation(Vector3::new(0.1, 0.0, 0.0));
            joints.push(Joint::new(format!("arm{i}"), Some(parent), offset));
        }
        for i in 0..40 {
            let parent = if i == 0 { 0 } else { joints.len() - 1 };
            let offset = Trs::from_translation(Vector3::new(0.0, -0.05, 0.0));
            joints.push(Joint::new(format!("tail{i}"), Some(parent), offset));
        }
        let mut s = Skeleton::new(joints).expect("a tree");
        s.set_default_dofs();
        s
    }

    #[test]
    fn a_run_longer_than_the_chain_limit_is_one_chain_whole() {
        let skeleton = tailed();
        let model = BoneModel::new(&skeleton, &skeleton.rest_pose(), 0.01, 1e-6);
        let chains = model.chains(24);
        assert!(chains.iter().any(|c| c.len() == 40), "the whole tail");
        assert!(chains.iter().all(|c| c.len() <= 24 || c.len() == 40));
        // Only the run from where it leaves the root, not its every tail end.
        assert_eq!(chains.iter().filter(|c| c.len() > 24).count(), 1);
        assert!(chains.iter().any(|c| c.len() == 3), "the arm");
    }
}
