//! The probabilistic data term (Cagniart et al. 2010, sections 3.3-3.4): a mixture with one
//! Gaussian component per patch plus a uniform outlier component over the scene's bounding
//! box. For every observed point and patch `P_k`, the component is centred on the deformed
//! position of `v_i^k`, the closest vertex of `P_k` with a compatible normal among the
//! predictions of `P_k` and of its neighbours (the multi-hypothesis mechanism, fig. 1).
//!
//! Each point keeps a list of its nearest few predictions within a cutoff of a few `sigma`,
//! found in a kd-tree ([`super::nearest`]) on a frame's first E-step and searched again only
//! where the mesh around the listed vertices has moved ([`EStepCache`]). The cost is linear in the number of points and no
//! points-by-patches matrix is ever formed. Posteriors (eq. 8) are collapsed per vertex into
//! the sums the M-step needs.

use rayon::prelude::*;

use super::model::{PatchModel, PatchPose, Predictions};
use super::nearest::{NearTree, NearestFew};
use super::point_tree::PointTree;
use crate::geometry::Aabb;
use crate::math::{Matrix3, Point3, Vector3};

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
    /// How many observed points each point stands for (see [`Observations::merged`]); empty
    /// when each stands for itself.
    pub counts: Vec<u32>,
}

impl Observations {
    /// How many observed points point `i` stands for.
    #[inline]
    pub fn count(&self, i: usize) -> u32 {
        self.counts.get(i).copied().unwrap_or(1)
    }

    /// The points merged by cubes of side `cell` and by normal direction (the axis the normal
    /// is closest to, and its sign when normals are oriented, so that the two sides of a
    /// thin part stay apart): one point per group at the mean of its points, with their
    /// mean normal, standing for all of them. The E-step counts each merged point as many
    /// times, so the data term is the full cloud's with every point moved to its group's
    /// mean (which also averages the sensor's noise), while the search and the posteriors
    /// cost a fraction. Cubes of about two point spacings keep the means within a small
    /// fraction of a spacing of a curved surface.
    pub fn merged(&self, cell: f64) -> Observations {
        if !(cell > 0.0 && cell.is_finite()) || self.points.len() < 2 {
            return self.clone();
        }
        let Some(bounds) = Aabb::from_points(&self.points) else {
            return self.clone();
        };
        const SIDE: u64 = (1 << 20) - 1;
        let cube = |x: f64, low: f64| (((x - low) / cell) as u64).min(SIDE);
        let mut keyed: Vec<(u64, u32)> = self
            .points
            .iter()
            .zip(&self.normals)
            .enumerate()
            .map(|(i, (p, n))| {
                let axis = (0..3)
                    .max_by(|&a, &b| n[a].abs().total_cmp(&n[b].abs()))
                    .unwrap_or(0);
                let side = if self.oriented && n[axis] < 0.0 { 3 } else { 0 };
                let key = cube(p.x, bounds.min.x)
                    | (cube(p.y, bounds.min.y) << 20)
                    | (cube(p.z, bounds.min.z) << 40)
                    | (((axis + side) as u64) << 60);
                (key, i as u32)
            })
            .collect();
        keyed.sort_unstable();
        let mut merged = Observations {
            oriented: self.oriented,
            ..Observations::default()
        };
        for group in keyed.chunk_by(|a, b| a.0 == b.0) {
            let first = self.normals[group[0].1 as usize];
            let (mut sum, mut normal, mut count) = (Vector3::zeros(), Vector3::zeros(), 0u32);
            for &(_, i) in group {
                let (i, c) = (i as usize, self.count(i as usize));
                sum += self.points[i].coords * c as f64;
                let n = self.normals[i];
                // Unoriented normals: turned to agree with the group's first.
                normal += if n.dot(&first) < 0.0 { -n } else { n } * c as f64;
                count += c;
            }
            merged.points.push(Point3::from(sum / count.max(1) as f64));
            merged
                .normals
                .push(normal.try_normalize(1e-12).unwrap_or(first));
            merged.counts.push(count);
        }
        merged
    }
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

/// A point's list is searched again once the hypotheses of its listed vertices, or of their
/// neighbours, moved by this fraction of a mean edge since it was searched.
const REUSE_DRIFT: f64 = 0.25;

/// The most candidates a point keeps (`DataTermOptions::max_candidates` is clamped to it).
const MAX_SLOTS: usize = super::nearest::MAX_NEAREST;

/// Each point's candidates, kept between the E-steps of one frame: the nearest few hypotheses
/// (blend entries: vertex `v` predicted by patch `l`) within the cutoff. The first E-step on a
/// frame searches a kd-tree for every point; the next ones search again only the points whose
/// listed vertices' hypotheses (or their neighbours') moved by more than [`REUSE_DRIFT`] of an
/// edge since their search (most of the mesh settles within a few iterations). A point with
/// no candidates is searched again only when the mesh may have come within its cutoff: its
/// list was complete within `cover` when searched, and no hypothesis has moved more than the
/// drift summed since. Points are visited in a spatial (Morton) order, so that neighbouring
/// points read neighbouring memory.
///
/// A thinned E-step ([`EStepCache::set_stride`]) uses the points at ranks `0, s, 2s, ...` of
/// that order, each standing for itself and the `s - 1` after it: an even spread over the
/// surface. Their lists stay in the cache, so the first E-step on every point searches only
/// the others.
#[derive(Clone, Debug, Default)]
pub struct EStepCache {
    /// The data the lists are for (address and length).
    data: (usize, usize),
    /// Slots per point (`max_candidates`).
    slots: usize,
    /// The points in visiting order; the per-point arrays below are in that order.
    order: Vec<u32>,
    /// `list[r * slots..][..count[r]]`: the candidates of point `order[r]`, in no particular order.
    list: Vec<u32>,
    count: Vec<u8>,
    /// The radius within which the list was complete when it was searched, and the E-step
    /// that searched it ([`NEVER_SEARCHED`] if none has).
    cover: Vec<f64>,
    searched_at: Vec<u32>,
    /// One point in `stride` (by rank) takes part in the E-steps (0 and 1: every point).
    stride: usize,
    /// `drift[t]`: the largest move of any hypothesis, summed over E-steps `1..=t`.
    drift: Vec<f64>,
    /// Every blend entry's prediction at the last E-step.
    previous: Vec<Point3>,
    /// `vertex_drift[t][v]`: how far the hypotheses of `v` and of its neighbours moved (the
    /// largest), summed over E-steps `1..=t`.
    vertex_drift: Vec<Vec<f32>>,
}

impl EStepCache {
    /// Forgets the candidates (the next E-step searches again).
    pub fn clear(&mut self) {
        self.data = (0, 0);
        self.previous.clear();
        self.drift.clear();
    }

