//! Every stroke compared with every chain of bones it could cover, both ways round
//! ([`candidates`]): what [`super::assignment`] chooses among.
//!
//! A stroke and a chain are compared in one of two ways. At the current pose: the mean
//! squared distance between their arclength samples, the attached end weighed more. Or by
//! shape (the default): the distance between where the chain attaches and where the stroke
//! starts, the residual once the chain is turned rigidly about its attachment onto the
//! stroke, and a small price for how far it had to turn. The second lets a limb drawn far
//! from where it is now still find its stroke; the price of turning keeps a leg raised
//! upright from taking the spine's stroke when the spine's own fits as well.

use std::collections::BinaryHeap;

use super::chains::SAMPLES;
use super::setup::Setup;
use crate::kinematics::ForwardKinematics;
use crate::math::{Point3, Vector3};
use crate::skeleton::Pose;

/// Chains more than this much longer or shorter (relative) than a stroke are not candidates.
const MAX_LENGTH_MISMATCH: f64 = 0.6;
/// Weight of the relative length mismatch (costs are in squared heights).
const LENGTH_WEIGHT: f64 = 0.1;
/// A chain attached further than this (heights) from where a stroke starts is not a
/// candidate for it (shape matching).
const MAX_ATTACH_DISTANCE: f64 = 0.5;
/// Weight of the squared attachment distance.
const ATTACH_WEIGHT: f64 = 2.0;
/// Weight of the squared distance the chain's tip travels when it is turned (heights).
const TURN_WEIGHT: f64 = 0.02;
/// A candidate costing more than this explains its stroke no better than setting the
/// stroke aside; it is also what a stray costs in the assignment.
pub(super) const STRAY_COST: f64 = 0.2;
/// The samples from a chain's attached end that say where it attaches (the first fifth or
/// so, which moves little with the limb's pose).
const PROXIMAL_SAMPLES: usize = 5;
/// Chains of up to this many bones are compared by their rest shape turned rigidly; longer
/// ones may bend (measured on the corpus's tuning half: 5 against 3 and a share of
/// 1 / joints for every chain).
const RIGID_CHAIN_BONES: usize = 5;
/// The candidates each stroke keeps (best first). Measured on the corpus's tuning half
/// with the assignment's search: 16 against 12 (two cases fewer) and 32 (as many, a larger
/// search).
pub(super) const KEPT_CANDIDATES: usize = 16;

/// One way for a stroke to be explained: its cost, the chain's index, and whether the
/// stroke runs tip first.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Candidate {
    pub cost: f64,
    pub chain: usize,
    pub reversed: bool,
}

/// Per stroke, its candidates, best first.
pub(super) type Candidates = Vec<Vec<Candidate>>;

/// A chain at `pose` sampled by arclength, with where it can bend and how far it reaches.
struct ChainSamples {
    samples: [Point3; SAMPLES],
    /// The joints inside the chain, where it can bend.
    bends: usize,
    /// The arclength of the samples: how far along them the chain reaches.
    reach: f64,
    /// The samples seen from where the chain attaches (its first sample).
    from_pivot: FromPivot,
}

/// Arclength samples seen from a pivot: the distance of each from it, and the sum of the
/// vectors from it to them (what [`turned_shape_cost`] compares between a chain and a stroke).
struct FromPivot {
    distances: [f64; SAMPLES],
    along: Vector3,
}

impl FromPivot {
    /// `SAMPLES` arclength samples (`oriented` from the chain's root end) seen from `pivot`.
    fn new(samples: impl Fn(usize) -> Point3, pivot: Point3) -> Self {
        let (mut distances, mut along) = ([0.0; SAMPLES], Vector3::zeros());
        for (i, distance) in distances.iter_mut().enumerate() {
            let v: Vector3 = samples(i) - pivot;
            *distance = v.norm();
            along += v;
        }
        Self { distances, along }
    }
}

