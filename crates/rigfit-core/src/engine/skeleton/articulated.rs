//! Damped normal equations of points carried by a skeleton, solved by the articulated-body
//! recursion (Featherstone, "Rigid Body Dynamics Algorithms", 2008, sections 7.2-7.3) in
//! O(joints). When every rotating joint's frame `A_j` is a rotation times a uniform scale,
//! each parameter moves the points below its joint by a rigid motion, a spatial vector
//! `S theta` (angular, linear velocity about one reference point). Then
//! `J^T W J = sum over joints b of (dV_b/dtheta)^T I_b (dV_b/dtheta)`, with `I_b` the 6x6
//! inertia of the weighted points joint `b` carries and `V_b` the sum of the motions of `b`
//! and its ancestors, and eliminating the parameters leaves first (block Gaussian
//! elimination, with the same pivots as an `L D L^T` factorisation) keeps each subtree's
//! Schur complement as one 6x6 articulated inertia.

use nalgebra::{DMatrix, Matrix6, Matrix6x3, Vector6};

use crate::engine::linear_algebra::NormalSink;
use crate::engine::skeleton::subtree_moments::{Axes, JointParams};
use crate::kinematics::{DofLayout, ForwardKinematics};
use crate::math::{Matrix3, Vector3, skew};

/// The motion subspace of some parameters: `count` (1 or 3) from `offset`, moving the
/// points by the spatial velocity `s theta` (unused columns zero).
#[derive(Clone, Copy, Debug)]
struct Motion {
    offset: usize,
    count: usize,
    s: Matrix6x3<f64>,
}

/// What eliminating a motion leaves for the forward pass: `U = I^A S`, `D^-1` and
/// `u = tau - S^T p^A`, so that `theta = D^-1 (u - U^T V_parent)`.
#[derive(Clone, Copy, Debug)]
struct Elimination {
    u_mat: Matrix6x3<f64>,
    d_inv: Matrix3,
    u: Vector3,
}

impl Default for Elimination {
    fn default() -> Self {
        Self {
            u_mat: Matrix6x3::zeros(),
            d_inv: Matrix3::zeros(),
            u: Vector3::zeros(),
        }
    }
}

/// The points' body inertias, the diagonal of `J^T W J`, `J^T W r` and the cost, for the
/// parameters of one layout.
#[derive(Clone, Debug, Default)]
pub struct ArticulatedNormalEquations {
    /// The point spatial velocities are taken about.
    reference: Vector3,
    parent: Vec<Option<usize>>,
    /// Per joint: its rotation and translation motions (eliminated in this order).
    rotation: Vec<Option<Motion>>,
    translation: Vec<Option<Motion>>,
    /// Per joint: the inertia of the points it carries, if it has any (else stale).
    body: Vec<Matrix6<f64>>,
    has_body: Vec<bool>,
    /// Per joint: whether some ancestor-or-self moves, and some descendant-or-self moves
    /// or carries points.
    moved: Vec<bool>,
    needed: Vec<bool>,
    /// The joints the solve visits (some ancestor-or-self has parameters, and some
    /// descendant-or-self has parameters or points), parents first, and the parent each
    /// passes its articulated inertia to.
    order: Vec<usize>,
    pass_to: Vec<Option<usize>>,
    /// The diagonal of `J^T W J` from the points, and from terms added through
    /// [`NormalSink`].
    points_diag: Vec<f64>,
    extra_diag: Vec<f64>,
    jtr: Vec<f64>,
    cost: f64,
    /// Workspace of the solve.
    damping: Vec<f64>,
    inertia: Vec<Matrix6<f64>>,
    bias: Vec<Vector6<f64>>,
    rotation_elimination: Vec<Elimination>,
    translation_elimination: Vec<Elimination>,
    velocity: Vec<Vector6<f64>>,
    step: Vec<f64>,
}

