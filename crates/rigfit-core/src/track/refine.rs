//! After EM, from the final E-step's inliers: the surface-fitting pass (eq. 21-22) and the
//! paper's texture refresh from the data.

use super::Tracker;
use super::m_step::Pull;
use super::texture::TexturePoint;
use crate::kinematics::ForwardKinematics;
use crate::math::{Point3, transform_point};
use crate::skeleton::Pose;

impl Tracker {
    /// Eq. (21)-(22): pulls the fused surface onto the inlier data points, each weighted by
    /// `exp(-d^2 / (2 sigma^2))`. The surface's closest point to a datum, carried by the
    /// dominant part's joint, moves toward the datum (its residual is along the surface
    /// normal, so the gradient is that of `d^2`).
    pub(super) fn surface_fit(
        &mut self,
        data: &[Point3],
        inlier: &[bool],
        best: &[u32],
        sigma: f64,
        start: &Pose,
    ) {
        for _ in 0..self.options.surface_fit_steps {
            let parts = &self.model.parts;
            let fk = ForwardKinematics::new(&self.model.skeleton, &self.pose);
            parts.place(&fk, &mut self.placed);
            let mut pulls = Vec::new();
            for (j, y) in data.iter().enumerate() {
                if !inlier[j] {
                    continue;
                }
                let hint = (best[j] != u32::MAX).then(|| self.texture[best[j] as usize].part);
                let Some(s) = parts.surface_distance(&self.placed, y, hint) else {
                    continue;
                };
                let g2 = s.gradient.norm_squared();
                if g2 < 1e-18 {
                    continue;
                }
                let beta = (-(s.distance * s.distance) / (2.0 * sigma * sigma)).exp();
                let foot = y - s.gradient * (s.distance / g2);
                let joint = parts.parts[s.dominant].joint;
                let Some(inv) = fk.world(joint).try_inverse() else {
                    continue;
                };
                let normal = crate::math::linear_part(&inv) * s.gradient;
                pulls.push(Pull {
                    point: TexturePoint::rigid(
                        joint,
                        transform_point(&inv, &foot),
                        normal,
                        s.dominant,
                    ),
                    target: *y,
                    weight: beta,
                });
            }
            self.fit(&pulls, start, 1, true, 1.0);
        }
    }

    /// The paper's texture update: the inlier data points near the fitted surface become
    /// the texture points of the next frame (kept when too few qualify).
    pub(super) fn refresh_texture(
        &mut self,
        data: &[Point3],
        inlier: &[bool],
        best: &[u32],
        fk: &ForwardKinematics,
    ) {
        let h = self.model.height;
        let parts = &self.model.parts;
        parts.place(fk, &mut self.placed);
        let mut fresh = Vec::new();
        for (j, y) in data.iter().enumerate() {
            if !inlier[j] || best[j] == u32::MAX {
                continue;
            }
            let hint = Some(self.texture[best[j] as usize].part);
            let near = parts
                .surface_distance(&self.placed, y, hint)
                .is_some_and(|s| s.distance.abs() < 0.05 * h);
            if !near {
                continue;
            }
            if let Some(t) = TexturePoint::attach(
                parts,
                &self.placed,
                fk,
                y,
                None,
                self.options.bending_exponent,
                hint,
            ) {
                fresh.push(t);
            }
        }
        // As many texture points as the model started with, at most.
        let keep = self.model.surface_samples.len().max(1);
        if fresh.len() * 4 >= self.texture.len().min(keep) {
            if fresh.len() > keep {
                let stride = fresh.len() as f64 / keep as f64;
                fresh = (0..keep)
                    .map(|k| fresh[(k as f64 * stride) as usize])
                    .collect();
            }
            self.texture = fresh;
            self.seen.clear();
        }
    }
}
