//! Forward kinematics and the analytic Jacobians of world points attached to joints.
//!
//! A joint's world transform is `W_j = W_parent * T_j * R_j * S_j`. Solvers move a pose by
//! parameter increments laid out by [`DofLayout`]: a free joint's translation is added in
//! its parent's frame, and every rotation is updated in the joint's own frame,
//! `R_j <- R_j * exp([delta]x)`. With `A_j = W_parent * T_j * R_j`, a world point `p`
//! carried by joint `j` or a descendant moves as
//! `dp/d delta_k = A_j.linear * (e_k x A_j^-1 (p))`.

use crate::math::{
    Matrix3, Matrix4, Point3, Quat, Vector3, exp_rotation, linear_part, skew, translation_part,
};
use crate::skeleton::{JointDof, Pose, Skeleton};

/// Where each joint's parameters sit in a solver's parameter vector.
#[derive(Clone, Debug, PartialEq)]
pub struct DofLayout {
    offsets: Vec<Option<usize>>,
    dofs: Vec<JointDof>,
    len: usize,
}

impl DofLayout {
    /// Every joint with its own degrees of freedom.
    pub fn new(skeleton: &Skeleton) -> Self {
        Self::with_active(skeleton, &vec![true; skeleton.len()])
    }

    /// Only the joints with `active[j]` move; the rest are held fixed.
    pub fn with_active(skeleton: &Skeleton, active: &[bool]) -> Self {
        let mut offsets = Vec::with_capacity(skeleton.len());
        let mut dofs = Vec::with_capacity(skeleton.len());
        let mut len = 0;
        for (i, joint) in skeleton.joints().iter().enumerate() {
            let dof = if active.get(i).copied().unwrap_or(false) {
                joint.dof
            } else {
                JointDof::Fixed
            };
            let n = dof.count();
            offsets.push((n > 0).then_some(len));
            dofs.push(dof);
            len += n;
        }
        Self { offsets, dofs, len }
    }

    /// The number of parameters.
    pub fn len(&self) -> usize {
        self.len
    }

    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// The number of joints the layout covers.
    pub fn joint_count(&self) -> usize {
        self.offsets.len()
    }

    /// The first parameter of a joint, if it has any.
    pub fn offset(&self, joint: usize) -> Option<usize> {
        self.offsets[joint]
    }

    /// The degrees of freedom a joint has in this layout.
    pub fn dof(&self, joint: usize) -> JointDof {
        self.dofs[joint]
    }

    /// Moves `pose` by the parameter increment `delta` (length [`Self::len`]).
    pub fn apply(&self, pose: &mut Pose, delta: &[f64]) {
        for (j, dof) in self.dofs.iter().enumerate() {
            let Some(o) = self.offsets[j] else { continue };
            let local = &mut pose.local[j];
            let rotation = match dof {
                JointDof::Fixed => continue,
                JointDof::Hinge { axis } => exp_rotation(&(axis.normalize() * delta[o])),
                JointDof::Ball => exp_rotation(&Vector3::new(delta[o], delta[o + 1], delta[o + 2])),
                JointDof::Free => {
                    local.translation += Vector3::new(delta[o], delta[o + 1], delta[o + 2]);
                    exp_rotation(&Vector3::new(delta[o + 3], delta[o + 4], delta[o + 5]))
                }
            };
            local.rotation = Quat::new_normalize((local.rotation * rotation).into_inner());
        }
    }
}

/// The world transforms of one pose, with what the Jacobians need cached per joint.
#[derive(Clone, Debug)]
pub struct ForwardKinematics {
    world: Vec<Matrix4>,
    /// Linear part of `A_j = W_parent * T_j * R_j` and its inverse.
    frame_linear: Vec<Matrix3>,
    frame_linear_inv: Vec<Matrix3>,
    /// Linear part of the parent's world transform (identity for roots).
    parent_linear: Vec<Matrix3>,
    /// World position of each joint's origin.
    origin: Vec<Vector3>,
    parent: Vec<Option<usize>>,
}