    /// The next E-steps use one point in `stride` of the visiting order, each counted as the
    /// points it stands for (1: every point).
    pub fn set_stride(&mut self, stride: usize) {
        self.stride = stride.max(1);
    }
}

/// `searched_at` of a point no E-step has searched yet.
const NEVER_SEARCHED: u32 = u32::MAX;

/// Points per parallel task of the posterior loop.
const POSTERIOR_CHUNK: usize = 1024;

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

/// The points' indices sorted along a Morton (Z-order) curve over their bounding box.
fn morton_order(points: &[Point3]) -> Vec<u32> {
    let Some(bounds) = Aabb::from_points(points) else {
        return Vec::new();
    };
    let extent = bounds.extent();
    let scale = 1023.0 / extent.x.max(extent.y).max(extent.z).max(1e-300);
    // Spreads the low 10 bits of `x` to every third bit.
    let spread = |x: u64| {
        let mut x = x & 0x3ff;
        x = (x | (x << 16)) & 0x0300_00ff;
        x = (x | (x << 8)) & 0x0300_f00f;
        x = (x | (x << 4)) & 0x030c_30c3;
        (x | (x << 2)) & 0x0924_9249
    };
    let mut keyed: Vec<(u64, u32)> = points
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let q = (p - bounds.min) * scale;
            let code = spread(q.x as u64) | (spread(q.y as u64) << 1) | (spread(q.z as u64) << 2);
            (code, i as u32)
        })
        .collect();
    keyed.sort_unstable();
    keyed.into_iter().map(|(_, i)| i).collect()
}

