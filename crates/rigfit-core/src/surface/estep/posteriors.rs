//! The posteriors of the E-step (Cagniart et al. 2010, eq. 8): for each point, each patch's
//! prior times its Gaussian (eq. 7) centred on the deformed vertex nearest to the point
//! among the patch's compatible candidates, over their sum with the uniform outlier
//! component; collapsed per vertex into the sums the M-step needs ([`VertexTargets`]).

use rayon::prelude::*;

use super::candidates::{ActiveRanks, EStepCache, MAX_SLOTS};
use super::hypotheses::Hypotheses;
use super::{DataTermOptions, Observations, refill};
use crate::engine::correspondence::{Evidence, GaussianKernel};
use crate::engine::spatial::{distance2, to_local};
use crate::geometry::Aabb;
use crate::math::{Point3, Vector3};
use crate::surface::model::PatchModel;

/// The E-step's output, collapsed per vertex: `sum_i w_iv`, `sum_i w_iv y_i` and
/// `sum_i w_iv |y_i|^2`, where `w_iv` is the posterior (eq. 8) of the component whose
/// closest vertex for `y_i` is `v`.
#[derive(Clone, Debug, Default)]
pub struct VertexTargets {
    pub weight: Vec<f64>,
    pub weighted_sum: Vec<Vector3>,
    pub weighted_square: Vec<f64>,
    /// Points whose outlier posterior is below one half.
    pub inliers: usize,
    /// `sum_ik w_ik |y_i - x(v_i^k)|^2` at the E-step's positions.
    pub weighted_residual: f64,
}

impl VertexTargets {
    /// `sum_v sum_i w_iv |y_i - x(v)|^2` for new positions.
    pub fn residual(&self, positions: &[Point3]) -> f64 {
        positions
            .iter()
            .enumerate()
            .map(|(v, x)| {
                self.weight[v] * x.coords.norm_squared() - 2.0 * x.coords.dot(&self.weighted_sum[v])
                    + self.weighted_square[v]
            })
            .sum::<f64>()
            .max(0.0)
    }

    pub fn total_weight(&self) -> f64 {
        self.weight.iter().sum()
    }

    /// Zero sums for `n_vertices` vertices, written over these (their buffers reused).
    fn reset(&mut self, n_vertices: usize) {
        refill(&mut self.weight, n_vertices, 0.0);
        refill(&mut self.weighted_sum, n_vertices, Vector3::zeros());
        refill(&mut self.weighted_square, n_vertices, 0.0);
        self.inliers = 0;
        self.weighted_residual = 0.0;
    }

    /// Adds another task's sums.
    fn add_sums(&mut self, other: &Self) {
        for (x, y) in self.weight.iter_mut().zip(&other.weight) {
            *x += y;
        }
        for (x, y) in self.weighted_sum.iter_mut().zip(&other.weighted_sum) {
            *x += y;
        }
        for (x, y) in self.weighted_square.iter_mut().zip(&other.weighted_square) {
            *x += y;
        }
        self.inliers += other.inliers;
        self.weighted_residual += other.weighted_residual;
    }
}

/// Points per parallel task of the posterior loop.
const POSTERIOR_CHUNK: usize = 1024;

/// The mixture's terms of one E-step, the same for every point (eq. 7-8).
pub(super) struct Mixture {
    /// Each patch's prior: the inliers' share in proportion to the patch's area.
    patch_prior: Vec<f64>,
    /// The outlier prior over the scene's volume (the uniform component).
    outlier_density: f64,
    /// The Gaussian's normalisation, `(2 pi sigma^2)^(-3/2)`.
    gauss_norm: f64,
    /// The Gaussian's kernel (eq. 7).
    kernel: GaussianKernel,
    /// Normals are compatible when their cosine is at least this.
    cos_limit: f32,
    /// Hypotheses farther than the cutoff (this squared) are neglected.
    cut2: f32,
}

