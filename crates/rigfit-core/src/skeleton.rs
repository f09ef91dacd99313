//! The joint tree: names, parents, rest (bind) transforms, degrees of freedom and limits,
//! and the [`Pose`] that gives every joint its current local transform.

use crate::math::{Matrix4, Quat, Trs, Vector3};

/// What a joint of the tree stands for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum JointKind {
    /// A joint that deforms the mesh (a glTF skin joint, a BVH joint).
    Skin,
    /// A node above or between skin joints that carries a transform but no skin weights
    /// (a glTF armature or scene-root node). Kept so world transforms are exact.
    Helper,
    /// A BVH `End Site`: a fixed point at the tip of a chain.
    EndSite,
    /// The tip of a leaf bone found from its skin ([`crate::Rig::tip_skinned_leaves`]):
    /// fixed like an end site and drawn and fitted as one, but not in the file, so never
    /// reported or written.
    SkinTip,
}

impl JointKind {
    /// A fixed point at the tip of a chain: an end site, or a tip found from the skin.
    pub fn is_tip(self) -> bool {
        matches!(self, JointKind::EndSite | JointKind::SkinTip)
    }
}

/// The degrees of freedom a solver may move at a joint. Rotations are increments applied in
/// the joint's own frame after its current rotation: `R <- R * exp([delta]x)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum JointDof {
    /// The joint does not move.
    Fixed,
    /// One rotation about an axis given in the joint's local frame.
    Hinge { axis: Vector3 },
    /// Three rotational degrees of freedom.
    Ball,
    /// Three translations (in the parent's frame) followed by three rotations.
    Free,
}

impl JointDof {
    /// How many parameters this kind of joint has.
    pub fn count(&self) -> usize {
        match self {
            JointDof::Fixed => 0,
            JointDof::Hinge { .. } => 1,
            JointDof::Ball => 3,
            JointDof::Free => 6,
        }
    }
}

/// Limits on a joint's rotation, expressed as bounds on the rotation vector (axis times
/// angle, radians) of `rest.rotation^-1 * rotation`. For a hinge only `x` is used (the
/// signed angle about the hinge axis).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct JointLimits {
    pub min: Vector3,
    pub max: Vector3,
}

/// One joint of a [`Skeleton`].
#[derive(Clone, Debug, PartialEq)]
pub struct Joint {
    pub name: String,
    /// Index of the parent joint; always smaller than this joint's own index.
    pub parent: Option<usize>,
    /// The rest (bind) local transform, relative to the parent (or the world for a root).
    pub rest: Trs,
    pub kind: JointKind,
    pub dof: JointDof,
    pub limits: Option<JointLimits>,
    /// For a joint that translates: the box its local translation keeps to (the rig's
    /// units; from a joints file's `translation`), soft in tracking's M-step.
    pub translation_limits: Option<JointLimits>,
    /// For a free joint the rig's clips keep at one place in another joint's frame (an IK
    /// goal at the end of its arm, [`crate::Rig::tie_goals`]): that place, held in tracking.
    pub tie: Option<JointTie>,
    /// For a free joint below the root that carries joints and that the rig's clips
    /// translate (a hip node a sit clip drops to the floor): a few local transforms its
    /// clips give it, far apart ([`crate::Rig::note_clip_places`]); for such a joint tied
    /// to another (`tie`), its transforms at the same clip times as that joint's places.
    /// Tracking's first-frame search tries the joints at each of them.
    pub clip_places: Vec<Trs>,
}

/// Where a joint's origin stays: at `offset` (the rig's units) in joint `to`'s frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct JointTie {
    pub to: usize,
    pub offset: Vector3,
}

impl Joint {
    /// A skin joint with a ball DOF and no limits.
    pub fn new(name: impl Into<String>, parent: Option<usize>, rest: Trs) -> Self {
        Self {
            name: name.into(),
            parent,
            rest,
            kind: JointKind::Skin,
            dof: JointDof::Ball,
            limits: None,
            translation_limits: None,
            tie: None,
            clip_places: Vec::new(),
        }
    }
}

/// Why a joint list is not a valid tree.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum SkeletonError {
    #[error("the skeleton has no joints")]
    Empty,
    #[error("joint {index} ('{name}') has parent {parent}, which does not come before it")]
    ParentOrder {
        index: usize,
        name: String,
        parent: usize,
    },
    #[error("joint {index} ('{name}') has a non-finite rest transform")]
    NonFinite { index: usize, name: String },
    #[error("joint {index} ('{name}') is its own ancestor: the parent links form a cycle")]
    Cycle { index: usize, name: String },
}

/// A joint tree stored parents-before-children, so one forward pass computes every world
/// transform.
#[derive(Clone, Debug, PartialEq)]
pub struct Skeleton {
    joints: Vec<Joint>,
    children: Vec<Vec<usize>>,
}