/// The inverse of a symmetric 3x3 matrix by its Cholesky factorisation, `None` when it is
/// not positive definite.
fn spd_inverse(d: &Matrix3) -> Option<Matrix3> {
    let l00 = d[(0, 0)];
    if l00.is_nan() || l00 <= 0.0 {
        return None;
    }
    let l00 = l00.sqrt();
    let l10 = d[(1, 0)] / l00;
    let l20 = d[(2, 0)] / l00;
    let l11 = d[(1, 1)] - l10 * l10;
    if l11.is_nan() || l11 <= 0.0 {
        return None;
    }
    let l11 = l11.sqrt();
    let l21 = (d[(2, 1)] - l20 * l10) / l11;
    let l22 = d[(2, 2)] - l20 * l20 - l21 * l21;
    if l22.is_nan() || l22 <= 0.0 {
        return None;
    }
    let l22 = l22.sqrt();
    // L^-1, lower triangular; then D^-1 = L^-T L^-1.
    let m00 = 1.0 / l00;
    let m11 = 1.0 / l11;
    let m22 = 1.0 / l22;
    let m10 = -l10 * m00 * m11;
    let m21 = -l21 * m11 * m22;
    let m20 = -(l20 * m00 + l21 * m10) * m22;
    let linv = Matrix3::new(m00, 0.0, 0.0, m10, m11, 0.0, m20, m21, m22);
    Some(linv.tr_mul(&linv))
}

/// Eliminates `motion` from a subtree with articulated inertia `ia` and bias `pa`, which
/// become the ones seen through the motion, into `out`; `false` when the pivot `D` is not
/// positive definite.
fn eliminate(
    motion: &Motion,
    ia: &mut Matrix6<f64>,
    pa: &mut Vector6<f64>,
    damping: &[f64],
    jtr: &[f64],
    out: &mut Elimination,
) -> bool {
    let u_mat = *ia * motion.s;
    // D = S^T U, symmetric.
    let mut d = Matrix3::zeros();
    for c in 0..3 {
        for r in 0..=c {
            let v = motion.s.column(r).dot(&u_mat.column(c));
            d[(r, c)] = v;
            d[(c, r)] = v;
        }
    }
    let mut tau = Vector3::zeros();
    for k in 0..3 {
        if k < motion.count {
            d[(k, k)] += damping[motion.offset + k];
            tau[k] = -jtr[motion.offset + k];
        } else {
            // Unused columns: a decoupled unknown that comes out zero.
            d[(k, k)] += 1.0;
        }
    }
    let Some(d_inv) = spd_inverse(&d) else {
        return false;
    };
    let u = tau - motion.s.tr_mul(pa);
    let k = u_mat * d_inv;
    // ia -= k U^T, which is symmetric: the upper triangle, mirrored.
    for c in 0..6 {
        for r in 0..=c {
            let v = ia[(r, c)]
                - (k[(r, 0)] * u_mat[(c, 0)]
                    + k[(r, 1)] * u_mat[(c, 1)]
                    + k[(r, 2)] * u_mat[(c, 2)]);
            ia[(r, c)] = v;
            ia[(c, r)] = v;
        }
    }
    *pa += k * u;
    out.u_mat = u_mat;
    out.d_inv = d_inv;
    out.u = u;
    true
}

impl ArticulatedNormalEquations {
    /// Empty equations, set up by [`crate::engine::SubtreeMoments::assemble_articulated`].
    pub fn new() -> Self {
        Self::default()
    }

    /// Sets up the motions of `layout`'s parameters at `fk` and clears the sums; `false`
    /// (and nothing done) when a rotating joint has no conformal factor (its motion is
    /// not rigid).
    pub(crate) fn reset(
        &mut self,
        fk: &ForwardKinematics,
        layout: &DofLayout,
        params: &[Option<JointParams>],
        conformal: &[Option<f64>],
    ) -> bool {
        let joints = params.len();
        let rigid = (0..joints)
            .all(|j| params[j].is_none_or(|p| p.rotation.is_none()) || conformal[j].is_some());
        if !rigid {
            return false;
        }
        self.reference = if joints > 0 {
            *fk.origin(0)
        } else {
            Vector3::zeros()
        };
        self.parent.clear();
        self.rotation.clear();
        self.translation.clear();
        for j in 0..joints {
            let (mut rotation, mut translation) = (None, None);
            if let Some(p) = params[j] {
                if let (Some((offset, axes)), Some(g)) = (p.rotation, conformal[j]) {
                    // J_j(p) theta = (g A_j theta) x (p - o_j): angular velocity
                    // `omega = g A_j theta`, linear `(o_j - c) x omega` about c.
                    let omega = fk.frame_linear(j) * g;
                    let omega = match axes {
                        Axes::All => omega,
                        Axes::One(axis) => {
                            let mut m = Matrix3::zeros();
                            m.set_column(0, &(omega * axis));
                            m
                        }
                    };
                    let mut s = Matrix6x3::zeros();
                    s.fixed_view_mut::<3, 3>(0, 0).copy_from(&omega);
                    s.fixed_view_mut::<3, 3>(3, 0)
                        .copy_from(&(skew(&(fk.origin(j) - self.reference)) * omega));
                    rotation = Some(Motion {
                        offset,
                        count: axes.count(),
                        s,
                    });
                }
                if let Some(offset) = p.translation {
                    let mut s = Matrix6x3::zeros();
                    s.fixed_view_mut::<3, 3>(3, 0)
                        .copy_from(fk.parent_linear(j));
                    translation = Some(Motion {
                        offset,
                        count: 3,
                        s,
                    });
                }
            }
            self.parent.push(fk.parent(j));
            self.rotation.push(rotation);
            self.translation.push(translation);
        }
        self.body.resize(joints, Matrix6::zeros());
        self.has_body.clear();
        self.has_body.resize(joints, false);
        self.order.clear();
        let n = layout.len();
        for v in [&mut self.points_diag, &mut self.extra_diag, &mut self.jtr] {
            v.clear();
            v.resize(n, 0.0);
        }
        self.cost = 0.0;
        true
    }

