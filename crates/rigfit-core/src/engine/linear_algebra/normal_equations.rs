//! Dense normal equations `J^T W J dtheta = -J^T W r` for models with few parameters (a
//! skeleton: 6 + 3 x joints), accumulated residual by residual from sparse Jacobian rows, and
//! solved with a Levenberg-Marquardt damping.

use nalgebra::{DMatrix, DVector};

use super::block_sparse::Block6;
use crate::math::{Matrix3, Vector3};

/// Accumulated `J^T J` (upper triangle, row-major), `J^T r` and the cost `r^T r`.
#[derive(Clone, Debug)]
pub struct NormalEquations {
    n: usize,
    jtj: Vec<f64>,
    pub jtr: DVector<f64>,
    pub cost: f64,
}

impl NormalEquations {
    pub fn new(n: usize) -> Self {
        Self {
            n,
            jtj: vec![0.0; n * n],
            jtr: DVector::zeros(n),
            cost: 0.0,
        }
    }

    /// Clears the sums for a new iteration.
    pub fn clear(&mut self) {
        self.jtj.fill(0.0);
        self.jtr.fill(0.0);
        self.cost = 0.0;
    }

    /// Adds a 3D residual `r` with weight `w` whose Jacobian columns are `cols`
    /// (parameter index, dr/dparameter), in any order.
    pub fn add_point(&mut self, r: &Vector3, w: f64, cols: &[(usize, Vector3)]) {
        NormalSink::add_point_columns(self, r, w, cols);
    }

    /// Adds a scalar residual `r` with weight `w` that depends on one parameter with
    /// derivative `d`.
    pub fn add_scalar(&mut self, r: f64, w: f64, col: usize, d: f64) {
        self.cost += w * r * r;
        self.jtr[col] += w * d * r;
        self.jtj[col * self.n + col] += w * d * d;
    }

    /// `J^T J` as a full symmetric matrix.
    pub fn jtj(&self) -> DMatrix<f64> {
        let n = self.n;
        DMatrix::from_fn(n, n, |i, j| {
            let (lo, hi) = if i <= j { (i, j) } else { (j, i) };
            self.jtj[lo * n + hi]
        })
    }

    /// The Levenberg-Marquardt step: `(J^T J + lambda diag(J^T J) + eps I) delta = -J^T r`.
    pub fn solve(&self, lambda: f64) -> Option<DVector<f64>> {
        let n = self.n;
        if n == 0 {
            return Some(DVector::zeros(0));
        }
        let mut a = self.jtj();
        let scale = (0..n).map(|i| a[(i, i)]).fold(0.0, f64::max).max(1e-12);
        for i in 0..n {
            a[(i, i)] += lambda * a[(i, i)] + 1e-9 * scale;
        }
        let chol = nalgebra::Cholesky::new(a)?;
        Some(-chol.solve(&self.jtr))
    }
}

/// Where Gauss-Newton sums go: `J^T W J`, `J^T W r` and the cost `r^T W r`, entry by entry
/// (or a block at once), so one assembly serves every storage: the dense
/// [`NormalEquations`], the block-sparse [`crate::engine::BlockSparseNormalEquations`], and
/// the skeleton's tree-structured [`crate::engine::TreeNormalEquations`] and
/// [`crate::engine::ArticulatedNormalEquations`].
pub trait NormalSink {
    /// Adds `v` to the symmetric entry `(i, j)` of `J^T W J` (each unordered pair once).
    fn add_jtj(&mut self, i: usize, j: usize, v: f64);
    /// Adds `v` to entry `i` of `J^T W r`.
    fn add_jtr(&mut self, i: usize, v: f64);
    /// Adds `c` to the cost.
    fn add_cost(&mut self, c: f64);
    /// The accumulated cost.
    fn cost(&self) -> f64;

    /// Adds `scale * m[(ia, ib)]` to the entry `(b + ib, a + ia)` of `J^T W J` for
    /// `ia < na`, `ib < nb`; with `diagonal` (the same parameters on both sides), only for
    /// `ia <= ib`.
    fn add_jtj_block(
        &mut self,
        (a, na): (usize, usize),
        (b, nb): (usize, usize),
        m: &Matrix3,
        scale: f64,
        diagonal: bool,
    ) {
        for ib in 0..nb {
            for ia in 0..if diagonal { ib + 1 } else { na } {
                self.add_jtj(b + ib, a + ia, scale * m[(ia, ib)]);
            }
        }
    }

    /// Adds the 6x6 `block` (row-major) to the entries `(row + a, column + b)` of
    /// `J^T W J`, where the parameter ranges `row..row + 6` and `column..column + 6` are
    /// the same or disjoint; on the diagonal (`row == column`) only its upper triangle,
    /// `a <= b`, is read. By default entry by entry; a storage of 6x6 blocks adds it at once.
    fn add_jtj_block6(&mut self, row: usize, column: usize, block: &Block6) {
        for a in 0..6 {
            for b in if row == column { a } else { 0 }..6 {
                self.add_jtj(row + a, column + b, block[6 * a + b]);
            }
        }
    }

    /// Adds a 3D residual `r` with weight `w` whose Jacobian columns are `cols` (parameter
    /// index, dr/dparameter; each index once).
    fn add_point_columns(&mut self, r: &Vector3, w: f64, cols: &[(usize, Vector3)]) {
        self.add_cost(w * r.norm_squared());
        for (a, &(ca, va)) in cols.iter().enumerate() {
            let wa = va * w;
            self.add_jtr(ca, wa.dot(r));
            for &(cb, vb) in &cols[a..] {
                self.add_jtj(ca, cb, wa.dot(&vb));
            }
        }
    }

    /// Adds a scalar residual `r` with weight `w` that depends on one parameter with
    /// derivative `d` (as [`NormalEquations::add_scalar`]).
    fn add_scalar(&mut self, r: f64, w: f64, col: usize, d: f64) {
        self.add_cost(w * r * r);
        self.add_jtr(col, w * d * r);
        self.add_jtj(col, col, w * d * d);
    }
}

impl NormalSink for NormalEquations {
    /// Dense upper-triangle storage: entry `(min(i, j), max(i, j))`.
    fn add_jtj(&mut self, i: usize, j: usize, v: f64) {
        let (lo, hi) = if i <= j { (i, j) } else { (j, i) };
        self.jtj[lo * self.n + hi] += v;
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

    fn add_scalar(&mut self, r: f64, w: f64, col: usize, d: f64) {
        NormalEquations::add_scalar(self, r, w, col, d);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn solves_a_small_least_squares_problem() {
        // r = p - target with J = I: the step is -r.
        let mut ne = NormalEquations::new(3);
        let r = Vector3::new(0.5, -1.0, 2.0);
        ne.add_point(
            &r,
            1.0,
            &[(0, Vector3::x()), (1, Vector3::y()), (2, Vector3::z())],
        );
        let step = ne.solve(0.0).expect("positive definite");
        assert!(
            (step[0] + 0.5).abs() < 1e-6
                && (step[1] - 1.0).abs() < 1e-6
                && (step[2] + 2.0).abs() < 1e-6
        );
    }
}
