//! Which chains a case draws: the limb chains of a skeleton, which of them carry skin weight,
//! and the choice of chains for each [`Coverage`] and of the limbs left undrawn.

use rand::Rng;
use rand::seq::index::sample;

use crate::math::Point3;
use crate::rig::Rig;
use crate::skeleton::{JointKind, Skeleton};

/// The shortest chain [`Coverage::EveryChain`] draws, as a fraction of the height.
pub const EVERY_CHAIN_MIN_LENGTH: f64 = 0.02;

/// The fewest and most limbs [`Coverage::FewLimbs`] draws.
pub const FEW_LIMBS: std::ops::RangeInclusive<usize> = 2..=3;

/// A skin weight below this does not make a joint deforming (exporters leave specks).
const MIN_DEFORMING_WEIGHT: f32 = 1e-3;

/// Which chains of the skeleton a case draws.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Coverage {
    /// The limbs: chains at least `CaseOptions::min_chain_length` long whose bones carry
    /// skin weight (every chain of a rig without meshes).
    #[default]
    Limbs,
    /// Every chain at least [`EVERY_CHAIN_MIN_LENGTH`] long: fingers, face, tails, and chains
    /// of bones that carry no skin weight (helper bones) too.
    EveryChain,
    /// Two or three of the limbs, chosen at random among those of two bones or more that no
    /// other limb hangs below (arms, legs, head, tail), or among all limbs when fewer than
    /// two are such.
    FewLimbs,
}

/// The limb chains of a skeleton: from the character's root or a branching joint, through
/// joints with one child, to a leaf or the next branching joint. Helpers above the root are
/// skipped as the posing model skips them; helper nodes below it (a hip or shoulder node
/// between the body and a limb) are links of their chain, as zero-length links are.
pub fn limb_chains(skeleton: &Skeleton) -> Vec<Vec<usize>> {
    let root = skeleton.skin_root();
    let linking = skeleton.linking_helpers();
    let included = |j: usize| skeleton.joint(j).kind != JointKind::Helper || linking[j];
    let children = |j: usize| -> Vec<usize> {
        skeleton
            .children(j)
            .iter()
            .copied()
            .filter(|&c| included(c))
            .collect()
    };
    let starts: Vec<usize> = (0..skeleton.len())
        .filter(|&j| {
            let under = root.is_none_or(|r| skeleton.is_ancestor_or_self(r, j));
            under
                && (Some(j) == root
                    || children(j).len() > 1
                    || (skeleton.joint(j).parent.is_none() && root.is_none()))
        })
        .collect();
    let mut chains = Vec::new();
    for s in starts {
        for c in children(s) {
            let mut chain = vec![s, c];
            let mut cur = c;
            loop {
                let next = children(cur);
                if next.len() != 1 {
                    break;
                }
                cur = next[0];
                chain.push(cur);
            }
            chains.push(chain);
        }
    }
    chains
}

/// For every joint, whether some mesh vertex carries its skin weight. Every joint of a rig
/// without mesh vertices counts as deforming.
pub fn deforming_joints(rig: &Rig) -> Vec<bool> {
    let mut deforming = vec![false; rig.skeleton.len()];
    let mut any_vertex = false;
    for mesh in &rig.meshes {
        for (joints, weights) in mesh.joints.iter().zip(&mesh.weights) {
            any_vertex = true;
            for (&j, &w) in joints.iter().zip(weights) {
                if w >= MIN_DEFORMING_WEIGHT {
                    if let Some(d) = deforming.get_mut(j as usize) {
                        *d = true;
                    }
                }
            }
        }
    }
    if !any_vertex {
        deforming.fill(true);
    }
    deforming
}

/// Whether a chain's bones carry skin weight: some joint after the one it attaches at
/// deforms. The attach point does not count: helper chains hang from deforming joints.
pub fn chain_deforms(deforming: &[bool], chain: &[usize]) -> bool {
    chain
        .iter()
        .skip(1)
        .any(|&j| deforming.get(j).copied().unwrap_or(true))
}

/// The length of the polyline through `chain`'s joints at `positions`.
pub fn chain_length(positions: &[Point3], chain: &[usize]) -> f64 {
    chain
        .windows(2)
        .map(|w| (positions[w[1]] - positions[w[0]]).norm())
        .sum()
}