impl Skeleton {
    /// Builds a skeleton; parents must come before their children.
    pub fn new(joints: Vec<Joint>) -> Result<Self, SkeletonError> {
        if joints.is_empty() {
            return Err(SkeletonError::Empty);
        }
        let mut children = vec![Vec::new(); joints.len()];
        for (index, joint) in joints.iter().enumerate() {
            if let Some(parent) = joint.parent {
                if parent >= index {
                    return Err(SkeletonError::ParentOrder {
                        index,
                        name: joint.name.clone(),
                        parent,
                    });
                }
                children[parent].push(index);
            }
            let r = &joint.rest;
            let finite = r.translation.iter().all(|v| v.is_finite())
                && r.scale.iter().all(|v| v.is_finite())
                && r.rotation.coords.iter().all(|v| v.is_finite());
            if !finite {
                return Err(SkeletonError::NonFinite {
                    index,
                    name: joint.name.clone(),
                });
            }
        }
        Ok(Self { joints, children })
    }

    /// Builds a skeleton from joints in any order (parents given as indices into `joints`),
    /// reordering them parents-first. Returns the skeleton and, for each input joint, its new
    /// index.
    pub fn from_unordered(mut joints: Vec<Joint>) -> Result<(Self, Vec<usize>), SkeletonError> {
        let n = joints.len();
        let mut children = vec![Vec::new(); n];
        let mut roots = Vec::new();
        for (i, j) in joints.iter().enumerate() {
            match j.parent {
                Some(p) if p < n && p != i => children[p].push(i),
                _ => roots.push(i),
            }
        }
        let mut order = Vec::with_capacity(n);
        let mut stack: Vec<usize> = roots.into_iter().rev().collect();
        while let Some(i) = stack.pop() {
            order.push(i);
            for &c in children[i].iter().rev() {
                stack.push(c);
            }
        }
        if order.len() != n {
            // A cycle: the joints on it are never reached from a root.
            let mut reached = vec![false; n];
            for &i in &order {
                reached[i] = true;
            }
            let index = reached.iter().position(|r| !r).unwrap_or(0);
            return Err(SkeletonError::Cycle {
                index,
                name: joints[index].name.clone(),
            });
        }
        let mut new_index = vec![0; n];
        for (new, &old) in order.iter().enumerate() {
            new_index[old] = new;
        }
        for j in joints.iter_mut() {
            j.parent = j.parent.map(|p| new_index[p]);
        }
        let mut slots: Vec<Option<Joint>> = joints.into_iter().map(Some).collect();
        let ordered = order
            .iter()
            .map(|&old| slots[old].take().expect("each joint is visited once"))
            .collect();
        Ok((Self::new(ordered)?, new_index))
    }

    pub fn joints(&self) -> &[Joint] {
        &self.joints
    }

    pub fn joint(&self, index: usize) -> &Joint {
        &self.joints[index]
    }

    /// Mutable access to the degrees of freedom and limits of a joint (the tree itself is
    /// fixed once built).
    pub fn set_dof(&mut self, index: usize, dof: JointDof, limits: Option<JointLimits>) {
        self.joints[index].dof = dof;
        self.joints[index].limits = limits;
    }

    /// Sets joint `index`'s translation box (see [`Joint::translation_limits`]).
    pub fn set_translation_limits(&mut self, index: usize, limits: Option<JointLimits>) {
        self.joints[index].translation_limits = limits;
    }

    /// Sets joint `index`'s tie (see [`Joint::tie`]).
    pub fn set_tie(&mut self, index: usize, tie: Option<JointTie>) {
        self.joints[index].tie = tie;
    }

    /// Sets joint `index`'s clip places (see [`Joint::clip_places`]).
    pub fn set_clip_places(&mut self, index: usize, places: Vec<Trs>) {
        self.joints[index].clip_places = places;
    }

    pub fn len(&self) -> usize {
        self.joints.len()
    }

    pub fn is_empty(&self) -> bool {
        self.joints.is_empty()
    }

    pub fn children(&self, index: usize) -> &[usize] {
        &self.children[index]
    }

    /// The index of the joint with this name.
    pub fn find(&self, name: &str) -> Option<usize> {
        self.joints.iter().position(|j| j.name == name)
    }

