//! Block-sparse normal equations: six parameters per block (a rigid motion), `J^T W J` in
//! 6x6 blocks over a fixed pattern ([`BlockPattern`], with its sparse Cholesky factorisation
//! computed once), filled through [`NormalSink`] ([`BlockSparseNormalEquations`]) and solved
//! with the pattern's factorisation. The surface tracker's patches are one such model.

use super::normal_equations::NormalSink;
use super::sparse_cholesky::{SolveError, SparseCholesky};

/// A 6x6 block, row-major.
pub type Block6 = [f64; 36];

/// Where a block sits: block row `row <= column` and block column `column`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BlockPosition {
    pub row: u32,
    pub column: u32,
}

/// The block pattern of a symmetric system (the upper triangle: the diagonal blocks and
/// each coupled pair once) and its sparse Cholesky factorisation's order and structure.
#[derive(Clone, Debug)]
pub struct BlockPattern {
    /// For each block column `l`, the block rows `k <= l` present (sorted).
    column_rows: Vec<Vec<u32>>,
    /// Offset of column `l`'s first block in the blocks' storage order.
    column_offset: Vec<usize>,
    /// Each block's position, in storage order (column by column, rows ascending).
    positions: Vec<BlockPosition>,
    cholesky: SparseCholesky,
}

impl BlockPattern {
    /// The pattern of `n` block columns with every diagonal block and the blocks coupling
    /// `pairs` (unordered; repeats ignored), factorised symbolically.
    pub fn new(
        n: usize,
        pairs: impl IntoIterator<Item = (usize, usize)>,
    ) -> Result<Self, SolveError> {
        let mut column_rows: Vec<Vec<u32>> = (0..n).map(|l| vec![l as u32]).collect();
        for (a, b) in pairs {
            let (k, l) = if a <= b { (a, b) } else { (b, a) };
            column_rows[l].push(k as u32);
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
        let positions = column_rows
            .iter()
            .enumerate()
            .flat_map(|(l, rows)| {
                rows.iter().map(move |&k| BlockPosition {
                    row: k,
                    column: l as u32,
                })
            })
            .collect();
        let cholesky = SparseCholesky::new(&column_rows, &column_offset)?;
        Ok(Self {
            column_rows,
            column_offset,
            positions,
            cholesky,
        })
    }

    /// Block columns (and rows): the system has six times as many unknowns.
    pub fn block_columns(&self) -> usize {
        self.column_rows.len()
    }

    pub fn block_count(&self) -> usize {
        self.positions.len()
    }

    /// Each block's position, in storage order.
    pub fn block_pairs(&self) -> &[BlockPosition] {
        &self.positions
    }

    /// Where the block coupling block columns `a` and `b` (either order) is stored, if the
    /// pattern has it.
    pub fn block_index(&self, a: usize, b: usize) -> Option<usize> {
        let (k, l) = if a <= b { (a, b) } else { (b, a) };
        let slot = self.column_rows.get(l)?.binary_search(&(k as u32)).ok()?;
        Some(self.column_offset[l] + slot)
    }

    /// Where block column `k`'s diagonal block is stored.
    pub fn diagonal_block(&self, k: usize) -> usize {
        self.block_index(k, k)
            .expect("every column holds its diagonal block")
    }

    /// The factorisation of the pattern.
    pub fn cholesky(&self) -> &SparseCholesky {
        &self.cholesky
    }

    /// Zero normal equations over this pattern.
    pub fn equations(&self) -> BlockSparseNormalEquations<'_> {
        BlockSparseNormalEquations {
            pattern: self,
            blocks: vec![[0.0; 36]; self.block_count()],
            jtr: vec![0.0; 6 * self.block_columns()],
            cost: 0.0,
        }
    }
}

/// `J^T W J` in the 6x6 blocks of a [`BlockPattern`] (a diagonal block's upper triangle is
/// what the solve reads), `J^T W r` and the cost.
#[derive(Clone, Debug)]
pub struct BlockSparseNormalEquations<'a> {
    pattern: &'a BlockPattern,
    blocks: Vec<Block6>,
    jtr: Vec<f64>,
    cost: f64,
}

