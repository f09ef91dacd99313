//! The block pattern of the M-step's normal equations (the patch graph) and the weights of
//! each block fixed by the model: the data term's blend pairs, those majorised onto the
//! diagonal, and the rest-frame moments of the rigidity term (eq. 4).

use super::block_moments::{OffsetMoments, contact_moments, member_moments, rigidity_pair_moments};
use crate::engine::linear_algebra::{BlockPattern, SolveError};
use crate::geometry::Aabb;
use crate::surface::model::PatchModel;

/// Pairs of blended patches whose share of a vertex's data term is at most this
/// (`alpha_a alpha_b`) are majorised too (see [`PatchSystem`]).
const SMALL_PAIR: f64 = 1e-2;

/// A blend entry's share of its patch's own (diagonal) block in the data term.
#[derive(Clone, Copy, Debug)]
pub(super) struct DiagonalEntry {
    /// The block `(a, a)` of the entry's patch `a` (read by the vertex-by-vertex reference
    /// in the tests; the step sums a patch's own block by patch).
    #[cfg_attr(not(test), allow(dead_code))]
    pub(super) block: u32,
    /// `alpha_a^2`, plus `alpha_a alpha_b` for every pair `b` majorised onto it.
    pub(super) weight: f64,
}

/// A pair of blend entries of one vertex kept in the data term: their positions `first <
/// second` in the vertex's row of the blend (ordered so that `k_first < k_second`), their
/// block `(k_first, k_second)` and its weight `alpha_first alpha_second`.
#[derive(Clone, Copy, Debug)]
pub(super) struct BlendPair {
    pub(super) first: u16,
    pub(super) second: u16,
    pub(super) block: u32,
    pub(super) weight: f64,
}

/// The rigidity term (eq. 4) of neighbouring patches `k < l`, or of a contact link: the
/// rest-frame moments of its blocks `(k,k)`, `(l,l)` and `(k,l)`.
#[derive(Clone, Copy, Debug)]
pub(super) struct RigidityPair {
    pub(super) k: usize,
    pub(super) l: usize,
    /// The contact link it comes from (an index into `PatchModel::contacts`), or `None`
    /// for neighbouring patches of one piece (read by the vertex-by-vertex reference in the
    /// tests).
    #[cfg_attr(not(test), allow(dead_code))]
    pub(super) contact: Option<usize>,
    /// Whether the pair's piece is a part of the object (its extent at most
    /// [`SMALL_PIECE`] of the reference's diagonal: a link, a limb's capsule), which the
    /// first iterations hold nearly rigid, rather than a body that bends as a whole.
    pub(super) small_piece: bool,
    pub(super) moments: [OffsetMoments; 3],
}

/// A piece is a part of the object when its extent is at most this fraction of the
/// reference's bounding-box diagonal.
pub const SMALL_PIECE: f64 = 0.5;

/// The M-step's block-sparse normal equations for one patch model: the block pattern (the
/// patch graph, with its reusable symbolic factorisation) and the weights of each block the
/// model fixes.
#[derive(Clone, Debug)]
pub struct PatchSystem {
    /// Block `(k, l)` couples patches `k` and `l` (six unknowns each).
    pub(super) pattern: BlockPattern,
    /// The data term's normal equations, per blend entry `(v, a)`: the block `(a, a)` and its
    /// weight. A vertex's Jacobian sums its blended patches' (eq. 2), so its term couples
    /// every pair of them; the cross term of a pair that is not neighbouring patches (or
    /// whose weight `alpha_a alpha_b` is tiny) is bounded by the two patches' own terms,
    /// `2 u^T P w <= u^T P u + w^T P w` (P positive semi-definite), and added to them here:
    /// `alpha_a^2 + alpha_a sum_b alpha_b` over such `b`. The system's pattern stays the
    /// patch graph (far less fill in the factorisation, fewer products to assemble), and the
    /// step minimises a majoriser of the Gauss-Newton model, so it still descends.
    pub(super) diagonal: Vec<DiagonalEntry>,
    /// `pairs[pair_start[v]..pair_start[v + 1]]`: the pairs of blend entries of `v` kept
    /// (see [`BlendPair`]).
    pair_start: Vec<u32>,
    pairs: Vec<BlendPair>,
    /// For each neighbouring pair `(k, l)` and each contact link: the rest-frame moments of its rigidity term
    /// (eq. 4) for the blocks `(k,k)`, `(l,l)` and `(k,l)`: the weights
    /// `alpha_k(v) + alpha_l(v)` never change, so the term's normal equations cost O(1) per
    /// pair instead of O(vertices).
    pub(super) rigidity_pairs: Vec<RigidityPair>,
    /// Each patch's rest moments over its own vertices, weight 1 each (the anchor term).
    pub(super) member_moments: Vec<OffsetMoments>,
}