    /// The joints with no parent.
    pub fn roots(&self) -> impl Iterator<Item = usize> + '_ {
        self.joints
            .iter()
            .enumerate()
            .filter(|(_, j)| j.parent.is_none())
            .map(|(i, _)| i)
    }

    /// True when `ancestor` is `joint` or one of its ancestors.
    pub fn is_ancestor_or_self(&self, ancestor: usize, joint: usize) -> bool {
        let mut cur = Some(joint);
        while let Some(j) = cur {
            if j == ancestor {
                return true;
            }
            if j < ancestor {
                return false;
            }
            cur = self.joints[j].parent;
        }
        false
    }

    /// The deepest joint that is an ancestor (or self) of every skin joint: the joint that
    /// moves the whole character. `None` when skin joints live in separate trees.
    pub fn skin_root(&self) -> Option<usize> {
        // Skin joints in each joint's subtree, children folded into parents (linear in the
        // joints however deep the tree).
        let mut below = vec![0usize; self.len()];
        for j in (0..self.len()).rev() {
            if self.joints[j].kind == JointKind::Skin {
                below[j] += 1;
            }
            if let Some(p) = self.joints[j].parent {
                below[p] += below[j];
            }
        }
        let first = (0..self.len()).find(|&i| self.joints[i].kind == JointKind::Skin)?;
        let total: usize = self.roots().map(|r| below[r]).sum();
        let mut candidate = Some(first);
        while let Some(c) = candidate {
            if below[c] == total {
                return Some(c);
            }
            candidate = self.joints[c].parent;
        }
        None
    }

    /// For every joint, whether it is a helper that links the skin together: a node below
    /// the skin root with skin joints or end sites below it (a hip or shoulder node between
    /// the body and a limb). Such links are bones of the character; helper leaves (IK
    /// goals, weapon sockets) and helpers above the root are not.
    pub fn linking_helpers(&self) -> Vec<bool> {
        let mut skin_below = vec![false; self.len()];
        for j in (0..self.len()).rev() {
            if let Some(p) = self.joints[j].parent {
                skin_below[p] |= skin_below[j] || self.joints[j].kind != JointKind::Helper;
            }
        }
        let under = self.skin_root().map(|r| self.subtree_mask(r));
        (0..self.len())
            .map(|j| {
                self.joints[j].kind == JointKind::Helper
                    && skin_below[j]
                    && under.as_ref().is_some_and(|u| u[j])
            })
            .collect()
    }

    /// For every joint, whether `ancestor` is it or one of its ancestors (one pass).
    pub fn subtree_mask(&self, ancestor: usize) -> Vec<bool> {
        let mut mask = vec![false; self.len()];
        for j in 0..self.len() {
            mask[j] = j == ancestor || self.joints[j].parent.is_some_and(|p| mask[p]);
        }
        mask
    }

    /// The default degrees of freedom of a character: the skin root (or every root when the
    /// skin is a forest) is free, other skin joints are ball joints, helpers above the root
    /// and end sites are fixed.
    pub fn set_default_dofs(&mut self) {
        let root = self.skin_root();
        let under = root.map(|r| self.subtree_mask(r));
        for i in 0..self.len() {
            let j = &self.joints[i];
            let under_root = under.as_ref().is_none_or(|u| u[i]);
            let dof = if Some(i) == root || (root.is_none() && j.parent.is_none()) {
                JointDof::Free
            } else if j.kind.is_tip() || !under_root {
                JointDof::Fixed
            } else {
                JointDof::Ball
            };
            self.joints[i].dof = dof;
        }
    }

    /// The rest pose: every joint at its rest transform.
    pub fn rest_pose(&self) -> Pose {
        Pose {
            local: self.joints.iter().map(|j| j.rest).collect(),
        }
    }

    /// The world transform of every joint for `pose`, as homogeneous matrices.
    pub fn world_matrices(&self, pose: &Pose) -> Vec<Matrix4> {
        let mut world: Vec<Matrix4> = Vec::with_capacity(self.len());
        for (i, joint) in self.joints.iter().enumerate() {
            let local = pose.local[i].to_matrix();
            let m = match joint.parent {
                Some(p) => world[p] * local,
                None => local,
            };
            world.push(m);
        }
        world
    }

    /// `pose` with the whole body moved by the rigid motion `x -> turn x + shift`: each
    /// joint without a parent carries it.
    pub fn moved_rigidly(&self, pose: &Pose, turn: &Quat, shift: &Vector3) -> Pose {
        let mut out = pose.clone();
        for (j, local) in out.local.iter_mut().enumerate() {
            if self.joint(j).parent.is_none() {
                local.translation = turn * local.translation + shift;
                local.rotation = turn * local.rotation;
            }
        }
        out
    }

    /// The world rotation of every joint for `pose`: the products of the local rotations
    /// from the root (scales left out).
    pub fn world_rotations(&self, pose: &Pose) -> Vec<Quat> {
        let mut world: Vec<Quat> = Vec::with_capacity(self.len());
        for (j, joint) in self.joints.iter().enumerate() {
            let parent = joint.parent.map_or_else(Quat::identity, |p| world[p]);
            world.push(parent * pose.local[j].rotation);
        }
        world
    }

    /// The local rotation of `joint` in `pose` turned by `turn` about world axes through the
    /// joint (its subtree turns with it); `world` is the pose's
    /// [`Skeleton::world_rotations`].
    pub fn turned_in_world(&self, pose: &Pose, world: &[Quat], joint: usize, turn: &Quat) -> Quat {
        let parent = self.joints[joint]
            .parent
            .map_or_else(Quat::identity, |p| world[p]);
        parent.inverse() * turn * parent * pose.local[joint].rotation
    }

    /// The world position of every joint for `pose`.
    pub fn joint_positions(&self, pose: &Pose) -> Vec<crate::math::Point3> {
        self.world_matrices(pose)
            .iter()
            .map(|m| crate::math::Point3::from(crate::math::translation_part(m)))
            .collect()
    }

    /// Moves each tied joint ([`Joint::tie`]) of `pose` to its place, in joint order: its
    /// local translation set so that its origin lies at its offset in the other joint's
    /// frame (an IK goal put back at the end of its arm). Rotations are kept.
    pub fn apply_ties(&self, pose: &mut Pose) {
        for (j, joint) in self.joints.iter().enumerate() {
            let Some(tie) = joint.tie else { continue };
            let world = self.world_matrices(pose);
            let place = crate::math::transform_point(&world[tie.to], &tie.offset.into());
            let parent = joint
                .parent
                .and_then(|p| world[p].try_inverse())
                .unwrap_or_else(Matrix4::identity);
            pose.local[j].translation = crate::math::transform_point(&parent, &place).coords;
        }
    }

    /// A pose whose world matrices are `world` (one per joint): each local transform is
    /// `parent_world^-1 * world`, decomposed into translation, rotation and scale.
    pub fn pose_from_world(&self, world: &[Matrix4]) -> Pose {
        let local = self
            .joints
            .iter()
            .enumerate()
            .map(|(i, joint)| {
                let m = match joint.parent {
                    Some(p) => world[p].try_inverse().unwrap_or_else(Matrix4::identity) * world[i],
                    None => world[i],
                };
                Trs::from_matrix(&m)
            })
            .collect();
        Pose { local }
    }
}

