//! Type aliases for the algebra, so nalgebra's generic types do not leak through every
//! signature, and the translation-rotation-scale transform used by every joint.

/// The scalar used throughout rigfit.
pub type Real = f64;
/// A point in 3D.
pub type Point3 = nalgebra::Point3<Real>;
/// A vector in 3D.
pub type Vector3 = nalgebra::Vector3<Real>;
/// A unit quaternion (a rotation).
pub type Quat = nalgebra::UnitQuaternion<Real>;
/// A 3x3 matrix.
pub type Matrix3 = nalgebra::Matrix3<Real>;
/// A 4x4 homogeneous matrix (affine transforms, possibly with scale).
pub type Matrix4 = nalgebra::Matrix4<Real>;

/// The largest coordinate magnitude rigfit takes, in any unit (a trillion: a thousand
/// kilometres in micrometres). Beyond it, squares and sums of squares lose all precision or
/// overflow: readers refuse such numbers and the solvers refuse such points.
pub const MAX_COORDINATE: Real = 1e12;

/// The index of the first point with a coordinate beyond [`MAX_COORDINATE`] (NaN is not
/// beyond it: check finiteness first).
pub fn first_out_of_range(points: &[Point3]) -> Option<usize> {
    points
        .iter()
        .position(|p| p.iter().any(|x| x.abs() > MAX_COORDINATE))
}

/// A transform made of a translation, a rotation and a per-axis scale, applied as
/// `T * R * S` (the glTF node convention).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Trs {
    pub translation: Vector3,
    pub rotation: Quat,
    pub scale: Vector3,
}

impl Default for Trs {
    fn default() -> Self {
        Self::IDENTITY
    }
}

impl Trs {
    /// The identity transform.
    pub const IDENTITY: Trs = Trs {
        translation: Vector3::new(0.0, 0.0, 0.0),
        rotation: Quat::new_unchecked(nalgebra::Quaternion::new(1.0, 0.0, 0.0, 0.0)),
        scale: Vector3::new(1.0, 1.0, 1.0),
    };

    /// A pure translation.
    pub fn from_translation(translation: Vector3) -> Self {
        Self {
            translation,
            ..Self::IDENTITY
        }
    }

    /// A translation followed by a rotation (unit scale).
    pub fn new(translation: Vector3, rotation: Quat) -> Self {
        Self {
            translation,
            rotation,
            scale: Vector3::new(1.0, 1.0, 1.0),
        }
    }

    /// The homogeneous matrix `T * R * S`.
    pub fn to_matrix(&self) -> Matrix4 {
        let rs =
            self.rotation.to_rotation_matrix().into_inner() * Matrix3::from_diagonal(&self.scale);
        let mut m = Matrix4::identity();
        m.fixed_view_mut::<3, 3>(0, 0).copy_from(&rs);
        m.fixed_view_mut::<3, 1>(0, 3).copy_from(&self.translation);
        m
    }

    /// Decomposes an affine matrix into translation, rotation and scale. Shear, which TRS
    /// cannot hold, is dropped; a negative determinant is carried by a negative x scale.
    pub fn from_matrix(m: &Matrix4) -> Self {
        let translation = Vector3::new(m[(0, 3)], m[(1, 3)], m[(2, 3)]);
        let linear: Matrix3 = m.fixed_view::<3, 3>(0, 0).into_owned();
        let mut scale = Vector3::new(
            linear.column(0).norm(),
            linear.column(1).norm(),
            linear.column(2).norm(),
        );
        if linear.determinant() < 0.0 {
            scale.x = -scale.x;
        }
        let mut rot = linear;
        for c in 0..3 {
            if scale[c].abs() > 0.0 {
                let col = rot.column(c) / scale[c];
                rot.set_column(c, &col);
            }
        }
        let rotation = Quat::from_matrix(&rot);
        Self {
            translation,
            rotation,
            scale,
        }
    }
}

/// Transforms a point by a homogeneous matrix (affine part only).
#[inline]
pub fn transform_point(m: &Matrix4, p: &Point3) -> Point3 {
    Point3::new(
        m[(0, 0)] * p.x + m[(0, 1)] * p.y + m[(0, 2)] * p.z + m[(0, 3)],
        m[(1, 0)] * p.x + m[(1, 1)] * p.y + m[(1, 2)] * p.z + m[(1, 3)],
        m[(2, 0)] * p.x + m[(2, 1)] * p.y + m[(2, 2)] * p.z + m[(2, 3)],
    )
}

/// The linear (3x3) part of a homogeneous matrix.
#[inline]
pub fn linear_part(m: &Matrix4) -> Matrix3 {
    m.fixed_view::<3, 3>(0, 0).into_owned()
}