/// The candidates of every stroke not `excluded`, at `pose`, judged by shape or by distance;
/// by shape, those costing more than `ceiling` are dropped (the assignment would set their
/// stroke aside at [`STRAY_COST`] rather than take them).
pub(super) fn candidates(
    setup: &Setup,
    pose: &Pose,
    chains: &[Vec<usize>],
    excluded: &[bool],
    by_shape: bool,
    ceiling: f64,
) -> Candidates {
    let model = &setup.model;
    let h = setup.height;
    let fk = ForwardKinematics::new(setup.skeleton, pose);
    // A chain is sampled when a stroke first needs it: most chains are too long or too
    // short for every stroke, or attach too far from it.
    let sample = |c: &[usize]| {
        let samples = model.chain_samples(c, &fk).0;
        let reach = (1..SAMPLES)
            .map(|i| (samples[i] - samples[i - 1]).norm())
            .sum();
        let from_pivot = FromPivot::new(|i| samples[i], samples[0]);
        ChainSamples {
            samples,
            bends: c.len().saturating_sub(1),
            reach,
            from_pivot,
        }
    };
    let mut sampled: Vec<Option<ChainSamples>> = (0..chains.len()).map(|_| None).collect();
    let lengths: Vec<f64> = chains
        .iter()
        .map(|c| c.iter().map(|&b| model.bones[b].length).sum())
        .collect();
    let translating: Vec<bool> = chains
        .iter()
        .map(|c| c.iter().any(|&b| model.bones[b].tip_translates))
        .collect();
    // Chains attach at few joints: each stroke is seen from each of them once, both ways
    // round. `pivot_slot[c]` numbers chain `c`'s joint among them; a slot holds the stroke
    // it was last filled for.
    let mut slot_of_joint: Vec<Option<usize>> = vec![None; setup.skeleton.len()];
    let mut pivots = 0;
    let pivot_slot: Vec<usize> = chains
        .iter()
        .map(|c| {
            *slot_of_joint[model.bones[c[0]].joint].get_or_insert_with(|| {
                pivots += 1;
                pivots - 1
            })
        })
        .collect();
    let mut stroke_from_pivot: Vec<[Option<(usize, FromPivot)>; 2]> =
        (0..pivots).map(|_| [None, None]).collect();
    let mut out: Candidates = vec![Vec::new(); setup.strokes.count()];
    for (s, list) in out.iter_mut().enumerate() {
        // Comparing every stroke with every chain is the solver's widest loop: an interrupt
        // leaves the remaining strokes without candidates (nothing more is assigned).
        if excluded[s] || setup.interrupt.is_set() {
            continue;
        }
        let (stroke, stroke_length) = &setup.strokes.by_arclength[s];
        let stroke_length = *stroke_length;
        // Only the best [`KEPT_CANDIDATES`] are kept: a chain whose cost cannot beat the
        // worst of the best so far is not measured further. The stroke's kept costs, as bits
        // (costs are never negative, so their bits order as they do), the worst on top.
        let kept_only = setup.options.global_assignment && setup.strokes.allowed_bones[s].is_none();
        let mut best_costs: BinaryHeap<u64> = BinaryHeap::with_capacity(KEPT_CANDIDATES + 1);
        let worst_kept = |best: &BinaryHeap<u64>| match best.peek() {
            Some(&bits) if kept_only && best.len() == KEPT_CANDIDATES => f64::from_bits(bits),
            _ => f64::INFINITY,
        };
        for (c, chain) in chains.iter().enumerate() {
            if !setup.stroke_may_cover(s, chain) {
                continue;
            }
            let length = &lengths[c];
            let mismatch = (stroke_length - length) / length.max(1e-12);
            if mismatch.abs() > MAX_LENGTH_MISMATCH && !translating[c] {
                continue;
            }
            let length_cost = LENGTH_WEIGHT * mismatch.min(MAX_LENGTH_MISMATCH).powi(2);
            if length_cost >= worst_kept(&best_costs) {
                continue;
            }
            // Where the chain attaches: its first sample, known before it is sampled.
            let pivot = fk.position(model.bones[chain[0]].joint);
            for reversed in [false, true] {
                // A pinned stroke keeps its chains however far they are.
                let pinned = setup.strokes.allowed_bones[s].is_some();
                // By shape, a chain attached too far from where the stroke starts is no
                // candidate (a pinned stroke's is judged by its distance alone).
                let attached_far =
                    (oriented(stroke, 0, reversed) - pivot).norm() > MAX_ATTACH_DISTANCE * h;
                if by_shape && attached_far && !pinned {
                    continue;
                }
                let sampled_chain = sampled[c].get_or_insert_with(|| sample(chain));
                let samples = &sampled_chain.samples;
                let near = || distance_cost(stroke, samples, reversed, h);
                // Where the chain attaches, then its distance now or its shape turned,
                // whichever is less (the distance is measured only for chains that attach
                // near the stroke, most do not).
                let mut cost = if by_shape && !attached_far {
                    // The shape and distance terms are never negative: a chain whose
                    // attachment alone costs more than the ceiling is dropped unmeasured.
                    let attach = ATTACH_WEIGHT * attach_cost(stroke, samples, reversed, h);
                    if !pinned && attach + length_cost > ceiling.min(worst_kept(&best_costs)) {
                        continue;
                    }
                    let slot = &mut stroke_from_pivot[pivot_slot[c]][reversed as usize];
                    if slot.as_ref().is_none_or(|(filled_for, _)| *filled_for != s) {
                        let seen = FromPivot::new(|i| oriented(stroke, i, reversed), pivot);
                        *slot = Some((s, seen));
                    }
                    let from_stroke = &slot.as_ref().expect("filled above").1;
                    attach + turned_shape_cost(sampled_chain, from_stroke, h, near())
                } else {
                    near()
                } + length_cost;
                if pinned {
                    // Cheaper than a stray, in the same order.
                    cost = 0.5 * STRAY_COST * cost / (cost + STRAY_COST);
                }
                if !by_shape || pinned || cost <= ceiling {
                    list.push(Candidate {
                        cost,
                        chain: c,
                        reversed,
                    });
                    best_costs.push(cost.to_bits());
                    if best_costs.len() > KEPT_CANDIDATES {
                        best_costs.pop();
                    }
                }
            }
        }
        // Candidates were pushed by chain, then direction: ordering ties by them keeps the
        // order of a stable sort by cost, so only the kept ones need sorting.
        let order = |a: &Candidate, b: &Candidate| {
            (a.cost.total_cmp(&b.cost))
                .then(a.chain.cmp(&b.chain))
                .then(a.reversed.cmp(&b.reversed))
        };
        if setup.options.global_assignment && list.len() > KEPT_CANDIDATES {
            list.select_nth_unstable_by(KEPT_CANDIDATES - 1, order);
            list.truncate(KEPT_CANDIDATES);
        }
        list.sort_unstable_by(order);
    }
    out
}

