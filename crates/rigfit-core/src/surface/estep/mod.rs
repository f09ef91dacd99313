//! The probabilistic data term (Cagniart et al. 2010, sections 3.3-3.4): a mixture with one
//! Gaussian component per patch plus a uniform outlier component over the scene's bounding
//! box. For every observed point and patch `P_k`, the component is centred on the deformed
//! position of `v_i^k`, the closest vertex of `P_k` with a compatible normal among the
//! predictions of `P_k` and of its neighbours (the multi-hypothesis mechanism, fig. 1).
//!
//! Each point keeps a list of its nearest few predictions within a cutoff of a few `sigma`,
//! found in the engine's kd-tree ([`crate::engine::spatial::NearTree`]) on a frame's first
//! E-step and searched again only where the mesh around the listed vertices has moved
//! ([`EStepCache`]). The cost is linear in the number of points and no points-by-patches
//! matrix is ever formed. Posteriors (eq. 8) are collapsed per vertex into
//! the sums the M-step needs.
//!
//! `observations` holds a frame's points and normals, `hypotheses` the predictions of a pose
//! worth a look, `candidates` each point's list and the cache that keeps it between
//! E-steps, and `posteriors` the mixture and its posteriors collapsed per vertex.

mod candidates;
mod hypotheses;
mod observations;
mod posteriors;

pub use candidates::EStepCache;
pub use observations::{Observations, estimate_normals};
pub use posteriors::VertexTargets;

use candidates::MAX_SLOTS;

/// Makes `buffer` `len` copies of `value`, over its old contents (the E-step's buffers are
/// reused from iteration to iteration: fresh ones of their size cost page faults).
fn refill<T: Clone>(buffer: &mut Vec<T>, len: usize, value: T) {
    buffer.clear();
    buffer.resize(len, value);
}
use posteriors::{Mixture, posteriors};

use super::model::{PatchModel, PatchPose, Predictions};
use crate::math::Point3;

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

/// [`e_step_cached`] from the pose's [`Predictions`], already computed. In steps: the pose's
/// hypotheses worth a look; the cache readied for this E-step (a new frame, or the drift
/// since the last one); the lists that drifted searched again; the mixture's terms; the
/// posteriors summed per vertex.
pub fn e_step_predicted(
    model: &PatchModel,
    predictions: &Predictions,
    positions: &[Point3],
    data: &Observations,
    sigma: f64,
    options: &DataTermOptions,
    cache: &mut EStepCache,
) -> VertexTargets {
    let cutoff = options.cutoff_sigmas * sigma;
    let slots = options.max_candidates.clamp(1, MAX_SLOTS);
    // Predictions of one vertex closer than this to its own patch's add nothing to search.
    let merge = 0.3 * model.mean_edge;
    let mut hypotheses = std::mem::take(&mut cache.hypotheses);
    hypotheses.refill(model, predictions, merge);
    let fresh = cache.begin(model, predictions, data, slots);
    // Keep or search each list again, by how far the hypotheses around its vertices moved
    // since it was searched.
    let ranks = cache.ranks_to_search(model, fresh, data.points.len(), cutoff);
    cache.search(&ranks, &hypotheses, data, cutoff, merge);
    let mixture = Mixture::new(model, data, positions, sigma, cutoff, options);
    let mut spare = std::mem::take(&mut cache.spare_sums);
    let targets = posteriors(
        model,
        &mixture,
        &hypotheses,
        positions,
        data,
        cache,
        &mut spare,
    );
    cache.spare_sums = spare;
    cache.hypotheses = hypotheses;
    targets
}