/// The hypotheses of a pose that are worth a look, vertex by vertex: each vertex predicted by
/// its own patch, and by each neighbouring patch whose prediction differs from that by more
/// than `merge` (eq. 1; the others add nothing).
struct Hypotheses {
    /// Every blend entry packed for the posterior loop, which reads them in random order.
    packed: Vec<PackedHypothesis>,
    /// The blend entries kept, vertex by vertex, and their positions in single precision
    /// relative to `origin` (for choosing neighbours, not for the posteriors).
    entry: Vec<u32>,
    origin: Point3,
    local: Vec<[f32; 3]>,
}

/// One blend entry `(l, v)` in one cache line's half: the prediction of `v` by patch `l`
/// relative to the origin, `v`'s normal turned by `l` (single precision: they choose and
/// screen candidates, the posteriors use the blended positions), `v` and `v`'s own patch.
#[derive(Clone, Copy, Debug, Default)]
struct PackedHypothesis {
    at: [f32; 3],
    vertex: u32,
    normal: [f32; 3],
    patch: u32,
}

impl Hypotheses {
    fn new(model: &PatchModel, predictions: &Predictions, merge: f64) -> Self {
        let at = &predictions.at;
        let origin = at.first().copied().unwrap_or_else(Point3::origin);
        let packed: Vec<PackedHypothesis> = (0..at.len())
            .into_par_iter()
            .map(|e| {
                let v = model.blend_vertex[e] as usize;
                let normal = predictions.normal[e];
                PackedHypothesis {
                    at: to_local(&at[e], &origin),
                    vertex: v as u32,
                    normal: [normal.x as f32, normal.y as f32, normal.z as f32],
                    patch: model.vertex_patch[v],
                }
            })
            .collect();
        let merge2 = merge * merge;
        let mut entry = Vec::with_capacity(model.vertex_count() * 2);
        let mut local = Vec::with_capacity(model.vertex_count() * 2);
        for v in 0..model.vertex_count() {
            let entries = model.blend_entries(v);
            let first = entries.start;
            for e in entries {
                if e == first || (at[e] - at[first]).norm_squared() > merge2 {
                    entry.push(e as u32);
                    local.push(packed[e].at);
                }
            }
        }
        Self {
            packed,
            entry,
            origin,
            local,
        }
    }
}

/// Squared distance in single precision.
#[inline]
fn distance2(a: &[f32; 3], b: &[f32; 3]) -> f32 {
    let (dx, dy, dz) = (a[0] - b[0], a[1] - b[1], a[2] - b[2]);
    dx * dx + dy * dy + dz * dz
}

/// A point searched again: its rank, the length of its new list and the list's cover.
type Searched = (u32, u8, f64);

/// `p - origin` in single precision.
#[inline]
pub(super) fn to_local(p: &Point3, origin: &Point3) -> [f32; 3] {
    [
        (p.x - origin.x) as f32,
        (p.y - origin.y) as f32,
        (p.z - origin.z) as f32,
    ]
}

/// [`e_step`] keeping each point's candidates in `cache` between the E-steps of a frame (see
/// [`EStepCache`]).
pub fn e_step_cached(
    model: &PatchModel,
    pose: &PatchPose,
    positions: &[Point3],
    data: &Observations,
    sigma: f64,
    options: &DataTermOptions,
    cache: &mut EStepCache,
) -> VertexTargets {
    let predictions = model.predictions(pose);
    e_step_predicted(model, &predictions, positions, data, sigma, options, cache)
}

