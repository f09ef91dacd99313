//! Articulated tracking in 3D point clouds (Dewaele et al. 2006): an articulated surface
//! model ([`parts`]: ellipsoids fused into one surface; [`texture`]: model points carried by
//! blends of adjacent parts' motions, eq. 3), aligned to each frame's points by EM with a
//! uniform outlier class ([`crate::engine::correspondence::em`], eq. 17) and Gauss-Newton / Levenberg-
//! Marquardt on eq. (20), with `sigma` annealed geometrically; then a surface-fitting pass
//! (eq. 21-22). [`Tracker`] runs it frame after frame from the previous pose.
//!
//! [`TrackOptions::paper`] is the method as published; [`TrackOptions::default`] adds what
//! the accuracy table in BENCHMARKS.md measures: constant-velocity prediction, coarse-to-
//! fine correspondences at large `sigma`, and texture points kept on the model's own
//! surface instead of refreshed from the (noisy) data every frame.

mod frame;
mod initialise;
mod limb_swings;
mod m_step;
mod model;
mod options;
pub mod parts;
mod refine;
mod take;
pub mod texture;
mod tracker;

use crate::engine::{Candidates, EmStep, PointGrid, SkeletonNormalEquations, SubtreeMoments};
use crate::kinematics::DofLayout;
use crate::math::{Point3, Vector3};
use crate::skeleton::{Pose, Skeleton};
use parts::{PartModel, PlacedParts};
use texture::TexturePoint;

pub use initialise::{Initialisation, InitialiseOptions, Tried, initialise, initialise_with};
pub use limb_swings::LimbSwingOptions;
pub use model::{MODEL_POINTS_SEED, bind_pose, texture_count};
pub use options::{TextureSource, TrackOptions};
pub use take::{FrameStart, StartMode, Take, TakeFrame, TakeOptions};
pub(crate) use tracker::TrackerStart;

/// Why a frame cannot be tracked.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum TrackError {
    #[error("the point cloud is empty")]
    EmptyCloud,
    #[error("point {index}: coordinate is not a finite number")]
    NonFinite { index: usize },
    #[error(
        "point {index}: a coordinate is beyond +-{:e}, out of range (a unit or export mistake)",
        crate::math::MAX_COORDINATE
    )]
    OutOfRange { index: usize },
    #[error("the rig has no volume to track: no mesh and no bones of any length")]
    NoParts,
    #[error("the rig has no joints that can move")]
    NothingMoves,
}

/// Whether a frame's points can be tracked: some, all finite and within range.
pub(crate) fn check_cloud(data: &[Point3]) -> Result<(), TrackError> {
    if data.is_empty() {
        return Err(TrackError::EmptyCloud);
    }
    if let Some(index) = data.iter().position(|p| !p.iter().all(|c| c.is_finite())) {
        return Err(TrackError::NonFinite { index });
    }
    if let Some(index) = crate::math::first_out_of_range(data) {
        return Err(TrackError::OutOfRange { index });
    }
    Ok(())
}

/// The articulated surface model of a rig.
#[derive(Clone, Debug)]
pub struct ArticulatedModel {
    pub skeleton: Skeleton,
    pub parts: PartModel,
    pub height: f64,
    /// The pose tracking starts from (the rig's stored pose).
    pub start: Pose,
    /// The pose the parts were fitted and the texture sampled in (the bind pose of a
    /// skinned character, else the stored pose).
    pub built: Pose,
    /// Points on the model's surface in the start pose (world), with their normals when
    /// known (else the fused surface's gradient is used).
    pub surface_samples: Vec<Point3>,
    pub surface_normals: Option<Vec<Vector3>>,
}

/// What tracking one frame found.
#[derive(Clone, Debug)]
pub struct FrameFit {
    pub pose: Pose,
    /// Data points taken as inliers (see [`FrameFit::inlier`]).
    pub inliers: usize,
    /// Per data point, whether it was taken as an inlier: its posterior of belonging to the
    /// model, at the noise level, is at least 0.1.
    pub inlier: Vec<bool>,
    /// EM iterations run.
    pub em_iterations: usize,
}

/// Tracks one model through a sequence of point clouds.
#[derive(Clone, Debug)]
pub struct Tracker {
    model: ArticulatedModel,
    pub(crate) options: TrackOptions,
    layout: DofLayout,
    pose: Pose,
    previous: Option<Pose>,
    texture: Vec<TexturePoint>,
    /// Typical spacing between texture points.
    spacing: f64,
    grid: PointGrid,
    candidates: Candidates,
    em: EmStep,
    moments: SubtreeMoments,
    normal: Option<SkeletonNormalEquations>,
    placed: PlacedParts,
    lambda: f64,
    /// Per texture point, whether data supported it at the end of the last frame.
    seen: Vec<bool>,
}

/// The share of `data` that `model` points explain: the data's summed inlier posteriors of
/// one E-step (eq. 17, with the outlier term `outlier_constant`) at `sigma`, per data point.
/// How the first-frame search, a take's start and its recovery compare fits.
pub(crate) fn explained_share(
    data: &[Point3],
    model: &[Point3],
    sigma: f64,
    outlier_constant: f64,
    grid: &mut PointGrid,
    em: &mut EmStep,
) -> f64 {
    if data.is_empty() {
        return 0.0;
    }
    crate::engine::em_step(
        crate::engine::WeightedPoints::unit(data),
        crate::engine::WeightedPoints::unit(model),
        sigma,
        outlier_constant,
        grid,
        em,
    );
    em.inlier.iter().sum::<f64>() / data.len() as f64
}
