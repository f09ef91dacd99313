//! The tracker's settings: the method as published ([`TrackOptions::paper`]) and the
//! default with prediction, coarse-to-fine matching and texture kept on the model.

use crate::engine::DEWAELE_OUTLIER_CONSTANT;

/// Where the texture points come from after each frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TextureSource {
    /// The paper: the data points fitted at the previous frame (inliers near the surface).
    RefreshFromData,
    /// The model's own surface samples, attached once (no drift from noisy data).
    ModelSurface,
}

/// Settings of the tracker. Lengths are fractions of the character's height.
#[derive(Clone, Debug)]
pub struct TrackOptions {
    /// `sigma_0`: the largest motion of a point expected between frames.
    pub max_motion: f64,
    /// `sigma` floor: the noise of the data.
    pub noise: f64,
    /// Annealing steps from `sigma_0` to the floor (geometric).
    pub anneal_steps: usize,
    /// EM iterations at each `sigma` above the floor, and at the floor.
    pub em_iterations: usize,
    pub final_em_iterations: usize,
    /// Gauss-Newton steps per M-step.
    pub gauss_newton_steps: usize,
    /// The outlier term `c` of eq. (17).
    pub outlier_constant: f64,
    /// The exponent `a` of eq. (3).
    pub bending_exponent: f64,
    /// Surface-fitting (eq. 21) Gauss-Newton steps after EM; 0 skips the pass.
    pub surface_fit_steps: usize,
    pub texture: TextureSource,
    /// Start each frame from the previous pose moved on by this fraction of the last
    /// frame's motion (0: from the previous pose, 1: constant velocity).
    pub prediction: f64,
    /// At large `sigma`, match voxel-grid representatives (weighted by their counts)
    /// instead of every point.
    pub coarse_to_fine: bool,
    /// Weight of the prior keeping joint rotations near the frame's start pose.
    pub prior_weight: f64,
    /// The prior also holds the translation of each free joint below a moving joint that
    /// carries joints (a hip node or an IK goal that a clip translates): where the data
    /// does not pin such a joint's place it would wander from frame to frame. The first-frame
    /// search turns it off (the rest pose is no place to hold those joints near).
    pub hold_free_joints: bool,
    /// Weight of the soft joint limits: each limited joint's rotation excess over its
    /// limits (radians, relative to rest) squared, as the skeleton's `limits` give them.
    pub limit_weight: f64,
    /// How many texture points the model has (0: from the surface's area).
    pub model_points: usize,
    /// Above the noise level, match only the texture points the data supported at the end
    /// of the previous frame (the side of the body the cameras see).
    pub visible_only: bool,
    /// Factor on each M-step's parameter step (1: plain EM).
    pub over_relaxation: f64,
    /// Pull texture points along their normals only (point-to-plane) in the M-step, when
    /// the model's normals come from a mesh (the fused ellipsoids' gradient is too crude).
    pub point_to_plane: bool,
    /// With `point_to_plane`, the share of each pull kept along the surface (0: the normal
    /// part alone). A little of it holds a limb from sliding or turning about its own axis,
    /// where the normal pulls alone leave it free.
    pub tangential: f64,
}

impl TrackOptions {
    /// The method as published: texture points refreshed from the data, no prediction,
    /// every point matched at every `sigma`.
    pub fn paper() -> Self {
        Self {
            max_motion: 0.08,
            anneal_steps: 5,
            em_iterations: 2,
            final_em_iterations: 8,
            texture: TextureSource::RefreshFromData,
            prediction: 0.0,
            coarse_to_fine: false,
            visible_only: false,
            point_to_plane: false,
            over_relaxation: 1.0,
            limit_weight: 0.0,
            ..Self::default()
        }
    }
}

impl Default for TrackOptions {
    fn default() -> Self {
        Self {
            max_motion: 0.04,
            noise: 0.01,
            anneal_steps: 4,
            em_iterations: 1,
            final_em_iterations: 6,
            gauss_newton_steps: 1,
            outlier_constant: DEWAELE_OUTLIER_CONSTANT,
            bending_exponent: 2.0,
            surface_fit_steps: 0,
            texture: TextureSource::ModelSurface,
            prediction: 0.5,
            coarse_to_fine: true,
            prior_weight: 0.02,
            hold_free_joints: true,
            limit_weight: 1.0,
            model_points: 0,
            visible_only: true,
            point_to_plane: true,
            // Measured on the tune half of the tracking corpus: 0.3 against 0, 0.1, 0.2, 0.4
            // and 0.5 (BENCHMARKS.md, issue 23).
            tangential: 0.3,
            over_relaxation: 1.8,
        }
    }
}
