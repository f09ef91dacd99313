//! The probabilistic data term (Cagniart et al. 2010, sections 3.3-3.4): a mixture with one
//! Gaussian component per patch plus a uniform outlier component over the scene's bounding
//! box. For every observed point and patch `P_k`, the component is centred on the deformed
//! position of `v_i^k`, the closest vertex of `P_k` with a compatible normal among the
//! predictions of `P_k` and of its neighbours (the multi-hypothesis mechanism, fig. 1).
//!
//! The predictions go into a kd-tree; each point asks for its nearest few within a cutoff of
//! a few `sigma`, so the cost is linear in the number of points and no points-by-patches
//! matrix is ever formed. Posteriors (eq. 8) are collapsed per vertex into the sums the
//! M-step needs.

use std::num::NonZero;

use kiddo::{ImmutableKdTree, SquaredEuclidean};
use rayon::prelude::*;

use super::model::{PatchModel, PatchPose};
use crate::geometry::Aabb;
use crate::math::{Matrix3, Point3, Vector3};

/// A kd-tree over 3D points (indices into the slice it was built from). Coordinates are
/// stored in single precision relative to the first point: ample for choosing neighbours,
/// and twice as fast to search.
#[derive(Debug)]
pub struct PointTree {
    tree: ImmutableKdTree<f32, 3>,
    origin: [f64; 3],
    len: usize,
}

impl PointTree {
    pub fn new(points: &[[f64; 3]]) -> Self {
        let origin = points.first().copied().unwrap_or([0.0; 3]);
        let local: Vec<[f32; 3]> = points
            .iter()
            .map(|p| [0, 1, 2].map(|a| (p[a] - origin[a]) as f32))
            .collect();
        let tree = ImmutableKdTree::new_from_slice(&local).expect("finite points build a kd-tree");
        Self {
            tree,
            origin,
            len: points.len(),
        }
    }

    fn local(&self, p: &Point3) -> [f32; 3] {
        [0, 1, 2].map(|a| (p[a] - self.origin[a]) as f32)
    }

    /// The index of the nearest point (`0` for an empty tree).
    pub fn nearest(&self, p: &Point3) -> usize {
        if self.len == 0 {
            return 0;
        }
        self.tree
            .query(&self.local(p))
            .nearest_one::<SquaredEuclidean<f32>>()
            .execute()
            .item as usize
    }

    /// Up to `n` nearest points within `radius`, nearest first, with squared distances.
    pub fn nearest_within(&self, p: &Point3, n: usize, radius: f64) -> Vec<(usize, f64)> {
        let Some(n) = NonZero::new(n.min(self.len)) else {
            return Vec::new();
        };
        self.tree
            .query(&self.local(p))
            .nearest_n::<SquaredEuclidean<f32>>(n)
            .within((radius * radius) as f32)
            .execute()
            .into_iter()
            .map(|r| (r.item as usize, r.distance as f64))
            .collect()
    }

    /// The `n` nearest points, nearest first.
    pub fn nearest_n(&self, p: &Point3, n: usize) -> Vec<usize> {
        let Some(n) = NonZero::new(n.min(self.len)) else {
            return Vec::new();
        };
        self.tree
            .query(&self.local(p))
            .nearest_n::<SquaredEuclidean<f32>>(n)
            .execute()
            .into_iter()
            .map(|r| r.item as usize)
            .collect()
    }
}

/// Normals of a point cloud by principal component analysis of each point's `k` nearest
/// neighbours. Their sign is unknown (see [`Observations::oriented`]).
pub fn estimate_normals(points: &[Point3], k: usize) -> Vec<Vector3> {
    let coords: Vec<[f64; 3]> = points.iter().map(|p| [p.x, p.y, p.z]).collect();
    let tree = PointTree::new(&coords);
    points
        .par_iter()
        .map(|p| {
            let near = tree.nearest_n(p, k);
            if near.len() < 3 {
                return Vector3::z();
            }
            let mean = near.iter().map(|&i| points[i].coords).sum::<Vector3>() / near.len() as f64;
            let mut cov = Matrix3::zeros();
            for &i in &near {
                let d = points[i].coords - mean;
                cov += d * d.transpose();
            }
            let eig = cov.symmetric_eigen();
            let smallest = (0..3)
                .min_by(|&a, &b| eig.eigenvalues[a].total_cmp(&eig.eigenvalues[b]))
                .unwrap_or(0);
            eig.eigenvectors
                .column(smallest)
                .into_owned()
                .try_normalize(1e-12)
                .unwrap_or_else(Vector3::z)
        })
        .collect()
}

/// One frame of observed data: points and normals.
#[derive(Clone, Debug, Default)]
pub struct Observations {
    pub points: Vec<Point3>,
    pub normals: Vec<Vector3>,
    /// False when the normals' signs are unknown (estimated from the points): a normal is
    /// then compatible with its opposite too.
    pub oriented: bool,
}

