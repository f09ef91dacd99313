//! The normal equations of skeletons (6 + 3 x joints parameters), the storages and sums
//! only an articulated model needs: [`subtree_moments`] sums the points' normal equations
//! in closed form per joint subtree (independent of the number of points), and
//! [`normal_equations`] ([`SkeletonNormalEquations`]) solves them by the articulated-body
//! recursion ([`articulated`], O(joints)) or a tree LDL^T with no fill-in ([`tree_solver`]),
//! else densely; [`chain_cross_moments`] sums blended points' lower columns against their
//! upper chains'. Every storage here is a [`crate::engine::NormalSink`].

pub mod articulated;
pub mod chain_cross_moments;
pub mod normal_equations;
pub mod subtree_moments;
pub mod tree_solver;

pub use articulated::ArticulatedNormalEquations;
pub use chain_cross_moments::ChainCrossMoments;
pub use normal_equations::SkeletonNormalEquations;
pub use subtree_moments::SubtreeMoments;
pub use tree_solver::TreeNormalEquations;
