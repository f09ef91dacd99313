//! The cross terms of `J^T W J` between a blended point's lower columns and its upper
//! chain's, summed in closed form. A point blended between two joints on one chain (eq. 3
//! of Dewaele et al. 2006) moves rigidly with the joints from the upper one up, so its
//! columns there are those of a point carried by the upper joint: affine in the point
//! ([`ForwardKinematics::point_jacobian_affine`]). The products of one lower column `c`
//! with them, summed over the points, follow from two moments per `(c, upper)`:
//! `sum w_c` and `sum w_c d^T` with `d` the point's offset from the upper joint's origin.
//! The sum costs O(pairs x depth) after O(1) a point and column, instead of O(depth) a
//! point and column.

use crate::engine::linear_algebra::NormalSink;
use crate::kinematics::{DofLayout, ForwardKinematics};
use crate::math::{Matrix3, Point3, Vector3};

/// No entry.
const NONE: usize = usize::MAX;

/// The moments of one lower column against one upper joint's chain.
#[derive(Clone, Debug)]
struct Entry {
    column: usize,
    upper: usize,
    /// `sum w_c` and `sum w_c d^T`, `w_c` the point's weighted lower column.
    sum: Vector3,
    moment: Matrix3,
    /// The next entry of the same column.
    next: usize,
}

/// Per lower column and upper joint, the moments of the blended points split there.
#[derive(Clone, Debug, Default)]
pub struct ChainCrossMoments {
    entries: Vec<Entry>,
    /// Per parameter, its first entry.
    first: Vec<usize>,
}

impl ChainCrossMoments {
    /// Empty sums over `parameters` parameters.
    pub fn new(parameters: usize) -> Self {
        Self {
            entries: Vec::new(),
            first: vec![NONE; parameters],
        }
    }

    /// Adds a point at `x` whose lower column `column` (weighted) is `weighted`, with the
    /// joints from `upper` up moving it rigidly.
    pub fn add(
        &mut self,
        fk: &ForwardKinematics,
        column: usize,
        upper: usize,
        x: &Point3,
        weighted: &Vector3,
    ) {
        let d = x.coords - fk.origin(upper);
        let mut at = self.first[column];
        while at != NONE && self.entries[at].upper != upper {
            at = self.entries[at].next;
        }
        if at == NONE {
            at = self.entries.len();
            self.entries.push(Entry {
                column,
                upper,
                sum: Vector3::zeros(),
                moment: Matrix3::zeros(),
                next: self.first[column],
            });
            self.first[column] = at;
        }
        let entry = &mut self.entries[at];
        entry.sum += weighted;
        entry.moment += weighted * d.transpose();
    }

    /// Adds to `sink` each lower column's products with its upper chain's columns (scaled
    /// by `scale`), summed over the points: with `v(o)` and `L` a column's value at the
    /// upper joint's origin `o` and its derivative, `sum w_c . v(x) = (sum w_c) . v(o) +
    /// <L, sum w_c d^T>`.
    pub fn assemble(
        &self,
        fk: &ForwardKinematics,
        layout: &DofLayout,
        scale: f64,
        sink: &mut impl NormalSink,
    ) {
        for entry in &self.entries {
            let origin = Point3::from(*fk.origin(entry.upper));
            fk.point_jacobian_affine(layout, entry.upper, &origin, |b, value, slope| {
                let v = entry.sum.dot(&value) + slope.component_mul(&entry.moment).sum();
                sink.add_jtj(entry.column, b, v * scale);
            });
        }
    }
}

#[cfg(test)]
mod tests {
    use std::collections::BTreeMap;

    use rand::{Rng, SeedableRng};

    use super::*;
    use crate::humanoid::humanoid;
    use crate::math::Quat;
    use crate::skeleton::JointDof;

    /// `J^T J` entries by (row, column), lower triangle.
    #[derive(Default)]
    struct Entries(BTreeMap<(usize, usize), f64>);

    impl NormalSink for Entries {
        fn add_jtj(&mut self, i: usize, j: usize, v: f64) {
            *self.0.entry((i.max(j), i.min(j))).or_default() += v;
        }
        fn add_jtr(&mut self, _: usize, _: f64) {}
        fn add_cost(&mut self, _: f64) {}
        fn cost(&self) -> f64 {
            0.0
        }
    }

