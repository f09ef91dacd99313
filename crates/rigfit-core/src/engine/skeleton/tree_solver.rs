//! Normal equations of a kinematic tree. A skeleton's `J^T W J` couples the parameters of
//! two joints only when one joint is an ancestor of the other. Numbered parents first (as a
//! [`DofLayout`] numbers them) and eliminated from the last parameter back, its `L D L^T`
//! factorisation has no fill-in: each parameter's row holds exactly its ancestors in a
//! parameter-level elimination tree (Liu, "The role of elimination trees in sparse
//! factorization", SIAM J. Matrix Anal. Appl. 1990), so a Levenberg-Marquardt step costs
//! O(parameters x depth^2) instead of the dense O(parameters^3).

use nalgebra::DMatrix;

use crate::engine::linear_algebra::NormalSink;
use crate::kinematics::DofLayout;
use crate::math::Matrix3;

/// No parent in the elimination tree.
const NONE: usize = usize::MAX;

/// The parameters of one joint: `count` from `first`, below the ancestors listed from
/// `path` in the tree's `paths` (as many as the first parameter's depth).
#[derive(Clone, Copy, Debug)]
struct Node {
    first: usize,
    count: usize,
    path: usize,
}

/// `J^T W J` (stored by ancestry), `J^T W r` and the cost of a skeleton's parameters.
#[derive(Clone, Debug)]
pub struct TreeNormalEquations {
    /// Per parameter: its parent in the elimination tree (the previous parameter of its
    /// joint, else the last parameter of the nearest ancestor joint with parameters).
    up: Vec<usize>,
    /// Per parameter: how many ancestors it has in the elimination tree.
    depth: Vec<usize>,
    /// Per parameter: where its row starts in `lower`; entry `m` of the row couples it
    /// with its ancestor at depth `m`.
    start: Vec<usize>,
    /// The joints with parameters, parents first: supernodes whose rows share their
    /// ancestors.
    nodes: Vec<Node>,
    /// The ancestors of each node's parameters, by depth (ranges given by the nodes).
    paths: Vec<usize>,
    diag: Vec<f64>,
    lower: Vec<f64>,
    jtr: Vec<f64>,
    cost: f64,
    /// The factorisation (`D` and the rows of `L`) and the step of the last solve.
    factor_diag: Vec<f64>,
    factor_lower: Vec<f64>,
    step: Vec<f64>,
}

impl TreeNormalEquations {
    /// The structure for `layout` on the joint tree given by `parent`, or `None` when the
    /// layout does not number every joint's parameters after its ancestors'.
    pub fn new(layout: &DofLayout, parent: impl Fn(usize) -> Option<usize>) -> Option<Self> {
        let n = layout.len();
        let mut up = Vec::with_capacity(n);
        let mut depth: Vec<usize> = Vec::with_capacity(n);
        // Per joint: the last parameter of its nearest ancestor-or-self with parameters.
        let mut last = vec![NONE; layout.joint_count()];
        let mut nodes = Vec::new();
        let mut paths = Vec::new();
        for j in 0..layout.joint_count() {
            let above = match parent(j) {
                Some(p) if p < j => last[p],
                Some(_) => return None,
                None => NONE,
            };
            let count = layout.dof(j).count();
            match layout.offset(j) {
                Some(o) if o == up.len() && count > 0 => {
                    for k in 0..count {
                        let u = if k == 0 { above } else { o + k - 1 };
                        up.push(u);
                        depth.push(if u == NONE { 0 } else { depth[u] + 1 });
                    }
                    last[j] = o + count - 1;
                    let path = paths.len();
                    let mut a = above;
                    while a != NONE {
                        paths.push(a);
                        a = up[a];
                    }
                    paths[path..].reverse();
                    nodes.push(Node {
                        first: o,
                        count,
                        path,
                    });
                }
                Some(_) => return None,
                None => last[j] = above,
            }
        }
        if up.len() != n {
            return None;
        }
        let mut start = Vec::with_capacity(n);
        let mut total = 0;
        for &d in &depth {
            start.push(total);
            total += d;
        }
        Some(Self {
            up,
            depth,
            start,
            nodes,
            paths,
            diag: vec![0.0; n],
            lower: vec![0.0; total],
            jtr: vec![0.0; n],
            cost: 0.0,
            factor_diag: Vec::with_capacity(n),
            factor_lower: Vec::with_capacity(total),
            step: Vec::with_capacity(n),
        })
    }