/// The translation part of a homogeneous matrix.
#[inline]
pub fn translation_part(m: &Matrix4) -> Vector3 {
    Vector3::new(m[(0, 3)], m[(1, 3)], m[(2, 3)])
}

/// `[v]x`, the cross-product matrix of `v`: the matrix of `u -> v x u`.
#[inline]
pub fn skew(v: &Vector3) -> Matrix3 {
    Matrix3::new(0.0, -v.z, v.y, v.z, 0.0, -v.x, -v.y, v.x, 0.0)
}

/// The rotation `exp([w]x)` of a rotation vector `w` (axis times angle).
#[inline]
pub fn exp_rotation(w: &Vector3) -> Quat {
    Quat::from_scaled_axis(*w)
}

/// A rotation matrix as a unit quaternion (Shepperd's method: robust to the rounding that
/// leaves a product of rotations slightly off orthogonal, where an angle taken from the
/// trace can be NaN).
pub fn rotation_quat(m: &Matrix3) -> Quat {
    Quat::from_rotation_matrix(&nalgebra::Rotation3::from_matrix_unchecked(*m))
}

/// The rotation nearest `m` (the orthogonal factor of its polar decomposition, by SVD), the
/// identity when `m` is degenerate.
pub fn nearest_rotation(m: &Matrix3) -> Matrix3 {
    let svd = m.svd(true, true);
    match (svd.u, svd.v_t) {
        (Some(u), Some(v_t)) => {
            let mut r = u * v_t;
            if r.determinant() < 0.0 {
                let mut u = u;
                u.column_mut(2).neg_mut();
                r = u * v_t;
            }
            if r.iter().all(|x| x.is_finite()) {
                r
            } else {
                Matrix3::identity()
            }
        }
        _ => Matrix3::identity(),
    }
}

/// The rotation a fraction `t` of the turn from `from` to `to`: `(to from^T)^t from`, by
/// quaternion slerp (the whole turn when the two are opposite).
pub fn rotation_toward(from: &Matrix3, to: &Matrix3, t: f64) -> Matrix3 {
    let turn = rotation_quat(&(to * from.transpose()));
    let part = Quat::identity().try_slerp(&turn, t, 1e-9).unwrap_or(turn);
    part.to_rotation_matrix().into_inner() * from
}

/// Two unit vectors completing the unit vector `axis` to a right-handed orthonormal basis
/// `(axis, u, v)`.
pub fn perpendicular_basis(axis: &Vector3) -> (Vector3, Vector3) {
    let helper = if axis.x.abs() < 0.9 {
        Vector3::x()
    } else {
        Vector3::y()
    };
    let u = axis.cross(&helper).normalize();
    let v = axis.cross(&u);
    (u, v)
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    fn rotation_toward_goes_the_fraction_of_the_turn() {
        let from = Quat::from_euler_angles(0.2, -0.4, 1.0)
            .to_rotation_matrix()
            .into_inner();
        let turn = Quat::from_axis_angle(&Vector3::z_axis(), 0.8);
        let to = turn.to_rotation_matrix().into_inner() * from;
        assert_relative_eq!(rotation_toward(&from, &to, 0.0), from, epsilon = 1e-12);
        assert_relative_eq!(rotation_toward(&from, &to, 1.0), to, epsilon = 1e-12);
        let half = Quat::from_axis_angle(&Vector3::z_axis(), 0.4)
            .to_rotation_matrix()
            .into_inner()
            * from;
        assert_relative_eq!(rotation_toward(&from, &to, 0.5), half, epsilon = 1e-12);
        assert_relative_eq!(
            rotation_quat(&to).angle(),
            Quat::from_rotation_matrix(&nalgebra::Rotation3::from_matrix_unchecked(to)).angle(),
            epsilon = 1e-12
        );
    }

    #[test]
    fn trs_matrix_round_trip() {
        let trs = Trs {
            translation: Vector3::new(1.0, -2.0, 3.0),
            rotation: Quat::from_euler_angles(0.3, -0.7, 1.1),
            scale: Vector3::new(2.0, 0.5, 1.5),
        };
        let back = Trs::from_matrix(&trs.to_matrix());
        assert_relative_eq!(back.translation, trs.translation, epsilon = 1e-12);
        assert_relative_eq!(back.scale, trs.scale, epsilon = 1e-12);
        assert!(back.rotation.angle_to(&trs.rotation) < 1e-9);
    }

    #[test]
    fn skew_is_the_cross_product() {
        let v = Vector3::new(0.3, -1.2, 2.5);
        let u = Vector3::new(-0.7, 0.4, 1.1);
        assert_eq!(skew(&v) * u, v.cross(&u));
        assert_eq!(skew(&v).transpose(), -skew(&v));
    }
}
