//! The correspondence engine shared by every model: soft correspondences between data
//! points and model points with an outlier class, annealed, alternated with a
//! Gauss-Newton / Levenberg-Marquardt fit of the model's parameters.
//!
//! A model only has to say where its points are and how they move with its parameters
//! (a [`crate::kinematics::ForwardKinematics`] for skeletons); the strategies here turn
//! (data, model points, temperature) into sparse weights, and [`normal_equations`] turns
//! weighted residuals into a parameter step. For skeletons, [`subtree_moments`] sums the
//! points' normal equations in closed form per joint subtree, and
//! [`skeleton_normal_equations`] solves them by the articulated-body recursion
//! ([`articulated`]) or without fill-in ([`tree_solver`]). [`em`] is the one-sided
//! strategy (Dewaele et al. 2006: each data point's posteriors over model points plus a
//! uniform outlier class), on the fixed-radius queries of [`point_grid`].

pub mod articulated;
pub mod em;
pub mod fitting_loop;
pub mod normal_equations;
pub mod point_grid;
pub mod skeleton_normal_equations;
pub mod softassign;
pub mod subtree_moments;
pub mod tree_solver;

pub use articulated::ArticulatedNormalEquations;
pub use em::{Candidates, EmStep, WeightedPoints, candidate_radius, em_step, em_step_with};
pub use normal_equations::{NormalEquations, NormalSink};
pub use point_grid::{PointGrid, voxel_subsample};
pub use skeleton_normal_equations::SkeletonNormalEquations;
pub use softassign::{MatchMatrix, SoftassignParams, softassign};
pub use subtree_moments::SubtreeMoments;
pub use tree_solver::TreeNormalEquations;
