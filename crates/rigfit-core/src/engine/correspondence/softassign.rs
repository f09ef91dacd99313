//! Two-sided softassign with an outlier row and column (Gold et al. 1998; Cannavò et al.
//! 2020, eq. 1-2), stored sparsely: entries below `exp(-CUTOFF)` of the outlier weight are
//! dropped, so memory grows with the number of close pairs, not model x data.

use crate::math::Point3;

/// An entry whose exponent is below `-CUTOFF` is dropped (it is < 1e-9 of an outlier's).
const CUTOFF: f64 = 20.7;

/// The match matrix `omega` of eq. (2): rows are model points, columns data points, plus an
/// outlier (slack) column per row and an outlier row per column.
#[derive(Clone, Debug, Default)]
pub struct MatchMatrix {
    /// Row `k`'s entries are `entries[row_start[k]..row_start[k + 1]]`.
    pub row_start: Vec<usize>,
    /// (data index, weight).
    pub entries: Vec<(u32, f64)>,
    /// `omega[k][M+1]`: how much model point `k` is unmatched.
    pub row_slack: Vec<f64>,
    /// `omega[K+1][i]`: how much data point `i` is an outlier.
    pub col_slack: Vec<f64>,
}

impl MatchMatrix {
    /// The entries of row `k`.
    pub fn row(&self, k: usize) -> &[(u32, f64)] {
        &self.entries[self.row_start[k]..self.row_start[k + 1]]
    }

    /// The number of model points.
    pub fn rows(&self) -> usize {
        self.row_slack.len()
    }

    /// Total matched weight of row `k` (`lambda_k`).
    pub fn row_weight(&self, k: usize) -> f64 {
        self.row(k).iter().map(|e| e.1).sum()
    }

    /// Total matched weight of every column.
    pub fn column_weights(&self) -> Vec<f64> {
        let mut w = vec![0.0; self.col_slack.len()];
        for &(i, m) in &self.entries {
            w[i as usize] += m;
        }
        w
    }

    /// The weighted mean of the data points matched to row `k` (`G_k` of Dewaele eq. 20),
    /// with its weight; `None` when the row is unmatched.
    pub fn target(&self, k: usize, data: &[Point3]) -> Option<(Point3, f64)> {
        let mut sum = nalgebra::Vector3::zeros();
        let mut w = 0.0;
        for &(i, m) in self.row(k) {
            sum += data[i as usize].coords * m;
            w += m;
        }
        (w > 1e-12).then(|| (Point3::from(sum / w), w))
    }

    /// The mean absolute change of the matched weights against another matrix of the same
    /// shape (used to decide that `omega` has converged).
    pub fn change_from(&self, other: &MatchMatrix) -> f64 {
        if other.rows() != self.rows() {
            return f64::INFINITY;
        }
        let a: f64 = self
            .row_slack
            .iter()
            .zip(&other.row_slack)
            .map(|(x, y)| (x - y).abs())
            .sum();
        a / self.rows().max(1) as f64
    }
}

/// Parameters of one softassign step.
#[derive(Clone, Copy, Debug)]
pub struct SoftassignParams {
    /// The inverse temperature (1 / length^2).
    pub beta: f64,
    /// `zeta` of eq. (1): a squared distance below which matching beats being an outlier.
    pub zeta: f64,
    /// Sinkhorn iterations at most.
    pub sinkhorn_iterations: usize,
    /// Stop Sinkhorn when no row or column sum is further than this from 1.
    pub sinkhorn_tolerance: f64,
}

/// Computes `omega` for model points `model` and data points `data` at temperature `beta`:
/// `omega_ki = exp(-beta (|y_i - v_k|^2 - zeta))` with outlier entries 1, then alternating
/// row and column normalisation (Sinkhorn) with the outlier row and column taking part.
/// `allowed(k, i)` may forbid pairs (a stroke pinned to some bones, a chain restriction).
pub fn softassign(
    model: &[Point3],
    data: &[Point3],
    params: &SoftassignParams,
    allowed: impl Fn(usize, usize) -> bool,
) -> MatchMatrix {
    let beta = params.beta;
    let max_d2 = params.zeta + CUTOFF / beta;
    let mut m = MatchMatrix {
        row_start: Vec::with_capacity(model.len() + 1),
        entries: Vec::new(),
        row_slack: vec![1.0; model.len()],
        col_slack: vec![1.0; data.len()],
    };
    m.row_start.push(0);
    for (k, v) in model.iter().enumerate() {
        for (i, y) in data.iter().enumerate() {
            let d2 = (y - v).norm_squared();
            if d2 < max_d2 && allowed(k, i) {
                // Exponent capped so a very cold temperature cannot overflow.
                let e = (-beta * (d2 - params.zeta)).min(300.0);
                m.entries.push((i as u32, e.exp()));
            }
        }
        m.row_start.push(m.entries.len());
    }
    let mut col_sum = vec![0.0; data.len()];
    for _ in 0..params.sinkhorn_iterations {
        // Rows (each real row with its outlier column).
        let mut worst: f64 = 0.0;
        for k in 0..model.len() {
            let range = m.row_start[k]..m.row_start[k + 1];
            let sum: f64 =
                m.entries[range.clone()].iter().map(|e| e.1).sum::<f64>() + m.row_slack[k];
            worst = worst.max((sum - 1.0).abs());
            for e in &mut m.entries[range] {
                e.1 /= sum;
            }
            m.row_slack[k] /= sum;
        }
        // Columns (each real column with its outlier row).
        col_sum.copy_from_slice(&m.col_slack);
        for &(i, w) in &m.entries {
            col_sum[i as usize] += w;
        }
        for (i, s) in col_sum.iter().enumerate() {
            worst = worst.max((s - 1.0).abs());
            m.col_slack[i] /= s;
        }
        for e in &mut m.entries {
            e.1 /= col_sum[e.0 as usize];
        }
        if worst < params.sinkhorn_tolerance {
            break;
        }
    }
    m
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn matches_near_points_and_rejects_far_ones() {
        let model = vec![Point3::new(0.0, 0.0, 0.0), Point3::new(1.0, 0.0, 0.0)];
        let data = vec![
            Point3::new(1.01, 0.0, 0.0),
            Point3::new(0.01, 0.0, 0.0),
            Point3::new(50.0, 0.0, 0.0),
        ];
        let p = SoftassignParams {
            beta: 400.0,
            zeta: 0.01,
            sinkhorn_iterations: 50,
            sinkhorn_tolerance: 1e-6,
        };
        let m = softassign(&model, &data, &p, |_, _| true);
        assert_eq!(m.row(0).len(), 1);
        assert_eq!(m.row(0)[0].0, 1);
        assert!(m.row(0)[0].1 > 0.8, "weight {}", m.row(0)[0].1);
        assert!(m.col_slack[2] > 0.99, "the far point is an outlier");
        let (t, w) = m.target(1, &data).expect("matched");
        assert!((t.x - 1.01).abs() < 1e-9 && w > 0.8);
    }
}