/// [`e_step_cached`] from the pose's [`Predictions`], already computed.
pub fn e_step_predicted(
    model: &PatchModel,
    predictions: &Predictions,
    positions: &[Point3],
    data: &Observations,
    sigma: f64,
    options: &DataTermOptions,
    cache: &mut EStepCache,
) -> VertexTargets {
    let n_vertices = model.vertex_count();
    let n_points = data.points.len();
    let cutoff = options.cutoff_sigmas * sigma;
    let cut2 = cutoff * cutoff;
    let slots = options.max_candidates.clamp(1, MAX_SLOTS);
    let stride = cache.stride.max(1);
    // The ranks taking part are `a * stride` for `a < active`.
    let active = n_points.div_ceil(stride);
    // Predictions of one vertex closer than this to its own patch's add nothing to search.
    let merge = 0.3 * model.mean_edge;
    let hypotheses = Hypotheses::new(model, predictions, merge);
    let data_id = (data.points.as_ptr() as usize, n_points);
    let fresh = cache.data != data_id
        || cache.slots != slots
        || cache.previous.len() != predictions.at.len()
        || cache.drift.is_empty();
    if fresh {
        cache.data = data_id;
        cache.slots = slots;
        cache.order = morton_order(&data.points);
        cache.list = vec![0; n_points * slots];
        cache.count = vec![0; n_points];
        cache.cover = vec![0.0; n_points];
        cache.searched_at = vec![NEVER_SEARCHED; n_points];
        cache.drift = vec![0.0];
        cache.vertex_drift.clear();
        cache.vertex_drift.push(vec![0.0; n_vertices]);
    } else {
        // How far each vertex's hypotheses moved since the last E-step, the largest over the
        // vertex and its neighbours (a hypothesis one ring away may come into a list).
        let moved: Vec<f32> = (0..n_vertices)
            .into_par_iter()
            .map(|v| {
                model
                    .blend_entries(v)
                    .map(|e| (predictions.at[e] - cache.previous[e]).norm_squared())
                    .fold(0.0, f64::max)
                    .sqrt() as f32
            })
            .collect();
        let graph = &model.graph;
        let last = cache.vertex_drift.last().expect("set on a fresh frame");
        let summed: Vec<f32> = (0..n_vertices)
            .into_par_iter()
            .map(|v| {
                let near = graph
                    .neighbours(v)
                    .map(|(w, _)| moved[w])
                    .fold(moved[v], f32::max);
                last[v] + near
            })
            .collect();
        cache.vertex_drift.push(summed);
        let largest = moved.iter().copied().fold(0.0, f32::max) as f64;
        let total = cache.drift.last().copied().unwrap_or(0.0) + largest;
        cache.drift.push(total);
    }
    let now = (cache.drift.len() - 1) as u32;
    let drift_now = cache.drift[now as usize];
    cache.previous.clone_from(&predictions.at);

    // Keep or search each list again, by how far the hypotheses around its vertices moved
    // since it was searched; note the points (ranks) that need a search.
    let needs_search: Vec<u32> = if fresh {
        (0..active).map(|a| (a * stride) as u32).collect()
    } else {
        let (list, count) = (&cache.list, &cache.count);
        let (drift, cover, searched_at) = (&cache.drift, &cache.cover, &cache.searched_at);
        let vertex_drift = &cache.vertex_drift;
        let drift_here = &vertex_drift[now as usize];
        let keep_below = (REUSE_DRIFT * model.mean_edge) as f32;
        (0..active)
            .into_par_iter()
            .filter_map(|a| {
                let r = a * stride;
                if searched_at[r] == NEVER_SEARCHED {
                    return Some(r as u32);
                }
                let then = searched_at[r] as usize;
                let listed = &list[r * slots..][..count[r] as usize];
                if listed.is_empty() {
                    let since = drift_now - drift[then];
                    return (cutoff + since > cover[r]).then_some(r as u32);
                }
                let drift_then = &vertex_drift[then];
                let local = listed
                    .iter()
                    .map(|&e| {
                        let v = model.blend_vertex[e as usize] as usize;
                        drift_here[v] - drift_then[v]
                    })
                    .fold(0.0, f32::max);
                (local > keep_below).then_some(r as u32)
            })
            .collect()
    };
    if !needs_search.is_empty() {
        let tree = NearTree::new(&hypotheses.local, &hypotheses.entry);
        let (order, list, count) = (&cache.order, &cache.list, &cache.count);
        let (origin, packed) = (hypotheses.origin, &hypotheses.packed);
        // Per chunk of points searched: (rank, count, cover) of each, and their lists.
        let found: Vec<(Vec<Searched>, Vec<u32>)> = needs_search
            .par_chunks(256)
            .map(|ranks| {
                let mut nearest = NearestFew::new(slots);
                let mut searched = Vec::with_capacity(ranks.len());
                let mut ids = Vec::with_capacity(ranks.len() * slots);
                // The last point searched and the farthest of its full list.
                let mut last: Option<([f32; 3], f32)> = None;
                for &r in ranks {
                    let y = data.points[order[r as usize] as usize];
                    let q = to_local(&y, &origin);
                    // A full list bounds the search: each of its entries is within `merge`
                    // of a kept hypothesis, so as many lie within its farthest plus `merge`.
                    let listed = &list[r as usize * slots..][..count[r as usize] as usize];
                    let mut reach = cutoff;
                    if listed.len() == slots {
                        let farthest2 = listed
                            .iter()
                            .map(|&e| distance2(&packed[e as usize].at, &q))
                            .fold(0.0, f32::max);
                        reach = reach.min((farthest2 as f64).sqrt() + merge);
                    }
                    // So does the last point's full list (points come in spatial order, the
                    // last one is near): all of it lies within its farthest plus the gap.
                    if let Some((p, farthest2)) = last {
                        let gap = distance2(&p, &q).sqrt();
                        reach = reach.min((farthest2.sqrt() + gap) as f64);
                    }
                    let reach2 = (reach * (1.0 + 1e-4)).powi(2);
                    tree.nearest_within(q, reach2 as f32, &mut nearest);
                    let full = nearest.is_full();
                    let farthest2 = nearest.farthest_distance2();
                    last = full.then_some((q, farthest2));
                    ids.extend_from_slice(nearest.ids());
                    let cover = if full {
                        (farthest2 as f64).sqrt()
                    } else {
                        cutoff
                    };
                    searched.push((r, nearest.len() as u8, cover));
                }
                (searched, ids)
            })
            .collect();
        for (searched, ids) in &found {
            let mut ids = ids.as_slice();
            for &(r, n, cover) in searched {
                let r = r as usize;
                let (mine, rest) = ids.split_at(n as usize);
                cache.list[r * slots..][..n as usize].copy_from_slice(mine);
                ids = rest;
                cache.count[r] = n;
                cache.cover[r] = cover;
                cache.searched_at[r] = now;
            }
        }
    }
    let cache = &*cache;
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

    let two_sigma2 = 2.0 * sigma * sigma;
    // Posteriors (eq. 8) summed per vertex: each task adds its points into its own sums,
    // and the tasks' sums are added at the end (as many as the pool splits the work into).
    let empty = || VertexTargets {
        weight: vec![0.0; n_vertices],
        weighted_sum: vec![Vector3::zeros(); n_vertices],
        weighted_square: vec![0.0; n_vertices],
        inliers: 0,
        weighted_residual: 0.0,
    };
    (0..active.div_ceil(POSTERIOR_CHUNK))
        .into_par_iter()
        .fold(empty, |mut sums, c| {
            // Per point: the best vertex of each patch found, `(patch, vertex, d2)`, and then
            // its squared distance to the deformed vertex and its likelihood.
            let mut found = [(0u32, 0u32, 0.0f64); MAX_SLOTS];
            let mut likelihood = [(0.0f64, 0.0f64); MAX_SLOTS];
            for a in c * POSTERIOR_CHUNK..((c + 1) * POSTERIOR_CHUNK).min(active) {
                let r = a * stride;
                let i = cache.order[r] as usize;
                let y = &data.points[i];
                let ny = data.normals[i];
                // The point stands for the ones up to the next rank taking part.
                let count = if stride == 1 {
                    data.count(i) as f64
                } else {
                    cache.order[r..(r + stride).min(n_points)]
                        .iter()
                        .map(|&j| data.count(j as usize) as f64)
                        .sum()
                };
                let mut n_found = 0;
                let list = &cache.list[r * slots..][..cache.count[r] as usize];
                let y_local = to_local(y, &hypotheses.origin);
                let ny_single = [ny.x as f32, ny.y as f32, ny.z as f32];
                for &e in list {
                    let h = &hypotheses.packed[e as usize];
                    let d2_hypothesis = distance2(&h.at, &y_local);
                    if d2_hypothesis > cut2_single {
                        continue;
                    }
                    let cos = ny_single[0] * h.normal[0]
                        + ny_single[1] * h.normal[1]
                        + ny_single[2] * h.normal[2];
                    let compatible = if data.oriented {
                        cos >= cos_limit
                    } else {
                        cos.abs() >= cos_limit
                    };
                    if !compatible {
                        continue;
                    }
                    let d2_hypothesis = d2_hypothesis as f64;
                    // v_i^k: the hypothesis of patch k nearest to y_i.
                    match found[..n_found].iter_mut().find(|f| f.0 == h.patch) {
                        Some(f) if d2_hypothesis < f.2 => *f = (h.patch, h.vertex, d2_hypothesis),
                        Some(_) => {}
                        None => {
                            found[n_found] = (h.patch, h.vertex, d2_hypothesis);
                            n_found += 1;
                        }
                    }
                }
                if n_found == 0 {
                    continue;
                }
                let found = &found[..n_found];
                // Eq. 8: prior times Gaussian (eq. 7), over the sum with the outlier term; the
                // component is centred on the deformed vertex.
                let mut total = outlier_density;
                for (&(k, v, _), l) in found.iter().zip(&mut likelihood) {
                    let d2 = (y - positions[v as usize]).norm_squared();
                    let p = patch_prior[k as usize] * gauss_norm * (-d2 / two_sigma2).exp();
                    total += p;
                    *l = (d2, p);
                }
                let (square, mut inlier_mass) = (y.coords.norm_squared(), 0.0);
                for (&(_, v, _), &(d2, p)) in found.iter().zip(&likelihood) {
                    let w = p / total;
                    if w > 1e-8 {
                        inlier_mass += w;
                        // A merged or thinned point counts as the points it stands for.
                        let (v, w) = (v as usize, w * count);
                        sums.weight[v] += w;
                        sums.weighted_sum[v] += y.coords * w;
                        sums.weighted_square[v] += w * square;
                        sums.weighted_residual += w * d2;
                    }
                }
                if inlier_mass > 0.5 {
                    sums.inliers += count as usize;
                }
            }
            sums
        })
        .reduce(empty, |mut a, b| {
            for (x, y) in a.weight.iter_mut().zip(&b.weight) {
                *x += y;
            }
            for (x, y) in a.weighted_sum.iter_mut().zip(&b.weighted_sum) {
                *x += y;
            }
            for (x, y) in a.weighted_square.iter_mut().zip(&b.weighted_square) {
                *x += y;
            }
            a.inliers += b.inliers;
            a.weighted_residual += b.weighted_residual;
            a
        })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::surface::cases::{bend, scan, torus};
    use crate::surface::model::PatchOptions;
    use rand::SeedableRng;

    /// A torus's patch model and a scan of the torus bent (4,000 points, a tenth clutter),
    /// with a `sigma` of 2% of the diagonal.
    fn bent_torus_scan(seed: u64) -> (PatchModel, Observations, f64) {
        let reference = torus(40, 20);
        let model = PatchModel::new(&reference, &PatchOptions::default()).expect("model");
        let diagonal = model.diagonal;
        let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
        let truth = bend(&reference, 0.2);
        let cloud = scan(
            &truth,
            &reference.triangles,
            4000,
            0.003 * diagonal,
            0.1,
            &mut rng,
        );
        let data = Observations::from_mesh(&cloud).expect("frame");
        (model, data, 0.02 * diagonal)
    }

    /// Within a frame, lists kept where the mesh barely moved and searched again where it
    /// moved give the posteriors of searching every point afresh.
    #[test]
    fn kept_lists_match_fresh_searches() {
        let (model, data, sigma) = bent_torus_scan(11);
        let options = DataTermOptions::default();
        let mut pose = model.rest_pose();
        let mut cache = EStepCache::default();
        for (step, slide) in [0.0, 0.1, 0.4, 0.1, 0.6].into_iter().enumerate() {
            // Half the patches slide along x (a tenth of an edge keeps their points' lists,
            // more searches them again); the others stay.
            for c in pose.centre.iter_mut().step_by(2) {
                c.x += slide * model.mean_edge;
            }
            let positions = model.positions(&pose);
            let kept = e_step_cached(
                &model, &pose, &positions, &data, sigma, &options, &mut cache,
            );
            let fresh = e_step(&model, &pose, &positions, &data, sigma, &options);
            let (wa, wb) = (kept.total_weight(), fresh.total_weight());
            assert!(wb > 100.0, "step {step}: {wb}");
            assert!(
                (wa - wb).abs() < 0.01 * wb,
                "step {step}: {wa} against {wb}"
            );
            let moved: f64 = kept
                .weight
                .iter()
                .zip(&fresh.weight)
                .map(|(x, y)| (x - y).abs())
                .sum();
            assert!(moved < 0.02 * wb, "step {step}: {moved} of {wb}");
        }
    }

    /// A thinned E-step counts each point it takes as the ones it stands for, and the full
    /// E-step after it, keeping the thinned points' lists, gives a fresh one's posteriors.
    #[test]
    fn thinned_e_steps_count_every_point_and_hand_their_lists_on() {
        let (model, data, sigma) = bent_torus_scan(5);
        let options = DataTermOptions::default();
        let pose = model.rest_pose();
        let positions = model.positions(&pose);
        let fresh = e_step(&model, &pose, &positions, &data, sigma, &options);
        let mut cache = EStepCache::default();
        cache.set_stride(4);
        let thinned = e_step_cached(
            &model, &pose, &positions, &data, sigma, &options, &mut cache,
        );
        let (wt, wf) = (thinned.total_weight(), fresh.total_weight());
        assert!((wt - wf).abs() < 0.05 * wf, "{wt} against {wf}");
        let (it, inf) = (thinned.inliers as f64, fresh.inliers as f64);
        assert!((it - inf).abs() < 0.05 * inf, "{it} against {inf}");
        cache.set_stride(1);
        let full = e_step_cached(
            &model, &pose, &positions, &data, sigma, &options, &mut cache,
        );
        assert_eq!(full.inliers, fresh.inliers);
        for (a, b) in full.weight.iter().zip(&fresh.weight) {
            assert!((a - b).abs() < 1e-9 * (1.0 + b), "{a} against {b}");
        }
    }

    /// Merging keeps every point counted and the two sides of a thin part apart.
    #[test]
    fn merging_counts_every_point_and_keeps_sides_apart() {
        let (mut points, mut normals) = (Vec::new(), Vec::new());
        for i in 0..10 {
            for j in 0..10 {
                for (z, side) in [(0.0, 1.0), (0.001, -1.0)] {
                    points.push(Point3::new(i as f64 * 0.01, j as f64 * 0.01, z));
                    normals.push(Vector3::new(0.0, 0.0, side));
                }
            }
        }
        let data = Observations {
            points,
            normals,
            oriented: true,
            counts: Vec::new(),
        };
        let merged = data.merged(0.025);
        assert_eq!(merged.counts.iter().sum::<u32>(), 200);
        assert!(merged.points.len() <= 2 * 16, "{}", merged.points.len());
        for (p, n) in merged.points.iter().zip(&merged.normals) {
            // Each merged point is one sheet's, with that sheet's normal.
            let sheet = if n.z > 0.0 { 0.0 } else { 0.001 };
            assert!((p.z - sheet).abs() < 1e-12 && (n.z.abs() - 1.0).abs() < 1e-12);
        }
        let again = merged.merged(0.05);
        assert_eq!(again.counts.iter().sum::<u32>(), 200);
        assert_eq!(data.merged(0.0).points.len(), 200);
    }

    #[test]
    fn morton_order_is_a_permutation_that_keeps_neighbours_close() {
        let points: Vec<Point3> = (0..1000)
            .map(|i| Point3::new((i % 10) as f64, ((i / 10) % 10) as f64, (i / 100) as f64))
            .collect();
        let mut order = morton_order(&points);
        let steps: f64 = order
            .windows(2)
            .map(|w| (points[w[0] as usize] - points[w[1] as usize]).norm())
            .sum();
        // A random order would step about 5 units on average.
        assert!(steps / 999.0 < 2.0, "{}", steps / 999.0);
        order.sort_unstable();
        assert!(order.iter().enumerate().all(|(i, &o)| o as usize == i));
    }
}
