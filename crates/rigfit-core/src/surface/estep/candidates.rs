//! Each point's candidate hypotheses and the cache that keeps them between the E-steps of a
//! frame ([`EStepCache`]): the points in Morton order, the drift of the hypotheses since each
//! list was searched, and the kd-tree search ([`NearTree`]) of the lists that
//! drifted.

use rayon::prelude::*;

use super::Observations;
use super::hypotheses::Hypotheses;
use super::{VertexTargets, refill};
use crate::engine::spatial::{
    MAX_NEAREST, NearTree, NearestFew, distance2, morton_order, to_local,
};
use crate::math::Point3;
use crate::surface::model::{PatchModel, Predictions};

/// A point's list is searched again once the hypotheses of its listed vertices, or of their
/// neighbours, moved by this fraction of a mean edge since it was searched.
const REUSE_DRIFT: f64 = 0.25;

/// The most candidates a point keeps (`DataTermOptions::max_candidates` is clamped to it).
pub(super) const MAX_SLOTS: usize = MAX_NEAREST;

/// Each point's candidates, kept between the E-steps of one frame: the nearest few hypotheses
/// (blend entries: vertex `v` predicted by patch `l`) within the cutoff. The first E-step on a
/// frame searches a kd-tree for every point; the next ones search again only the points whose
/// listed vertices' hypotheses (or their neighbours') moved by more than a quarter of an edge
/// (`REUSE_DRIFT`) since their search (most of the mesh settles within a few iterations). A
/// point with no candidates is searched again only when the mesh may have come within its
/// cutoff: its list was complete within `cover` when searched, and no hypothesis has moved
/// more than the drift summed since. Points are visited in a spatial (Morton) order, so that neighbouring
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
    pub(super) slots: usize,
    /// The points in visiting order; the per-point arrays below are in that order.
    pub(super) order: Vec<u32>,
    /// `list[r * slots..][..count[r]]`: the candidates of point `order[r]`, in no particular order.
    pub(super) list: Vec<u32>,
    pub(super) count: Vec<u8>,
    /// The radius within which the list was complete when it was searched, and the E-step
    /// that searched it ([`NEVER_SEARCHED`] if none has).
    cover: Vec<f64>,
    searched_at: Vec<u32>,
    /// One point in `stride` (by rank) takes part in the E-steps (0 and 1: every point).
    pub(super) stride: usize,
    /// `drift[t]`: the largest move of any hypothesis, summed over E-steps `1..=t`.
    drift: Vec<f64>,
    /// Every blend entry's prediction at the last E-step.
    previous: Vec<Point3>,
    /// `vertex_drift[t][v]`: how far the hypotheses of `v` and of its neighbours moved (the
    /// largest), summed over E-steps `1..=t`.
    vertex_drift: Vec<Vec<f32>>,
    /// The last E-step's hypotheses and their kd-tree, their buffers reused by the next.
    pub(super) hypotheses: Hypotheses,
    tree: NearTree,
    /// Per-vertex sums no longer needed, their buffers reused by the next posteriors.
    pub(super) spare_sums: Vec<VertexTargets>,
}

impl EStepCache {
    /// Hands back an E-step's sums once they are no longer needed: the next E-step writes
    /// over their buffers.
    pub fn recycle(&mut self, targets: VertexTargets) {
        if self.spare_sums.len() < rayon::current_num_threads() {
            self.spare_sums.push(targets);
        }
    }
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

/// The ranks of the visiting order taking part in an E-step: `a * stride` for `a < active`.
#[derive(Clone, Copy, Debug)]
pub(super) struct ActiveRanks {
    pub(super) stride: usize,
    pub(super) active: usize,
}

/// A point searched again: its rank, the length of its new list and the list's cover.
#[derive(Clone, Copy, Debug)]
struct SearchedPoint {
    rank: u32,
    count: u8,
    cover: f64,
}

/// The points searched by one task, and their new lists one after the other.
struct SearchedChunk {
    points: Vec<SearchedPoint>,
    ids: Vec<u32>,
}

impl EStepCache {
    /// Readies the cache for an E-step on `data` with the pose's `predictions`: on another
    /// frame (other data or settings, or after [`EStepCache::clear`]) it starts with every
    /// point unsearched; otherwise it adds up how far the hypotheses moved since the last
    /// E-step, vertex by vertex and at most. Returns whether it started afresh.
    pub(super) fn begin(
        &mut self,
        model: &PatchModel,
        predictions: &Predictions,
        data: &Observations,
        slots: usize,
    ) -> bool {
        let n_vertices = model.vertex_count();
        let n_points = data.points.len();
        let data_id = (data.points.as_ptr() as usize, n_points);
        let fresh = self.data != data_id
            || self.slots != slots
            || self.previous.len() != predictions.at.len()
            || self.drift.is_empty();
        if fresh {
            self.data = data_id;
            self.slots = slots;
            self.order = morton_order(&data.points);
            // Written over the last frame's buffers (fresh ones cost page faults).
            refill(&mut self.list, n_points * slots, 0);
            refill(&mut self.count, n_points, 0);
            refill(&mut self.cover, n_points, 0.0);
            refill(&mut self.searched_at, n_points, NEVER_SEARCHED);
            refill(&mut self.drift, 1, 0.0);
            let mut first = self.vertex_drift.drain(..).next().unwrap_or_default();
            refill(&mut first, n_vertices, 0.0);
            self.vertex_drift.push(first);
        } else {
            // How far each vertex's hypotheses moved since the last E-step, the largest over
            // the vertex and its neighbours (a hypothesis one ring away may come into a list).
            let previous = &self.previous;
            let moved: Vec<f32> = (0..n_vertices)
                .into_par_iter()
                .map(|v| {
                    model
                        .blend_entries(v)
                        .map(|e| (predictions.at[e] - previous[e]).norm_squared())
                        .fold(0.0, f64::max)
                        .sqrt() as f32
                })
                .collect();
            let graph = &model.graph;
            let last = self.vertex_drift.last().expect("set on a fresh frame");
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
            self.vertex_drift.push(summed);
            let largest = moved.iter().copied().fold(0.0, f32::max) as f64;
            let total = self.drift.last().copied().unwrap_or(0.0) + largest;
            self.drift.push(total);
        }
        // Copied in parallel: a megabyte or more, every E-step.
        self.previous.resize(predictions.at.len(), Point3::origin());
        self.previous
            .par_chunks_mut(8192)
            .zip(predictions.at.par_chunks(8192))
            .for_each(|(to, from)| to.copy_from_slice(from));
        fresh
    }