impl Mixture {
    /// The terms for the deformed mesh `positions`, `sigma` and components neglected beyond
    /// `cutoff`.
    pub(super) fn new(
        model: &PatchModel,
        data: &Observations,
        positions: &[Point3],
        sigma: f64,
        cutoff: f64,
        options: &DataTermOptions,
    ) -> Self {
        let cut2 = cutoff * cutoff;
        // Priors: the outlier ratio, and the rest in proportion to patch areas.
        let total_area: f64 = model.area.iter().sum();
        let outlier_prior = options.outlier_ratio.clamp(1e-6, 1.0 - 1e-6);
        let patch_prior: Vec<f64> = model
            .area
            .iter()
            .map(|&a| {
                (1.0 - outlier_prior)
                    * if total_area > 0.0 {
                        a / total_area
                    } else {
                        1.0 / model.patch_count() as f64
                    }
            })
            .collect();
        // The uniform component over the scene's bounding box (points and mesh).
        let scene = Aabb::from_points(data.points.iter().chain(positions.iter()));
        let volume = scene
            .map(|b| {
                let e = b.extent();
                let floor = 1e-3 * model.diagonal;
                e.x.max(floor) * e.y.max(floor) * e.z.max(floor)
            })
            .unwrap_or(1.0);
        let outlier_density = outlier_prior / volume;
        let gauss_norm = (2.0 * std::f64::consts::PI * sigma * sigma).powf(-1.5);
        let cos_limit = options.normal_angle.to_radians().cos() as f32;
        let cut2_single = cut2 as f32;

        Self {
            patch_prior,
            outlier_density,
            gauss_norm,
            kernel: GaussianKernel::new(sigma),
            cos_limit,
            cut2: cut2_single,
        }
    }
}

/// The hypothesis of one patch nearest to a point among its compatible candidates (`v_i^k`):
/// the patch, the vertex and the squared distance to the hypothesis.
#[derive(Clone, Copy, Debug)]
struct PatchNearest {
    patch: u32,
    vertex: u32,
    d2: f64,
}

/// One component of a point: the squared distance to its deformed vertex and its prior
/// times its Gaussian.
#[derive(Clone, Copy, Debug)]
struct Likelihood {
    d2: f64,
    p: f64,
}

/// Posteriors (eq. 8) summed per vertex over the points taking part, with each point's
/// candidates from `cache`: each task (one per thread) adds its points into its own sums, and
/// the tasks' sums are added at the end. The sums are written over the buffers of `spare`
/// (sums no longer needed: fresh buffers of a whole mesh's size cost page faults).
pub(super) fn posteriors(
    model: &PatchModel,
    mixture: &Mixture,
    hypotheses: &Hypotheses,
    positions: &[Point3],
    data: &Observations,
    cache: &EStepCache,
    spare: &mut Vec<VertexTargets>,
) -> VertexTargets {
    let n_vertices = model.vertex_count();
    let slots = cache.slots;
    let ActiveRanks { stride, active } = cache.active_ranks(data.points.len());
    let chunks = active.div_ceil(POSTERIOR_CHUNK);
    // As many tasks as threads: each task's sums are a whole mesh's to zero and to add.
    let per_task = chunks.div_ceil(rayon::current_num_threads()).max(1);
    let tasks = chunks.div_ceil(per_task).max(1);
    spare.resize_with(tasks, VertexTargets::default);
    let mut task_sums = std::mem::take(spare);
    task_sums
        .par_iter_mut()
        .enumerate()
        .for_each(|(task, sums)| {
            sums.reset(n_vertices);
            // Per point: the best vertex of each patch found, and then its squared distance to
            // the deformed vertex and its likelihood.
            let mut found = [PatchNearest {
                patch: 0,
                vertex: 0,
                d2: 0.0,
            }; MAX_SLOTS];
            let mut likelihood = [Likelihood { d2: 0.0, p: 0.0 }; MAX_SLOTS];
            let points = task * per_task * POSTERIOR_CHUNK
                ..((task + 1) * per_task * POSTERIOR_CHUNK).min(active);
            for a in points {
                let r = a * stride;
                let i = cache.order[r] as usize;
                let count = stands_for(data, cache, r, stride);
                let list = &cache.list[r * slots..][..cache.count[r] as usize];
                let n_found = nearest_per_patch(mixture, hypotheses, data, i, list, &mut found);
                if n_found == 0 {
                    continue;
                }
                add_posteriors(
                    sums,
                    mixture,
                    positions,
                    &data.points[i],
                    count,
                    &found[..n_found],
                    &mut likelihood,
                );
            }
        });
    let mut tasks = task_sums.into_iter();
    let mut total = tasks.next().expect("one task at least");
    for sums in tasks {
        total.add_sums(&sums);
        spare.push(sums);
    }
    total
}

