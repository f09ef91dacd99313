//! Which chain each stroke covers. Every stroke is compared with every chain of bones it
//! could cover, both ways round ([`candidates`]); then the strokes' chains are chosen
//! together so that no two strokes share a bone and the total cost is least, a stroke with
//! no chain left being set aside as a stray ([`assign`]).
//!
//! A stroke and a chain are compared in one of two ways. At the current pose: the mean
//! squared distance between their arclength samples, the attached end weighed more. Or by
//! shape (the default): the distance between where the chain attaches and where the stroke
//! starts, the residual once the chain is turned rigidly about its attachment onto the
//! stroke, and a small price for how far it had to turn. The second lets a limb drawn far
//! from where it is now still find its stroke; the price of turning keeps a leg raised
//! upright from taking the spine's stroke when the spine's own fits as well.

use super::chains::{Assignment, SAMPLES};
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
/// with the search below: 16 against 12 (two cases fewer) and 32 (as many, a larger search).
const KEPT_CANDIDATES: usize = 16;
/// Search nodes per group of strokes competing for bones (picks ruled out by the bound
/// count too), before the best assignment found so far is kept. Far from the pose, most
/// searches end at the budget: many chains fit a stroke almost alike. Measured on the
/// tuning half: with the tighter bound and 16 candidates, 1,000 and 500 alike; before
/// them, 500 to 5,000 within 10 of 2,160 cases either way (BENCHMARKS.md, session 20).
const SEARCH_BUDGET: usize = 1_000;

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
                    if !pinned && attach + length_cost > ceiling {
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

/// Each stroke's chain: strokes with a `fixed` chain keep it, `excluded` strokes stay set
/// aside, the others are chosen together (or greedily, best first, without
/// `global_assignment`) so that no bone is covered twice.
///
/// When the greedy assignment is `settled` (the one the pose was just fitted to), it is
/// kept without a search: the fit has made it the obvious one.
pub(super) fn assign(
    setup: &Setup,
    chains: &[Vec<usize>],
    candidates: &Candidates,
    fixed: &[Assignment],
    excluded: &[bool],
    settled: Option<&[Assignment]>,
) -> Vec<Assignment> {
    let greedy = complete_greedily(setup, chains, candidates, fixed, excluded);
    if !setup.options.global_assignment || settled == Some(greedy.as_slice()) {
        return greedy;
    }
    least_cost(setup, chains, candidates, fixed, excluded, greedy)
}

/// Greedy assignment: strokes with a `fixed` chain keep it, `excluded` strokes stay set
/// aside, the others take, best first, the best candidate whose bones are still free (the
/// local moves complete their trial assignments this way).
pub(super) fn complete_greedily(
    setup: &Setup,
    chains: &[Vec<usize>],
    candidates: &Candidates,
    fixed: &[Assignment],
    excluded: &[bool],
) -> Vec<Assignment> {
    let strokes = candidates.len();
    let mut used = vec![false; setup.model.bones.len()];
    let mut result: Vec<Assignment> = fixed.to_vec();
    let mut done: Vec<bool> = excluded.to_vec();
    for (s, f) in fixed.iter().enumerate() {
        if let Some((chain, _)) = f {
            done[s] = true;
            chain.iter().for_each(|&b| used[b] = true);
        }
    }
    // Each stroke's first candidate that may still be free: bones only ever become used, so
    // a candidate passed over never comes back (the scan is linear in the candidates).
    let mut first_free = vec![0usize; strokes];
    loop {
        // The unassigned stroke whose best still-free chain fits best.
        let mut pick: Option<(usize, Candidate)> = None;
        for s in 0..strokes {
            if done[s] {
                continue;
            }
            let list = &candidates[s];
            let skip = list[first_free[s]..]
                .iter()
                .position(|c| chains[c.chain].iter().all(|&b| !used[b]))
                .unwrap_or(list.len() - first_free[s]);
            first_free[s] += skip;
            match list.get(first_free[s]) {
                Some(&c) if pick.is_none_or(|p| c.cost < p.1.cost) => pick = Some((s, c)),
                Some(_) => {}
                None => done[s] = true,
            }
        }
        let Some((s, c)) = pick else {
            break;
        };
        done[s] = true;
        chains[c.chain].iter().for_each(|&b| used[b] = true);
        result[s] = Some((chains[c.chain].clone(), c.reversed));
    }
    result
}

/// The least-cost assignment (a stray costs [`STRAY_COST`]), by branch and bound over each
/// group of strokes whose candidates share bones, starting from the greedy one.
fn least_cost(
    setup: &Setup,
    chains: &[Vec<usize>],
    candidates: &Candidates,
    fixed: &[Assignment],
    excluded: &[bool],
    greedy: Vec<Assignment>,
) -> Vec<Assignment> {
    let bones = setup.model.bones.len();
    let mut used = vec![false; bones];
    for (chain, _) in fixed.iter().flatten() {
        chain.iter().for_each(|&b| used[b] = true);
    }
    let free: Vec<usize> = (0..candidates.len())
        .filter(|&s| fixed[s].is_none() && !excluded[s])
        .collect();
    // Groups: strokes linked by a bone some candidate of each covers.
    let mut group: Vec<usize> = (0..candidates.len()).collect();
    fn find(group: &mut [usize], s: usize) -> usize {
        let mut r = s;
        while group[r] != r {
            group[r] = group[group[r]];
            r = group[r];
        }
        r
    }
    let mut bone_owner: Vec<Option<usize>> = vec![None; bones];
    for &s in &free {
        for c in &candidates[s] {
            for &b in &chains[c.chain] {
                match bone_owner[b] {
                    None => bone_owner[b] = Some(s),
                    Some(o) => {
                        let (ro, rs) = (find(&mut group, o), find(&mut group, s));
                        group[ro] = rs;
                    }
                }
            }
        }
    }
    let mut result = greedy;
    let mut members: std::collections::BTreeMap<usize, Vec<usize>> = Default::default();
    for &s in &free {
        members.entry(find(&mut group, s)).or_default().push(s);
    }
    // Per bone, the strokes' candidates that cover it: (depth of the stroke in its group's
    // search, the candidates as bits). A group's bones are its own.
    let mut covered_by: Vec<Vec<(usize, u64)>> = vec![Vec::new(); bones];
    for mut strokes in members.into_values() {
        // The strokes with the fewest choices are decided first (the search narrows fastest).
        strokes.sort_by_key(|&s| candidates[s].len());
        let depths = strokes.len();
        // Candidates a fixed chain's bones already rule out, per depth; then the rest.
        let mut blocked = vec![0u64; (depths + 1) * depths];
        for (depth, &s) in strokes.iter().enumerate() {
            for (k, c) in candidates[s].iter().enumerate() {
                for &b in &chains[c.chain] {
                    blocked[depth] |= u64::from(used[b]) << k;
                    match covered_by[b].last_mut() {
                        Some((d, bits)) if *d == depth => *bits |= 1 << k,
                        _ => covered_by[b].push((depth, 1 << k)),
                    }
                }
            }
        }
        let start: Vec<Option<usize>> = strokes
            .iter()
            .map(|&s| {
                result[s].as_ref().and_then(|(chain, rev)| {
                    candidates[s]
                        .iter()
                        .position(|c| chains[c.chain] == *chain && c.reversed == *rev)
                })
            })
            .collect();
        // The least the strokes from each depth on can cost, conflicts ignored.
        let mut least_after = vec![0.0; strokes.len() + 1];
        for (i, &s) in strokes.iter().enumerate().rev() {
            let least = candidates[s]
                .first()
                .map_or(STRAY_COST, |c| c.cost.min(STRAY_COST));
            least_after[i] = least_after[i + 1] + least;
        }
        let mut search = GroupSearch {
            chains,
            candidates,
            covered_by: &covered_by,
            strokes: &strokes,
            least_after,
            blocked,
            picks: vec![None; strokes.len()],
            best: start.clone(),
            best_cost: group_cost(candidates, &strokes, &start),
            nodes: 0,
        };
        search.descend(0, 0.0);
        for (i, &s) in strokes.iter().enumerate() {
            result[s] = search.best[i].map(|k| {
                let c = candidates[s][k];
                (chains[c.chain].clone(), c.reversed)
            });
        }
    }
    result
}

fn group_cost(candidates: &Candidates, strokes: &[usize], picks: &[Option<usize>]) -> f64 {
    strokes
        .iter()
        .zip(picks)
        .map(|(&s, p)| p.map_or(STRAY_COST, |k| candidates[s][k].cost))
        .sum()
}

/// The bits of a stroke's `count` candidates.
fn all_bits(count: usize) -> u64 {
    u64::MAX.checked_shr(64 - count as u32).unwrap_or(0)
}

// A stroke's candidates are bits of a `u64` in the search.
const _: () = assert!(KEPT_CANDIDATES <= 64);

/// Depth-first branch and bound over one group's strokes.
struct GroupSearch<'a> {
    chains: &'a [Vec<usize>],
    candidates: &'a Candidates,
    /// Per bone, the candidates that cover it: (depth, candidates as bits).
    covered_by: &'a [Vec<(usize, u64)>],
    strokes: &'a [usize],
    /// The least the strokes from each depth on can cost (a bound, conflicts ignored).
    least_after: Vec<f64>,
    /// Per depth of the search, then per depth: the candidates (as bits) whose bones the
    /// chains picked above it, or fixed ones, already cover.
    blocked: Vec<u64>,
    picks: Vec<Option<usize>>,
    best: Vec<Option<usize>>,
    best_cost: f64,
    nodes: usize,
}

