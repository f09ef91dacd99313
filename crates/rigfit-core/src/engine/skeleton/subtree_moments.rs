//! Closed-form Gauss-Newton sums for points carried by a skeleton. The Jacobian of a point
//! `p` carried at or below joint `a` with respect to `a`'s rotation is `-A_a [q_a]x`, with
//! `q_a = A_a^-1 (p - o_a)` (see [`crate::kinematics`]), and with respect to a free joint's
//! translation the constant parent linear part `P_a`. Both are affine in `p`, so every block
//! of `J^T W J` and `J^T W r` over all the points follows from the moments of the points
//! in a joint's subtree (`sum w`, `sum w d`, `sum w d d^T`, `sum w r`, `sum w d r^T`, with
//! `d = p - o`), accumulated bottom-up: the assembly costs O(joints x depth) whatever the
//! number of points, or O(joints) for [`ArticulatedNormalEquations`].

use crate::engine::linear_algebra::NormalSink;
use crate::engine::skeleton::articulated::ArticulatedNormalEquations;
use crate::kinematics::{DofLayout, ForwardKinematics};
use crate::math::{Matrix3, Point3, Vector3, skew};
use crate::skeleton::JointDof;

/// Per joint, the moments of the weighted points in its subtree about the joint's origin.
#[derive(Clone, Debug, Default)]
pub struct SubtreeMoments {
    weight: Vec<f64>,
    /// `sum w d` and `sum w d d^T`, with `d = p - o_j`.
    first: Vec<Vector3>,
    second: Vec<Matrix3>,
    /// `sum w r` and `sum w d r^T`.
    residual: Vec<Vector3>,
    cross: Vec<Matrix3>,
    cost: f64,
    /// Per joint, its parameters, its nearest proper ancestor that has some, and
    /// [`conformal_factor`] of its frame (for joints that rotate).
    params: Vec<Option<JointParams>>,
    above: Vec<Option<usize>>,
    conformal: Vec<Option<f64>>,
}

/// `g` with `A A^T / det(A) = g I` when `A` is a rotation times a uniform scale (to a
/// relative 1e-12), so that `A [A^-1 d]x = g [d]x A`.
pub(crate) fn conformal_factor(a: &Matrix3) -> Option<f64> {
    let aat = a * a.transpose();
    let sigma = aat.trace() / 3.0;
    let det = a.determinant();
    let off = (aat - Matrix3::from_diagonal_element(sigma)).amax();
    (det != 0.0 && det.is_finite() && off <= 1e-12 * sigma).then(|| sigma / det)
}

/// The rotation parameters a joint has: all three axes, or one hinge axis.
#[derive(Clone, Copy, Debug)]
pub(crate) enum Axes {
    All,
    One(Vector3),
}

impl Axes {
    pub(crate) fn count(self) -> usize {
        match self {
            Axes::All => 3,
            Axes::One(_) => 1,
        }
    }
}

/// Where a joint's translation and rotation parameters start.
#[derive(Clone, Copy, Debug)]
pub(crate) struct JointParams {
    pub(crate) translation: Option<usize>,
    pub(crate) rotation: Option<(usize, Axes)>,
}

impl JointParams {
    /// The parameters `layout` gives `joint`.
    pub(crate) fn of(layout: &DofLayout, joint: usize) -> Option<Self> {
        let o = layout.offset(joint)?;
        let (translation, rotation) = match layout.dof(joint) {
            JointDof::Fixed => return None,
            JointDof::Hinge { axis } => (None, Some((o, Axes::One(axis.normalize())))),
            JointDof::Ball => (None, Some((o, Axes::All))),
            JointDof::Free => (Some(o), Some((o + 3, Axes::All))),
        };
        Some(Self {
            translation,
            rotation,
        })
    }
}

/// Rows of the blocks below: component `k` of `e_i x u` is `sign * u_m` for the two
/// `(k, m, sign)` of row `i`.
const CROSS: [[(usize, usize, f64); 2]; 3] = [
    [(1, 2, -1.0), (2, 1, 1.0)],
    [(0, 2, 1.0), (2, 0, -1.0)],
    [(0, 1, -1.0), (1, 0, 1.0)],
];

