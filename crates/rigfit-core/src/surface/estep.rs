//! The probabilistic data term (Cagniart et al. 2010, sections 3.3-3.4): a mixture with one
//! Gaussian component per patch plus a uniform outlier component over the scene's bounding
//! box. For every observed point and patch `P_k`, the component is centred on the deformed
//! position of `v_i^k`, the closest vertex of `P_k` with a compatible normal among the
//! predictions of `P_k` and of its neighbours (the multi-hypothesis mechanism, fig. 1).
//!
//! Each point keeps a list of its nearest few predictions within a cutoff of a few `sigma`:
//! found in a kd-tree on a frame's first E-step, then kept up to date by walking the mesh
//! from the list ([`EStepCache`]). The cost is linear in the number of points and no
//! points-by-patches matrix is ever formed. Posteriors (eq. 8) are collapsed per vertex into
//! the sums the M-step needs.

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
    /// Refresh the candidate lists within a frame by walking the mesh from them (see
    /// [`EStepCache`]); false searches the kd-tree again at every refresh, as before.
    pub walk: bool,
}

impl Default for DataTermOptions {
    fn default() -> Self {
        Self {
            outlier_ratio: 0.15,
            normal_angle: 60.0,
            cutoff_sigmas: 3.0,
            max_candidates: 12,
            walk: true,
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

/// The candidate lists are walked again once some hypothesis moved by this fraction of a
/// mean edge since they were last refreshed; below it they are kept as they are.
const REUSE_DRIFT: f64 = 0.25;

/// Beyond this many mean edges of drift the lists are searched again rather than walked: a
/// walk reaches one ring past the listed vertices.
const WALK_DRIFT: f64 = 1.5;

/// The most candidates a point keeps (`DataTermOptions::max_candidates` is clamped to it).
const MAX_SLOTS: usize = 64;

/// Each point's candidates, kept between the E-steps of one frame: the nearest few hypotheses
/// (blend entries: vertex `v` predicted by patch `l`) within the cutoff. The first E-step on a
/// frame searches a kd-tree; the next ones keep the lists while the hypotheses have moved by
/// less than [`REUSE_DRIFT`] of an edge, search again past [`WALK_DRIFT`] edges, and in
/// between refresh every list by walking the mesh from it (the hypotheses of the listed
/// vertices and of their neighbours), which keeps the lists current through the small
/// steps of the later iterations without searching. A point
/// with no candidates is searched again only when the mesh may have come within its cutoff:
/// its list was complete within `cover` when searched, and no hypothesis has moved more than
/// the drift summed since. Points are visited in a spatial (Morton) order, so that
/// neighbouring points read neighbouring memory.
#[derive(Clone, Debug, Default)]
pub struct EStepCache {
    /// The data the lists are for (address and length).
    data: (usize, usize),
    /// Slots per point (`max_candidates`).
    slots: usize,
    /// The points in visiting order; the per-point arrays below are in that order.
    order: Vec<u32>,
    /// `list[r * slots..][..count[r]]`: the candidates of point `order[r]`, nearest first.
    list: Vec<u32>,
    count: Vec<u8>,
    /// The radius within which the list was complete when it was searched, and the E-step
    /// that searched it.
    cover: Vec<f64>,
    searched_at: Vec<u32>,
    /// `drift[t]`: the largest move of any hypothesis, summed over E-steps `1..=t`.
    drift: Vec<f64>,
    /// Every blend entry's prediction at the last E-step.
    previous: Vec<Point3>,
    /// The E-step that last walked or searched the lists.
    refreshed_at: u32,
}

impl EStepCache {
    /// Forgets the candidates (the next E-step searches again).
    pub fn clear(&mut self) {
        self.data = (0, 0);
        self.previous.clear();
        self.drift.clear();
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
    /// Every blend entry's prediction, and the vertex's normal turned by the entry's patch.
    at: Vec<Point3>,
    normal: Vec<Vector3>,
    /// `entry[start[v]..start[v + 1]]`: the blend entries of `v` kept, with their positions.
    start: Vec<u32>,
    entry: Vec<u32>,
    position: Vec<Point3>,
}

impl Hypotheses {
    fn new(model: &PatchModel, pose: &PatchPose, merge: f64) -> Self {
        let (at, normal): (Vec<Point3>, Vec<Vector3>) = (0..model.blend_patch.len())
            .into_par_iter()
            .map(|e| {
                let (l, v) = (
                    model.blend_patch[e] as usize,
                    model.blend_vertex[e] as usize,
                );
                (
                    model.prediction(pose, l, v),
                    pose.rotation[l] * model.rest_normals[v],
                )
            })
            .unzip();
        let merge2 = merge * merge;
        let mut start = Vec::with_capacity(model.vertex_count() + 1);
        let mut entry = Vec::with_capacity(model.vertex_count() * 2);
        let mut position = Vec::with_capacity(model.vertex_count() * 2);
        start.push(0);
        for v in 0..model.vertex_count() {
            let (a, b) = (
                model.blend_start[v] as usize,
                model.blend_start[v + 1] as usize,
            );
            for e in a..b {
                if e == a || (at[e] - at[a]).norm_squared() > merge2 {
                    entry.push(e as u32);
                    position.push(at[e]);
                }
            }
            start.push(entry.len() as u32);
        }
        Self {
            at,
            normal,
            start,
            entry,
            position,
        }
    }

    fn of_vertex(&self, v: usize) -> std::ops::Range<usize> {
        self.start[v] as usize..self.start[v + 1] as usize
    }
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
    let n_vertices = model.vertex_count();
    let n_points = data.points.len();
    let cutoff = options.cutoff_sigmas * sigma;
    let cut2 = cutoff * cutoff;
    let slots = options.max_candidates.clamp(1, MAX_SLOTS);
    let hypotheses = Hypotheses::new(model, pose, 0.3 * model.mean_edge);
    let data_id = (data.points.as_ptr() as usize, n_points);
    let fresh = cache.data != data_id
        || cache.slots != slots
        || cache.previous.len() != hypotheses.at.len()
        || cache.drift.is_empty();
    if fresh {
        cache.data = data_id;
        cache.slots = slots;
        cache.order = morton_order(&data.points);
        cache.list = vec![0; n_points * slots];
        cache.count = vec![0; n_points];
        cache.cover = vec![0.0; n_points];
        cache.searched_at = vec![0; n_points];
        cache.drift = vec![0.0];
        cache.refreshed_at = 0;
    } else {
        let moved = hypotheses
            .at
            .par_iter()
            .zip(&cache.previous)
            .map(|(a, b)| (a - b).norm_squared())
            .reduce(|| 0.0, f64::max)
            .sqrt();
        let total = cache.drift.last().copied().unwrap_or(0.0) + moved;
        cache.drift.push(total);
    }
    let now = (cache.drift.len() - 1) as u32;
    let drift_now = cache.drift[now as usize];
    cache.previous.clone_from(&hypotheses.at);

    // Keep, walk or search the lists; note the points (ranks) that need a search.
    let since_refresh = drift_now - cache.drift[cache.refreshed_at as usize];
    let needs_search: Vec<u32> = if since_refresh <= REUSE_DRIFT * model.mean_edge && !fresh {
        Vec::new()
    } else if fresh || since_refresh > WALK_DRIFT * model.mean_edge || !options.walk {
        cache.refreshed_at = now;
        (0..n_points as u32).collect()
    } else {
        cache.refreshed_at = now;
        let graph = &model.graph;
        let hypotheses = &hypotheses;
        let (order, drift, cover, searched_at) =
            (&cache.order, &cache.drift, &cache.cover, &cache.searched_at);
        cache
            .list
            .par_chunks_mut(slots)
            .zip(cache.count.par_iter_mut())
            .enumerate()
            .map_init(
                || {
                    (
                        vec![u32::MAX; n_vertices],
                        Vec::<usize>::with_capacity(MAX_SLOTS),
                        Vec::<(f64, u32)>::with_capacity(4 * MAX_SLOTS),
                    )
                },
                |(seen, listed, near), (r, (list, count))| {
                    if *count == 0 {
                        let since = drift_now - drift[searched_at[r] as usize];
                        return (cutoff + since > cover[r]).then_some(r as u32);
                    }
                    let y = data.points[order[r] as usize];
                    let stamp = r as u32;
                    near.clear();
                    let gather = |w: usize, near: &mut Vec<(f64, u32)>| {
                        for h in hypotheses.of_vertex(w) {
                            let d2 = (y - hypotheses.position[h]).norm_squared();
                            if d2 <= cut2 {
                                near.push((d2, hypotheses.entry[h]));
                            }
                        }
                    };
                    // The listed vertices, then their neighbours, each once.
                    listed.clear();
                    for &e in &list[..*count as usize] {
                        let v = model.blend_vertex[e as usize] as usize;
                        if seen[v] != stamp {
                            seen[v] = stamp;
                            listed.push(v);
                            gather(v, near);
                        }
                    }
                    for &v in listed.iter() {
                        let (a, b) = (graph.start[v] as usize, graph.start[v + 1] as usize);
                        for &w in &graph.adjacent[a..b] {
                            let w = w as usize;
                            if seen[w] != stamp {
                                seen[w] = stamp;
                                gather(w, near);
                            }
                        }
                    }
                    if near.len() > slots {
                        near.select_nth_unstable_by(slots - 1, |a, b| a.0.total_cmp(&b.0));
                        near.truncate(slots);
                    }
                    near.sort_unstable_by(|a, b| a.0.total_cmp(&b.0));
                    for (slot, &(_, e)) in list.iter_mut().zip(near.iter()) {
                        *slot = e;
                    }
                    *count = near.len() as u8;
                    None
                },
            )
            .flatten()
            .collect()
    };
    if !needs_search.is_empty() {
        let coords: Vec<[f64; 3]> = hypotheses
            .position
            .iter()
            .map(|p| [p.x, p.y, p.z])
            .collect();
        let tree = PointTree::new(&coords);
        let order = &cache.order;
        let found: Vec<Vec<(usize, f64)>> = needs_search
            .par_iter()
            .map(|&r| tree.nearest_within(&data.points[order[r as usize] as usize], slots, cutoff))
            .collect();
        for (near, &r) in found.iter().zip(&needs_search) {
            let r = r as usize;
            for (slot, &(h, _)) in cache.list[r * slots..].iter_mut().zip(near) {
                *slot = hypotheses.entry[h];
            }
            cache.count[r] = near.len() as u8;
            cache.cover[r] = if near.len() == slots {
                near.last().map_or(cutoff, |&(_, d2)| d2.sqrt())
            } else {
                cutoff
            };
            cache.searched_at[r] = now;
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
    let cos_limit = options.normal_angle.to_radians().cos();

    // Per point: the best vertex of each patch found, its posterior.
    struct Chunk {
        entries: Vec<(u32, u32, f64)>,
        inliers: usize,
        weighted_residual: f64,
    }
    let chunks: Vec<Chunk> = cache
        .order
        .par_chunks(1024)
        .enumerate()
        .map(|(c, points)| {
            let mut chunk = Chunk {
                entries: Vec::with_capacity(points.len() * 2),
                inliers: 0,
                weighted_residual: 0.0,
            };
            let mut found: Vec<(usize, usize, f64)> = Vec::with_capacity(16);
            for (j, &i) in points.iter().enumerate() {
                let r = c * 1024 + j;
                let i = i as usize;
                let y = &data.points[i];
                let ny = data.normals[i];
                found.clear();
                let list = &cache.list[r * slots..][..cache.count[r] as usize];
                for &e in list {
                    let e = e as usize;
                    let d2_hypothesis = (y - hypotheses.at[e]).norm_squared();
                    if d2_hypothesis > cut2 {
                        continue;
                    }
                    let vertex = model.blend_vertex[e];
                    let cos = ny.dot(&hypotheses.normal[e]);
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::surface::cases::{bend, scan, torus};
    use crate::surface::model::PatchOptions;
    use rand::SeedableRng;

    /// Within a frame, lists refreshed by walking the mesh give the posteriors that searching
    /// the kd-tree again gives, once the mesh has moved by a few tenths of an edge.
    #[test]
    fn walked_lists_match_searched_lists() {
        let reference = torus(40, 20);
        let model = PatchModel::new(&reference, &PatchOptions::default()).expect("model");
        let diagonal = model.diagonal;
        let mut rng = rand::rngs::StdRng::seed_from_u64(11);
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
        let sigma = 0.02 * diagonal;
        let mut pose = model.rest_pose();
        let mut walked = EStepCache::default();
        let mut searched = EStepCache::default();
        let walking = DataTermOptions::default();
        let searching = DataTermOptions {
            walk: false,
            ..DataTermOptions::default()
        };
        for step in 0..4 {
            // Every patch slides by 0.4 of an edge along x: a refresh each step.
            for c in &mut pose.centre {
                c.x += 0.4 * model.mean_edge;
            }
            let positions = model.positions(&pose);
            let a = e_step_cached(
                &model,
                &pose,
                &positions,
                &data,
                sigma,
                &walking,
                &mut walked,
            );
            let b = e_step_cached(
                &model,
                &pose,
                &positions,
                &data,
                sigma,
                &searching,
                &mut searched,
            );
            let (wa, wb) = (a.total_weight(), b.total_weight());
            assert!(wb > 100.0, "step {step}: {wb}");
            assert!(
                (wa - wb).abs() < 0.01 * wb,
                "step {step}: {wa} against {wb}"
            );
            let moved: f64 = a
                .weight
                .iter()
                .zip(&b.weight)
                .map(|(x, y)| (x - y).abs())
                .sum();
            assert!(moved < 0.02 * wb, "step {step}: {moved} of {wb}");
        }
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
