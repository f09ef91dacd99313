//! The M-step (Cagniart et al. 2010, eq. 15): one Gauss-Newton step on the data term (the
//! E-step's posteriors collapsed per vertex) plus the rigidity energy (eq. 4). Unknowns are
//! six per patch (a rotation increment `R_k <- exp([w_k]x) R_k` and a centre shift); the
//! normal equations are block-sparse with the pattern of the patch adjacency (two rings:
//! a vertex blends its patch's neighbours, which may not neighbour each other). The pattern
//! never changes, so its fill-reducing order and symbolic Cholesky factorisation are computed
//! once and reused, and the values are gathered straight into the permuted matrix.

use std::fmt;
use std::sync::{Arc, Mutex, PoisonError};

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::sparse::linalg::cholesky::{
    CholeskySymbolicParams, SymbolicCholesky, SymmetricOrdering, factorize_symbolic_cholesky,
};
use faer::sparse::linalg::{SupernodalThreshold, amd};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMat, SymbolicSparseColMatRef};
use faer::{Conj, Par, Side};
use rayon::prelude::*;

use super::estep::VertexTargets;
use super::model::{PatchModel, PatchPose};
use crate::math::{Matrix3, Point3, Vector3, exp_rotation, skew};

/// A 6x6 block, row-major.
type Block = [f64; 36];

/// Pairs of blended patches whose share of a vertex's data term is at most this
/// (`alpha_a alpha_b`) are majorised too (see [`PatchSystem`]).
const SMALL_PAIR: f64 = 1e-2;

/// The block pattern of the normal equations and its reusable symbolic factorisation.
#[derive(Clone, Debug)]
pub struct PatchSystem {
    patch_count: usize,
    /// For each block column `l`, the block rows `k <= l` present (sorted).
    column_rows: Vec<Vec<u32>>,
    /// Offset of column `l`'s first block in `blocks`.
    column_offset: Vec<usize>,
    /// The patches `(k, l)`, `k <= l`, of every block.
    block_patches: Vec<(u32, u32)>,
    /// The data term's normal equations, per blend entry `(v, a)`: the block `(a, a)` and its
    /// weight. A vertex's Jacobian sums its blended patches' (eq. 2), so its term couples
    /// every pair of them; the cross term of a pair that is not neighbouring patches (or
    /// whose weight `alpha_a alpha_b` is tiny) is bounded by the two patches' own terms,
    /// `2 u^T P w <= u^T P u + w^T P w` (P positive semi-definite), and added to them here:
    /// `alpha_a^2 + alpha_a sum_b alpha_b` over such `b`. The system's pattern stays the
    /// patch graph (far less fill in the factorisation, fewer products to assemble), and the
    /// step minimises a majoriser of the Gauss-Newton model, so it still descends.
    diagonal: Vec<(u32, f64)>,
    /// `pairs[pair_start[v]..pair_start[v + 1]]`: the pairs of blend entries of `v` kept
    /// (`blend` positions `i < j` in the row, ordered so that `k_i < k_j`), their block
    /// `(k_i, k_j)` and weight `alpha_i alpha_j`.
    pair_start: Vec<u32>,
    pairs: Vec<(u16, u16, u32, f64)>,
    /// For each neighbouring pair `(k, l)`: blocks `(k,k)`, `(l,l)`, `(min,max)`, and the
    /// rest-frame moments of its rigidity term (eq. 4) for those blocks: the weights
    /// `alpha_k(v) + alpha_l(v)` never change, so the term's normal equations cost O(1) per
    /// pair instead of O(vertices).
    rigidity_pairs: Vec<(usize, usize, [u32; 3], [OffsetMoments; 3])>,
    /// The fill-reducing (AMD) order of the scalar unknowns: position `i` of the permuted
    /// system holds unknown `permutation[i]`.
    permutation: Vec<usize>,
    /// The lower triangle of the permuted matrix (sorted rows), the triangle faer's
    /// supernodal factorisation reads, so it neither permutes nor transposes it.
    permuted_lower: SymbolicSparseColMat<usize>,
    /// The factorisation's structure (supernodes) for the permuted matrix, computed once.
    symbolic: Arc<SymbolicCholesky<usize>>,
    /// For each scalar entry of `permuted_lower`, its block and position in the block.
    value_source: Vec<(u32, u8)>,
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

/// Problems of the linear solve.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum SolveError {
    #[error("the normal equations could not be factorised")]
    Factorisation,
}

