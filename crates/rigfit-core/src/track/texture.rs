//! Texture points (Dewaele et al. 2006): model points loosely attached to the articulated
//! surface. A point near a joint follows a blend of the rigid motions of the two adjacent
//! parts it lies between, weighted by their fields raised to the power `a` (eq. 3), so the
//! skin stretches and compresses as the surface bends.

pub use crate::geometry::sample_triangles;
use crate::kinematics::{DofLayout, ForwardKinematics};
use crate::math::{Point3, Vector3, linear_part, transform_point};
use crate::track::parts::{PartModel, PlacedParts, ellipsoid_distance};

/// A model point carried by one joint, or by a blend of two (eq. 3).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TexturePoint {
    /// The joints whose motions carry the point; the same joint twice when rigid.
    pub joints: [usize; 2],
    /// The point in each joint's frame.
    pub local: [Point3; 2],
    /// The surface normal at the point, in each joint's frame.
    pub normal: [Vector3; 2],
    /// The weight of `joints[0]` (the dominant part's joint); `1 - weight` for the other.
    pub weight: f64,
    /// The dominant part.
    pub part: usize,
}

impl TexturePoint {
    /// Attaches the world point `x` with surface normal `normal` (the fused surface's
    /// gradient when `None`) to the model in the pose of `fk` (with the parts placed for
    /// that pose): to its dominant part's joint and, near a joint, also to the adjacent part
    /// on another joint, with the weights of eq. (3) for exponent `a`.
    pub fn attach(
        model: &PartModel,
        placed: &PlacedParts,
        fk: &ForwardKinematics,
        x: &Point3,
        normal: Option<Vector3>,
        exponent: f64,
        hint: Option<usize>,
    ) -> Option<Self> {
        let s = model.surface_distance(placed, x, hint)?;
        let n = normal.unwrap_or(s.gradient).try_normalize(1e-12)?;
        let p = s.dominant;
        let jp = model.parts[p].joint;
        let dp = ellipsoid_distance(&placed.center[p], &placed.inv_shape[p], x).0;
        let other = model.adjacent[p]
            .iter()
            .filter(|&&q| model.parts[q].joint != jp)
            .map(|&q| {
                let dq = ellipsoid_distance(&placed.center[q], &placed.inv_shape[q], x).0;
                (q, dq)
            })
            .min_by(|a, b| a.1.total_cmp(&b.1));
        let local = |j: usize| {
            fk.world(j)
                .try_inverse()
                .map(|inv| (transform_point(&inv, x), linear_part(&inv) * n))
        };
        let (lp, np) = local(jp)?;
        // Eq. (3): w_p = phi_p^a / (phi_p^a + phi_q^a) with phi = exp(-d / nu).
        let blend = other.and_then(|(q, dq)| {
            let w = 1.0 / (1.0 + (-exponent * (dq - dp) / model.fusion).exp());
            (w < 0.999).then_some((model.parts[q].joint, w))
        });
        Some(match blend {
            Some((jq, w)) => {
                let (lq, nq) = local(jq)?;
                Self {
                    joints: [jp, jq],
                    local: [lp, lq],
                    normal: [np, nq],
                    weight: w,
                    part: p,
                }
            }
            None => Self::rigid(jp, lp, np, p),
        })
    }

    /// A point rigidly carried by `joint` at `local`, with normal `normal` (joint frame).
    pub fn rigid(joint: usize, local: Point3, normal: Vector3, part: usize) -> Self {
        Self {
            joints: [joint, joint],
            local: [local, local],
            normal: [normal, normal],
            weight: 1.0,
            part,
        }
    }

    /// The point's unit surface normal in the pose of `fk` (blended as the point).
    pub fn world_normal(&self, fk: &ForwardKinematics) -> Vector3 {
        let a = linear_part(fk.world(self.joints[0])) * self.normal[0];
        let n = if self.weight >= 1.0 {
            a
        } else {
            a * self.weight
                + linear_part(fk.world(self.joints[1])) * self.normal[1] * (1.0 - self.weight)
        };
        n.try_normalize(1e-12).unwrap_or(n)
    }

    /// The point's world position in the pose of `fk` (eq. 3).
    pub fn world(&self, fk: &ForwardKinematics) -> Point3 {
        let a = fk.point(self.joints[0], &self.local[0]);
        if self.weight >= 1.0 {
            return a;
        }
        let b = fk.point(self.joints[1], &self.local[1]);
        Point3::from(a.coords * self.weight + b.coords * (1.0 - self.weight))
    }

