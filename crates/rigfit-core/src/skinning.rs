//! Linear blend skinning of mesh vertices and normals.

use crate::math::{Matrix3, Matrix4, Point3, Vector3, linear_part, transform_point};

/// A mesh bound to a skeleton: vertices in bind (mesh) space, up to four influences per
/// vertex given as skeleton joint indices, and an inverse bind matrix per skeleton joint.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SkinnedMesh {
    pub name: String,
    pub positions: Vec<Point3>,
    pub normals: Option<Vec<Vector3>>,
    pub triangles: Vec<[u32; 3]>,
    /// Skeleton joint index of each influence.
    pub joints: Vec<[u32; 4]>,
    /// Weight of each influence; rows sum to 1 (normalised on read).
    pub weights: Vec<[f32; 4]>,
    /// `bone_from_mesh` at bind time, indexed by skeleton joint (identity where unused).
    pub inverse_bind: Vec<Matrix4>,
}

impl SkinnedMesh {
    /// The skinning matrix of every joint: `world_from_joint * joint_from_mesh_at_bind`.
    pub fn joint_matrices(&self, world: &[Matrix4]) -> Vec<Matrix4> {
        world
            .iter()
            .zip(&self.inverse_bind)
            .map(|(w, ib)| w * ib)
            .collect()
    }

    /// Skinned world positions and (when the mesh has them) normals for joint world
    /// matrices `world`: `v' = sum_k w_k * W_k * IB_k * v`; normals by the cofactor of the
    /// blended linear part, renormalised.
    pub fn skin(&self, world: &[Matrix4]) -> (Vec<Point3>, Option<Vec<Vector3>>) {
        let mats = self.joint_matrices(world);
        let mut positions = Vec::with_capacity(self.positions.len());
        let mut normals = self.normals.as_ref().map(|n| Vec::with_capacity(n.len()));
        for (v, p) in self.positions.iter().enumerate() {
            let mut blended = Matrix4::zeros();
            for k in 0..4 {
                let w = self.weights[v][k] as f64;
                if w != 0.0 {
                    blended += mats[self.joints[v][k] as usize] * w;
                }
            }
            positions.push(transform_point(&blended, p));
            if let (Some(out), Some(src)) = (normals.as_mut(), self.normals.as_ref()) {
                let n = cofactor(&linear_part(&blended)) * src[v];
                let len = n.norm();
                out.push(if len > 0.0 { n / len } else { src[v] });
            }
        }
        (positions, normals)
    }

    /// The joint with the largest weight for each vertex.
    pub fn dominant_joint(&self) -> Vec<usize> {
        self.joints
            .iter()
            .zip(&self.weights)
            .map(|(j, w)| {
                let k = (0..4).max_by(|&a, &b| w[a].total_cmp(&w[b])).unwrap_or(0);
                j[k] as usize
            })
            .collect()
    }
}

/// The cofactor matrix (`det(M) * M^-T`): it maps normals the way `M` maps tangents.
fn cofactor(m: &Matrix3) -> Matrix3 {
    let (c0, c1, c2) = (m.column(0), m.column(1), m.column(2));
    Matrix3::from_columns(&[c1.cross(&c2), c2.cross(&c0), c0.cross(&c1)])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::{Quat, Trs};

    #[test]
    fn cofactor_keeps_normals_perpendicular() {
        let m = Trs {
            translation: Vector3::zeros(),
            rotation: Quat::from_euler_angles(0.3, 0.2, 0.1),
            scale: Vector3::new(2.0, 0.5, 1.0),
        }
        .to_matrix();
        let l = linear_part(&m);
        let tangent = Vector3::new(1.0, 1.0, 0.0);
        let normal = Vector3::new(1.0, -1.0, 0.3);
        assert!((l * tangent).dot(&(cofactor(&l) * normal)).abs() < 1e-12);
    }
}
