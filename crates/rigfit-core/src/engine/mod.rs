//! The correspondence engine shared by every model: soft correspondences between data
//! points and model points with an outlier class, annealed, alternated with a
//! Gauss-Newton / Levenberg-Marquardt fit of the model's parameters.
//!
//! A model only has to say where its points are and how they move with its parameters
//! (a [`crate::kinematics::ForwardKinematics`] for skeletons); the strategies here turn
//! (data, model points, temperature) into sparse weights, and [`normal_equations`] turns
//! weighted residuals into a parameter step.

pub mod normal_equations;
pub mod softassign;

pub use normal_equations::NormalEquations;
pub use softassign::{MatchMatrix, SoftassignParams, softassign};