    /// The number of parameters.
    pub fn len(&self) -> usize {
        self.diag.len()
    }

    /// Whether there are no parameters.
    pub fn is_empty(&self) -> bool {
        self.diag.is_empty()
    }

    /// Clears the sums for a new iteration.
    pub fn clear(&mut self) {
        self.diag.fill(0.0);
        self.lower.fill(0.0);
        self.jtr.fill(0.0);
        self.cost = 0.0;
    }

    /// Whether `J^T J` may hold a nonzero at `(i, j)`: the same parameter, or one an
    /// ancestor of the other in the elimination tree.
    pub fn is_structural(&self, i: usize, j: usize) -> bool {
        let (hi, lo) = if i >= j { (i, j) } else { (j, i) };
        let mut cur = hi;
        while cur != NONE && cur > lo {
            cur = self.up[cur];
        }
        cur == lo
    }

    /// `J^T W r`.
    pub fn jtr(&self) -> &[f64] {
        &self.jtr
    }

    /// `J^T W J` as a full symmetric matrix.
    pub fn jtj(&self) -> DMatrix<f64> {
        let n = self.len();
        let mut m = DMatrix::zeros(n, n);
        for i in 0..n {
            m[(i, i)] = self.diag[i];
            let mut j = self.up[i];
            while j != NONE {
                let v = self.lower[self.start[i] + self.depth[j]];
                m[(i, j)] = v;
                m[(j, i)] = v;
                j = self.up[j];
            }
        }
        m
    }

    /// The Levenberg-Marquardt step `(J^T J + lambda diag(J^T J) + eps I) delta = -J^T r`
    /// (as [`crate::engine::NormalEquations::solve`]) by a leaves-first `L D L^T`
    /// factorisation; `None` when the damped matrix is not positive definite.
    pub fn solve(&mut self, lambda: f64) -> Option<&[f64]> {
        let scale = self.diag.iter().copied().fold(0.0, f64::max).max(1e-12);
        self.factor_diag.clear();
        self.factor_diag
            .extend(self.diag.iter().map(|&a| a + (lambda * a + 1e-9 * scale)));
        self.factor_lower.clone_from(&self.lower);
        let (depth, start) = (&self.depth, &self.start);
        let d = &mut self.factor_diag;
        // Eliminate joint by joint, leaves first. Eliminating parameter i takes the rank-one
        // update `- row row^T / d_i` off its ancestors' block, which stays within their
        // rows; within a joint it is applied at once, to the ancestors outside the joint
        // after the joint's last parameter, fused over its rows.
        for node in self.nodes.iter().rev() {
            let (s, c) = (node.first, node.count);
            let a = depth[s];
            let path = &self.paths[node.path..node.path + a];
            // Row k of the joint starts at `offset(k)` after row 0 and is `a + k` long.
            let offset = |k: usize| k * a + k * k.saturating_sub(1) / 2;
            let (head, tail) = self.factor_lower.split_at_mut(start[s]);
            for k in (0..c).rev() {
                let di = d[s + k];
                if di.is_nan() || di <= 0.0 {
                    return None;
                }
                let (before, rest) = tail.split_at_mut(offset(k));
                let row = &rest[..a + k];
                let inv = 1.0 / di;
                for kk in (0..k).rev() {
                    let m = a + kk;
                    let f = row[m] * inv;
                    d[s + kk] -= f * row[m];
                    let target = &mut before[offset(kk)..offset(kk) + m];
                    for (x, &y) in target.iter_mut().zip(&row[..m]) {
                        *x -= f * y;
                    }
                }
            }
            let rows = &*tail;
            let mut k = 0;
            while k < c {
                let chunk = (c - k).min(3);
                let r0 = &rows[offset(k)..offset(k) + a];
                let i0 = 1.0 / d[s + k];
                match chunk {
                    3 => {
                        let r1 = &rows[offset(k + 1)..offset(k + 1) + a];
                        let r2 = &rows[offset(k + 2)..offset(k + 2) + a];
                        let (i1, i2) = (1.0 / d[s + k + 1], 1.0 / d[s + k + 2]);
                        for (m, &j) in path.iter().enumerate() {
                            let (f0, f1, f2) = (r0[m] * i0, r1[m] * i1, r2[m] * i2);
                            d[j] -= f0 * r0[m] + f1 * r1[m] + f2 * r2[m];
                            let target = &mut head[start[j]..start[j] + m];
                            for (((x, &y0), &y1), &y2) in
                                target.iter_mut().zip(&r0[..m]).zip(&r1[..m]).zip(&r2[..m])
                            {
                                *x -= f0 * y0 + f1 * y1 + f2 * y2;
                            }
                        }
                    }
                    2 => {
                        let r1 = &rows[offset(k + 1)..offset(k + 1) + a];
                        let i1 = 1.0 / d[s + k + 1];
                        for (m, &j) in path.iter().enumerate() {
                            let (f0, f1) = (r0[m] * i0, r1[m] * i1);
                            d[j] -= f0 * r0[m] + f1 * r1[m];
                            let target = &mut head[start[j]..start[j] + m];
                            for ((x, &y0), &y1) in target.iter_mut().zip(&r0[..m]).zip(&r1[..m]) {
                                *x -= f0 * y0 + f1 * y1;
                            }
                        }
                    }
                    _ => {
                        for (m, &j) in path.iter().enumerate() {
                            let f0 = r0[m] * i0;
                            d[j] -= f0 * r0[m];
                            let target = &mut head[start[j]..start[j] + m];
                            for (x, &y0) in target.iter_mut().zip(&r0[..m]) {
                                *x -= f0 * y0;
                            }
                        }
                    }
                }
                k += chunk;
            }
            for k in 0..c {
                let inv = 1.0 / d[s + k];
                for x in &mut tail[offset(k)..offset(k) + a + k] {
                    *x *= inv;
                }
            }
        }
        // L D L^T x = -J^T r: forward from the leaves, then back from the roots.
        let x = &mut self.step;
        x.clear();
        x.extend(self.jtr.iter().map(|&g| -g));
        let l = &self.factor_lower;
        for node in self.nodes.iter().rev() {
            let (s, c) = (node.first, node.count);
            let a = depth[s];
            let path = &self.paths[node.path..node.path + a];
            for k in (0..c).rev() {
                let i = s + k;
                let xi = x[i];
                let row = &l[start[i]..start[i] + a + k];
                for (&j, &lij) in path.iter().zip(row) {
                    x[j] -= lij * xi;
                }
                for kk in 0..k {
                    x[s + kk] -= row[a + kk] * xi;
                }
            }
        }
        for (xi, di) in x.iter_mut().zip(d.iter()) {
            *xi /= di;
        }
        for node in &self.nodes {
            let (s, c) = (node.first, node.count);
            let a = depth[s];
            let path = &self.paths[node.path..node.path + a];
            for k in 0..c {
                let i = s + k;
                let row = &l[start[i]..start[i] + a + k];
                let mut sum = x[i];
                for (&j, &lij) in path.iter().zip(row) {
                    sum -= lij * x[j];
                }
                for kk in 0..k {
                    sum -= row[a + kk] * x[s + kk];
                }
                x[i] = sum;
            }
        }
        Some(&self.step)
    }
}

