//! The sparse Cholesky factorisation of a block pattern's scalar matrix (6x6 blocks; faer,
//! supernodal): the fill-reducing (AMD) order and the symbolic factorisation are computed
//! once, and each solve gathers the blocks' values straight into the permuted lower
//! triangle, factorises it and solves, with buffers kept between solves.

use std::fmt;
use std::sync::{Arc, Mutex, PoisonError};

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::sparse::linalg::cholesky::{
    CholeskySymbolicParams, SymbolicCholesky, SymmetricOrdering, factorize_symbolic_cholesky,
};
use faer::sparse::linalg::{SupernodalThreshold, amd};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMat, SymbolicSparseColMatRef};
use faer::{Conj, Par, Side};

use super::block_sparse::Block6;

/// Problems of the linear solve.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum SolveError {
    #[error("the normal equations could not be factorised")]
    Factorisation,
}

/// Where a scalar entry's value is in the blocks: its block and its position in the block
/// (row-major).
#[derive(Clone, Copy, Debug)]
struct ValueSource {
    block: u32,
    position: u8,
}

/// A scalar entry of the matrix: its row and column, and where its value is.
#[derive(Clone, Copy, Debug)]
struct ScalarEntry {
    row: usize,
    column: usize,
    source: ValueSource,
}

/// The factorisation of the block pattern's scalar matrix: its order, the pattern it reads
/// and the symbolic factorisation, computed once.
#[derive(Clone, Debug)]
pub struct SparseCholesky {
    /// The fill-reducing (AMD) order of the scalar unknowns: position `i` of the permuted
    /// system holds unknown `permutation[i]`.
    permutation: Vec<usize>,
    /// The lower triangle of the permuted matrix (sorted rows), the triangle faer's
    /// supernodal factorisation reads, so it neither permutes nor transposes it.
    permuted_lower: SymbolicSparseColMat<usize>,
    /// The factorisation's structure (supernodes) for the permuted matrix, computed once.
    symbolic: Arc<SymbolicCholesky<usize>>,
    /// For each scalar entry of `permuted_lower`, its block and position in the block.
    value_source: Vec<ValueSource>,
    buffers: SolveBuffers,
}

/// The numeric factorisation's buffers, kept between solves so that they are allocated
/// once. A clone starts with empty ones.
#[derive(Default)]
struct SolveBuffers(Mutex<SolveBufferSet>);

#[derive(Default)]
struct SolveBufferSet {
    /// The permuted matrix's values, in `value_source` order.
    values: Vec<f64>,
    factor: Vec<f64>,
    permuted_rhs: Vec<f64>,
    scratch: Option<MemBuffer>,
}

impl Clone for SolveBuffers {
    fn clone(&self) -> Self {
        Self::default()
    }
}

impl fmt::Debug for SolveBuffers {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("SolveBuffers")
    }
}