/// Whether chain `inner` hangs below chain `outer` (attaches at or below its last joint).
fn hangs_below(skeleton: &Skeleton, outer: &[usize], inner: &[usize]) -> bool {
    match (outer.last(), inner.first()) {
        (Some(&end), Some(&attach)) => skeleton.is_ancestor_or_self(end, attach),
        _ => false,
    }
}

/// The indices of the chains among `chains` that are at least `min_length` long and below
/// which no other such chain hangs: the arms, legs, heads and tails of a body.
pub fn outer_limbs(
    skeleton: &Skeleton,
    chains: &[Vec<usize>],
    lengths: &[f64],
    min_length: f64,
) -> Vec<usize> {
    (0..chains.len())
        .filter(|&c| {
            lengths[c] >= min_length
                && !(0..chains.len()).any(|o| {
                    o != c
                        && lengths[o] >= min_length
                        && hangs_below(skeleton, &chains[c], &chains[o])
                })
        })
        .collect()
}

/// The chains a case with `coverage` draws, before any is dropped. `limb_length` is the
/// shortest limb (height units); only [`Coverage::FewLimbs`] draws random numbers.
pub(super) fn covered_chains(
    skeleton: &Skeleton,
    deforming: &[bool],
    positions: &[Point3],
    coverage: Coverage,
    limb_length: f64,
    height: f64,
    rng: &mut impl Rng,
) -> Vec<Vec<usize>> {
    let all = limb_chains(skeleton);
    let limbs: Vec<Vec<usize>> = all
        .iter()
        .filter(|c| chain_length(positions, c) >= limb_length && chain_deforms(deforming, c))
        .cloned()
        .collect();
    match coverage {
        Coverage::Limbs => limbs,
        Coverage::EveryChain => all
            .into_iter()
            .filter(|c| chain_length(positions, c) >= EVERY_CHAIN_MIN_LENGTH * height)
            .collect(),
        Coverage::FewLimbs => {
            let lengths: Vec<f64> = limbs.iter().map(|c| chain_length(positions, c)).collect();
            let mut pool: Vec<usize> = outer_limbs(skeleton, &limbs, &lengths, limb_length)
                .into_iter()
                .filter(|&c| limbs[c].len() >= 3)
                .collect();
            if pool.len() < *FEW_LIMBS.start() {
                pool = (0..limbs.len()).collect();
            }
            let count = rng.random_range(FEW_LIMBS).min(pool.len());
            let mut picked: Vec<usize> = sample(rng, pool.len(), count)
                .into_iter()
                .map(|k| pool[k])
                .collect();
            picked.sort_unstable();
            picked.into_iter().map(|k| limbs[k].clone()).collect()
        }
    }
}

/// Removes `count` limbs from `chains` at random and returns them.
///
/// [`Coverage::Limbs`] keeps the rule its first callers were tuned on: a limb is a drawn
/// chain that ends at a leaf. Otherwise a limb is a drawn chain at least `limb_length` long
/// below which no other such chain hangs (an arm ending in a hand counts), and dropping it
/// drops every drawn chain hanging below it too (the hand's fingers). Nothing is dropped
/// once a single limb is left.
pub(super) fn drop_limbs(
    skeleton: &Skeleton,
    positions: &[Point3],
    chains: &mut Vec<Vec<usize>>,
    coverage: Coverage,
    limb_length: f64,
    count: usize,
    rng: &mut impl Rng,
) -> Vec<Vec<usize>> {
    let mut dropped = Vec::new();
    for _ in 0..count {
        let limbs: Vec<usize> = if coverage == Coverage::Limbs {
            (0..chains.len())
                .filter(|&c| {
                    chains[c]
                        .last()
                        .is_some_and(|&end| skeleton.children(end).is_empty())
                })
                .collect()
        } else {
            let lengths: Vec<f64> = chains.iter().map(|c| chain_length(positions, c)).collect();
            outer_limbs(skeleton, chains, &lengths, limb_length)
        };
        if limbs.len() <= 1 {
            break;
        }
        let pick = limbs[rng.random_range(0..limbs.len())];
        let limb = chains.remove(pick);
        if coverage != Coverage::Limbs {
            let (below, kept): (Vec<_>, Vec<_>) = std::mem::take(chains)
                .into_iter()
                .partition(|c| hangs_below(skeleton, &limb, c));
            *chains = kept;
            dropped.push(limb);
            dropped.extend(below);
        } else {
            dropped.push(limb);
        }
    }
    dropped
}