impl NormalSink for TreeNormalEquations {
    /// Entry `(i, j)` must be structural ([`Self::is_structural`]).
    fn add_jtj(&mut self, i: usize, j: usize, v: f64) {
        let (hi, lo) = if i >= j { (i, j) } else { (j, i) };
        if hi == lo {
            self.diag[hi] += v;
        } else {
            debug_assert!(self.is_structural(hi, lo), "({hi}, {lo}) is not structural");
            assert!(
                self.depth[lo] < self.depth[hi],
                "({hi}, {lo}) is not structural"
            );
            self.lower[self.start[hi] + self.depth[lo]] += v;
        }
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

    /// `a..a + na` must be consecutive parameters of one joint, ancestors of (or, with
    /// `diagonal`, the same as) `b..b + nb`: each row takes them as one contiguous run.
    fn add_jtj_block(
        &mut self,
        (a, na): (usize, usize),
        (b, nb): (usize, usize),
        m: &Matrix3,
        scale: f64,
        diagonal: bool,
    ) {
        let da = self.depth[a];
        for ib in 0..nb {
            let i = b + ib;
            let n = if diagonal { ib } else { na };
            assert!(da + n <= self.depth[i], "({i}, {a}) is not structural");
            debug_assert!(n == 0 || self.is_structural(i, a + n - 1));
            let at = self.start[i] + da;
            for (ia, x) in self.lower[at..at + n].iter_mut().enumerate() {
                *x += scale * m[(ia, ib)];
            }
            if diagonal {
                self.diag[i] += scale * m[(ib, ib)];
            }
        }
    }
}
