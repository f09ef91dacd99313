//! The one-sided EM correspondence of Dewaele et al. (2006), section 3: model points are
//! classes, plus one uniform outlier class; each data point's posteriors over the model
//! points and the outlier class sum to one (eq. 17), a model point may take several data
//! points (one-to-many). Only model points within a cutoff of a few `sigma` are visited,
//! so a step costs O(data x neighbours), never data x model.

use rayon::prelude::*;

use super::candidates::{CUTOFF_SIGMAS, Candidates, candidate_radius};
use super::posterior::{Evidence, GaussianKernel};
use crate::engine::spatial::PointGrid;
use crate::math::{Point3, Vector3};

/// Data points per parallel chunk of sums (smaller clouds are summed on the calling thread).
const PARALLEL_CHUNK: usize = 4096;
/// Clouds of at least this many points and at most [`PARALLEL_CHUNK`] find their posteriors
/// in parallel and sum them on the calling thread (smaller ones run on the calling thread).
const VISITED_IN_PARALLEL: usize = 512;
/// The runs such a cloud's posteriors are found in: enough for two threads to share.
const VISIT_RUNS: usize = 4;

/// What one E-step gives the M-step.
#[derive(Clone, Debug, Default)]
pub struct EmStep {
    /// Per model point, `lambda_i = sum_j alpha_ij` (eq. 20), with data weights.
    pub lambda: Vec<f64>,
    /// Per model point, `G_i = sum_j alpha_ij Y_j / lambda_i` (eq. 20); meaningless where
    /// `lambda_i` is zero.
    pub target: Vec<Point3>,
    /// Per data point, its posterior of being an inlier, `sum_i alpha_ij`.
    pub inlier: Vec<f64>,
    /// Per data point, the model point with the largest posterior (`u32::MAX`: none).
    pub best: Vec<u32>,
}

impl EmStep {
    /// Data points whose inlier posterior is at least one half.
    pub fn inlier_count(&self) -> usize {
        self.inlier.iter().filter(|&&a| a >= 0.5).count()
    }
}

/// Per-chunk sums: `lambda` and `sum alpha Y` per model point.
#[derive(Clone)]
struct Sums {
    lambda: Vec<f64>,
    moment: Vec<Vector3>,
}

impl Sums {
    fn new(n: usize) -> Self {
        Self {
            lambda: vec![0.0; n],
            moment: vec![Vector3::zeros(); n],
        }
    }

    fn merge(mut self, other: Sums) -> Sums {
        for i in 0..self.lambda.len() {
            self.lambda[i] += other.lambda[i];
            self.moment[i] += other.moment[i];
        }
        self
    }
}

/// Points with a weight each (how many points each stands for; 1 for all when `None`).
#[derive(Debug, Clone, Copy)]
pub struct WeightedPoints<'a> {
    pub points: &'a [Point3],
    pub weights: Option<&'a [f64]>,
}

impl<'a> WeightedPoints<'a> {
    /// Every point with weight 1.
    pub fn unit(points: &'a [Point3]) -> Self {
        Self {
            points,
            weights: None,
        }
    }
}

/// One E-step (eq. 17) of data points against model points (each standing for its weight
/// in points) at width `sigma`, with outlier constant `outlier_c`. `grid` is rebuilt over
/// the model, and each data point's neighbours within the kernel's cutoff are read from it
/// as they are used (no candidate lists are kept).
pub fn em_step(
    data: WeightedPoints<'_>,
    model: WeightedPoints<'_>,
    sigma: f64,
    outlier_c: f64,
    grid: &mut PointGrid,
    out: &mut EmStep,
) {
    let cutoff = candidate_radius(sigma, 0.0);
    grid.rebuild(model.points, cutoff);
    let neighbours = GridNeighbours { grid, cutoff };
    em_step_over(data, model, sigma, outlier_c, &neighbours, out);
}

/// [`em_step`] over neighbours found beforehand: only `candidates` are considered, and of
/// them those within the kernel's cutoff of their data point now.
pub fn em_step_with(
    data: WeightedPoints<'_>,
    model: WeightedPoints<'_>,
    sigma: f64,
    outlier_c: f64,
    candidates: &Candidates,
    out: &mut EmStep,
) {
    let neighbours = ListedNeighbours {
        candidates,
        model: model.points,
    };
    em_step_over(data, model, sigma, outlier_c, &neighbours, out);
}

/// Where an E-step finds each data point's model neighbours.
trait Neighbours: Sync {
    /// Hands `f(model index, squared distance)` the neighbours of data point `j` at `y`.
    fn each(&self, j: usize, y: &Point3, f: impl FnMut(usize, f64));
}

/// Read from a grid over the model as they are used.
struct GridNeighbours<'a> {
    grid: &'a PointGrid,
    cutoff: f64,
}

impl Neighbours for GridNeighbours<'_> {
    fn each(&self, _: usize, y: &Point3, f: impl FnMut(usize, f64)) {
        self.grid.for_each_within(y, self.cutoff, f);
    }
}