/// How many observed points the point at rank `r` stands for: its own count, and when the
/// E-step is thinned, those of the points up to the next rank taking part.
#[inline]
fn stands_for(data: &Observations, cache: &EStepCache, r: usize, stride: usize) -> f64 {
    if stride == 1 {
        data.count(cache.order[r] as usize) as f64
    } else {
        cache.order[r..(r + stride).min(data.points.len())]
            .iter()
            .map(|&j| data.count(j as usize) as f64)
            .sum()
    }
}

/// Point `i`'s nearest compatible hypothesis of each patch among its candidates `list`
/// (within the cutoff, normals within the angle), written to `found`; returns how many
/// patches have one.
#[inline]
fn nearest_per_patch(
    mixture: &Mixture,
    hypotheses: &Hypotheses,
    data: &Observations,
    i: usize,
    list: &[u32],
    found: &mut [PatchNearest; MAX_SLOTS],
) -> usize {
    let y = &data.points[i];
    let ny = data.normals[i];
    let mut n_found = 0;
    let y_local = to_local(y, &hypotheses.origin);
    let ny_single = [ny.x as f32, ny.y as f32, ny.z as f32];
    for &e in list {
        let h = &hypotheses.packed[e as usize];
        let d2_hypothesis = distance2(&h.at, &y_local);
        if d2_hypothesis > mixture.cut2 {
            continue;
        }
        let cos =
            ny_single[0] * h.normal[0] + ny_single[1] * h.normal[1] + ny_single[2] * h.normal[2];
        let compatible = if data.oriented {
            cos >= mixture.cos_limit
        } else {
            cos.abs() >= mixture.cos_limit
        };
        if !compatible {
            continue;
        }
        let d2_hypothesis = d2_hypothesis as f64;
        let nearest = PatchNearest {
            patch: h.patch,
            vertex: h.vertex,
            d2: d2_hypothesis,
        };
        // v_i^k: the hypothesis of patch k nearest to y_i.
        match found[..n_found].iter_mut().find(|f| f.patch == h.patch) {
            Some(f) if d2_hypothesis < f.d2 => *f = nearest,
            Some(_) => {}
            None => {
                found[n_found] = nearest;
                n_found += 1;
            }
        }
    }
    n_found
}

/// Adds the posteriors of point `y` (eq. 8) over the patches `found` to `sums`, the point
/// counted as the `count` points it stands for (`likelihood`: scratch, as long as `found`).
#[inline]
fn add_posteriors(
    sums: &mut VertexTargets,
    mixture: &Mixture,
    positions: &[Point3],
    y: &Point3,
    count: f64,
    found: &[PatchNearest],
    likelihood: &mut [Likelihood; MAX_SLOTS],
) {
    // Eq. 8: prior times Gaussian (eq. 7), over the sum with the outlier term; the
    // component is centred on the deformed vertex.
    let mut evidence = Evidence::starting_at(mixture.outlier_density);
    for (f, l) in found.iter().zip(likelihood.iter_mut()) {
        let d2 = (y - positions[f.vertex as usize]).norm_squared();
        let p =
            mixture.patch_prior[f.patch as usize] * mixture.gauss_norm * mixture.kernel.exact(d2);
        evidence.add(p);
        *l = Likelihood { d2, p };
    }
    let (square, mut inlier_mass) = (y.coords.norm_squared(), 0.0);
    for (f, l) in found.iter().zip(likelihood.iter()) {
        let w = evidence.posterior(l.p);
        if w > 1e-8 {
            inlier_mass += w;
            // A merged or thinned point counts as the points it stands for.
            let (v, w) = (f.vertex as usize, w * count);
            sums.weight[v] += w;
            sums.weighted_sum[v] += y.coords * w;
            sums.weighted_square[v] += w * square;
            sums.weighted_residual += w * l.d2;
        }
    }
    if inlier_mass > 0.5 {
        sums.inliers += count as usize;
    }
}
