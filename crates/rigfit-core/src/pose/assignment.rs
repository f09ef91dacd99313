//! Which chain each stroke covers: from the strokes' [`Candidates`], the strokes' chains
//! are chosen together so that no two strokes share a bone and the total cost is least, a
//! stroke with no chain left being set aside as a stray ([`assign`]).

use super::candidates::{Candidate, Candidates, KEPT_CANDIDATES, STRAY_COST};
use super::chains::Assignment;
use super::setup::Setup;

/// Search nodes per group of strokes competing for bones (picks ruled out by the bound
/// count too), before the best assignment found so far is kept. Far from the pose, most
/// searches end at the budget: many chains fit a stroke almost alike. Measured on the
/// tuning half: with the tighter bound and 16 candidates, 1,000 and 500 alike; before
/// them, 500 to 5,000 within 10 of 2,160 cases either way (BENCHMARKS.md, session 20).
const SEARCH_BUDGET: usize = 1_000;

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
