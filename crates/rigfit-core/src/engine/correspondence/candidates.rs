//! Each data point's candidate model points for the articulated tracker's E-steps
//! ([`Candidates`]): found once in a [`PointGrid`] within the kernel's cutoff plus a margin,
//! and reused while the model moves less than the margin.

use crate::engine::spatial::PointGrid;
use crate::math::Point3;

/// Kernel cutoff in units of `sigma`: there a model point's kernel, `exp(-3.1)`, is about
/// 1% of the outlier term `c` (Dewaele eq. 17).
pub(super) const CUTOFF_SIGMAS: f64 = 2.5;

/// For each data point, the model points within a radius of it: found once with a
/// [`PointGrid`] and reused by several E-steps while the model moves less than the margin
/// added to the kernel's cutoff.
#[derive(Clone, Debug, Default)]
pub struct Candidates {
    /// `model[start[j]..start[j + 1]]` are data point `j`'s candidates.
    start: Vec<u32>,
    model: Vec<u32>,
}

impl Candidates {
    /// Finds, for every data point, the model points within `radius`.
    pub fn find(&mut self, data: &[Point3], model: &[Point3], radius: f64, grid: &mut PointGrid) {
        grid.rebuild(model, radius);
        self.start.clear();
        self.model.clear();
        self.start.push(0);
        for y in data {
            grid.for_each_within(y, radius, |i, _| self.model.push(i as u32));
            self.start.push(self.model.len() as u32);
        }
    }

    /// Candidates kept, over all data points.
    pub fn len(&self) -> usize {
        self.model.len()
    }

    pub fn is_empty(&self) -> bool {
        self.model.is_empty()
    }

    /// Data point `j`'s candidates.
    pub fn of(&self, j: usize) -> &[u32] {
        &self.model[self.start[j] as usize..self.start[j + 1] as usize]
    }
}

/// The radius [`Candidates`] should be found with for E-steps at `sigma` while model
/// points move by up to `margin`.
pub fn candidate_radius(sigma: f64, margin: f64) -> f64 {
    CUTOFF_SIGMAS * sigma + margin
}