impl SparseCholesky {
    /// The factorisation of the block pattern given, for each block column `l`, by the block
    /// rows `k <= l` present (`column_rows`, sorted) and the offset of its first block
    /// (`column_offset`).
    pub fn new(column_rows: &[Vec<u32>], column_offset: &[usize]) -> Result<Self, SolveError> {
        let n = column_rows.len();
        // The scalar pattern: upper triangle of the block pattern, column by column, each
        // entry with its block and position in the block.
        let dim = 6 * n;
        let mut entries = Vec::new();
        for l in 0..n {
            for b in 0..6 {
                for (slot, &k) in column_rows[l].iter().enumerate() {
                    let block = (column_offset[l] + slot) as u32;
                    let rows = if k as usize == l { b + 1 } else { 6 };
                    for a in 0..rows {
                        entries.push(ScalarEntry {
                            row: 6 * k as usize + a,
                            column: 6 * l + b,
                            source: ValueSource {
                                block,
                                position: (6 * a + b) as u8,
                            },
                        });
                    }
                }
            }
        }
        // Already in column order: the sort only yields where each column starts.
        let (upper, entries) = column_pattern(dim, &entries, |e| e.row, |e| e.column);
        let (permutation, new_index) = fill_reducing_order(upper.as_ref())?;
        // Entry (r, c) moves to (new r, new c); the matrix is symmetric, so it keeps its value
        // in whichever triangle it lands, and the lower one holds it as (max, min).
        let permuted: Vec<ScalarEntry> = entries
            .iter()
            .map(
                |&ScalarEntry {
                     row,
                     column,
                     source,
                 }| {
                    let (i, j) = (new_index[row], new_index[column]);
                    ScalarEntry {
                        row: i.max(j),
                        column: i.min(j),
                        source,
                    }
                },
            )
            .collect();
        // Stable sorts by row, then by column: columns with their rows in order.
        let (_, permuted) = bucket_sort(dim, &permuted, |e| e.row);
        let (permuted_lower, permuted) = column_pattern(dim, &permuted, |e| e.row, |e| e.column);
        let value_source = permuted.iter().map(|e| e.source).collect();
        // The symbolic analysis reads the upper triangle: the same pattern transposed, whose
        // rows come out in order as the lower triangle is read column by column.
        let (permuted_upper, _) = column_pattern(dim, &permuted, |e| e.column, |e| e.row);
        let symbolic = factorize_symbolic_cholesky(
            permuted_upper.as_ref(),
            Side::Upper,
            SymmetricOrdering::Identity,
            CholeskySymbolicParams {
                supernodal_flop_ratio_threshold: SupernodalThreshold::FORCE_SUPERNODAL,
                ..Default::default()
            },
        )
        .map_err(|_| SolveError::Factorisation)?;
        let symbolic = Arc::new(symbolic);
        Ok(Self {
            permutation,
            permuted_lower,
            symbolic,
            value_source,
            buffers: SolveBuffers::default(),
        })
    }

    /// Solves `H x = rhs` for the assembled blocks (upper triangle read).
    pub fn solve(&self, blocks: &[Block6], rhs: &mut [f64]) -> Result<(), SolveError> {
        // The buffers hold nothing that outlives a solve, so a poisoned lock is still usable.
        let mut buffers = self
            .buffers
            .0
            .lock()
            .unwrap_or_else(PoisonError::into_inner);
        let SolveBufferSet {
            values,
            factor,
            permuted_rhs,
            scratch,
        } = &mut *buffers;
        values.clear();
        values.extend(
            self.value_source
                .iter()
                .map(|s| blocks[s.block as usize][s.position as usize]),
        );
        let matrix = SparseColMatRef::new(self.permuted_lower.as_ref(), values);
        // One thread: the system is small (six unknowns a patch), and handing its supernodes
        // to a thread pool costs more than it saves.
        let par = Par::Seq;
        let symbolic = &*self.symbolic;
        // The factorisation overwrites every value, so the buffer is only sized once.
        factor.resize(symbolic.len_val(), 0.0);
        let scratch = scratch.get_or_insert_with(|| {
            MemBuffer::new(
                symbolic
                    .factorize_numeric_llt_scratch::<f64>(par, Default::default())
                    .or(symbolic.solve_in_place_scratch::<f64>(1, par)),
            )
        });
        let stack = MemStack::new(scratch);
        let llt = symbolic
            .factorize_numeric_llt(
                factor,
                matrix,
                Side::Lower,
                Default::default(),
                par,
                stack,
                Default::default(),
            )
            .map_err(|_| SolveError::Factorisation)?;
        permuted_rhs.clear();
        permuted_rhs.extend(self.permutation.iter().map(|&old| rhs[old]));
        llt.solve_in_place_with_conj(
            Conj::No,
            faer::MatMut::from_column_major_slice_mut(permuted_rhs, symbolic.nrows(), 1),
            par,
            stack,
        );
        for (&old, &x) in self.permutation.iter().zip(permuted_rhs.iter()) {
            rhs[old] = x;
        }
        if rhs.iter().all(|x| x.is_finite()) {
            Ok(())
        } else {
            Err(SolveError::Factorisation)
        }
    }
}