/// Found beforehand ([`Candidates`]).
struct ListedNeighbours<'a> {
    candidates: &'a Candidates,
    model: &'a [Point3],
}

impl Neighbours for ListedNeighbours<'_> {
    fn each(&self, j: usize, y: &Point3, mut f: impl FnMut(usize, f64)) {
        for &i in self.candidates.of(j) {
            let i = i as usize;
            f(i, (self.model[i] - y).norm_squared());
        }
    }
}

/// The E-step over each data point's `neighbours`: those beyond the kernel's cutoff are
/// skipped.
fn em_step_over(
    data: WeightedPoints<'_>,
    model: WeightedPoints<'_>,
    sigma: f64,
    outlier_c: f64,
    neighbours: &impl Neighbours,
    out: &mut EmStep,
) {
    let (data, data_weight) = (data.points, data.weights);
    let model_weight = model.weights;
    let n = model.points.len();
    let cutoff2 = (CUTOFF_SIGMAS * sigma).powi(2);
    let kernel = GaussianKernel::new(sigma);
    out.inlier.clear();
    out.inlier.resize(data.len(), 0.0);
    out.best.clear();
    out.best.resize(data.len(), u32::MAX);

    // For one data point: its posteriors (eq. 17), each neighbour's `alpha_ij * w_j` into
    // `found`; returns (inlier, best).
    let posteriors_of = |j: usize, y: &Point3, found: &mut Vec<(usize, f64)>| {
        found.clear();
        let mut evidence = Evidence::new();
        neighbours.each(j, y, |i, d2| {
            if d2 <= cutoff2 {
                let e = model_weight.map_or(1.0, |w| w[i]) * kernel.fast(d2);
                evidence.add(e);
                found.push((i, e));
            }
        });
        if evidence.total() == 0.0 {
            found.clear();
            return (0.0, u32::MAX);
        }
        let wj = data_weight.map_or(1.0, |w| w[j]);
        let norm = evidence.normaliser(outlier_c);
        let mut best = (0.0, u32::MAX);
        for (i, e) in found.iter_mut() {
            let a = *e * norm;
            if a > best.0 {
                best = (a, *i as u32);
            }
            *e = a * wj;
        }
        (evidence.total() * norm, best.1)
    };
    // A point's posteriors into `sums` (eq. 20's lambda and moment).
    let add = |sums: &mut Sums, y: &Point3, i: usize, w: f64| {
        sums.lambda[i] += w;
        sums.moment[i] += y.coords * w;
    };
    let visit = |j: usize, y: &Point3, sums: &mut Sums, found: &mut Vec<(usize, f64)>| {
        let (inlier, best) = posteriors_of(j, y, found);
        for &(i, w) in found.iter() {
            add(sums, y, i, w);
        }
        (inlier, best)
    };

    let sums = if data.len() < VISITED_IN_PARALLEL || rayon::current_num_threads() < 2 {
        let mut sums = Sums::new(n);
        let mut scratch = Vec::new();
        for (j, y) in data.iter().enumerate() {
            let (a, b) = visit(j, y, &mut sums, &mut scratch);
            out.inlier[j] = a;
            out.best[j] = b;
        }
        sums
    } else if data.len() <= PARALLEL_CHUNK {
        // The points' posteriors found in parallel, then summed in order: the same sums,
        // to the last bit, as one pass on the calling thread.
        let run = data.len().div_ceil(VISIT_RUNS);
        // Per run, each point's posteriors after a marker (`u32::MAX`).
        let runs: Vec<Vec<(u32, f64)>> = data
            .par_chunks(run)
            .zip(out.inlier.par_chunks_mut(run))
            .zip(out.best.par_chunks_mut(run))
            .enumerate()
            .map(|(c, ((ys, inl), best))| {
                let mut posteriors = Vec::with_capacity(16 * ys.len());
                let mut found = Vec::new();
                for (k, y) in ys.iter().enumerate() {
                    (inl[k], best[k]) = posteriors_of(c * run + k, y, &mut found);
                    posteriors.push((u32::MAX, 0.0));
                    posteriors.extend(found.iter().map(|&(i, w)| (i as u32, w)));
                }
                posteriors
            })
            .collect();
        let mut sums = Sums::new(n);
        let mut points = data.iter();
        let mut y = &data[0];
        for (i, w) in runs.iter().flatten().copied() {
            match i {
                u32::MAX => y = points.next().expect("a marker per point"),
                i => add(&mut sums, y, i as usize, w),
            }
        }
        sums
    } else {
        data.par_chunks(PARALLEL_CHUNK)
            .zip(out.inlier.par_chunks_mut(PARALLEL_CHUNK))
            .zip(out.best.par_chunks_mut(PARALLEL_CHUNK))
            .enumerate()
            .map(|(c, ((ys, inl), best))| {
                let mut sums = Sums::new(n);
                let mut scratch = Vec::new();
                for (k, y) in ys.iter().enumerate() {
                    let (a, b) = visit(c * PARALLEL_CHUNK + k, y, &mut sums, &mut scratch);
                    inl[k] = a;
                    best[k] = b;
                }
                sums
            })
            .reduce(|| Sums::new(n), Sums::merge)
    };
    out.lambda.clear();
    out.lambda.extend_from_slice(&sums.lambda);
    out.target.clear();
    out.target.extend(
        sums.moment
            .iter()
            .zip(&sums.lambda)
            .map(|(m, &l)| Point3::from(if l > 0.0 { m / l } else { *m })),
    );
}