/// Settings of the data term.
#[derive(Clone, Debug)]
pub struct DataTermOptions {
    /// Expected fraction of outlier points: the prior of the uniform component.
    pub outlier_ratio: f64,
    /// Normals are compatible when they make an angle below this (degrees).
    pub normal_angle: f64,
    /// Components farther than this many `sigma` are neglected (the `epsilon` of eq. 7).
    pub cutoff_sigmas: f64,
    /// At most this many predictions are looked at per point.
    pub max_candidates: usize,
}

impl Default for DataTermOptions {
    fn default() -> Self {
        Self {
            outlier_ratio: 0.15,
            normal_angle: 60.0,
            cutoff_sigmas: 3.0,
            max_candidates: 12,
        }
    }
}

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
}

/// Candidates are searched again once a hypothesis moved by this fraction of a mean edge.
const REUSE_DRIFT: f64 = 0.25;

/// The hypotheses and each point's candidates among them, kept between the E-steps of one
/// frame while no prediction has moved by more than a fraction of the mesh's spacing: the
/// kd-tree is then neither rebuilt nor searched again.
#[derive(Clone, Debug, Default)]
pub struct EStepCache {
    /// Each hypothesis: (vertex, patch whose prediction it is).
    keys: Vec<(u32, u32)>,
    /// Where the hypotheses were when the candidates were found.
    found_at: Vec<Point3>,
    /// `candidates[start[i]..start[i + 1]]` are point `i`'s hypotheses.
    start: Vec<u32>,
    candidates: Vec<u32>,
    /// The search radius and the data it was run on (address and length).
    radius: f64,
    data: (usize, usize),
}

impl EStepCache {
    /// Forgets the candidates (the next E-step searches again).
    pub fn clear(&mut self) {
        self.keys.clear();
        self.found_at.clear();
    }
}

/// Runs the E-step: posteriors of every point over the patches and the outlier component
/// (eq. 8), for the deformed mesh `positions` of `pose`.
pub fn e_step(
    model: &PatchModel,
    pose: &PatchPose,
    positions: &[Point3],
    data: &Observations,
    sigma: f64,
    options: &DataTermOptions,
) -> VertexTargets {
    e_step_cached(
        model,
        pose,
        positions,
        data,
        sigma,
        options,
        &mut EStepCache::default(),
    )
}