/// `items` ordered by `key` (below `buckets`), keeping the order of equal keys (a counting
/// sort), and where each key's run starts (`buckets + 1` offsets).
fn bucket_sort<T: Copy>(
    buckets: usize,
    items: &[T],
    key: impl Fn(&T) -> usize,
) -> (Vec<usize>, Vec<T>) {
    let mut start = vec![0usize; buckets + 1];
    for item in items {
        start[key(item) + 1] += 1;
    }
    for k in 0..buckets {
        start[k + 1] += start[k];
    }
    let mut next = start.clone();
    let mut order = vec![0usize; items.len()];
    for (i, item) in items.iter().enumerate() {
        let k = key(item);
        order[next[k]] = i;
        next[k] += 1;
    }
    (start, order.into_iter().map(|i| items[i]).collect())
}

/// The `dim` x `dim` pattern of `entries` given each one's row and column, and the entries
/// column by column in that pattern's order (within a column, in the order given).
fn column_pattern<T: Copy>(
    dim: usize,
    entries: &[T],
    row: impl Fn(&T) -> usize,
    column: impl Fn(&T) -> usize,
) -> (SymbolicSparseColMat<usize>, Vec<T>) {
    let (col_ptr, sorted) = bucket_sort(dim, entries, column);
    let rows = sorted.iter().map(row).collect();
    let pattern = SymbolicSparseColMat::new_checked(dim, dim, col_ptr, None, rows);
    (pattern, sorted)
}

/// The AMD order of a symmetric matrix given by its upper triangle, as faer's symbolic
/// Cholesky computes it: `(forward, inverse)`, where position `i` holds unknown
/// `forward[i]` and unknown `j` moves to `inverse[j]`.
fn fill_reducing_order(
    upper: SymbolicSparseColMatRef<'_, usize>,
) -> Result<(Vec<usize>, Vec<usize>), SolveError> {
    let dim = upper.ncols();
    let mut forward = vec![0; dim];
    let mut inverse = vec![0; dim];
    let mut memory = MemBuffer::new(amd::order_maybe_unsorted_scratch::<usize>(
        dim,
        upper.compute_nnz(),
    ));
    amd::order_maybe_unsorted(
        &mut forward,
        &mut inverse,
        upper,
        CholeskySymbolicParams::default().amd_params,
        MemStack::new(&mut memory),
    )
    .map_err(|_| SolveError::Factorisation)?;
    Ok((forward, inverse))
}

#[cfg(test)]
mod tests {
    use super::super::BlockPattern;
    use rand::{Rng, SeedableRng};

    /// The sparse solve satisfies the block system it was given (a ring of blocks with a
    /// few chords).
    #[test]
    fn solve_satisfies_the_block_system() {
        let n = 40;
        let pairs = (0..n)
            .map(|k| (k, (k + 1) % n))
            .chain((0..n).step_by(7).map(|k| (k, (k + 13) % n)));
        let pattern = BlockPattern::new(n, pairs).expect("pattern");
        let mut rng = rand::rngs::StdRng::seed_from_u64(9);
        let mut blocks = vec![[0.0; 36]; pattern.block_count()];
        for (block, pair) in blocks.iter_mut().zip(pattern.block_pairs()) {
            for (i, x) in block.iter_mut().enumerate() {
                *x = rng.random::<f64>() - 0.5;
                if pair.row == pair.column && i % 7 == 0 {
                    *x += 40.0;
                }
            }
        }
        let dim = 6 * n;
        let wanted: Vec<f64> = (0..dim).map(|_| rng.random::<f64>() - 0.5).collect();
        let mut x = wanted.clone();
        pattern.cholesky().solve(&blocks, &mut x).expect("solve");
        // H x, reading each diagonal block's upper triangle.
        let mut product = vec![0.0; dim];
        for (block, pair) in blocks.iter().zip(pattern.block_pairs()) {
            let (k, l) = (pair.row as usize, pair.column as usize);
            for a in 0..6 {
                for b in 0..6 {
                    let value = if k == l {
                        block[6 * a.min(b) + a.max(b)]
                    } else {
                        block[6 * a + b]
                    };
                    product[6 * k + a] += value * x[6 * l + b];
                    if k != l {
                        product[6 * l + b] += value * x[6 * k + a];
                    }
                }
            }
        }
        for (p, w) in product.iter().zip(&wanted) {
            assert!((p - w).abs() < 1e-9, "{p} {w}");
        }
    }
}