impl ForwardKinematics {
    /// Runs forward kinematics for `pose`.
    pub fn new(skeleton: &Skeleton, pose: &Pose) -> Self {
        let n = skeleton.len();
        let mut fk = Self {
            world: Vec::with_capacity(n),
            frame_linear: Vec::with_capacity(n),
            frame_linear_inv: Vec::with_capacity(n),
            parent_linear: Vec::with_capacity(n),
            origin: Vec::with_capacity(n),
            parent: Vec::with_capacity(n),
        };
        fk.update(skeleton, pose);
        fk
    }

    /// Runs forward kinematics for `pose` again, reusing the storage (the same as
    /// [`Self::new`]).
    pub fn update(&mut self, skeleton: &Skeleton, pose: &Pose) {
        let fk = self;
        fk.world.clear();
        fk.frame_linear.clear();
        fk.frame_linear_inv.clear();
        fk.parent_linear.clear();
        fk.origin.clear();
        fk.parent.clear();
        for (i, joint) in skeleton.joints().iter().enumerate() {
            let local = &pose.local[i];
            let parent_world = joint
                .parent
                .map(|p| fk.world[p])
                .unwrap_or_else(Matrix4::identity);
            let parent_lin = linear_part(&parent_world);
            let r = local.rotation.to_rotation_matrix().into_inner();
            let frame_lin = parent_lin * r;
            let world_lin = frame_lin * Matrix3::from_diagonal(&local.scale);
            let origin = parent_lin * local.translation + translation_part(&parent_world);
            let mut world = Matrix4::identity();
            world.fixed_view_mut::<3, 3>(0, 0).copy_from(&world_lin);
            world.fixed_view_mut::<3, 1>(0, 3).copy_from(&origin);
            fk.frame_linear_inv
                .push(frame_lin.try_inverse().unwrap_or_else(Matrix3::zeros));
            fk.frame_linear.push(frame_lin);
            fk.parent_linear.push(parent_lin);
            fk.origin.push(origin);
            fk.world.push(world);
            fk.parent.push(joint.parent);
        }
    }

    /// World matrices of all joints.
    pub fn world_matrices(&self) -> &[Matrix4] {
        &self.world
    }

    /// World matrix of one joint.
    pub fn world(&self, joint: usize) -> &Matrix4 {
        &self.world[joint]
    }

    /// World position of a joint's origin.
    pub fn position(&self, joint: usize) -> Point3 {
        Point3::from(self.origin[joint])
    }

    /// The number of joints.
    pub fn len(&self) -> usize {
        self.world.len()
    }

    /// Whether there are no joints.
    pub fn is_empty(&self) -> bool {
        self.world.is_empty()
    }

    /// The parent of a joint.
    pub fn parent(&self, joint: usize) -> Option<usize> {
        self.parent[joint]
    }

    /// World position of a joint's origin, `o_j`, as a vector.
    pub fn origin(&self, joint: usize) -> &Vector3 {
        &self.origin[joint]
    }

    /// Linear part of `A_j = W_parent * T_j * R_j`: a rotation increment `delta` moves a
    /// carried point `p` by `A_j (delta x A_j^-1 (p - o_j))`.
    pub fn frame_linear(&self, joint: usize) -> &Matrix3 {
        &self.frame_linear[joint]
    }

    /// Inverse of [`Self::frame_linear`] (zero when that is singular).
    pub fn frame_linear_inv(&self, joint: usize) -> &Matrix3 {
        &self.frame_linear_inv[joint]
    }

    /// Linear part of the parent's world transform (identity for roots): the Jacobian of a
    /// carried point with respect to a free joint's translation.
    pub fn parent_linear(&self, joint: usize) -> &Matrix3 {
        &self.parent_linear[joint]
    }

    /// A point given in a joint's local frame, in world space.
    pub fn point(&self, joint: usize, local: &Point3) -> Point3 {
        crate::math::transform_point(&self.world[joint], local)
    }

