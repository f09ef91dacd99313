//! The correspondence engine shared by every model: soft correspondences between data
//! points and model points with an outlier class, annealed, alternated with a
//! Gauss-Newton / Levenberg-Marquardt fit of the model's parameters.
//!
//! A model only has to say where its points are and how they move with its parameters; the
//! engine's rooms hold the rest:
//! - [`correspondence`]: softassign (two-sided), EM posteriors with the outlier class
//!   (one-sided: the Gaussian kernel and the normalisation every E-step shares), the
//!   candidate lists the E-steps reuse;
//! - [`spatial`]: the spatial indices, the grid and the kd-trees side by side;
//! - [`linear_algebra`]: the normal equations behind [`NormalSink`], dense and block-sparse
//!   (with the sparse Cholesky factorisation);
//! - [`skeleton`]: the skeleton-only sums and storages (subtree moments, the articulated-body
//!   recursion, the tree solver);
//! - [`awake_pool`]: a frame's many short parallel loops run with the pool's workers kept
//!   awake between them.

pub mod awake_pool;
pub mod correspondence;
pub mod fitting_loop;
pub mod linear_algebra;
pub mod skeleton;
pub mod spatial;

pub use awake_pool::run_with_workers_awake;
pub use correspondence::{
    Candidates, DEWAELE_OUTLIER_CONSTANT, EmStep, Evidence, GaussianKernel, MatchMatrix,
    SoftassignParams, WeightedPoints, candidate_radius, em_step, em_step_with, exp_negative,
    softassign,
};
pub use linear_algebra::{
    Block6, BlockPattern, BlockPosition, BlockSparseNormalEquations, NormalEquations, NormalSink,
    SolveError, SparseCholesky,
};
pub use skeleton::{
    ArticulatedNormalEquations, ChainCrossMoments, SkeletonNormalEquations, SubtreeMoments,
    TreeNormalEquations,
};
pub use spatial::{NearTree, NearestFew, PointGrid, PointTree, morton_order, voxel_subsample};

// The module paths before the engine's rooms (`crate::engine::em`, ...), kept for the code
// written against them.
#[doc(hidden)]
pub use correspondence::em;
#[doc(hidden)]
pub use linear_algebra::normal_equations;
#[doc(hidden)]
pub use spatial::grid as point_grid;