    /// Sets the inertia of the points `joint` carries from their weight `w`, `sum w d` and
    /// `sum w d d^T` with `d = p - o_joint`, times `scale`: the quadratic form of
    /// `sum w |omega x (p - c) + v|^2`.
    pub(crate) fn set_body(
        &mut self,
        fk: &ForwardKinematics,
        joint: usize,
        w: f64,
        first: &Vector3,
        second: &Matrix3,
        scale: f64,
    ) {
        let r = fk.origin(joint) - self.reference;
        let m1 = first + r * w;
        let m2 = second + r * first.transpose() + first * r.transpose() + r * (r * w).transpose();
        let mut inertia = Matrix6::zeros();
        inertia
            .fixed_view_mut::<3, 3>(0, 0)
            .copy_from(&(Matrix3::from_diagonal_element(m2.trace()) - m2));
        let cross = skew(&m1);
        inertia.fixed_view_mut::<3, 3>(0, 3).copy_from(&cross);
        inertia
            .fixed_view_mut::<3, 3>(3, 0)
            .copy_from(&cross.transpose());
        inertia
            .fixed_view_mut::<3, 3>(3, 3)
            .copy_from(&Matrix3::from_diagonal_element(w));
        self.body[joint] = inertia * scale;
        self.has_body[joint] = true;
    }

    /// Lists the joints the solve visits, once the bodies are set.
    pub(crate) fn finish(&mut self) {
        let joints = self.parent.len();
        let moves = |j: usize| self.rotation[j].is_some() || self.translation[j].is_some();
        // Parents come first.
        let (moved, needed) = (&mut self.moved, &mut self.needed);
        moved.clear();
        for j in 0..joints {
            let m = moves(j) || self.parent[j].is_some_and(|p| moved[p]);
            moved.push(m);
        }
        needed.clear();
        needed.extend((0..joints).map(|j| moves(j) || self.has_body[j]));
        for j in (0..joints).rev() {
            if let (true, Some(p)) = (needed[j], self.parent[j]) {
                needed[p] = true;
            }
        }
        self.order.clear();
        self.order
            .extend((0..joints).filter(|&j| moved[j] && needed[j]));
        self.pass_to.clear();
        self.pass_to
            .extend((0..joints).map(|j| self.parent[j].filter(|&p| moved[p] && needed[p])));
    }

    /// Adds to the points' part of the diagonal of `J^T W J`.
    pub(crate) fn add_points_diagonal(&mut self, i: usize, v: f64) {
        self.points_diag[i] += v;
    }

    /// The number of parameters.
    pub fn len(&self) -> usize {
        self.jtr.len()
    }

    /// Whether there are no parameters.
    pub fn is_empty(&self) -> bool {
        self.jtr.is_empty()
    }

    /// `J^T W r`.
    pub fn jtr(&self) -> &[f64] {
        &self.jtr
    }