    /// The Jacobian of the world point `p`, rigidly carried by `joint`, with respect to every
    /// parameter of `layout`: calls `column(parameter_index, dp/dparameter)` for each
    /// parameter that moves it (the joint's own and its ancestors'). Others are zero.
    pub fn point_jacobian(
        &self,
        layout: &DofLayout,
        joint: usize,
        p: &Point3,
        column: impl FnMut(usize, Vector3),
    ) {
        self.point_jacobian_below(layout, joint, None, p, column);
    }

    /// [`Self::point_jacobian`] over the joints from `joint` up to, not including, `stop`
    /// (every ancestor when `None` or when `stop` is not one).
    pub fn point_jacobian_below(
        &self,
        layout: &DofLayout,
        joint: usize,
        stop: Option<usize>,
        p: &Point3,
        mut column: impl FnMut(usize, Vector3),
    ) {
        let mut cur = Some(joint);
        while let Some(j) = cur {
            if cur == stop {
                break;
            }
            cur = self.parent[j];
            let Some(o) = layout.offset(j) else { continue };
            let a = &self.frame_linear[j];
            // The point in the joint's rotated frame, before the increment: q = A_j^-1 (p - o_j).
            let q = self.frame_linear_inv[j] * (p.coords - self.origin[j]);
            match layout.dof(j) {
                JointDof::Fixed => {}
                JointDof::Hinge { axis } => column(o, a * axis.normalize().cross(&q)),
                JointDof::Ball => {
                    for k in 0..3 {
                        column(o + k, a * Vector3::ith(k, 1.0).cross(&q));
                    }
                }
                JointDof::Free => {
                    let pl = &self.parent_linear[j];
                    for k in 0..3 {
                        column(o + k, pl.column(k).into_owned());
                        column(o + 3 + k, a * Vector3::ith(k, 1.0).cross(&q));
                    }
                }
            }
        }
    }

    /// [`Self::point_jacobian`]'s columns as affine functions of the point: calls
    /// `column(parameter_index, dp/dparameter at p, its derivative with respect to p)`. A
    /// rotation's column `A_j (e x A_j^-1 (p - o_j))` has the derivative `A_j [e]x A_j^-1`;
    /// a free joint's translation column is constant. A sum over many points of their
    /// columns against other vectors then follows from the points' moments about `p`.
    pub fn point_jacobian_affine(
        &self,
        layout: &DofLayout,
        joint: usize,
        p: &Point3,
        mut column: impl FnMut(usize, Vector3, Matrix3),
    ) {
        let mut cur = Some(joint);
        while let Some(j) = cur {
            cur = self.parent[j];
            let Some(o) = layout.offset(j) else { continue };
            let a = &self.frame_linear[j];
            let a_inv = &self.frame_linear_inv[j];
            let q = a_inv * (p.coords - self.origin[j]);
            let mut rotation = |index: usize, axis: Vector3| {
                column(index, a * axis.cross(&q), a * skew(&axis) * a_inv)
            };
            match layout.dof(j) {
                JointDof::Fixed => {}
                JointDof::Hinge { axis } => rotation(o, axis.normalize()),
                JointDof::Ball => (0..3).for_each(|k| rotation(o + k, Vector3::ith(k, 1.0))),
                JointDof::Free => {
                    (0..3).for_each(|k| rotation(o + 3 + k, Vector3::ith(k, 1.0)));
                    let pl = &self.parent_linear[j];
                    for k in 0..3 {
                        column(o + k, pl.column(k).into_owned(), Matrix3::zeros());
                    }
                }
            }
        }
    }
}