#[cfg(test)]
mod tests {
    use super::super::test_clouds::{on_threads, square_grid, winding_cloud};
    use super::*;
    use crate::engine::correspondence::DEWAELE_OUTLIER_CONSTANT;

    /// Brute-force eq. (17) on a small case.
    #[test]
    fn posteriors_match_the_formula() {
        let model = vec![
            Point3::new(0.0, 0.0, 0.0),
            Point3::new(0.1, 0.0, 0.0),
            Point3::new(0.0, 0.2, 0.0),
        ];
        let data = vec![
            Point3::new(0.02, 0.01, 0.0),
            Point3::new(0.09, 0.0, 0.01),
            Point3::new(5.0, 5.0, 5.0),
        ];
        let sigma = 0.05;
        let mut grid = PointGrid::default();
        let mut out = EmStep::default();
        em_step(
            WeightedPoints::unit(&data),
            WeightedPoints::unit(&model),
            sigma,
            DEWAELE_OUTLIER_CONSTANT,
            &mut grid,
            &mut out,
        );
        let kernel = |y: &Point3, x: &Point3| {
            let d2 = (y - x).norm_squared();
            if d2.sqrt() <= CUTOFF_SIGMAS * sigma {
                (-d2 / (2.0 * sigma * sigma)).exp()
            } else {
                0.0
            }
        };
        for i in 0..model.len() {
            let mut lambda = 0.0;
            let mut moment = Vector3::zeros();
            for y in &data {
                let total: f64 = model.iter().map(|x| kernel(y, x)).sum();
                let a = kernel(y, &model[i]) / (total + DEWAELE_OUTLIER_CONSTANT);
                lambda += a;
                moment += y.coords * a;
            }
            approx::assert_relative_eq!(out.lambda[i], lambda, max_relative = 1e-6);
            if lambda > 0.0 {
                approx::assert_relative_eq!(out.target[i].coords, moment / lambda, epsilon = 1e-9);
            }
        }
        assert_eq!(out.inlier[2], 0.0);
        assert_eq!(out.best[2], u32::MAX);
        assert_eq!(out.best[0], 0);
        assert_eq!(out.best[1], 1);
        // One model point's kernel (at most 1) cannot outweigh c ~ 3.76: a datum is an
        // inlier only where the model is dense at the scale of sigma.
        assert_eq!(out.inlier_count(), 0);
        assert!(out.inlier[0] > 0.1);
    }

    /// A cloud small enough to be summed on one thread gives the same bits whether its
    /// posteriors were found on one thread or several.
    #[test]
    fn posteriors_found_in_parallel_sum_to_the_same_bits() {
        let model = square_grid(400, 20);
        let data = winding_cloud(3000, (0.37, 0.11), (0.1, 0.1), 0.002);
        let weights: Vec<f64> = (0..data.len()).map(|i| 1.0 + (i % 3) as f64).collect();
        let run = |threads: usize| {
            on_threads(threads, || {
                let mut grid = PointGrid::default();
                let mut out = EmStep::default();
                let data = WeightedPoints {
                    points: &data,
                    weights: Some(&weights),
                };
                em_step(
                    data,
                    WeightedPoints::unit(&model),
                    0.015,
                    3.76,
                    &mut grid,
                    &mut out,
                );
                out
            })
        };
        let (one, two) = (run(1), run(2));
        assert!(one.lambda.iter().any(|&l| l > 0.0));
        assert_eq!(one.lambda, two.lambda);
        assert_eq!(one.target, two.target);
        assert_eq!(one.inlier, two.inlier);
        assert_eq!(one.best, two.best);
    }

    #[test]
    fn parallel_and_serial_agree() {
        let model = square_grid(300, 17);
        let data: Vec<Point3> = (0..10_000)
            .map(|i| Point3::new((i % 97) as f64 * 0.0017, (i / 97) as f64 * 0.0017, 0.003))
            .collect();
        let mut grid = PointGrid::default();
        let (mut a, mut b) = (EmStep::default(), EmStep::default());
        em_step(
            WeightedPoints::unit(&data),
            WeightedPoints::unit(&model),
            0.01,
            3.76,
            &mut grid,
            &mut a,
        );
        let mut lam = vec![0.0; model.len()];
        for chunk in data.chunks(1000) {
            em_step(
                WeightedPoints::unit(chunk),
                WeightedPoints::unit(&model),
                0.01,
                3.76,
                &mut grid,
                &mut b,
            );
            for i in 0..lam.len() {
                lam[i] += b.lambda[i];
            }
        }
        for i in 0..lam.len() {
            approx::assert_relative_eq!(a.lambda[i], lam[i], epsilon = 1e-9);
        }
    }
}