    /// `J^T W J` as a full symmetric matrix (blocks `S_a^T I^C_b S_b`, with `I^C_b` the
    /// inertia of the points below `b`).
    pub fn jtj(&self) -> DMatrix<f64> {
        let n = self.len();
        let mut h = DMatrix::zeros(n, n);
        let mut composite: Vec<Matrix6<f64>> = (0..self.body.len())
            .map(|j| {
                if self.has_body[j] {
                    self.body[j]
                } else {
                    Matrix6::zeros()
                }
            })
            .collect();
        for j in (0..composite.len()).rev() {
            if let Some(p) = self.parent[j] {
                let c = composite[j];
                composite[p] += c;
            }
        }
        let motions = |j: usize| {
            [self.rotation[j], self.translation[j]]
                .into_iter()
                .flatten()
        };
        for b in 0..composite.len() {
            for mb in motions(b) {
                let mut cur = Some(b);
                while let Some(a) = cur {
                    cur = self.parent[a];
                    for ma in motions(a) {
                        let block = ma.s.transpose() * composite[b] * mb.s;
                        for k in 0..ma.count {
                            for l in 0..mb.count {
                                h[(ma.offset + k, mb.offset + l)] = block[(k, l)];
                                h[(mb.offset + l, ma.offset + k)] = block[(k, l)];
                            }
                        }
                    }
                }
            }
        }
        for i in 0..n {
            h[(i, i)] += self.extra_diag[i];
        }
        h
    }

    /// The Levenberg-Marquardt step `(J^T J + lambda diag(J^T J) + eps I) delta = -J^T r`
    /// (as [`crate::engine::NormalEquations::solve`]); `None` when the damped matrix is
    /// not positive definite.
    pub fn solve(&mut self, lambda: f64) -> Option<&[f64]> {
        let n = self.len();
        let full = |i: usize| self.points_diag[i] + self.extra_diag[i];
        let scale = (0..n).map(full).fold(0.0, f64::max).max(1e-12);
        self.damping.clear();
        self.damping
            .extend((0..n).map(|i| self.extra_diag[i] + (lambda * full(i) + 1e-9 * scale)));
        let joints = self.parent.len();
        self.inertia.resize(joints, Matrix6::zeros());
        self.bias.resize(joints, Vector6::zeros());
        for &j in &self.order {
            if self.has_body[j] {
                self.inertia[j].copy_from(&self.body[j]);
            } else {
                self.inertia[j].fill(0.0);
            }
            self.bias[j].fill(0.0);
        }
        self.rotation_elimination
            .resize(joints, Elimination::default());
        self.translation_elimination
            .resize(joints, Elimination::default());
        for &j in self.order.iter().rev() {
            // The joint's articulated inertia and bias, and its parent's (which comes
            // first).
            let (inertia_head, inertia_tail) = self.inertia.split_at_mut(j);
            let (bias_head, bias_tail) = self.bias.split_at_mut(j);
            let (ia, pa) = (&mut inertia_tail[0], &mut bias_tail[0]);
            if let Some(m) = &self.rotation[j] {
                let out = &mut self.rotation_elimination[j];
                if !eliminate(m, ia, pa, &self.damping, &self.jtr, out) {
                    return None;
                }
            }
            if let Some(m) = &self.translation[j] {
                let out = &mut self.translation_elimination[j];
                if !eliminate(m, ia, pa, &self.damping, &self.jtr, out) {
                    return None;
                }
            }
            if let Some(p) = self.pass_to[j] {
                inertia_head[p] += &*ia;
                bias_head[p] += &*pa;
            }
        }
        self.step.clear();
        self.step.resize(n, 0.0);
        self.velocity.resize(joints, Vector6::zeros());
        for &j in &self.order {
            let mut v = self.pass_to[j].map_or_else(Vector6::zeros, |p| self.velocity[p]);
            let eliminated = [
                (&self.translation[j], &self.translation_elimination[j]),
                (&self.rotation[j], &self.rotation_elimination[j]),
            ];
            for (m, e) in eliminated {
                let Some(m) = m else { continue };
                let theta = e.d_inv * (e.u - e.u_mat.tr_mul(&v));
                self.step[m.offset..m.offset + m.count]
                    .copy_from_slice(&theta.as_slice()[..m.count]);
                v += m.s * theta;
            }
            self.velocity[j] = v;
        }
        Some(&self.step)
    }
}

impl NormalSink for ArticulatedNormalEquations {
    /// Only diagonal entries: the rest of `J^T W J` is held by the body inertias.
    fn add_jtj(&mut self, i: usize, j: usize, v: f64) {
        assert_eq!(
            i, j,
            "articulated normal equations take only diagonal terms"
        );
        self.extra_diag[i] += v;
    }

    fn add_jtr(&mut self, i: usize, v: f64) {
        self.jtr[i] += v;
    }

    fn add_cost(&mut self, c: f64) {
        self.cost += c;
    }

    fn cost(&self) -> f64 {
        self.cost
    }
}