impl PatchSystem {
    pub fn new(model: &PatchModel) -> Result<Self, SolveError> {
        // The pattern is the patch graph and the contact links: blend pairs that are not
        // neighbours are majorised onto the diagonal (see `diagonal`), so they add no fill.
        let pattern = BlockPattern::new(model.patch_count(), model.linked_pairs())?;
        let block_of = |a: usize, b: usize| -> u32 {
            pattern
                .block_index(a, b)
                .expect("every pair is in the pattern") as u32
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
                            pairs.push(BlendPair {
                                first: i as u16,
                                second: j as u16,
                                block: block_of(a, b),
                                weight: alpha_a * alpha_b,
                            });
                        }
                    } else {
                        weight += alpha_a * alpha_b;
                    }
                }
                diagonal.push(DiagonalEntry {
                    block: block_of(a, a),
                    weight,
                });
            }
            pair_start.push(pairs.len() as u32);
        }
        // Each piece's extent, from its patches' vertices.
        let pieces = model.piece_count();
        let mut piece_patches: Vec<Vec<usize>> = vec![Vec::new(); pieces];
        for (k, &piece) in model.component.iter().enumerate() {
            piece_patches[piece as usize].push(k);
        }
        let bounds: Vec<Option<Aabb>> = piece_patches
            .iter()
            .map(|patches| {
                Aabb::from_points(
                    patches
                        .iter()
                        .flat_map(|&k| &model.members[k])
                        .map(|&v| &model.rest[v as usize]),
                )
            })
            .collect();
        let small: Vec<bool> = bounds
            .iter()
            .map(|b| b.is_some_and(|b| b.diagonal() <= SMALL_PIECE * model.diagonal))
            .collect();
        let rigidity_pairs = model
            .neighbour_pairs()
            .into_iter()
            .map(|(k, l)| RigidityPair {
                k,
                l,
                contact: None,
                small_piece: small[model.component[k] as usize],
                moments: rigidity_pair_moments(model, k, l),
            })
            .chain(
                model
                    .contacts
                    .iter()
                    .enumerate()
                    .map(|(i, link)| RigidityPair {
                        k: link.k as usize,
                        l: link.l as usize,
                        contact: Some(i),
                        small_piece: false,
                        moments: contact_moments(model, link),
                    }),
            )
            .collect();
        let member_moments = (0..model.patch_count())
            .map(|k| member_moments(model, k))
            .collect();
        Ok(Self {
            pattern,
            diagonal,
            pair_start,
            pairs,
            rigidity_pairs,
            member_moments,
        })
    }

    /// The pairs of blend entries of vertex `v` kept in the data term (see `pairs`).
    pub(super) fn vertex_pairs(&self, v: usize) -> &[BlendPair] {
        &self.pairs[self.pair_start[v] as usize..self.pair_start[v + 1] as usize]
    }

    pub fn block_count(&self) -> usize {
        self.pattern.block_count()
    }
}
