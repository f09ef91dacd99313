//! The M-step (Cagniart et al. 2010, eq. 15): one Gauss-Newton step on the data term (the
//! E-step's posteriors collapsed per vertex) plus the rigidity energy (eq. 4). Unknowns are
//! six per patch (a rotation increment `R_k <- exp([w_k]x) R_k` and a centre shift); the
//! normal equations are block-sparse with the pattern of the patch adjacency (two rings:
//! a vertex blends its patch's neighbours, which may not neighbour each other). The pattern
//! never changes, so its fill-reducing order and symbolic Cholesky factorisation are computed
//! once and reused, and the values are gathered straight into the permuted matrix.
//!
//! The storage, the pattern's factorisation and the solve are the engine's
//! ([`crate::engine::linear_algebra::block_sparse`], one more [`crate::engine::NormalSink`]);
//! the patch-specific assembly is here: `patch_system` holds the patch graph's pattern and
//! the fixed weights of each block, `block_moments` the sums the blocks are assembled from,
//! and `gauss_newton` the step itself.

mod block_moments;
mod gauss_newton;
mod patch_system;
#[cfg(test)]
mod reference;

pub use crate::engine::linear_algebra::SolveError;
pub use gauss_newton::{StepWeights, anchor_weights, gauss_newton_step, patch_support};
pub use patch_system::PatchSystem;