/// `sum w [u]x^T H [v]x` from `Q = sum w u v^T`: entry `(i, j)` is
/// `sum w (e_i x u)^T H (e_j x v)`.
fn cross_sandwich(h: &Matrix3, q: &Matrix3) -> Matrix3 {
    Matrix3::from_fn(|i, j| {
        let mut s = 0.0;
        for &(k, m, si) in &CROSS[i] {
            for &(l, n, sj) in &CROSS[j] {
                s += si * sj * h[(k, l)] * q[(m, n)];
            }
        }
        s
    })
}

/// The diagonal of [`cross_sandwich`].
fn cross_sandwich_diagonal(h: &Matrix3, q: &Matrix3) -> Vector3 {
    Vector3::from_fn(|i, _| {
        let mut s = 0.0;
        for &(k, m, si) in &CROSS[i] {
            for &(l, n, sj) in &CROSS[i] {
                s += si * sj * h[(k, l)] * q[(m, n)];
            }
        }
        s
    })
}

/// Adds `scale * B_a^T m B_b` to `J^T J`, rows at `a`'s parameters from `ra` and columns
/// at `b`'s from `rb`, where `B` picks the parameters' axes. With `diagonal` (the same
/// parameters on both sides), only the lower triangle.
fn add_block(
    sink: &mut impl NormalSink,
    m: &Matrix3,
    (ra, axes_a): (usize, Axes),
    (rb, axes_b): (usize, Axes),
    diagonal: bool,
    scale: f64,
) {
    let projected;
    let m = match (axes_a, axes_b) {
        (Axes::All, Axes::All) => m,
        _ => {
            let mut left = *m;
            if let Axes::One(u) = axes_a {
                left = Matrix3::zeros();
                left.set_row(0, &(u.transpose() * m));
            }
            projected = match axes_b {
                Axes::All => left,
                Axes::One(v) => {
                    let mut right = Matrix3::zeros();
                    right.set_column(0, &(left * v));
                    right
                }
            };
            &projected
        }
    };
    sink.add_jtj_block(
        (ra, axes_a.count()),
        (rb, axes_b.count()),
        m,
        scale,
        diagonal,
    );
}

/// Adds the diagonal of `scale * B^T m B` to `J^T J` at the parameters from `r`.
fn add_diagonal(sink: &mut impl NormalSink, m: &Matrix3, (r, axes): (usize, Axes), scale: f64) {
    match axes {
        Axes::All => (0..3).for_each(|k| sink.add_jtj(r + k, r + k, scale * m[(k, k)])),
        Axes::One(u) => sink.add_jtj(r, r, scale * u.dot(&(m * u))),
    }
}

/// Takes the points' diagonal of `J^T J`, `J^T r` and cost into
/// [`ArticulatedNormalEquations`] (the rest of `J^T J` is in its body inertias).
struct PointsPart<'a>(&'a mut ArticulatedNormalEquations);

impl NormalSink for PointsPart<'_> {
    fn add_jtj(&mut self, i: usize, j: usize, v: f64) {
        assert_eq!(i, j, "only the diagonal");
        self.0.add_points_diagonal(i, v);
    }

    fn add_jtr(&mut self, i: usize, v: f64) {
        self.0.add_jtr(i, v);
    }

    fn add_cost(&mut self, c: f64) {
        self.0.add_cost(c);
    }

    fn cost(&self) -> f64 {
        self.0.cost()
    }
}

impl SubtreeMoments {
    /// Empty sums; [`Self::reset`] sizes them.
    pub fn new() -> Self {
        Self::default()
    }

    /// Starts new sums over `joints` joints.
    pub fn reset(&mut self, joints: usize) {
        self.weight.clear();
        self.weight.resize(joints, 0.0);
        self.first.clear();
        self.first.resize(joints, Vector3::zeros());
        self.second.clear();
        self.second.resize(joints, Matrix3::zeros());
        self.residual.clear();
        self.residual.resize(joints, Vector3::zeros());
        self.cross.clear();
        self.cross.resize(joints, Matrix3::zeros());
        self.cost = 0.0;
    }

