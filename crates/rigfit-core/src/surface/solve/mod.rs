//! The M-step (Cagniart et al. 2010, eq. 15): one Gauss-Newton step on the data term (the
//! E-step's posteriors collapsed per vertex) plus the rigidity energy (eq. 4). Unknowns are
//! six per patch (a rotation increment `R_k <- exp([w_k]x) R_k` and a centre shift); the
//! normal equations are block-sparse with the pattern of the patch adjacency (two rings:
//! a vertex blends its patch's neighbours, which may not neighbour each other). The pattern
//! never changes, so its fill-reducing order and symbolic Cholesky factorisation are computed
//! once and reused, and the values are gathered straight into the permuted matrix.
//!
//! `patch_system` holds the block pattern and the fixed weights of each block,
//! `sparse_cholesky` the scalar pattern and its factorisation (faer), `block_moments` the
//! sums the blocks are assembled from, and `gauss_newton` the step itself.

mod block_moments;
mod gauss_newton;
mod patch_system;
#[cfg(test)]
mod reference;
mod sparse_cholesky;

pub use gauss_newton::{StepWeights, gauss_newton_step};
pub use patch_system::PatchSystem;

/// A 6x6 block, row-major.
type Block = [f64; 36];

/// Problems of the linear solve.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum SolveError {
    #[error("the normal equations could not be factorised")]
    Factorisation,
}