    /// A posed humanoid with a free root, a hinge and a free joint below the root, whose
    /// world frames are scaled unevenly (as an imported rig's can be).
    fn posed() -> (crate::skeleton::Skeleton, ForwardKinematics, DofLayout, f64) {
        let rig = humanoid();
        let mut skeleton = rig.skeleton.clone();
        let elbow = skeleton.find("LeftForeArm").expect("elbow");
        let spine = skeleton.find("Spine").expect("spine");
        skeleton.set_dof(
            elbow,
            JointDof::Hinge {
                axis: Vector3::new(0.3, 1.0, 0.2),
            },
            None,
        );
        skeleton.set_dof(spine, JointDof::Free, None);
        let mut pose = rig.pose.clone();
        let mut rng = rand::rngs::StdRng::seed_from_u64(3);
        for local in &mut pose.local {
            let w = Vector3::new(rng.random(), rng.random(), rng.random()) * 0.8;
            local.rotation *= Quat::from_scaled_axis(w);
        }
        pose.local[spine].scale = Vector3::new(1.0, 1.3, 0.8);
        pose.local[0].translation += Vector3::new(3.0, -2.0, 5.0);
        let fk = ForwardKinematics::new(&skeleton, &pose);
        let layout = DofLayout::new(&skeleton);
        (skeleton, fk, layout, rig.height())
    }

    /// The affine columns agree with `point_jacobian` at the point and a step away.
    #[test]
    fn affine_columns_match_the_jacobian_at_and_near_the_point() {
        let (skeleton, fk, layout, h) = posed();
        let hand = skeleton.find("LeftHand").expect("hand");
        let p = fk.position(hand) + Vector3::new(0.02, -0.05, 0.01) * h;
        let step = Vector3::new(0.1, 0.07, -0.12) * h;
        let mut exact = BTreeMap::new();
        fk.point_jacobian(&layout, hand, &(p + step), |i, v| {
            exact.insert(i, v);
        });
        let mut seen = 0;
        fk.point_jacobian_affine(&layout, hand, &p, |i, value, slope| {
            let mut at = Vector3::zeros();
            fk.point_jacobian(&layout, hand, &p, |k, v| {
                if k == i {
                    at = v;
                }
            });
            assert!((value - at).norm() <= 1e-12 * h, "column {i} at the point");
            let moved = value + slope * step;
            assert!(
                (moved - exact[&i]).norm() <= 1e-9 * h,
                "column {i} a step away"
            );
            seen += 1;
        });
        assert_eq!(seen, exact.len());
    }

    /// The products of lower columns with the upper chains' columns, summed from the
    /// moments, match the sum point by point.
    #[test]
    fn cross_moments_match_the_products_point_by_point() {
        let (skeleton, fk, layout, h) = posed();
        let uppers = ["LeftForeArm", "Spine", "RightUpLeg", "Head"]
            .map(|name| skeleton.find(name).expect("joint"));
        let mut rng = rand::rngs::StdRng::seed_from_u64(8);
        let mut by_points = Entries::default();
        let mut cross = ChainCrossMoments::new(layout.len());
        let lower_columns = [1, 4, 9, 20];
        for n in 0..200 {
            let upper = uppers[n % uppers.len()];
            let column = lower_columns[(n / 3) % lower_columns.len()];
            let x = fk.position(upper)
                + Vector3::new(rng.random(), rng.random(), rng.random()) * 0.2 * h;
            let weighted =
                Vector3::new(rng.random(), rng.random(), rng.random()) - Vector3::from_element(0.5);
            fk.point_jacobian(&layout, upper, &x, |b, v| {
                by_points.add_jtj(column, b, weighted.dot(&v) * 2.0);
            });
            cross.add(&fk, column, upper, &x, &weighted);
        }
        let mut by_moments = Entries::default();
        cross.assemble(&fk, &layout, 2.0, &mut by_moments);
        assert_eq!(by_points.0.len(), by_moments.0.len());
        let largest = by_points.0.values().fold(0.0f64, |m, v| m.max(v.abs()));
        for (key, v) in &by_points.0 {
            let w = by_moments.0[key];
            assert!((v - w).abs() <= 1e-10 * largest, "{key:?}: {v} against {w}");
        }
    }
}