impl PatchSystem {
    pub fn new(model: &PatchModel) -> Result<Self, SolveError> {
        let n = model.patch_count();
        let mut column_rows: Vec<Vec<u32>> = (0..n).map(|l| vec![l as u32]).collect();
        let mut add = |a: usize, b: usize| {
            let (k, l) = if a <= b { (a, b) } else { (b, a) };
            column_rows[l].push(k as u32);
        };
        // The pattern is the patch graph: blend pairs that are not neighbours are majorised
        // onto the diagonal (see `diagonal`), so they add no fill.
        for (k, l) in model.neighbour_pairs() {
            add(k, l);
        }
        for rows in &mut column_rows {
            rows.sort_unstable();
            rows.dedup();
        }
        let mut column_offset = Vec::with_capacity(n + 1);
        let mut total = 0;
        for rows in &column_rows {
            column_offset.push(total);
            total += rows.len();
        }
        column_offset.push(total);
        let block_patches = column_rows
            .iter()
            .enumerate()
            .flat_map(|(l, rows)| rows.iter().map(move |&k| (k, l as u32)))
            .collect();
        let block_of = |column_rows: &[Vec<u32>], a: usize, b: usize| -> u32 {
            let (k, l) = if a <= b { (a, b) } else { (b, a) };
            let slot = column_rows[l]
                .binary_search(&(k as u32))
                .expect("every pair is in the pattern");
            (column_offset[l] + slot) as u32
        };
        let joined = |a: usize, b: usize| model.neighbours[a].binary_search(&(b as u32)).is_ok();
        let mut diagonal = Vec::with_capacity(model.blend_patch.len());
        let mut pair_start = Vec::with_capacity(model.vertex_count() + 1);
        let mut pairs = Vec::new();
        pair_start.push(0u32);
        for v in 0..model.vertex_count() {
            let blend: Vec<(usize, f64)> = model.blend(v).collect();
            for (i, &(a, alpha_a)) in blend.iter().enumerate() {
                let mut weight = alpha_a * alpha_a;
                for (j, &(b, alpha_b)) in blend.iter().enumerate() {
                    if i == j {
                        continue;
                    }
                    if joined(a, b) && alpha_a * alpha_b > SMALL_PAIR {
                        if a < b {
                            pairs.push((
                                i as u16,
                                j as u16,
                                block_of(&column_rows, a, b),
                                alpha_a * alpha_b,
                            ));
                        }
                    } else {
                        weight += alpha_a * alpha_b;
                    }
                }
                diagonal.push((block_of(&column_rows, a, a), weight));
            }
            pair_start.push(pairs.len() as u32);
        }
        let rigidity_pairs = model
            .neighbour_pairs()
            .into_iter()
            .map(|(k, l)| {
                (
                    k,
                    l,
                    [
                        block_of(&column_rows, k, k),
                        block_of(&column_rows, l, l),
                        block_of(&column_rows, k, l),
                    ],
                    rigidity_pair_moments(model, k, l),
                )
            })
            .collect();
        // The scalar pattern: upper triangle of the block pattern, column by column, each
        // entry as (row, column, block, position in the block).
        let dim = 6 * n;
        let mut entries = Vec::new();
        for l in 0..n {
            for b in 0..6 {
                for (slot, &k) in column_rows[l].iter().enumerate() {
                    let block = (column_offset[l] + slot) as u32;
                    let rows = if k as usize == l { b + 1 } else { 6 };
                    for a in 0..rows {
                        entries.push((6 * k as usize + a, 6 * l + b, block, (6 * a + b) as u8));
                    }
                }
            }
        }
        // Already in column order: the sort only yields where each column starts.
        let (upper, entries) = column_pattern(dim, &entries, |e| e.0, |e| e.1);
        let (permutation, new_index) = fill_reducing_order(upper.as_ref())?;
        // Entry (r, c) moves to (new r, new c); the matrix is symmetric, so it keeps its value
        // in whichever triangle it lands, and the lower one holds it as (max, min).
        let permuted: Vec<(usize, usize, u32, u8)> = entries
            .iter()
            .map(|&(row, column, block, position)| {
                let (i, j) = (new_index[row], new_index[column]);
                (i.max(j), i.min(j), block, position)
            })
            .collect();
        // Stable sorts by row, then by column: columns with their rows in order.
        let (_, permuted) = bucket_sort(dim, &permuted, |e| e.0);
        let (permuted_lower, permuted) = column_pattern(dim, &permuted, |e| e.0, |e| e.1);
        let value_source = permuted
            .iter()
            .map(|&(.., block, position)| (block, position))
            .collect();
        // The symbolic analysis reads the upper triangle: the same pattern transposed, whose
        // rows come out in order as the lower triangle is read column by column.
        let (permuted_upper, _) = column_pattern(dim, &permuted, |e| e.1, |e| e.0);
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
            patch_count: n,
            column_rows,
            column_offset,
            block_patches,
            diagonal,
            pair_start,
            pairs,
            rigidity_pairs,
            permutation,
            permuted_lower,
            symbolic,
            value_source,
            buffers: SolveBuffers::default(),
        })
    }

    /// The pairs of blend entries of vertex `v` kept in the data term (see `pairs`).
    fn vertex_pairs(&self, v: usize) -> &[(u16, u16, u32, f64)] {
        &self.pairs[self.pair_start[v] as usize..self.pair_start[v + 1] as usize]
    }

    pub fn block_count(&self) -> usize {
        self.column_offset[self.patch_count]
    }

    /// Solves `H x = rhs` for the assembled blocks (upper triangle read).
    fn solve(&self, blocks: &[Block], rhs: &mut [f64]) -> Result<(), SolveError> {
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
                .map(|&(b, e)| blocks[b as usize][e as usize]),
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

/// Weighted sums over vertices of their rest-frame offsets from two patch centres,
/// `a_v = x^0(v) - c_a^0` and `b_v = x^0(v) - c_b^0`. With the rotations they give
/// `sum_v beta_v J_a(v)^T J_b(v)` for `J = [-[q]x, I]`, `q_a = R_a a_v`, in O(1): the
/// rotation block is `tr(S) I - S^T` with `S = sum beta q_a q_b^T = R_a (sum beta a b^T) R_b^T`.
#[derive(Clone, Copy, Debug)]
struct OffsetMoments {
    /// `sum beta`.
    weight: f64,
    /// `sum beta a_v`.
    first_a: Vector3,
    /// `sum beta b_v`.
    first_b: Vector3,
    /// `sum beta a_v b_v^T`.
    second: Matrix3,
}

impl Default for OffsetMoments {
    fn default() -> Self {
        Self {
            weight: 0.0,
            first_a: Vector3::zeros(),
            first_b: Vector3::zeros(),
            second: Matrix3::zeros(),
        }
    }
}

impl OffsetMoments {
    #[inline]
    fn add(&mut self, beta: f64, a: &Vector3, b: &Vector3) {
        self.weight += beta;
        self.first_a += a * beta;
        self.first_b += b * beta;
        self.second += (a * beta) * b.transpose();
    }

    /// `(sum beta q_a, sum beta q_b, sum beta q_a q_b^T)` for rotations `R_a`, `R_b`.
    #[inline]
    fn rotated(&self, ra: &Matrix3, rb: &Matrix3) -> (Vector3, Vector3, Matrix3) {
        (
            ra * self.first_a,
            rb * self.first_b,
            ra * self.second * rb.transpose(),
        )
    }

    /// Adds `scale * sum beta J_a^T J_b`, where
    /// `J_a^T J_b = [[-[q_a]x [q_b]x, [q_a]x], [-[q_b]x, I]]` and
    /// `-[q_a]x [q_b]x = (q_a . q_b) I - q_b q_a^T`.
    #[inline]
    fn add_to_block(&self, block: &mut Block, scale: f64, ra: &Matrix3, rb: &Matrix3) {
        let (ma, mb, s) = self.rotated(ra, rb);
        add_jtj_sums(block, scale, self.weight, &ma, &mb, &s);
    }
}

/// Adds `scale * [[tr(S) I - S^T, [m_a]x], [-[m_b]x, w I]]` to `block`: the sum of
/// `beta J_a^T J_b` over points with `w = sum beta`, `m = sum beta q`,
/// `S = sum beta q_a q_b^T`.
#[inline]
fn add_jtj_sums(
    block: &mut Block,
    scale: f64,
    weight: f64,
    ma: &Vector3,
    mb: &Vector3,
    s: &Matrix3,
) {
    let sa = skew(ma);
    let sb = skew(mb);
    let trace = s.trace();
    for r in 0..3 {
        for c in 0..3 {
            let diagonal = if r == c { trace } else { 0.0 };
            block[6 * r + c] += scale * (diagonal - s[(c, r)]);
            block[6 * r + c + 3] += scale * sa[(r, c)];
            block[6 * (r + 3) + c] -= scale * sb[(r, c)];
        }
        block[6 * (r + 3) + r + 3] += scale * weight;
    }
}

/// `sum beta q_a x q_b` from `S = sum beta q_a q_b^T`: `[a x b]x = b a^T - a b^T`, so the
/// sum is the axial vector of `S^T - S`.
#[inline]
fn cross_sum(s: &Matrix3) -> Vector3 {
    Vector3::new(
        s[(1, 2)] - s[(2, 1)],
        s[(2, 0)] - s[(0, 2)],
        s[(0, 1)] - s[(1, 0)],
    )
}

/// The moments of the rigidity term of neighbouring patches `k < l` (eq. 4): over the
/// vertices of both, weights `alpha_k(v) + alpha_l(v)`, for blocks `(k,k)`, `(l,l)`, `(k,l)`.
fn rigidity_pair_moments(model: &PatchModel, k: usize, l: usize) -> [OffsetMoments; 3] {
    let mut out = [OffsetMoments::default(); 3];
    for &v in model.members[k].iter().chain(&model.members[l]) {
        let v = v as usize;
        let beta = model.alpha(k, v) + model.alpha(l, v);
        let a = model.rest[v] - model.rest_centre[k];
        let b = model.rest[v] - model.rest_centre[l];
        out[0].add(beta, &a, &a);
        out[1].add(beta, &b, &b);
        out[2].add(beta, &a, &b);
    }
    out
}

/// The upper triangle of a symmetric 3x3 matrix, row by row: `xx, xy, xz, yy, yz, zz`.
const SYMMETRIC3: [(usize, usize); 6] = [(0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2)];

/// The isotropic part of a block's data term, summed over vertices: rest-frame moments of the
/// offsets `a_v` from one patch's rest centre, `sum w`, `sum w a` and `sum w a a^T`
/// (symmetric: its upper triangle, see [`SYMMETRIC3`]).
#[derive(Clone, Copy, Debug, Default)]
struct RestMoments {
    weight: f64,
    first: [f64; 3],
    second: [f64; 6],
}

impl RestMoments {
    #[inline]
    fn add(&mut self, w: f64, a: &[f64; 3]) {
        self.weight += w;
        for i in 0..3 {
            self.first[i] += w * a[i];
        }
        for (s, &(r, c)) in self.second.iter_mut().zip(&SYMMETRIC3) {
            *s += w * a[r] * a[c];
        }
    }

    fn add_sums(&mut self, other: &Self) {
        self.weight += other.weight;
        add_slices(&mut self.first, &other.first);
        add_slices(&mut self.second, &other.second);
    }

    /// The moments of the pair `(a_v, b_v)` with `b_v = a_v + delta` (`delta = c_a^0 - c_b^0`,
    /// zero for a patch with itself): `sum w b_v = sum w a_v + w delta` and
    /// `sum w a_v b_v^T = sum w a_v a_v^T + (sum w a_v) delta^T`.
    fn offset_moments(&self, delta: &Vector3) -> OffsetMoments {
        let first = Vector3::from(self.first);
        let mut second = Matrix3::zeros();
        for (&s, &(i, j)) in self.second.iter().zip(&SYMMETRIC3) {
            second[(i, j)] = s;
            second[(j, i)] = s;
        }
        OffsetMoments {
            weight: self.weight,
            first_a: first,
            first_b: first + delta * self.weight,
            second: second + first * delta.transpose(),
        }
    }
}

/// One block's share of the data term, summed over the vertices it blends: the isotropic part
/// as [`RestMoments`], and the `N` sums of the part along the normal, `c u_a u_b^T` with
/// `u = [q x n; n]` in world coordinates ([`OwnBlockSums`], [`PairBlockSums`]).
#[derive(Clone, Copy, Debug)]
struct BlockSums<const N: usize> {
    isotropic: RestMoments,
    normal: [f64; N],
}

impl<const N: usize> Default for BlockSums<N> {
    fn default() -> Self {
        Self {
            isotropic: RestMoments::default(),
            normal: [0.0; N],
        }
    }
}

impl<const N: usize> BlockSums<N> {
    fn add_sums(&mut self, other: &Self) {
        self.isotropic.add_sums(&other.isotropic);
        add_slices(&mut self.normal, &other.normal);
    }
}

/// A diagonal block (a patch with itself): the part along the normal is symmetric, kept as
/// its upper triangle, row by row.
type OwnBlockSums = BlockSums<21>;

impl OwnBlockSums {
    #[inline]
    fn add_vertex(&mut self, isotropic: f64, along_normal: f64, offset: &[f64; 3], u: &[f64; 6]) {
        self.isotropic.add(isotropic, offset);
        let mut t = 0;
        for i in 0..6 {
            let ci = along_normal * u[i];
            for &uj in &u[i..] {
                self.normal[t] += ci * uj;
                t += 1;
            }
        }
    }

    /// Adds the sums to the block of a patch with rotation `r`.
    fn add_to_block(&self, block: &mut Block, r: &Matrix3) {
        self.isotropic
            .offset_moments(&Vector3::zeros())
            .add_to_block(block, 1.0, r, r);
        let mut t = 0;
        for i in 0..6 {
            for j in i..6 {
                block[6 * i + j] += self.normal[t];
                if j != i {
                    block[6 * j + i] += self.normal[t];
                }
                t += 1;
            }
        }
    }
}

/// An off-diagonal block (patches `a < b` blended at the same vertices): the isotropic part of
/// the offsets from patch `a`'s centre (those from `b`'s differ by the two centres'
/// difference), the part along the normal in full (row-major).
type PairBlockSums = BlockSums<36>;

impl PairBlockSums {
    #[inline]
    fn add_vertex(
        &mut self,
        isotropic: f64,
        along_normal: f64,
        offset_a: &[f64; 3],
        u: (&[f64; 6], &[f64; 6]),
    ) {
        self.isotropic.add(isotropic, offset_a);
        for i in 0..6 {
            let ci = along_normal * u.0[i];
            for j in 0..6 {
                self.normal[6 * i + j] += ci * u.1[j];
            }
        }
    }

    /// Adds the sums to the block of patches `a` and `b` (rotations `ra`, `rb`), where
    /// `delta = c_a^0 - c_b^0`.
    fn add_to_block(&self, block: &mut Block, ra: &Matrix3, rb: &Matrix3, delta: &Vector3) {
        self.isotropic
            .offset_moments(delta)
            .add_to_block(block, 1.0, ra, rb);
        for (b, n) in block.iter_mut().zip(&self.normal) {
            *b += n;
        }
    }
}

/// Per patch blended at a vertex: index, alpha, rest offset, `q = R offset`, `u = [q x n; n]`.
type BlendedPatch = (usize, f64, [f64; 3], Vector3, [f64; 6]);

#[inline]
fn add_slices(to: &mut [f64], from: &[f64]) {
    for (t, f) in to.iter_mut().zip(from) {
        *t += f;
    }
}

/// Adds `w * J^T r` for `J = [-[q]x, I]`.
#[inline]
fn add_jtr(g: &mut [f64], w: f64, q: &Vector3, r: &Vector3) {
    let top = q.cross(r);
    for i in 0..3 {
        g[i] += w * top[i];
        g[i + 3] += w * r[i];
    }
}

/// Weights of the two energy terms.
#[derive(Clone, Debug)]
pub struct StepWeights {
    /// Weight of the data term: `1 / sigma^2`.
    pub data: f64,
    /// Weight of the rigidity energy (eq. 4).
    pub rigidity: f64,
    /// Levenberg-Marquardt damping, relative to each diagonal entry.
    pub damping: f64,
    /// Weight of the data residual's component along the surface, against 1 across it:
    /// 1 is the paper's point-to-point distance; below 1 lets a vertex slide along the
    /// surface toward the centroid of its points without the mesh being dragged by the way
    /// points happen to fall around vertices.
    pub tangential: f64,
    /// The step taken is this multiple of the Gauss-Newton step (1: the step itself).
    pub relaxation: f64,
}

/// One vertex's data term: `weight * |x(v) - ybar_v|_P^2` with `P = n n^T + t (I - n n^T)`.
struct DataTerm {
    vertex: usize,
    weight: f64,
    normal: Vector3,
    /// `weight * P`.
    metric: Matrix3,
    residual: Vector3,
}

/// The data term of every vertex with posterior weight (eq. 15, collapsed per vertex).
fn data_terms(
    positions: &[Point3],
    normals: &[Vector3],
    targets: &VertexTargets,
    weights: &StepWeights,
) -> Vec<DataTerm> {
    (0..positions.len())
        .filter(|&v| targets.weight[v] > 1e-12)
        .map(|v| {
            let w = targets.weight[v];
            let ybar = targets.weighted_sum[v] / w;
            let n = normals[v];
            let across = n * n.transpose();
            let weight = w * weights.data;
            let metric = (across + (Matrix3::identity() - across) * weights.tangential) * weight;
            DataTerm {
                vertex: v,
                weight,
                normal: n,
                metric,
                residual: positions[v].coords - ybar,
            }
        })
        .collect()
}

/// One Gauss-Newton step on `data * sum_v W_v |x(v) - ybar_v|_P^2 + rigidity * E_r`, applied
/// to `pose` in place, where `P = n n^T + tangential (I - n n^T)` for the vertex normal `n`.
pub fn gauss_newton_step(
    model: &PatchModel,
    system: &PatchSystem,
    pose: &mut PatchPose,
    positions: &[Point3],
    normals: &[Vector3],
    targets: &VertexTargets,
    weights: &StepWeights,
) -> Result<(), SolveError> {
    let n = model.patch_count();
    let mut blocks = vec![[0.0; 36]; system.block_count()];
    let mut gradient = vec![0.0; 6 * n];

    // Data term, vertex by vertex: residual x(v) - ybar_v with weight W_v; the Jacobian of
    // x(v) is sum_k alpha_k(v) J_k(v) (eq. 2).
    let data_terms = data_terms(positions, normals, targets, weights);
    // Eq. 15's normal equations for the data term. With `P = t I + (1 - t) n n^T` and
    // `J_a = alpha_a [-[q_a]x, I]`, each block `sum_v W_v J_a^T P J_b` splits into an
    // isotropic part (summed as rest-frame moments, rotated once per block) and a rank-one
    // part along the normal. Two halves in parallel, each into its own sums, then added.
    let half = data_terms.len().div_ceil(2).max(1);
    let partial: Vec<(Vec<OwnBlockSums>, Vec<PairBlockSums>, Vec<f64>)> = data_terms
        .par_chunks(half)
        .map(|terms| {
            let mut own = vec![OwnBlockSums::default(); n];
            let mut pair = vec![PairBlockSums::default(); system.block_count()];
            let mut gradient = vec![0.0; 6 * n];
            let mut blend: Vec<BlendedPatch> = Vec::with_capacity(16);
            for term in terms {
                let v = term.vertex;
                let pr = term.metric * term.residual;
                let isotropic = weights.tangential * term.weight;
                let along_normal = (1.0 - weights.tangential) * term.weight;
                let normal = term.normal;
                blend.clear();
                blend.extend(model.blend(v).map(|(k, a)| {
                    let rest_offset = model.rest[v] - model.rest_centre[k];
                    let q = pose.rotation[k] * rest_offset;
                    let c = q.cross(&normal);
                    let u = [c.x, c.y, c.z, normal.x, normal.y, normal.z];
                    (k, a, rest_offset.into(), q, u)
                }));
                let first = model.blend_start[v] as usize;
                for (i, (k, alpha, offset, q, u)) in blend.iter().enumerate() {
                    add_jtr(&mut gradient[6 * k..6 * k + 6], *alpha, q, &pr);
                    let weight = system.diagonal[first + i].1;
                    own[*k].add_vertex(isotropic * weight, along_normal * weight, offset, u);
                }
                for &(i, j, block, weight) in system.vertex_pairs(v) {
                    let (_, _, offset_a, _, ua) = &blend[i as usize];
                    let ub = &blend[j as usize].4;
                    pair[block as usize].add_vertex(
                        isotropic * weight,
                        along_normal * weight,
                        offset_a,
                        (ua, ub),
                    );
                }
            }
            (own, pair, gradient)
        })
        .collect();
    let mut own = vec![OwnBlockSums::default(); n];
    let mut pair = vec![PairBlockSums::default(); system.block_count()];
    for (part_own, part_pair, part_gradient) in partial {
        for (t, s) in own.iter_mut().zip(&part_own) {
            t.add_sums(s);
        }
        for (t, s) in pair.iter_mut().zip(&part_pair) {
            t.add_sums(s);
        }
        add_slices(&mut gradient, &part_gradient);
    }
    for (block, (sum, &(a, b))) in blocks
        .iter_mut()
        .zip(pair.iter().zip(&system.block_patches))
    {
        let (a, b) = (a as usize, b as usize);
        if a == b {
            own[a].add_to_block(block, &pose.rotation[a]);
        } else {
            let delta = model.rest_centre[a] - model.rest_centre[b];
            sum.add_to_block(block, &pose.rotation[a], &pose.rotation[b], &delta);
        }
    }

    // Rigidity (eq. 4): residual x_k(v) - x_l(v) over v in P_k and P_l, weight
    // alpha_k(v) + alpha_l(v); the Jacobian is J_k(v) for patch k and -J_l(v) for patch l.
    // From the pair's rest-frame moments: with d = c_k - c_l and r = d + q_k - q_l,
    // sum beta q_k x r = m_k x d - X and sum beta q_l x r = m_l x d - X, X = sum q_k x q_l.
    for (k, l, ids, moments) in &system.rigidity_pairs {
        let (k, l) = (*k, *l);
        let (rk, rl) = (&pose.rotation[k], &pose.rotation[l]);
        let w = weights.rigidity;
        moments[0].add_to_block(&mut blocks[ids[0] as usize], w, rk, rk);
        moments[1].add_to_block(&mut blocks[ids[1] as usize], w, rl, rl);
        moments[2].add_to_block(&mut blocks[ids[2] as usize], -w, rk, rl);
        let (mk, ml, s) = moments[2].rotated(rk, rl);
        let crossed = cross_sum(&s);
        let d = pose.centre[k] - pose.centre[l];
        let residual_sum = d * moments[2].weight + mk - ml;
        let top_k = mk.cross(&d) - crossed;
        let top_l = ml.cross(&d) - crossed;
        for i in 0..3 {
            gradient[6 * k + i] += w * top_k[i];
            gradient[6 * k + 3 + i] += w * residual_sum[i];
            gradient[6 * l + i] -= w * top_l[i];
            gradient[6 * l + 3 + i] -= w * residual_sum[i];
        }
    }

    damp_solve_and_apply(
        model,
        system,
        pose,
        &mut blocks,
        &gradient,
        targets,
        weights,
    )
}

/// Adds the damping to the assembled normal equations, solves them and applies the step
/// (rotation increments and centre shifts) to `pose`.
fn damp_solve_and_apply(
    model: &PatchModel,
    system: &PatchSystem,
    pose: &mut PatchPose,
    blocks: &mut [Block],
    gradient: &[f64],
    targets: &VertexTargets,
    weights: &StepWeights,
) -> Result<(), SolveError> {
    let n = model.patch_count();
    // Damping: relative (Levenberg-Marquardt) plus a floor so that patches with no data and
    // no neighbours (a lone object out of view) stay put instead of making H singular.
    // Rotation entries scale with length^2: the floor compares them at the model's size.
    let diagonal_block = |k: usize| {
        let slot = system.column_rows[k]
            .binary_search(&(k as u32))
            .expect("every column holds its diagonal block");
        system.column_offset[k] + slot
    };
    let max_translation = (0..n)
        .flat_map(|k| (3..6).map(move |i| (k, i)))
        .map(|(k, i)| blocks[diagonal_block(k)][7 * i])
        .fold(0.0, f64::max)
        .max(1e-300);
    // A weak prior to stay put, worth about `damping` of an average patch's data, so that a
    // patch seen by a handful of points cannot swing far in one step.
    let data_weight: f64 = targets.weight.iter().sum::<f64>() * weights.data;
    let floor_translation = 1e-9 * max_translation + weights.damping * data_weight / n as f64;
    let floor_rotation = floor_translation * model.diagonal * model.diagonal;
    for k in 0..n {
        let block = &mut blocks[diagonal_block(k)];
        for i in 0..6 {
            let floor = if i < 3 {
                floor_rotation
            } else {
                floor_translation
            };
            block[7 * i] += weights.damping * block[7 * i] + floor;
        }
    }

    let mut rhs: Vec<f64> = gradient.iter().map(|g| -g).collect();
    system.solve(blocks, &mut rhs)?;
    for x in &mut rhs {
        *x *= weights.relaxation;
    }
    for k in 0..n {
        let w = Vector3::new(rhs[6 * k], rhs[6 * k + 1], rhs[6 * k + 2]);
        let dc = Vector3::new(rhs[6 * k + 3], rhs[6 * k + 4], rhs[6 * k + 5]);
        let turn = exp_rotation(&w).to_rotation_matrix().into_inner();
        pose.rotation[k] = orthonormalise(&(turn * pose.rotation[k]));
        pose.centre[k] += dc;
    }
    Ok(())
}

/// `m` made a rotation again (products of rotations drift by rounding): Gram-Schmidt on its
/// columns, which for a matrix this close to a rotation is the nearest one to rounding.
fn orthonormalise(m: &Matrix3) -> Matrix3 {
    let x = m.column(0).normalize();
    let y = m.column(1) - x * x.dot(&m.column(1));
    let y = y.normalize();
    let z = x.cross(&y);
    Matrix3::from_columns(&[x, y, z])
}

#[cfg(test)]
mod reference {
    //! The assembly before the moment form, vertex by vertex (for the equivalence test).
    #![allow(clippy::all)]
    use super::*;
    type PairTerms = (usize, usize, [u32; 3], [Block; 3], [f64; 12]);
    /// Adds `w * J_a^T J_b` for `J = [-[q]x, I]` (the Jacobian of a prediction with respect to
    /// its patch's rotation increment and centre shift).
    #[inline]
    pub fn add_jtj(block: &mut Block, w: f64, qa: &Vector3, qb: &Vector3) {
        let sa = skew(qa);
        let sb = skew(qb);
        // J_a^T J_b = [[-[qa]x [qb]x, [qa]x], [-[qb]x, I]].
        let tl = -(sa * sb);
        for r in 0..3 {
            for c in 0..3 {
                block[6 * r + c] += w * tl[(r, c)];
                block[6 * r + c + 3] += w * sa[(r, c)];
                block[6 * (r + 3) + c] -= w * sb[(r, c)];
            }
            block[6 * (r + 3) + r + 3] += w;
        }
    }

    /// Adds `J_a^T P J_b` for `J = [-[q]x, I]` and a symmetric metric `P` (already weighted).
    #[inline]
    pub fn add_jtpj(block: &mut Block, p: &Matrix3, qa: &Vector3, qb: &Vector3) {
        let sa = skew(qa);
        let sb = skew(qb);
        // J_a^T P J_b = [[-[qa]x P [qb]x, [qa]x P], [-P [qb]x, P]].
        let sap = sa * p;
        let tl = -(sap * sb);
        let bl = -(p * sb);
        for r in 0..3 {
            for c in 0..3 {
                block[6 * r + c] += tl[(r, c)];
                block[6 * r + c + 3] += sap[(r, c)];
                block[6 * (r + 3) + c] += bl[(r, c)];
                block[6 * (r + 3) + c + 3] += p[(r, c)];
            }
        }
    }

    /// One Gauss-Newton step on `data * sum_v W_v |x(v) - ybar_v|_P^2 + rigidity * E_r`, applied
    /// to `pose` in place, where `P = n n^T + tangential (I - n n^T)` for the vertex normal `n`.
    pub fn reference_step(
        model: &PatchModel,
        system: &PatchSystem,
        pose: &mut PatchPose,
        positions: &[Point3],
        normals: &[Vector3],
        targets: &VertexTargets,
        weights: &StepWeights,
    ) -> Result<(), SolveError> {
        let n = model.patch_count();
        let mut blocks = vec![[0.0; 36]; system.block_count()];
        let mut gradient = vec![0.0; 6 * n];

        // Data term, vertex by vertex: residual x(v) - ybar_v with weight W_v; the Jacobian of
        // x(v) is sum_k alpha_k(v) J_k(v) (eq. 2).
        let data_terms: Vec<(usize, Matrix3, Vector3)> =
            super::data_terms(positions, normals, targets, weights)
                .into_iter()
                .map(|t| (t.vertex, t.metric, t.residual))
                .collect();
        // Two halves in parallel, each into its own blocks, then summed.
        let half = data_terms.len().div_ceil(2).max(1);
        let partial: Vec<(Vec<Block>, Vec<f64>)> = data_terms
            .par_chunks(half)
            .map(|terms| {
                let mut blocks = vec![[0.0; 36]; system.block_count()];
                let mut gradient = vec![0.0; 6 * n];
                let mut blend: Vec<(usize, f64, Vector3)> = Vec::with_capacity(16);
                for &(v, metric, r) in terms {
                    let pr = metric * r;
                    blend.clear();
                    blend.extend(
                        model
                            .blend(v)
                            .map(|(k, a)| (k, a, model.offset(pose, k, v))),
                    );
                    let first = model.blend_start[v] as usize;
                    for (i, &(k, alpha, q)) in blend.iter().enumerate() {
                        add_jtr(&mut gradient[6 * k..6 * k + 6], alpha, &q, &pr);
                        let (block, weight) = system.diagonal[first + i];
                        add_jtpj(&mut blocks[block as usize], &(metric * weight), &q, &q);
                    }
                    for &(i, j, block, weight) in system.vertex_pairs(v) {
                        let (_, _, qa) = blend[i as usize];
                        let (_, _, qb) = blend[j as usize];
                        add_jtpj(&mut blocks[block as usize], &(metric * weight), &qa, &qb);
                    }
                }
                (blocks, gradient)
            })
            .collect();
        for (b, g) in partial {
            for (t, s) in blocks.iter_mut().zip(&b) {
                for (x, y) in t.iter_mut().zip(s) {
                    *x += y;
                }
            }
            for (x, y) in gradient.iter_mut().zip(&g) {
                *x += y;
            }
        }

        // Rigidity (eq. 4): residual x_k(v) - x_l(v) over v in P_k and P_l, weight
        // alpha_k(v) + alpha_l(v); the Jacobian is J_k(v) for patch k and -J_l(v) for patch l.
        let rigidity: Vec<PairTerms> = system
            .rigidity_pairs
            .par_iter()
            .map(|&(k, l, ids, _)| {
                let mut b = [[0.0; 36]; 3];
                let mut g = [0.0; 12];
                for &v in model.members[k].iter().chain(&model.members[l]) {
                    let v = v as usize;
                    let beta = weights.rigidity * (model.alpha(k, v) + model.alpha(l, v));
                    let qk = model.offset(pose, k, v);
                    let ql = model.offset(pose, l, v);
                    let r = (pose.centre[k] + qk) - (pose.centre[l] + ql);
                    add_jtj(&mut b[0], beta, &qk, &qk);
                    add_jtj(&mut b[1], beta, &ql, &ql);
                    add_jtj(&mut b[2], -beta, &qk, &ql);
                    add_jtr(&mut g[..6], beta, &qk, &r);
                    add_jtr(&mut g[6..], -beta, &ql, &r);
                }
                (k, l, ids, b, g)
            })
            .collect();
        // Pairs are (k, l) with k < l: the cross block is stored as it is.
        for (k, l, ids, b, g) in rigidity {
            for (slot, block) in ids.iter().zip(&b) {
                for (t, s) in blocks[*slot as usize].iter_mut().zip(block) {
                    *t += s;
                }
            }
            for i in 0..6 {
                gradient[6 * k + i] += g[i];
                gradient[6 * l + i] += g[6 + i];
            }
        }

        super::damp_solve_and_apply(
            model,
            system,
            pose,
            &mut blocks,
            &gradient,
            targets,
            weights,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::surface::cases::torus;
    use crate::surface::model::PatchOptions;
    use rand::{Rng, SeedableRng};

    /// The sparse solve satisfies the block system it was given.
    #[test]
    fn solve_satisfies_the_block_system() {
        let reference = torus(30, 15);
        let model = PatchModel::new(&reference, &PatchOptions::default()).expect("model");
        let system = PatchSystem::new(&model).expect("system");
        let mut rng = rand::rngs::StdRng::seed_from_u64(9);
        let mut blocks = vec![[0.0; 36]; system.block_count()];
        for (block, &(k, l)) in blocks.iter_mut().zip(&system.block_patches) {
            for (i, x) in block.iter_mut().enumerate() {
                *x = rng.random::<f64>() - 0.5;
                if k == l && i % 7 == 0 {
                    *x += 40.0;
                }
            }
        }
        let dim = 6 * model.patch_count();
        let wanted: Vec<f64> = (0..dim).map(|_| rng.random::<f64>() - 0.5).collect();
        let mut x = wanted.clone();
        system.solve(&blocks, &mut x).expect("solve");
        // H x, reading each diagonal block's upper triangle.
        let mut product = vec![0.0; dim];
        for (block, &(k, l)) in blocks.iter().zip(&system.block_patches) {
            let (k, l) = (k as usize, l as usize);
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

    /// The moment form of the normal equations takes the same step as summing vertex by
    /// vertex.
    #[test]
    fn moment_assembly_matches_vertex_by_vertex_sums() {
        let reference = torus(30, 15);
        let model = PatchModel::new(&reference, &PatchOptions::default()).expect("model");
        let system = PatchSystem::new(&model).expect("system");
        let mut rng = rand::rngs::StdRng::seed_from_u64(5);
        let mut pose = model.rest_pose();
        for k in 0..model.patch_count() {
            let w = Vector3::new(rng.random(), rng.random(), rng.random()) * 0.3;
            pose.rotation[k] = exp_rotation(&w).to_rotation_matrix().into_inner();
            pose.centre[k] += Vector3::new(rng.random(), rng.random(), rng.random()) * 0.05;
        }
        let positions = model.positions(&pose);
        let normals = model.normals(&pose);
        let n = model.vertex_count();
        let mut targets = VertexTargets {
            weight: vec![0.0; n],
            weighted_sum: vec![Vector3::zeros(); n],
            weighted_square: vec![0.0; n],
            ..Default::default()
        };
        for v in 0..n {
            if rng.random::<f64>() < 0.8 {
                let w: f64 = rng.random();
                let y = positions[v].coords
                    + Vector3::new(rng.random(), rng.random(), rng.random()) * 0.1;
                targets.weight[v] = w;
                targets.weighted_sum[v] = y * w;
                targets.weighted_square[v] = w * y.norm_squared();
            }
        }
        for (data, rigidity, tangential) in [
            (40.0, 0.0, 1.0),
            (40.0, 0.0, 0.0),
            (0.0, 3.0, 1.0),
            (40.0, 3.0, 0.3),
        ] {
            let weights = StepWeights {
                data,
                rigidity,
                damping: 1e-3,
                tangential,
                relaxation: 1.0,
            };
            let mut moment_pose = pose.clone();
            gauss_newton_step(
                &model,
                &system,
                &mut moment_pose,
                &positions,
                &normals,
                &targets,
                &weights,
            )
            .expect("step");
            let mut vertex_pose = pose.clone();
            reference::reference_step(
                &model,
                &system,
                &mut vertex_pose,
                &positions,
                &normals,
                &targets,
                &weights,
            )
            .expect("step");
            for k in 0..model.patch_count() {
                let dr = (moment_pose.rotation[k] - vertex_pose.rotation[k])
                    .abs()
                    .max();
                let dc = (moment_pose.centre[k] - vertex_pose.centre[k]).norm();
                assert!(
                    dr < 1e-9 && dc < 1e-9,
                    "{data} {rigidity} {tangential} patch {k}: rotation {dr}, centre {dc}"
                );
            }
        }
    }
}