    /// The Jacobian of the point's world position (eq. 3, blend weights held fixed) with
    /// respect to the parameters of `layout`, columns scaled by `scale`: the weighted sum
    /// of both carried positions' Jacobians. Appends (parameter, column), each parameter
    /// once, to `cols`. When one joint is above the other, the joints from the upper one
    /// up move the blend rigidly (columns at the blended point) and only those between
    /// move the lower part's position (weighted): no merging needed.
    pub fn jacobian(
        &self,
        fk: &ForwardKinematics,
        layout: &DofLayout,
        scale: f64,
        cols: &mut Vec<(usize, Vector3)>,
    ) {
        let start = cols.len();
        let Some(upper) = self.chain_split(fk, layout, scale, cols) else {
            // Not on one chain: sum both Jacobians, merging shared ancestors.
            for k in 0..2 {
                let w = if k == 0 {
                    self.weight
                } else {
                    1.0 - self.weight
                };
                let p = fk.point(self.joints[k], &self.local[k]);
                fk.point_jacobian(layout, self.joints[k], &p, |i, v| {
                    let v = v * (w * scale);
                    match cols[start..].iter_mut().find(|c| c.0 == i) {
                        Some(c) => c.1 += v,
                        None => cols.push((i, v)),
                    }
                });
            }
            return;
        };
        fk.point_jacobian(layout, upper, &self.world(fk), |i, v| {
            cols.push((i, v * scale))
        });
    }

    /// For a point whose two joints lie on one chain: the upper joint, from which up the
    /// joints move the point rigidly (eq. 3: both carried positions turn with them), so
    /// their columns are those of a point carried by it at the blended position; appended to `lower`, the columns (scaled by
    /// `scale`) of the joints from the lower one up to the upper one, which move only the
    /// lower part's position, weighted by its share. `None` (and nothing appended) when the
    /// joints are on different branches.
    pub fn chain_split(
        &self,
        fk: &ForwardKinematics,
        layout: &DofLayout,
        scale: f64,
        lower: &mut Vec<(usize, Vector3)>,
    ) -> Option<usize> {
        let [j0, j1] = self.joints;
        let above = |upper: usize, below: usize| {
            let mut cur = Some(below);
            while let Some(c) = cur {
                if c == upper {
                    return true;
                }
                cur = fk.parent(c);
            }
            false
        };
        let (upper, low, k_low, w_low) = if above(j1, j0) {
            (j1, j0, 0, self.weight)
        } else if above(j0, j1) {
            (j0, j1, 1, 1.0 - self.weight)
        } else {
            return None;
        };
        if low != upper {
            let y = fk.point(low, &self.local[k_low]);
            fk.point_jacobian_below(layout, low, Some(upper), &y, |i, v| {
                lower.push((i, v * (w_low * scale)))
            });
        }
        Some(upper)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::humanoid::humanoid;
    use crate::math::{Quat, Vector3};
    use rand::SeedableRng;

    #[test]
    fn blended_points_follow_both_parts() {
        let rig = humanoid();
        let h = rig.height();
        let model = PartModel::fit_to_skin(&rig.skeleton, &rig.pose, &rig.meshes, h);
        let fk = ForwardKinematics::new(&rig.skeleton, &rig.pose);
        let mut placed = PlacedParts::default();
        model.place(&fk, &mut placed);
        let world = rig.skeleton.world_matrices(&rig.pose);
        let (verts, _) = rig.meshes[0].skin(&world);
        let points: Vec<TexturePoint> = verts
            .iter()
            .filter_map(|v| TexturePoint::attach(&model, &placed, &fk, v, None, 2.0, None))
            .collect();
        assert!(points.len() > verts.len() * 9 / 10);
        let blended = points.iter().filter(|p| p.weight < 1.0).count();
        assert!(blended > 20, "{blended} blended points");
        // At the pose they were attached in, points stay where they were.
        for (p, v) in points.iter().zip(&verts).take(200) {
            assert!((p.world(&fk) - v).norm() < 1e-9);
        }
        // Bend an elbow: blended points move part of the way.
        let elbow = rig.skeleton.find("LeftForeArm").expect("humanoid elbow");
        let mut pose = rig.pose.clone();
        pose.local[elbow].rotation *= Quat::from_scaled_axis(Vector3::new(0.0, 0.0, 1.0));
        let bent = ForwardKinematics::new(&rig.skeleton, &pose);
        let partly = points
            .iter()
            .filter(|p| p.weight < 0.9 && p.weight > 0.1 && p.joints.contains(&elbow))
            .count();
        assert!(partly > 0);
        for p in points.iter().filter(|p| p.joints.contains(&elbow)) {
            let moved = (p.world(&bent) - p.world(&fk)).norm();
            assert!(moved.is_finite());
        }
    }

    #[test]
    fn triangle_samples_are_area_uniform() {
        let vertices = vec![
            Point3::new(0.0, 0.0, 0.0),
            Point3::new(1.0, 0.0, 0.0),
            Point3::new(0.0, 1.0, 0.0),
            Point3::new(0.0, 0.0, 3.0),
        ];
        // Areas 0.5 and 1.5.
        let triangles = vec![[0, 1, 2], [0, 1, 3]];
        let mut rng = rand::rngs::StdRng::seed_from_u64(1);
        let s = sample_triangles(&vertices, &triangles, 20_000, &mut rng);
        let second = s.iter().filter(|(_, t)| *t == 1).count() as f64 / 20_000.0;
        assert!((second - 0.75).abs() < 0.02, "{second}");
    }
}