/// The Jacobian of the point `local` (in `joint`'s frame) by central differences of step `h`
/// over every parameter of `layout`: the reference the analytic [`ForwardKinematics::
/// point_jacobian`] is checked against.
pub fn numeric_point_jacobian(
    skeleton: &Skeleton,
    layout: &DofLayout,
    pose: &Pose,
    joint: usize,
    local: &Point3,
    h: f64,
) -> Vec<Vector3> {
    (0..layout.len())
        .map(|c| {
            let mut delta = vec![0.0; layout.len()];
            delta[c] = h;
            let mut plus = pose.clone();
            layout.apply(&mut plus, &delta);
            delta[c] = -h;
            let mut minus = pose.clone();
            layout.apply(&mut minus, &delta);
            (ForwardKinematics::new(skeleton, &plus).point(joint, local)
                - ForwardKinematics::new(skeleton, &minus).point(joint, local))
                / (2.0 * h)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Trs;
    use crate::skeleton::{Joint, JointDof};

    fn test_skeleton() -> Skeleton {
        let mut joints = vec![
            Joint::new(
                "root",
                None,
                Trs {
                    translation: Vector3::new(0.1, 0.9, -0.2),
                    rotation: Quat::from_euler_angles(0.1, 0.2, 0.3),
                    scale: Vector3::new(1.2, 0.8, 1.1),
                },
            ),
            Joint::new(
                "a",
                Some(0),
                Trs::from_translation(Vector3::new(0.0, 0.5, 0.0)),
            ),
            Joint::new(
                "b",
                Some(1),
                Trs::new(
                    Vector3::new(0.3, 0.4, 0.1),
                    Quat::from_euler_angles(0.5, 0.0, 0.2),
                ),
            ),
            Joint::new(
                "c",
                Some(2),
                Trs::from_translation(Vector3::new(0.0, 0.3, 0.2)),
            ),
        ];
        joints[0].dof = JointDof::Free;
        joints[2].dof = JointDof::Hinge {
            axis: Vector3::new(1.0, 1.0, 0.0),
        };
        Skeleton::new(joints).expect("valid")
    }

    #[test]
    fn jacobian_matches_finite_differences() {
        let s = test_skeleton();
        let layout = DofLayout::new(&s);
        let mut pose = s.rest_pose();
        pose.local[1].rotation = Quat::from_euler_angles(0.3, -0.2, 0.5);
        let local_point = Point3::new(0.05, 0.1, -0.07);
        let fk = ForwardKinematics::new(&s, &pose);
        let p = fk.point(3, &local_point);
        let mut analytic = vec![Vector3::zeros(); layout.len()];
        fk.point_jacobian(&layout, 3, &p, |c, v| analytic[c] = v);
        let numeric = numeric_point_jacobian(&s, &layout, &pose, 3, &local_point, 1e-6);
        for (c, n) in numeric.iter().enumerate() {
            assert!(
                (n - analytic[c]).norm() < 1e-6,
                "column {c}: {n} vs {}",
                analytic[c]
            );
        }
    }

    #[test]
    fn fk_matches_skeleton_world_matrices() {
        let s = test_skeleton();
        let pose = s.rest_pose();
        let fk = ForwardKinematics::new(&s, &pose);
        for (a, b) in fk.world_matrices().iter().zip(s.world_matrices(&pose)) {
            assert!((a - b).norm() < 1e-12);
        }
    }

    #[test]
    fn update_matches_new() {
        let s = test_skeleton();
        let mut pose = s.rest_pose();
        let mut fk = ForwardKinematics::new(&s, &pose);
        pose.local[2].rotation = Quat::from_euler_angles(0.4, -0.1, 0.2);
        fk.update(&s, &pose);
        let fresh = ForwardKinematics::new(&s, &pose);
        assert_eq!(fk.world_matrices(), fresh.world_matrices());
        for j in 0..s.len() {
            assert_eq!(fk.frame_linear(j), fresh.frame_linear(j));
            assert_eq!(fk.frame_linear_inv(j), fresh.frame_linear_inv(j));
            assert_eq!(fk.parent_linear(j), fresh.parent_linear(j));
            assert_eq!(fk.origin(j), fresh.origin(j));
        }
    }

    #[test]
    fn inactive_joints_have_no_parameters() {
        let s = test_skeleton();
        let layout = DofLayout::with_active(&s, &[false, true, false, true]);
        assert_eq!(layout.len(), 6);
        assert_eq!(layout.offset(0), None);
        assert_eq!(layout.offset(3), Some(3));
    }
}