    /// Adds the world point `p` carried by `joint`, with residual `r` and weight `w` (as
    /// [`crate::engine::NormalEquations::add_point`] with `p`'s Jacobian columns).
    pub fn add_point(
        &mut self,
        fk: &ForwardKinematics,
        joint: usize,
        p: &Point3,
        r: &Vector3,
        w: f64,
    ) {
        self.cost += w * r.norm_squared();
        let d = p.coords - fk.origin(joint);
        let wd = d * w;
        self.weight[joint] += w;
        self.first[joint] += wd;
        self.second[joint] += wd * d.transpose();
        self.residual[joint] += r * w;
        self.cross[joint] += wd * r.transpose();
    }

    /// The cost `sum w |r|^2` of the points added.
    pub fn cost(&self) -> f64 {
        self.cost
    }

    /// Sums the moments up the tree and adds the points' `J^T W J`, `J^T W r` and cost to
    /// `sink`, for the parameters of `layout` with Jacobian columns scaled by
    /// `column_scale`. The sums are the subtrees' afterwards: [`Self::reset`] before
    /// adding points again.
    pub fn assemble(
        &mut self,
        fk: &ForwardKinematics,
        layout: &DofLayout,
        column_scale: f64,
        sink: &mut impl NormalSink,
    ) {
        self.prepare(fk, layout);
        self.sum_up(fk);
        self.emit(fk, column_scale, sink, true);
    }

    /// As [`Self::assemble`] into `system`, whose solve needs only the points' body
    /// inertias besides the diagonal of `J^T J`; `false` (and nothing done) when some
    /// rotating joint's frame is not conformal, which it cannot represent.
    pub fn assemble_articulated(
        &mut self,
        fk: &ForwardKinematics,
        layout: &DofLayout,
        column_scale: f64,
        system: &mut ArticulatedNormalEquations,
    ) -> bool {
        self.prepare(fk, layout);
        if !system.reset(fk, layout, &self.params, &self.conformal) {
            return false;
        }
        let s2 = column_scale * column_scale;
        for j in 0..self.params.len() {
            if self.weight[j] != 0.0 {
                system.set_body(fk, j, self.weight[j], &self.first[j], &self.second[j], s2);
            }
        }
        system.finish();
        self.sum_up(fk);
        self.emit(fk, column_scale, &mut PointsPart(system), false);
        true
    }

    /// Each joint's parameters, nearest ancestor with parameters and conformal factor.
    fn prepare(&mut self, fk: &ForwardKinematics, layout: &DofLayout) {
        let joints = layout.joint_count().min(self.weight.len());
        self.params.clear();
        self.params
            .extend((0..joints).map(|j| JointParams::of(layout, j)));
        self.conformal.clear();
        self.conformal.extend((0..joints).map(|j| {
            self.params[j]
                .and_then(|p| p.rotation)
                .and_then(|_| conformal_factor(fk.frame_linear(j)))
        }));
        self.above.clear();
        for j in 0..joints {
            let above = fk.parent(j).and_then(|p| {
                if self.params[p].is_some() {
                    Some(p)
                } else {
                    self.above[p]
                }
            });
            self.above.push(above);
        }
    }

    /// Turns each joint's own moments into its subtree's: children come after their
    /// parents, so each subtree's moments are shifted to its parent's origin
    /// (`d_parent = d + delta`) and added.
    fn sum_up(&mut self, fk: &ForwardKinematics) {
        for j in (0..self.params.len()).rev() {
            let w = self.weight[j];
            let Some(p) = fk.parent(j).filter(|_| w != 0.0) else {
                continue;
            };
            let delta = fk.origin(j) - fk.origin(p);
            let (first, residual) = (self.first[j], self.residual[j]);
            let second = self.second[j]
                + delta * first.transpose()
                + first * delta.transpose()
                + delta * (delta * w).transpose();
            let cross = self.cross[j] + delta * residual.transpose();
            self.weight[p] += w;
            self.first[p] += first + delta * w;
            self.second[p] += second;
            self.residual[p] += residual;
            self.cross[p] += cross;
        }
    }

