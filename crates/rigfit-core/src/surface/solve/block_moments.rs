//! The sums the M-step's blocks are assembled from: weighted moments of the vertices'
//! rest-frame offsets from the patch centres, rotated once per block instead of summed vertex
//! by vertex (`J^T J` for `J = [-[q]x, I]`), for the rigidity term (eq. 4) and the isotropic
//! part of the data term, and the data term's part along the normal.

use crate::engine::linear_algebra::Block6;
use crate::math::{Matrix3, Vector3, skew};
use crate::surface::contacts::ContactLink;
use crate::surface::model::PatchModel;

/// Weighted sums over vertices of their rest-frame offsets from two patch centres,
/// `a_v = x^0(v) - c_a^0` and `b_v = x^0(v) - c_b^0`. With the rotations they give
/// `sum_v beta_v J_a(v)^T J_b(v)` for `J = [-[q]x, I]`, `q_a = R_a a_v`, in O(1): the
/// rotation block is `tr(S) I - S^T` with `S = sum beta q_a q_b^T = R_a (sum beta a b^T) R_b^T`.
#[derive(Clone, Copy, Debug)]
pub(super) struct OffsetMoments {
    /// `sum beta`.
    pub(super) weight: f64,
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
    pub(super) fn rotated(&self, ra: &Matrix3, rb: &Matrix3) -> (Vector3, Vector3, Matrix3) {
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
    pub(super) fn add_to_block(&self, block: &mut Block6, scale: f64, ra: &Matrix3, rb: &Matrix3) {
        let (ma, mb, s) = self.rotated(ra, rb);
        add_jtj_sums(block, scale, self.weight, &ma, &mb, &s);
    }
}

/// Adds `scale * [[tr(S) I - S^T, [m_a]x], [-[m_b]x, w I]]` to `block`: the sum of
/// `beta J_a^T J_b` over points with `w = sum beta`, `m = sum beta q`,
/// `S = sum beta q_a q_b^T`.
#[inline]
fn add_jtj_sums(
    block: &mut Block6,
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
pub(super) fn cross_sum(s: &Matrix3) -> Vector3 {
    Vector3::new(
        s[(1, 2)] - s[(2, 1)],
        s[(2, 0)] - s[(0, 2)],
        s[(0, 1)] - s[(1, 0)],
    )
}

/// The moments of the rigidity term of neighbouring patches `k < l` (eq. 4): over the
/// vertices of both, weights `alpha_k(v) + alpha_l(v)`, for blocks `(k,k)`, `(l,l)`, `(k,l)`.
pub(super) fn rigidity_pair_moments(model: &PatchModel, k: usize, l: usize) -> [OffsetMoments; 3] {
    let vertices = model.members[k].iter().chain(&model.members[l]).map(|&v| {
        let v = v as usize;
        (v, model.alpha(k, v) + model.alpha(l, v))
    });
    pair_moments(model, k, l, vertices)
}

/// The moments of a contact link's rigidity term: over its vertices, its weight each.
pub(super) fn contact_moments(model: &PatchModel, link: &ContactLink) -> [OffsetMoments; 3] {
    let vertices = link.vertices.iter().map(|&v| (v as usize, link.weight));
    pair_moments(model, link.k as usize, link.l as usize, vertices)
}

/// The rest moments of patch `k`'s own vertices, weight 1 each (blocks `(k,k)`).
pub(super) fn member_moments(model: &PatchModel, k: usize) -> OffsetMoments {
    let vertices = model.members[k].iter().map(|&v| (v as usize, 1.0));
    pair_moments(model, k, k, vertices)[0]
}

/// The moments of a rigidity term between patches `k` and `l` over `(vertex, beta)`.
fn pair_moments(
    model: &PatchModel,
    k: usize,
    l: usize,
    vertices: impl Iterator<Item = (usize, f64)>,
) -> [OffsetMoments; 3] {
    let mut out = [OffsetMoments::default(); 3];
    for (v, beta) in vertices {
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
pub(super) struct BlockSums<const N: usize> {
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
    pub(super) fn add_sums(&mut self, other: &Self) {
        self.isotropic.add_sums(&other.isotropic);
        add_slices(&mut self.normal, &other.normal);
    }
}

/// A diagonal block (a patch with itself): the part along the normal is symmetric, kept as
/// its upper triangle, row by row.
pub(super) type OwnBlockSums = BlockSums<21>;

impl OwnBlockSums {
    #[inline]
    pub(super) fn add_vertex(
        &mut self,
        isotropic: f64,
        along_normal: f64,
        offset: &[f64; 3],
        u: &[f64; 6],
    ) {
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
    pub(super) fn add_to_block(&self, block: &mut Block6, r: &Matrix3) {
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
pub(super) type PairBlockSums = BlockSums<36>;

impl PairBlockSums {
    #[inline]
    pub(super) fn add_vertex(
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
    pub(super) fn add_to_block(
        &self,
        block: &mut Block6,
        ra: &Matrix3,
        rb: &Matrix3,
        delta: &Vector3,
    ) {
        self.isotropic
            .offset_moments(delta)
            .add_to_block(block, 1.0, ra, rb);
        for (b, n) in block.iter_mut().zip(&self.normal) {
            *b += n;
        }
    }
}

#[inline]
pub(super) fn add_slices(to: &mut [f64], from: &[f64]) {
    for (t, f) in to.iter_mut().zip(from) {
        *t += f;
    }
}

/// Adds `w * J^T r` for `J = [-[q]x, I]`.
#[inline]
pub(super) fn add_jtr(g: &mut [f64], w: f64, q: &Vector3, r: &Vector3) {
    let top = q.cross(r);
    for i in 0..3 {
        g[i] += w * top[i];
        g[i + 3] += w * r[i];
    }
}