/// [`e_step`] reusing `cache`'s candidates (each point's nearest hypotheses within the
/// cutoff) while no hypothesis has moved by more than a quarter of a mean edge since they
/// were found and the cutoff has not grown; otherwise the hypotheses are made and searched
/// again and kept in `cache`.
pub fn e_step_cached(
    model: &PatchModel,
    pose: &PatchPose,
    positions: &[Point3],
    data: &Observations,
    sigma: f64,
    options: &DataTermOptions,
    cache: &mut EStepCache,
) -> VertexTargets {
    let n_vertices = model.vertex_count();
    let cutoff = options.cutoff_sigmas * sigma;
    let data_id = (data.points.as_ptr() as usize, data.points.len());
    // Where the cached hypotheses are now, and whether the candidates still hold.
    let now: Vec<Point3> = cache
        .keys
        .par_iter()
        .map(|&(v, l)| model.prediction(pose, l as usize, v as usize))
        .collect();
    let drift = now
        .iter()
        .zip(&cache.found_at)
        .map(|(a, b)| (a - b).norm_squared())
        .fold(0.0, f64::max)
        .sqrt();
    // The candidates are each point's nearest few: they stay its nearest only while the
    // hypotheses move by a fraction of their spacing.
    let valid = !cache.keys.is_empty()
        && cache.data == data_id
        && cutoff <= cache.radius
        && drift <= REUSE_DRIFT * model.mean_edge;
    let now = if valid {
        now
    } else {
        // The hypotheses: for every vertex v of P_k, its prediction by P_k and by each
        // neighbour l of P_k. Predictions that agree with the patch's own (within a fraction
        // of an edge) add nothing and are left out, so a well-registered mesh costs one entry
        // per vertex.
        let merge = 0.3 * model.mean_edge;
        let per_vertex: Vec<Vec<((u32, u32), Point3)>> = (0..n_vertices)
            .into_par_iter()
            .map(|v| {
                let k = model.vertex_patch[v] as usize;
                let own = model.prediction(pose, k, v);
                let mut out = vec![((v as u32, k as u32), own)];
                for &l in &model.neighbours[k] {
                    let p = model.prediction(pose, l as usize, v);
                    if (p - own).norm() > merge {
                        out.push(((v as u32, l), p));
                    }
                }
                out
            })
            .collect();
        let (keys, at): (Vec<(u32, u32)>, Vec<Point3>) = per_vertex.into_iter().flatten().unzip();
        let coords: Vec<[f64; 3]> = at.iter().map(|p| [p.x, p.y, p.z]).collect();
        let tree = PointTree::new(&coords);
        let radius = cutoff;
        let lists: Vec<Vec<u32>> = data
            .points
            .par_iter()
            .map(|y| {
                tree.nearest_within(y, options.max_candidates, radius)
                    .into_iter()
                    .map(|(h, _)| h as u32)
                    .collect()
            })
            .collect();
        cache.start.clear();
        cache.candidates.clear();
        cache.start.push(0);
        for list in lists {
            cache.candidates.extend(list);
            cache.start.push(cache.candidates.len() as u32);
        }
        cache.keys = keys;
        cache.found_at.clone_from(&at);
        cache.radius = radius;
        cache.data = data_id;
        at
    };
    let cache = &*cache;
    // The hypotheses' normals, turned by their patch.
    let now_normal: Vec<Vector3> = cache
        .keys
        .par_iter()
        .map(|&(v, l)| pose.rotation[l as usize] * model.rest_normals[v as usize])
        .collect();

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
    let cos_limit = options.normal_angle.to_radians().cos();

    // Per point: the best vertex of each patch found, its posterior.
    struct Chunk {
        entries: Vec<(u32, u32, f64)>,
        inliers: usize,
        weighted_residual: f64,
    }
    let chunks: Vec<Chunk> = data
        .points
        .par_chunks(1024)
        .enumerate()
        .map(|(c, points)| {
            let mut chunk = Chunk {
                entries: Vec::with_capacity(points.len() * 2),
                inliers: 0,
                weighted_residual: 0.0,
            };
            let mut found: Vec<(usize, usize, f64)> = Vec::with_capacity(16);
            for (j, y) in points.iter().enumerate() {
                let i = c * 1024 + j;
                let ny = data.normals[i];
                found.clear();
                let cut2 = cutoff * cutoff;
                let from = cache.start[i] as usize;
                let to = cache.start[i + 1] as usize;
                for &h in &cache.candidates[from..to] {
                    let h = h as usize;
                    let d2_hypothesis = (y - now[h]).norm_squared();
                    if d2_hypothesis > cut2 {
                        continue;
                    }
                    let (vertex, _) = cache.keys[h];
                    let cos = ny.dot(&now_normal[h]);
                    let compatible = if data.oriented {
                        cos >= cos_limit
                    } else {
                        cos.abs() >= cos_limit
                    };
                    if !compatible {
                        continue;
                    }
                    let v = vertex as usize;
                    let k = model.vertex_patch[v] as usize;
                    // v_i^k: the hypothesis of patch k nearest to y_i.
                    match found.iter_mut().find(|f| f.0 == k) {
                        Some(f) if d2_hypothesis < f.2 => *f = (k, v, d2_hypothesis),
                        Some(_) => {}
                        None => found.push((k, v, d2_hypothesis)),
                    }
                }
                for f in found.iter_mut() {
                    // The component is centred on the deformed vertex (eq. 7).
                    f.2 = (y - positions[f.1]).norm_squared();
                }
                if found.is_empty() {
                    continue;
                }
                // Eq. 8: prior times Gaussian (eq. 7), over the sum with the outlier term.
                let mut total = outlier_density;
                for f in found.iter_mut() {
                    let p = patch_prior[f.0] * gauss_norm * (-f.2 / (2.0 * sigma * sigma)).exp();
                    total += p;
                    // The likelihood replaces the distance from here on.
                    f.2 = p;
                }
                let mut inlier_mass = 0.0;
                for &(_, v, p) in found.iter() {
                    let w = p / total;
                    if w > 1e-8 {
                        inlier_mass += w;
                        chunk.entries.push((i as u32, v as u32, w));
                        chunk.weighted_residual += w * (y - positions[v]).norm_squared();
                    }
                }
                if inlier_mass > 0.5 {
                    chunk.inliers += 1;
                }
            }
            chunk
        })
        .collect();

    let mut targets = VertexTargets {
        weight: vec![0.0; n_vertices],
        weighted_sum: vec![Vector3::zeros(); n_vertices],
        weighted_square: vec![0.0; n_vertices],
        inliers: 0,
        weighted_residual: 0.0,
    };
    for chunk in chunks {
        targets.inliers += chunk.inliers;
        targets.weighted_residual += chunk.weighted_residual;
        for (i, v, w) in chunk.entries {
            let y = data.points[i as usize].coords;
            let v = v as usize;
            targets.weight[v] += w;
            targets.weighted_sum[v] += y * w;
            targets.weighted_square[v] += w * y.norm_squared();
        }
    }
    targets
}