/// The stroke's arclength sample `i` counted from the end that lies on the chain's root.
fn oriented(stroke: &[Point3], i: usize, reversed: bool) -> Point3 {
    stroke[if reversed { SAMPLES - 1 - i } else { i }]
}

/// Mean squared distance at the current pose (heights), the attached end weighed more:
/// where a chain attaches moves little with the pose, its tip moves most.
pub(super) fn distance_cost(stroke: &[Point3], chain: &[Point3], reversed: bool, h: f64) -> f64 {
    let (weights, weight_sum) = &DISTANCE_WEIGHTS;
    let mut sum = 0.0;
    for (i, weight) in weights.iter().enumerate() {
        sum += weight * (oriented(stroke, i, reversed) - chain[i]).norm_squared();
    }
    sum / weight_sum / (h * h)
}

/// The weight of each sample in [`distance_cost`], from the attached end (1.2) to the tip
/// (0.2), and their sum (added in order).
const DISTANCE_WEIGHTS: ([f64; SAMPLES], f64) = {
    let (mut weights, mut sum, mut i) = ([0.0; SAMPLES], 0.0, 0);
    while i < SAMPLES {
        weights[i] = 1.2 - i as f64 / (SAMPLES - 1) as f64;
        sum += weights[i];
        i += 1;
    }
    (weights, sum)
};

/// How well a chain's shape fits a stroke once turned about where it attaches, in squared
/// heights. The turned fit is measured without solving for the rotation: the residual
/// compares the samples' distances from the attachment (what no turn changes; a lower bound
/// of the residual after the best turn), and the turn is the angle between the chain's and
/// the stroke's mean directions from it, priced by how far the chain's tip travels.
///
/// `from_stroke` is the stroke (oriented) seen from where the chain attaches. Returns the
/// least of that and `near` (the cost at the current pose), without pricing the turn when
/// the residual alone already reaches `near`.
fn turned_shape_cost(sampled: &ChainSamples, from_stroke: &FromPivot, h: f64, near: f64) -> f64 {
    let from_chain = &sampled.from_pivot;
    let mut residual = 0.0;
    for i in 0..SAMPLES {
        residual += (from_chain.distances[i] - from_stroke.distances[i]).powi(2);
    }
    let (along_chain, along_stroke) = (from_chain.along, from_stroke.along);
    let mut residual = residual / SAMPLES as f64 / (h * h);
    let bends = sampled.bends;
    if bends >= RIGID_CHAIN_BONES {
        // A long chain (a tail, a spine) bends: its samples may come nearer its attachment
        // than its rest shape has them, never farther than its arclength. Only reaching too
        // far is sure; the rest-shape residual counts less the more joints it can bend at.
        let too_far = (0..SAMPLES)
            .map(|i| {
                let reach = sampled.reach * i as f64 / (SAMPLES - 1) as f64;
                (from_stroke.distances[i] - reach).max(0.0).powi(2)
            })
            .sum::<f64>()
            / SAMPLES as f64
            / (h * h);
        let rigid_share = RIGID_CHAIN_BONES as f64 / (1.0 + bends as f64);
        residual = too_far + rigid_share * (residual - too_far).max(0.0);
    }
    if residual >= near {
        return near;
    }
    let angle = along_chain.angle(&along_stroke);
    let reach = from_chain.distances[SAMPLES - 1] / h;
    (residual + TURN_WEIGHT * (angle * reach).powi(2)).min(near)
}

/// Where the chain attaches: the mean squared distance of the stroke's and the chain's
/// proximal samples, in squared heights.
fn attach_cost(stroke: &[Point3], chain: &[Point3], reversed: bool, h: f64) -> f64 {
    (0..PROXIMAL_SAMPLES)
        .map(|i| (oriented(stroke, i, reversed) - chain[i]).norm_squared())
        .sum::<f64>()
        / PROXIMAL_SAMPLES as f64
        / (h * h)
}