    /// The ranks taking part in an E-step on `n_points` points (see [`EStepCache::set_stride`]).
    pub(super) fn active_ranks(&self, n_points: usize) -> ActiveRanks {
        let stride = self.stride.max(1);
        ActiveRanks {
            stride,
            active: n_points.div_ceil(stride),
        }
    }

    /// The index of the current E-step in the drift sums (0: the frame's first).
    fn now(&self) -> u32 {
        (self.drift.len() - 1) as u32
    }

    /// The ranks taking part ([`ActiveRanks`]) whose lists are searched again,
    /// by how far the hypotheses around their listed vertices moved since they were
    /// searched: every one on a fresh frame; then those not searched yet, those whose listed
    /// vertices' hypotheses (or their neighbours') drifted by more than [`REUSE_DRIFT`] of an
    /// edge, and those with an empty list that the mesh may have come within `cutoff` of.
    pub(super) fn ranks_to_search(
        &self,
        model: &PatchModel,
        fresh: bool,
        n_points: usize,
        cutoff: f64,
    ) -> Vec<u32> {
        let ActiveRanks { stride, active } = self.active_ranks(n_points);
        if fresh {
            return (0..active).map(|a| (a * stride) as u32).collect();
        }
        let slots = self.slots;
        let now = self.now();
        let drift_now = self.drift[now as usize];
        let (list, count) = (&self.list, &self.count);
        let (drift, cover, searched_at) = (&self.drift, &self.cover, &self.searched_at);
        let vertex_drift = &self.vertex_drift;
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
    }

    /// Searches a kd-tree of the hypotheses for the points at `ranks` and keeps their new
    /// lists: the nearest `slots` hypotheses within `cutoff`, each search bounded by the
    /// point's old list and by the list of the point searched just before it (`merge`: how
    /// far a hypothesis left out of the tree may lie from one kept).
    pub(super) fn search(
        &mut self,
        ranks: &[u32],
        hypotheses: &Hypotheses,
        data: &Observations,
        cutoff: f64,
        merge: f64,
    ) {
        if ranks.is_empty() {
            return;
        }
        let slots = self.slots;
        let now = self.now();
        self.tree.rebuild(&hypotheses.local, &hypotheses.entry);
        let tree = &self.tree;
        let (order, list, count) = (&self.order, &self.list, &self.count);
        let (origin, packed, kept) = (hypotheses.origin, &hypotheses.packed, &hypotheses.kept);
        // Per chunk of points searched: the rank, count and cover of each, and their lists.
        let found: Vec<SearchedChunk> = ranks
            .par_chunks(256)
            .map(|ranks| {
                let mut nearest = NearestFew::new(slots);
                let mut points = Vec::with_capacity(ranks.len());
                let mut ids = Vec::with_capacity(ranks.len() * slots);
                // The last point searched and the farthest of its full list.
                let mut last: Option<([f32; 3], f32)> = None;
                for &r in ranks {
                    let y = data.points[order[r as usize] as usize];
                    let q = to_local(&y, &origin);
                    // A full list bounds the search: each of its entries is within `merge`
                    // of a kept hypothesis, so as many lie within its farthest plus `merge`
                    // (within its farthest when all of them are still kept).
                    let listed = &list[r as usize * slots..][..count[r as usize] as usize];
                    let mut reach = cutoff;
                    if listed.len() == slots {
                        let farthest2 = listed
                            .iter()
                            .map(|&e| distance2(&packed[e as usize].at, &q))
                            .fold(0.0, f32::max);
                        let all_kept = listed.iter().all(|&e| kept[e as usize]);
                        let slack = if all_kept { 0.0 } else { merge };
                        reach = reach.min((farthest2 as f64).sqrt() + slack);
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
                    points.push(SearchedPoint {
                        rank: r,
                        count: nearest.len() as u8,
                        cover,
                    });
                }
                SearchedChunk { points, ids }
            })
            .collect();
        for chunk in &found {
            let mut ids = chunk.ids.as_slice();
            for point in &chunk.points {
                let (r, n) = (point.rank as usize, point.count);
                let (mine, rest) = ids.split_at(n as usize);
                self.list[r * slots..][..n as usize].copy_from_slice(mine);
                ids = rest;
                self.count[r] = n;
                self.cover[r] = point.cover;
                self.searched_at[r] = now;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::surface::estep::{DataTermOptions, e_step, e_step_cached};
    use crate::surface::model::PatchOptions;
    use crate::surface::test_meshes::{bend, scan, torus};
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
}