impl GroupSearch<'_> {
    fn descend(&mut self, depth: usize, cost: f64) {
        self.nodes += 1;
        if self.nodes > SEARCH_BUDGET {
            return;
        }
        let Some(&s) = self.strokes.get(depth) else {
            if cost < self.best_cost {
                self.best_cost = cost;
                self.best.clone_from(&self.picks);
            }
            return;
        };
        let rest = self.least_after[depth + 1];
        let depths = self.strokes.len();
        let list = &self.candidates[s];
        // The candidates no chain picked above (or fixed) rules out, in order.
        let mut open = !self.blocked[depth * depths + depth] & all_bits(list.len());
        // Costs come sorted (NaN last): the last that is a number.
        let last_number = list.iter().rposition(|c| !c.cost.is_nan());
        while open != 0 {
            let k = open.trailing_zeros() as usize;
            open &= open - 1;
            let c = list[k];
            // Candidates come best first: once one cannot beat the best, none after can
            // (those ruled out are skipped unjudged: one of them that cannot beat the best
            // means this one cannot either, unless this one's cost is no number).
            let judged = match last_number {
                Some(j) if c.cost.is_nan() && j < k => list[j],
                _ => c,
            };
            if cost + judged.cost + rest >= self.best_cost - 1e-12 {
                break;
            }
            let chains = self.chains;
            self.block_below(depth, &chains[c.chain]);
            // The bound again, without the candidates this pick rules out below.
            if cost + c.cost + self.least_open_below(depth) >= self.best_cost - 1e-12 {
                self.nodes += 1;
                if self.nodes > SEARCH_BUDGET {
                    return;
                }
                continue;
            }
            self.picks[depth] = Some(k);
            self.descend(depth + 1, cost + c.cost);
        }
        self.picks[depth] = None;
        if cost + STRAY_COST + rest < self.best_cost - 1e-12 {
            self.block_below(depth, &[]);
            self.descend(depth + 1, cost + STRAY_COST);
        }
    }

    /// The least the strokes below `depth` can cost once the candidates blocked there
    /// (by the picks down to `depth`) are left out: each stroke's cheapest open candidate
    /// or a stray, conflicts among them ignored. At least `least_after[depth + 1]`.
    fn least_open_below(&self, depth: usize) -> f64 {
        let depths = self.strokes.len();
        let row = &self.blocked[(depth + 1) * depths..(depth + 2) * depths];
        (depth + 1..depths)
            .map(|d| {
                let list = &self.candidates[self.strokes[d]];
                match !row[d] & all_bits(list.len()) {
                    0 => STRAY_COST,
                    open => {
                        let cost = list[open.trailing_zeros() as usize].cost;
                        // A cost that is no number bounds nothing.
                        if cost.is_nan() {
                            0.0
                        } else {
                            cost.min(STRAY_COST)
                        }
                    }
                }
            })
            .sum()
    }

    /// The candidates blocked below `depth` once `chain` is picked there: those blocked at
    /// `depth`, and those covering a bone of `chain`.
    fn block_below(&mut self, depth: usize, chain: &[usize]) {
        let depths = self.strokes.len();
        let (above, below) = self.blocked.split_at_mut((depth + 1) * depths);
        below[depth + 1..depths]
            .copy_from_slice(&above[depth * depths + depth + 1..][..depths - depth - 1]);
        for &b in chain {
            for &(d, bits) in &self.covered_by[b] {
                if d > depth {
                    below[d] |= bits;
                }
            }
        }
    }
}
