//! The hypotheses of a pose worth a look in the E-step (eq. 1: each vertex predicted by its
//! own patch and by the neighbouring patches whose predictions differ), packed in single
//! precision for the candidate search and the posteriors.

use rayon::prelude::*;

use super::refill;
use crate::engine::spatial::to_local;
use crate::math::Point3;
use crate::surface::model::{PatchModel, Predictions};

/// The hypotheses of a pose that are worth a look, vertex by vertex: each vertex predicted by
/// its own patch, and by each neighbouring patch whose prediction differs from that by more
/// than `merge` (eq. 1; the others add nothing).
#[derive(Clone, Debug, Default)]
pub(super) struct Hypotheses {
    /// Every blend entry packed for the posterior loop, which reads them in random order.
    pub(super) packed: Vec<PackedHypothesis>,
    /// The blend entries kept, vertex by vertex, and their positions in single precision
    /// relative to `origin` (for choosing neighbours, not for the posteriors).
    pub(super) entry: Vec<u32>,
    /// `kept[e]`: blend entry `e` is among `entry` (in the E-step's kd-tree).
    pub(super) kept: Vec<bool>,
    pub(super) origin: Point3,
    pub(super) local: Vec<[f32; 3]>,
}

/// One blend entry `(l, v)` in one cache line's half: the prediction of `v` by patch `l`
/// relative to the origin, `v`'s normal turned by `l` (single precision: they choose and
/// screen candidates, the posteriors use the blended positions), `v` and `v`'s own patch.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct PackedHypothesis {
    pub(super) at: [f32; 3],
    pub(super) vertex: u32,
    pub(super) normal: [f32; 3],
    pub(super) patch: u32,
}

impl Hypotheses {
    /// Fills the hypotheses of a pose in place, their buffers reused (an E-step makes them
    /// every iteration: fresh buffers of this size cost page faults).
    pub(super) fn refill(&mut self, model: &PatchModel, predictions: &Predictions, merge: f64) {
        let at = &predictions.at;
        let origin = at.first().copied().unwrap_or_else(Point3::origin);
        self.origin = origin;
        self.packed.resize(at.len(), PackedHypothesis::default());
        const CHUNK: usize = 2048;
        self.packed
            .par_chunks_mut(CHUNK)
            .enumerate()
            .for_each(|(chunk, packed)| {
                for (i, h) in packed.iter_mut().enumerate() {
                    let e = chunk * CHUNK + i;
                    let v = model.blend_vertex[e] as usize;
                    let normal = predictions.normal[e];
                    *h = PackedHypothesis {
                        at: to_local(&at[e], &origin),
                        vertex: v as u32,
                        normal: [normal.x as f32, normal.y as f32, normal.z as f32],
                        patch: model.vertex_patch[v],
                    };
                }
            });
        let packed = &self.packed;
        let merge2 = merge * merge;
        // Chosen vertex by vertex in runs of vertices side by side, then joined in order.
        const RUN: usize = 1024;
        let runs: Vec<(Vec<u32>, Vec<[f32; 3]>)> = (0..model.vertex_count().div_ceil(RUN))
            .into_par_iter()
            .map(|run| {
                let vertices = run * RUN..((run + 1) * RUN).min(model.vertex_count());
                let mut entry = Vec::with_capacity(2 * vertices.len());
                let mut local = Vec::with_capacity(2 * vertices.len());
                for v in vertices {
                    let entries = model.blend_entries(v);
                    let first = entries.start;
                    for e in entries {
                        if e == first || (at[e] - at[first]).norm_squared() > merge2 {
                            entry.push(e as u32);
                            local.push(packed[e].at);
                        }
                    }
                }
                (entry, local)
            })
            .collect();
        self.entry.clear();
        self.local.clear();
        for (e, l) in runs {
            self.entry.extend_from_slice(&e);
            self.local.extend_from_slice(&l);
        }
        refill(&mut self.kept, at.len(), false);
        for &e in &self.entry {
            self.kept[e as usize] = true;
        }
    }
}