    /// Adds the cost, `J^T W r` and `J^T W J` from the subtree sums to `sink`: every
    /// block with `pairs`, else only the diagonal.
    fn emit(
        &self,
        fk: &ForwardKinematics,
        column_scale: f64,
        sink: &mut impl NormalSink,
        pairs: bool,
    ) {
        sink.add_cost(self.cost);
        let s2 = column_scale * column_scale;
        for b in 0..self.params.len() {
            let w = self.weight[b];
            if w == 0.0 {
                continue;
            }
            let Some(pb) = self.params[b] else {
                continue;
            };
            let ob = fk.origin(b);
            let (a_b, ai_b, p_b) = (
                fk.frame_linear(b),
                fk.frame_linear_inv(b),
                fk.parent_linear(b),
            );
            let (first, second) = (&self.first[b], &self.second[b]);
            // sum w q_b, sum w d_b q_b^T, A_b [sum w q_b]x = -sum w J_b, and
            // sum w [d_b]x J_b.
            let v_b = ai_b * first;
            let u_b = second * ai_b.transpose();
            // J^T r: sum w q_b x (A_b^T r) for a rotation, P_b^T sum w r for a translation.
            if let Some(t) = pb.translation {
                let g = p_b.transpose() * self.residual[b];
                for k in 0..3 {
                    sink.add_jtr(t + k, column_scale * g[k]);
                }
            }
            if let Some((o, axes)) = pb.rotation {
                let n = ai_b * self.cross[b] * a_b;
                let g = Vector3::new(
                    n[(1, 2)] - n[(2, 1)],
                    n[(2, 0)] - n[(0, 2)],
                    n[(0, 1)] - n[(1, 0)],
                );
                match axes {
                    Axes::All => {
                        for k in 0..3 {
                            sink.add_jtr(o + k, column_scale * g[k]);
                        }
                    }
                    Axes::One(axis) => sink.add_jtr(o, column_scale * axis.dot(&g)),
                }
            }
            if !pairs {
                match pb.rotation {
                    Some((o, Axes::All)) => {
                        let d = cross_sandwich_diagonal(&(a_b.transpose() * a_b), &(ai_b * u_b));
                        (0..3).for_each(|k| sink.add_jtj(o + k, o + k, s2 * d[k]));
                    }
                    Some(r) => {
                        let m = cross_sandwich(&(a_b.transpose() * a_b), &(ai_b * u_b));
                        add_diagonal(sink, &m, r, s2);
                    }
                    None => {}
                }
                if let Some(t) = pb.translation {
                    add_diagonal(sink, &(p_b.transpose() * p_b * w), (t, Axes::All), s2);
                }
                continue;
            }
            let y_b = a_b * skew(&v_b);
            let e_b = cross_sandwich(a_b, &u_b);
            // J^T J blocks with every ancestor-or-self `a`, over the points below `b`.
            let mut cur = Some(b);
            while let Some(a) = cur {
                cur = self.above[a];
                let Some(pa) = self.params[a] else {
                    continue;
                };
                let same = a == b;
                let delta = ob - fk.origin(a);
                let (a_a, ai_a, p_a) = (
                    fk.frame_linear(a),
                    fk.frame_linear_inv(a),
                    fk.parent_linear(a),
                );
                if let (Some(ra), Some(rb)) = (pa.rotation, pb.rotation) {
                    let m = match self.conformal[a] {
                        // J_a^T = g_a A_a^T [d_b + delta]x.
                        Some(g) => (a_a.transpose() * (e_b - skew(&delta) * y_b)) * g,
                        None => {
                            // sum w q_a q_b^T with q_a = A_a^-1 (d_b + delta).
                            let q = ai_a * u_b + (ai_a * delta) * v_b.transpose();
                            cross_sandwich(&(a_a.transpose() * a_b), &q)
                        }
                    };
                    add_block(sink, &m, ra, rb, same, s2);
                }
                if let (Some(ta), Some(tb)) = (pa.translation, pb.translation) {
                    let m = p_a.transpose() * p_b * w;
                    add_block(sink, &m, (ta, Axes::All), (tb, Axes::All), same, s2);
                }
                if let (Some(ta), Some(rb)) = (pa.translation, pb.rotation) {
                    let m = -(p_a.transpose() * y_b);
                    add_block(sink, &m, (ta, Axes::All), rb, false, s2);
                }
                if let (Some(ra), Some(tb), false) = (pa.rotation, pb.translation, same) {
                    let m = skew(&(ai_a * (first + delta * w))) * a_a.transpose() * p_b;
                    add_block(sink, &m, ra, (tb, Axes::All), false, s2);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests;
