//! Dense normal equations `J^T W J dtheta = -J^T W r` for models with few parameters (a
//! skeleton: 6 + 3 x joints), accumulated residual by residual from sparse Jacobian rows, and
//! solved with a Levenberg-Marquardt damping.

use nalgebra::{DMatrix, DVector};

use crate::math::Vector3;

/// Accumulated `J^T J`, `J^T r` and the cost `r^T r`.
#[derive(Clone, Debug)]
pub struct NormalEquations {
    pub jtj: DMatrix<f64>,
    pub jtr: DVector<f64>,
    pub cost: f64,
}

impl NormalEquations {
    pub fn new(n: usize) -> Self {
        Self {
            jtj: DMatrix::zeros(n, n),
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
    /// (parameter index, dr/dparameter).
    pub fn add_point(&mut self, r: &Vector3, w: f64, cols: &[(usize, Vector3)]) {
        self.cost += w * r.norm_squared();
        for (a, &(ca, va)) in cols.iter().enumerate() {
            self.jtr[ca] += w * va.dot(r);
            for &(cb, vb) in &cols[a..] {
                let v = w * va.dot(&vb);
                self.jtj[(ca, cb)] += v;
                if ca != cb {
                    self.jtj[(cb, ca)] += v;
                }
            }
        }
    }

    /// Adds a scalar residual `r` with weight `w` that depends on one parameter with
    /// derivative `d`.
    pub fn add_scalar(&mut self, r: f64, w: f64, col: usize, d: f64) {
        self.cost += w * r * r;
        self.jtr[col] += w * d * r;
        self.jtj[(col, col)] += w * d * d;
    }

    /// The Levenberg-Marquardt step: `(J^T J + lambda diag(J^T J) + eps I) delta = -J^T r`.
    pub fn solve(&self, lambda: f64) -> Option<DVector<f64>> {
        let n = self.jtr.len();
        if n == 0 {
            return Some(DVector::zeros(0));
        }
        let mut a = self.jtj.clone();
        let scale = (0..n).map(|i| a[(i, i)]).fold(0.0, f64::max).max(1e-12);
        for i in 0..n {
            a[(i, i)] += lambda * a[(i, i)] + 1e-9 * scale;
        }
        let chol = nalgebra::Cholesky::new(a)?;
        Some(-chol.solve(&self.jtr))
    }
}
