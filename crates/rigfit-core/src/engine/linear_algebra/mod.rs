//! The linear algebra of the M-step: Gauss-Newton / Levenberg-Marquardt normal equations
//! `J^T W J dtheta = -J^T W r`, assembled through one trait, [`NormalSink`], into the
//! storage that suits a model: dense ([`NormalEquations`], few parameters), block-sparse
//! with a sparse Cholesky factorisation ([`block_sparse`] over [`sparse_cholesky`]: six
//! parameters per block, a fixed pattern, as the surface tracker's patches), and the
//! skeleton storages of [`crate::engine::skeleton`].

pub mod block_sparse;
pub mod normal_equations;
pub mod sparse_cholesky;

pub use block_sparse::{Block6, BlockPattern, BlockPosition, BlockSparseNormalEquations};
pub use normal_equations::{NormalEquations, NormalSink};
pub use sparse_cholesky::{SolveError, SparseCholesky};
