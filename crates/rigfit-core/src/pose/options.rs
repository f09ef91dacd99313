//! How a solve runs ([`PoseOptions`]), the bounds on what it takes, and why it may refuse
//! ([`PoseError`]).

use crate::skeleton::Pose;

/// Stroke points further than this many character heights from the rig are rejected.
pub const MAX_STROKE_DISTANCE: f64 = 100.0;

/// The most strokes one solve takes (more than any rig has chains to match).
pub const MAX_STROKES: usize = 1_000;

/// The most stroke points one solve takes, all strokes together, before resampling.
pub const MAX_STROKE_POINTS: usize = 1_000_000;

/// The most joints a rig may have for posing (ten times the largest production rigs).
pub const MAX_POSE_JOINTS: usize = 10_000;

/// How the solver runs. [`PoseOptions::paper`] is the method as published;
/// [`PoseOptions::default`] adds rigfit's improvements. Lengths are fractions of the
/// character's height.
#[derive(Clone, Debug, PartialEq)]
pub struct PoseOptions {
    /// Resample strokes evenly and smooth them before matching.
    pub beautify: bool,
    /// Before articulated fitting, align the whole character rigidly from several headings
    /// and keep the best.
    pub rigid_init: bool,
    /// Give each stroke one connected chain of bones (in order) and restrict its matches to
    /// it; undrawn bones keep their start pose; strokes no chain explains are set aside.
    pub chain_assignment: bool,
    /// Choose every stroke's chain (or stray) together, as one assignment problem, instead
    /// of greedily one stroke after another.
    pub global_assignment: bool,
    /// Judge a stroke against a chain by where the chain attaches and by its shape with the
    /// chain turned about its attachment, so that a limb drawn far from where it is now
    /// still gets its stroke; otherwise by the distance at the current pose.
    pub shape_matching: bool,
    /// Run the paper's softassign annealing over all bones before the chain step (measured:
    /// the chain step does better from the rigid alignment alone).
    pub anneal_before_chains: bool,
    /// Spacing of the model points along the bones.
    pub spacing: f64,
    /// Spacing of stroke samples after resampling.
    pub stroke_spacing: f64,
    /// Annealing: the match scale `sigma = 1/sqrt(beta)` goes from `sigma_start` to
    /// `sigma_end`.
    pub sigma_start: f64,
    pub sigma_end: f64,
    /// Steps of the annealing schedule.
    pub anneal_steps: usize,
    /// Paper: beta grows by a fixed amount per step; otherwise geometrically.
    pub additive_beta: bool,
    /// `zeta` of eq. (1) as a distance: matches further than this lose to the outlier class.
    pub outlier_distance: f64,
    /// Weight of `Phi(p)`: keeps joint rotations near the start pose.
    pub prior_weight: f64,
    /// Gauss-Newton steps per match update.
    pub gauss_newton_steps: usize,
    /// Extra iterations at the final temperature until the match converges.
    pub max_final_iterations: usize,
    /// A stroke whose RMS distance to its fitted chain exceeds this is a stray.
    pub stray_distance: f64,
    /// Poses tried as starts beside the rigid placements and the start pose (a neighbouring
    /// keyframe; the corpus offers the truth, to tell a search that missed from a score
    /// that chose wrong). Poses whose joint count is not the skeleton's are ignored.
    pub extra_starts: Vec<Pose>,
    /// Fit every start (the rigid placements and the character turned where it stands)
    /// even when the character where it stands already explains the strokes convincingly.
    /// Slower; on the posing corpus the shortcut lost one held-out case in 1,800 (measured
    /// with the earlier bend weight among hypotheses, 5e-4).
    pub search_every_start: bool,
}

impl Default for PoseOptions {
    fn default() -> Self {
        Self {
            beautify: true,
            rigid_init: true,
            chain_assignment: true,
            global_assignment: true,
            shape_matching: true,
            anneal_before_chains: false,
            spacing: 0.025,
            stroke_spacing: 0.025,
            sigma_start: 0.2,
            sigma_end: 0.012,
            anneal_steps: 14,
            additive_beta: false,
            outlier_distance: 0.06,
            prior_weight: 0.002,
            gauss_newton_steps: 1,
            max_final_iterations: 12,
            stray_distance: 0.06,
            extra_starts: Vec::new(),
            search_every_start: false,
        }
    }
}

impl PoseOptions {
    /// The method as published: softassign with outlier row and column, beta raised by a
    /// fixed step, all bones, raw strokes (only resampled to the model's spacing).
    pub fn paper() -> Self {
        Self {
            beautify: false,
            rigid_init: false,
            chain_assignment: false,
            global_assignment: false,
            shape_matching: false,
            additive_beta: true,
            ..Self::default()
        }
    }
}

/// Why strokes cannot be used.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PoseError {
    #[error("no strokes")]
    NoStrokes,
    #[error("strokes: {count} strokes, more than the {MAX_STROKES} one solve takes")]
    TooManyStrokes { count: usize },
    #[error("strokes: {count} points in all, more than the {MAX_STROKE_POINTS} one solve takes")]
    TooManyPoints { count: usize },
    #[error("the rig has {count} joints, more than the {MAX_POSE_JOINTS} posing takes")]
    TooManyJoints { count: usize },
    #[error("strokes[{stroke}]: a stroke needs at least 2 points")]
    StrokeTooShort { stroke: usize },
    #[error("strokes[{stroke}].points[{point}]: coordinate is not a finite number")]
    NonFinite { stroke: usize, point: usize },
    #[error(
        "strokes[{stroke}].points[{point}]: the point is more than {MAX_STROKE_DISTANCE} character heights away from the rig"
    )]
    FarAway { stroke: usize, point: usize },
    #[error("strokes[{stroke}].bones: unknown bone '{name}'")]
    UnknownStrokeBone { stroke: usize, name: String },
    #[error("unknown bone '{name}' in the list of bones that may move")]
    UnknownBone { name: String },
    #[error("the rig has no bones to align (no joint with a child at a distance)")]
    NoBones,
    #[error("none of the chosen bones can move")]
    NothingMoves,
    #[error(
        "the rig is a set of markers under '{root}' (each moved by translation alone): a stroke cannot say which marker it draws; pin each stroke to its marker (\"bones\": [name]) or fit the markers to points with rigfit track"
    )]
    UnpinnedMarkers { root: String },
    #[error("the solve was stopped before it finished (deadline passed or cancelled)")]
    Interrupted,
}

impl PoseError {
    /// True when the rig (or the list of bones that may move) is at fault, not the strokes:
    /// callers name the rig's file in the message.
    pub fn is_rig_problem(&self) -> bool {
        matches!(
            self,
            Self::UnknownBone { .. }
                | Self::NoBones
                | Self::UnpinnedMarkers { .. }
                | Self::NothingMoves
                | Self::TooManyJoints { .. }
        )
    }
}