impl BlockSparseNormalEquations<'_> {
    /// The blocks, in the pattern's storage order.
    pub fn blocks(&self) -> &[Block6] {
        &self.blocks
    }

    /// Block column `k`'s diagonal block.
    pub fn diagonal_block(&self, k: usize) -> &Block6 {
        &self.blocks[self.pattern.diagonal_block(k)]
    }

    /// Block column `k`'s diagonal block, to change (damping).
    pub fn diagonal_block_mut(&mut self, k: usize) -> &mut Block6 {
        &mut self.blocks[self.pattern.diagonal_block(k)]
    }

    /// `J^T W r`.
    pub fn jtr(&self) -> &[f64] {
        &self.jtr
    }

    /// The Gauss-Newton step `x` of `(J^T W J) x = -J^T W r`.
    pub fn solve(&self) -> Result<Vec<f64>, SolveError> {
        let mut rhs: Vec<f64> = self.jtr.iter().map(|g| -g).collect();
        self.pattern.cholesky.solve(&self.blocks, &mut rhs)?;
        Ok(rhs)
    }

    fn block_mut(&mut self, a: usize, b: usize) -> &mut Block6 {
        let index = self
            .pattern
            .block_index(a, b)
            .expect("an entry within the block pattern");
        &mut self.blocks[index]
    }
}

impl NormalSink for BlockSparseNormalEquations<'_> {
    /// Entry `(min(i, j), max(i, j))` of its block.
    fn add_jtj(&mut self, i: usize, j: usize, v: f64) {
        let (lo, hi) = if i <= j { (i, j) } else { (j, i) };
        self.block_mut(lo / 6, hi / 6)[6 * (lo % 6) + hi % 6] += v;
    }

    fn add_jtr(&mut self, i: usize, v: f64) {
        self.jtr[i] += v;
    }

    fn add_cost(&mut self, c: f64) {
        self.cost += c;
    }

    fn cost(&self) -> f64 {
        self.cost
    }

    /// Added to its stored block at once, entry by entry in storage order (transposed when
    /// given below the diagonal); a diagonal block is added whole.
    fn add_jtj_block6(&mut self, row: usize, column: usize, block: &Block6) {
        debug_assert!(row % 6 == 0 && column % 6 == 0, "blocks are aligned");
        let (k, l) = (row / 6, column / 6);
        let stored = self.block_mut(k, l);
        if k <= l {
            for (t, x) in stored.iter_mut().zip(block) {
                *t += x;
            }
        } else {
            for a in 0..6 {
                for b in 0..6 {
                    stored[6 * b + a] += block[6 * a + b];
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::engine::NormalEquations;
    use crate::math::Vector3;

    /// Entries, points and blocks added to the block-sparse storage solve as the dense
    /// storage does.
    #[test]
    fn block_sparse_solves_as_dense() {
        let n = 5;
        let pattern = BlockPattern::new(n, (0..n - 1).map(|k| (k + 1, k))).expect("pattern");
        let mut sparse = pattern.equations();
        let mut dense = NormalEquations::new(6 * n);
        for k in 0..n {
            let mut block = [0.0; 36];
            for a in 0..6 {
                block[7 * a] = 2.0 + (k + a) as f64;
            }
            sparse.add_jtj_block6(6 * k, 6 * k, &block);
            dense.add_jtj_block6(6 * k, 6 * k, &block);
        }
        let coupled = [(0, 3, 0.3), (7, 13, -0.2), (20, 14, 0.1), (29, 24, 0.25)];
        for (i, j, v) in coupled {
            NormalSink::add_jtj(&mut sparse, i, j, v);
            NormalSink::add_jtj(&mut dense, i, j, v);
        }
        let columns = [(6, Vector3::new(0.1, 0.2, 0.3)), (13, Vector3::x())];
        let r = Vector3::new(0.5, -0.5, 1.0);
        sparse.add_point_columns(&r, 2.0, &columns);
        dense.add_point_columns(&r, 2.0, &columns);
        for i in 0..6 * n {
            sparse.add_jtr(i, (i as f64).sin());
            dense.add_jtr(i, (i as f64).sin());
        }
        let x = sparse.solve().expect("solve");
        let y = dense.solve(0.0).expect("solve");
        for i in 0..6 * n {
            approx::assert_relative_eq!(x[i], y[i], epsilon = 1e-6);
        }
        approx::assert_relative_eq!(sparse.cost(), dense.cost);
    }
}
