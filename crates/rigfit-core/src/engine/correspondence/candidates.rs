//! Each data point's candidate model points for the articulated tracker's E-steps
//! ([`Candidates`]): found once in a [`PointGrid`] within the kernel's cutoff plus a margin,
//! and reused while the model moves less than the margin.

use rayon::prelude::*;

use crate::engine::spatial::PointGrid;
use crate::math::Point3;

/// Clouds of at least this many data points are searched in parallel (smaller ones on the
/// calling thread),
const FOUND_IN_PARALLEL: usize = 512;
/// in runs of this many points.
const FOUND_RUN: usize = 256;

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
        if data.len() < FOUND_IN_PARALLEL || rayon::current_num_threads() < 2 {
            for y in data {
                grid.for_each_within(y, radius, |i, _| self.model.push(i as u32));
                self.start.push(self.model.len() as u32);
            }
            return;
        }
        // Runs of data points searched in parallel, their lists joined in order: the same
        // lists as one pass on the calling thread.
        let grid = &*grid;
        let runs: Vec<(Vec<u32>, Vec<u32>)> = data
            .par_chunks(FOUND_RUN)
            .map(|ys| {
                let (mut found, mut ends) = (Vec::new(), Vec::with_capacity(ys.len()));
                for y in ys {
                    grid.for_each_within(y, radius, |i, _| found.push(i as u32));
                    ends.push(found.len() as u32);
                }
                (found, ends)
            })
            .collect();
        for (found, ends) in runs {
            let base = self.model.len() as u32;
            self.model.extend_from_slice(&found);
            self.start.extend(ends.iter().map(|&e| base + e));
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

#[cfg(test)]
mod tests {
    use super::super::test_clouds::{on_threads, square_grid, winding_cloud};
    use super::*;

    /// Searched on one thread or several, every data point gets the same list, in order.
    #[test]
    fn lists_found_in_parallel_are_the_lists_found_in_turn() {
        let model = square_grid(500, 25);
        let data = winding_cloud(2000, (0.31, 0.07), (0.12, 0.1), 0.0);
        let find = |threads: usize| {
            on_threads(threads, || {
                let mut found = Candidates::default();
                found.find(&data, &model, 0.025, &mut PointGrid::default());
                found
            })
        };
        let (one, two) = (find(1), find(2));
        assert!(one.len() > data.len());
        assert_eq!(one.start, two.start);
        assert_eq!(one.model, two.model);
        for j in [0, 255, 256, 1999] {
            assert!(
                one.of(j)
                    .iter()
                    .all(|&i| { (model[i as usize] - data[j]).norm() <= 0.025 * (1.0 + 1e-12) })
            );
        }
    }
}