/// The local transform of every joint (the same order as the skeleton).
#[derive(Clone, Debug, PartialEq)]
pub struct Pose {
    pub local: Vec<Trs>,
}

impl Pose {
    /// The local rotation of a joint.
    pub fn rotation(&self, joint: usize) -> Quat {
        self.local[joint].rotation
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn chain() -> Vec<Joint> {
        vec![
            Joint::new("a", None, Trs::IDENTITY),
            Joint::new(
                "b",
                Some(0),
                Trs::from_translation(Vector3::new(0.0, 1.0, 0.0)),
            ),
            Joint::new(
                "c",
                Some(1),
                Trs::from_translation(Vector3::new(0.0, 1.0, 0.0)),
            ),
        ]
    }

    #[test]
    fn rejects_bad_parent_order() {
        let mut j = chain();
        j[1].parent = Some(2);
        assert!(matches!(
            Skeleton::new(j),
            Err(SkeletonError::ParentOrder { .. })
        ));
    }

    #[test]
    fn reorders_unordered_joints() {
        let mut j = chain();
        j.swap(0, 2); // c, b, a with parents to be remapped
        j[0].parent = Some(1);
        j[1].parent = Some(2);
        j[2].parent = None;
        let (s, map) = Skeleton::from_unordered(j).expect("valid tree");
        assert_eq!(s.joint(0).name, "a");
        assert_eq!(s.joint(2).name, "c");
        assert_eq!(map, vec![2, 1, 0]);
        let p = s.joint_positions(&s.rest_pose());
        assert!((p[2].y - 2.0).abs() < 1e-12);
    }

    #[test]
    fn detects_cycles() {
        let mut j = chain();
        j[0].parent = Some(2);
        assert!(Skeleton::from_unordered(j).is_err());
    }

    #[test]
    fn world_from_local_round_trip() {
        let mut s = Skeleton::new(chain()).expect("valid");
        s.set_default_dofs();
        let mut pose = s.rest_pose();
        pose.local[1].rotation = Quat::from_euler_angles(0.2, 0.4, -0.3);
        let world = s.world_matrices(&pose);
        let back = s.pose_from_world(&world);
        for (a, b) in back.local.iter().zip(&pose.local) {
            assert!((a.translation - b.translation).norm() < 1e-12);
            assert!(a.rotation.angle_to(&b.rotation) < 1e-9);
        }
        assert_eq!(s.joint(0).dof, JointDof::Free);
        assert_eq!(s.skin_root(), Some(0));
    }
}
