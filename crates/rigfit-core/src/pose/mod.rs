//! Posing a skeleton from 3D strokes (Cannavò et al. 2020, section 3.2): match stroke
//! points to points along the bones by softassign under deterministic annealing, solve the
//! joint rotations that align the bones to their matches, and alternate until the match
//! converges. Beyond the paper: stroke beautification, a rigid multi-start alignment for a
//! far start pose, and a chain step that gives each stroke one connected chain of bones
//! (chosen for all strokes together, by where chains attach and their shape), so undrawn
//! limbs keep their start pose and stray strokes are set aside.
//!
//! The rooms of a solve, in order: `setup` (checks, samples, bone model), `multi_start`
//! (rigid placements), `assignment` (which chain each stroke covers), `fitting`
//! (Levenberg-Marquardt), `local_moves` (improving an assignment), `annealing` (the paper's
//! softassign), run by `solver`.

mod annealing;
mod assignment;
pub mod beautify;
pub mod bones;
mod candidates;
mod chains;
mod fitting;
mod local_moves;
mod mirror_image;
mod mirror_moves;
mod multi_start;
mod options;
mod row_shift;
mod score;
mod setup;
pub mod sketch;
mod solver;

use crate::interrupt::Interrupt;
use crate::skeleton::{Pose, Skeleton};
use crate::strokes::Stroke;

pub use bones::BoneModel;
pub use options::{
    MAX_POSE_JOINTS, MAX_STROKE_DISTANCE, MAX_STROKE_POINTS, MAX_STROKES, PoseError, PoseOptions,
};

/// What the solver found.
#[derive(Clone, Debug)]
pub struct PoseResult {
    pub pose: Pose,
    /// For each input stroke, the joints (bones, named by the joint that turns them) it was
    /// matched to, in order along the stroke; empty for a stroke set aside as a stray.
    pub stroke_bones: Vec<Vec<usize>>,
    /// Match-and-align iterations run.
    pub iterations: usize,
    /// The final energy of eq. (1) (squared distances in the rig's units).
    pub energy: f64,
}

/// The posing problem: a skeleton, the pose to start from, strokes, and which joints may
/// move.
#[derive(Clone, Debug)]
pub struct PoseProblem<'a> {
    pub skeleton: &'a Skeleton,
    pub start: &'a Pose,
    pub strokes: &'a [Stroke],
    /// Names of the joints that may move (`--bones`); all when `None`.
    pub movable: Option<&'a [String]>,
    /// The character's height (lengths in the options are fractions of it).
    pub height: f64,
}

/// Poses `problem.skeleton` so its bones lie along the strokes.
pub fn solve_pose(problem: &PoseProblem, options: &PoseOptions) -> Result<PoseResult, PoseError> {
    solve_pose_interruptible(problem, options, &Interrupt::never())
}

/// [`solve_pose`] that gives up with [`PoseError::Interrupted`] soon after `interrupt` is set
/// (a deadline, or a client that went away).
pub fn solve_pose_interruptible(
    problem: &PoseProblem,
    options: &PoseOptions,
    interrupt: &Interrupt,
) -> Result<PoseResult, PoseError> {
    let setup = setup::Setup::new(problem, options, interrupt)?;
    let result = solver::Solver::new(setup).run();
    if interrupt.is_set() {
        return Err(PoseError::Interrupted);
    }
    result
}
