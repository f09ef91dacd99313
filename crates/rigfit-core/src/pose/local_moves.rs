//! Local moves on a fitted hypothesis: the moves between mirror-image limbs
//! ([`swap_mirror_limbs`], [`turn_round_at_forks`], [`take_mirror_limbs_held_in_part`],
//! [`move_to_free_mirror_limbs`]), trade a stray for an assigned stroke, give a stray the
//! free limbs most like it ([`limb_picks`]), give a stroke another close chain (the strokes
//! that lose bones pick again), move a stroke to a free chain of about its length, shift a
//! run of strokes along a row of alike limbs ([`shift_along_rows`]), and turn the joint a
//! row fans out of with the row's strokes placed anew ([`turn_row_joints`]). Every move is
//! judged by one accept step ([`Solver::accept`]): a quick fit, then a full one when it
//! explains the strokes better.

use super::assignment::complete_greedily;
use super::candidates::{Candidate, Candidates, STRAY_COST, candidates};
use super::chains::{Assignment, better_direction, stroke_length};
use super::fitting::FULL_FIT_STEPS;
use super::mirror_moves::{
    move_to_free_mirror_limbs, swap_mirror_limbs, take_mirror_limbs_held_in_part,
    turn_round_at_forks,
};
use super::row_shift::{shift_along_rows, turn_row_joints};
use super::solver::{ChainFit, Solver};

/// Levenberg-Marquardt steps used to judge a trial assignment.
const QUICK_FIT_STEPS: usize = 8;

/// A chain is tried for a stroke when its cost at the current pose is within this factor of
/// the stroke's own chain's.
const EJECTION_COST_RATIO: f64 = 3.0;

/// The most strokes set aside as strays that are tried in place of an assigned stroke, per
/// pass.
const MAX_STRAY_EXCHANGES: usize = 8;

/// Passes over all moves (a pass that improves nothing ends the search).
const PASSES: usize = 2;

/// Mirror-image limbs: chains of as many bones whose lengths differ by at most this share.
pub(super) const MIRROR_LENGTH_TOLERANCE: f64 = 0.15;

/// Improves `fit` by local moves until none helps.
pub(super) fn improve(solver: &mut Solver, mut fit: ChainFit) -> ChainFit {
    solver.fitter.pose = fit.pose.clone();
    solver.by_shape = fit.by_shape;
    for _pass in 0..PASSES {
        if solver.setup.interrupt.is_set() {
            break;
        }
        let mut improved = swap_mirror_limbs(solver, &mut fit);
        improved |= turn_round_at_forks(solver, &mut fit);
        improved |= trade_strays(solver, &mut fit);
        improved |= give_strays_free_chains(solver, &mut fit);
        improved |= take_close_chains(solver, &mut fit);
        improved |= move_to_free_chains(solver, &mut fit);
        improved |= take_mirror_limbs_held_in_part(solver, &mut fit);
        improved |= shift_along_rows(solver, &mut fit);
        improved |= turn_row_joints(solver, &mut fit);
        improved |= move_to_free_mirror_limbs(solver, &mut fit);
        if !improved {
            break;
        }
    }
    fit.pose = solver.fitter.pose.clone();
    fit
}

impl Solver<'_> {
    /// The one accept step: judges `trial` from the current pose by a quick fit; when it
    /// explains the strokes better than `fit`, fits it fully and makes it `fit`. Otherwise
    /// the pose is restored.
    pub(super) fn accept(&mut self, trial: Vec<Assignment>, fit: &mut ChainFit) -> bool {
        self.accept_judged_after(trial, fit, QUICK_FIT_STEPS)
    }

    /// [`Solver::accept`] judging `trial` after `judge_steps` fitting steps (a limb that
    /// must swing far to reach its stroke needs more than the quick fit).
    pub(super) fn accept_judged_after(
        &mut self,
        trial: Vec<Assignment>,
        fit: &mut ChainFit,
        judge_steps: usize,
    ) -> bool {
        if self.trials_left == 0 {
            self.last_judged = f64::INFINITY;
            return false;
        }
        self.trials_left -= 1;
        let saved = self.fitter.pose.clone();
        let layout = self.fitter.keep_unexplained_at_start(&self.setup, &trial);
        self.fitter
            .fit_arclength(&self.setup, &layout, &trial, judge_steps);
        self.last_judged = self.score(&trial, &layout);
        if self.last_judged < fit.score {
            self.fitter
                .fit_arclength(&self.setup, &layout, &trial, FULL_FIT_STEPS);
            self.limit_tail(&layout, &trial);
            fit.score = self.score(&trial, &layout);
            fit.assignment = trial;
            fit.layout = layout;
            return true;
        }
        self.fitter.pose = saved;
        false
    }

    /// The candidates at the current pose, by shape those costing at most a stray (ranked
    /// again only when the pose or the matching changed since the last call).
    pub(super) fn ranked_now(&self) -> Candidates {
        let mut last = self.ranked_at.borrow_mut();
        if let Some((pose, by_shape, ranked)) = last.as_ref()
            && *pose == self.fitter.pose
            && *by_shape == self.by_shape
        {
            return ranked.clone();
        }
        let ranked = self.ranked_among(&self.chains, STRAY_COST);
        *last = Some((self.fitter.pose.clone(), self.by_shape, ranked.clone()));
        ranked
    }

    /// Every stroke's candidates among `chains` at the current pose, by shape those costing
    /// at most `ceiling`.
    fn ranked_among(&self, chains: &[Vec<usize>], ceiling: f64) -> Candidates {
        let none = vec![false; self.setup.strokes.count()];
        candidates(
            &self.setup,
            &self.fitter.pose,
            chains,
            &none,
            self.by_shape,
            ceiling,
        )
    }

    /// Every stroke's candidates among the chains no stroke of `assignment` covers a bone
    /// of, by shape however far they must turn (chain indices into `self.chains`).
    fn free_chains_ranked(&self, assignment: &[Assignment]) -> Candidates {
        let used = self.bones_taken(assignment, None);
        let free: Vec<usize> = (0..self.chains.len())
            .filter(|&c| self.chains[c].iter().all(|&b| !used[b]))
            .collect();
        let chains: Vec<Vec<usize>> = free.iter().map(|&c| self.chains[c].clone()).collect();
        let mut ranked = self.ranked_among(&chains, f64::INFINITY);
        for c in ranked.iter_mut().flatten() {
            c.chain = free[c.chain];
        }
        ranked
    }

    /// Which bones the strokes of `assignment` cover, stroke `except` left out.
    pub(super) fn bones_taken(
        &self,
        assignment: &[Assignment],
        except: Option<usize>,
    ) -> Vec<bool> {
        let mut taken = vec![false; self.setup.model.bones.len()];
        for (t, a) in assignment.iter().enumerate() {
            if Some(t) != except {
                a.iter().flat_map(|a| &a.0).for_each(|&b| taken[b] = true);
            }
        }
        taken
    }

    /// The stroke of `assignment` covering each bone, if any.
    pub(super) fn bone_owners(&self, assignment: &[Assignment]) -> Vec<Option<usize>> {
        let mut owner = vec![None; self.setup.model.bones.len()];
        for (t, a) in assignment.iter().enumerate() {
            a.iter()
                .flat_map(|a| &a.0)
                .for_each(|&b| owner[b] = Some(t));
        }
        owner
    }

    pub(super) fn chain_length(&self, chain: &[usize]) -> f64 {
        chain
            .iter()
            .map(|&b| self.setup.model.bones[b].length)
            .sum()
    }
}

/// A stroke set aside as a stray may be the real one: give it the chain of an assigned
/// stroke and set that one aside instead.
fn trade_strays(solver: &mut Solver, fit: &mut ChainFit) -> bool {
    let strokes = fit.assignment.len();
    let mut improved = false;
    // The candidates at the current pose, computed again only after the pose moved.
    let mut ranked_now: Option<Candidates> = None;
    let mut set_aside: Vec<usize> = (0..strokes)
        .filter(|&e| fit.assignment[e].is_none())
        .collect();
    if set_aside.len() > MAX_STRAY_EXCHANGES {
        // Many strays (clutter): only those that fit some chain best are tried.
        let ranked = solver.ranked_now();
        let best = |e: usize| ranked[e].first().map_or(f64::INFINITY, |c| c.cost);
        set_aside.sort_by(|&a, &b| best(a).total_cmp(&best(b)));
        set_aside.truncate(MAX_STRAY_EXCHANGES);
        set_aside.sort_unstable();
        ranked_now = Some(ranked);
    }
    for e in set_aside {
        if fit.assignment[e].is_some() {
            continue;
        }
        let ranked = ranked_now
            .get_or_insert_with(|| solver.ranked_now())
            .clone();
        if ranked[e].first().is_none_or(|c| c.cost >= STRAY_COST) && solver.by_shape {
            // No chain could take it.
            continue;
        }
        for s in 0..strokes {
            if fit.assignment[s].is_none() {
                continue;
            }
            // Stroke `e` takes its best chain among the bones `s` leaves free.
            let mut fixed = fit.assignment.clone();
            fixed[s] = None;
            let mut excluded: Vec<bool> =
                (0..strokes).map(|t| t != e && fixed[t].is_none()).collect();
            excluded[s] = true;
            let trial =
                complete_greedily(&solver.setup, &solver.chains, &ranked, &fixed, &excluded);
            if trial[e].is_some() && solver.accept(trial, fit) {
                improved = true;
                ranked_now = None;
                break;
            }
        }
    }
    improved
}

/// A stroke set aside because no chain looked like it at the start pose (a limb drawn bent
/// far from its shape there) may still be one: give it the free limbs that fit it best
/// ([`limb_picks`]), however much they must bend, and let a full fit judge.
fn give_strays_free_chains(solver: &mut Solver, fit: &mut ChainFit) -> bool {
    let strokes = fit.assignment.len();
    let mut improved = false;
    let set_aside: Vec<usize> = (0..strokes)
        .filter(|&e| fit.assignment[e].is_none())
        .collect();
    if set_aside.is_empty() || set_aside.len() > MAX_STRAY_EXCHANGES {
        return false;
    }
    // Only the free chains are ranked: ranked among all, a stroke's best few are the
    // chains around it, and those are taken.
    let mut ranked = solver.free_chains_ranked(&fit.assignment);
    for e in set_aside {
        let picks = limb_picks(
            &ranked[e],
            |c| (solver.chains[c.chain][0], c.reversed),
            |c| solver.chain_length(&solver.chains[c.chain]),
            stroke_length(&solver.setup, e),
        );
        for pick in picks {
            let mut trial = fit.assignment.clone();
            trial[e] = Some((solver.chains[pick.chain].clone(), pick.reversed));
            if solver.accept_judged_after(trial, fit, FULL_FIT_STEPS) {
                improved = true;
                ranked = solver.free_chains_ranked(&fit.assignment);
                break;
            }
        }
    }
    improved
}

/// Free limbs tried for a stroke set aside.
const FREE_CHAINS_TRIED: usize = 2;

/// Of a stroke's candidates `ranked` (best first), one per limb (`limb`: the chain's first
/// bone and which way round the stroke runs) for the [`FREE_CHAINS_TRIED`] best limbs: the
/// one whose `length` is nearest the stroke's `drawn` length. Shape alone cannot tell how
/// much of a limb a stroke drawn far from it covers, and a part of one limb that looks a
/// little more like the stroke would otherwise take every trial.
fn limb_picks(
    ranked: &[Candidate],
    limb: impl Fn(&Candidate) -> (usize, bool),
    length: impl Fn(&Candidate) -> f64,
    drawn: f64,
) -> Vec<Candidate> {
    let mut limbs: Vec<(usize, bool)> = Vec::new();
    for c in ranked {
        if limbs.len() < FREE_CHAINS_TRIED && !limbs.contains(&limb(c)) {
            limbs.push(limb(c));
        }
    }
    let mismatch = |c: &&Candidate| (length(c) - drawn).abs();
    limbs
        .into_iter()
        .filter_map(|l| {
            ranked
                .iter()
                .filter(|c| limb(c) == l)
                .min_by(|a, b| mismatch(a).total_cmp(&mismatch(b)))
                .copied()
        })
        .collect()
}

/// Give a stroke one of its best candidate chains at the current pose, and let the strokes
/// whose chains that takes pick again.
fn take_close_chains(solver: &mut Solver, fit: &mut ChainFit) -> bool {
    let strokes = fit.assignment.len();
    let mut improved = false;
    let ranked = solver.ranked_now();
    for s in 0..strokes {
        let Some((current, _)) = fit.assignment[s].clone() else {
            continue;
        };
        // Only chains that lie about as close to the stroke as its own does.
        let chains = &solver.chains;
        let own = ranked[s]
            .iter()
            .find(|c| chains[c.chain] == current)
            .map_or(f64::INFINITY, |c| c.cost);
        let picks: Vec<_> = ranked[s]
            .iter()
            .filter(|c| chains[c.chain] != current && c.cost < EJECTION_COST_RATIO * own)
            .take(2)
            .copied()
            .collect();
        for pick in picks {
            let chain = &solver.chains[pick.chain];
            let mut fixed = fit.assignment.clone();
            fixed[s] = Some((chain.clone(), pick.reversed));
            for (t, f) in fixed.iter_mut().enumerate() {
                if t != s
                    && f.as_ref()
                        .is_some_and(|(ct, _)| ct.iter().any(|b| chain.contains(b)))
                {
                    *f = None;
                }
            }
            let excluded: Vec<bool> = (0..strokes).map(|t| fit.assignment[t].is_none()).collect();
            let trial =
                complete_greedily(&solver.setup, &solver.chains, &ranked, &fixed, &excluded);
            if trial != fit.assignment && solver.accept(trial, fit) {
                improved = true;
                break;
            }
        }
    }
    improved
}

/// Move a stroke to a free chain of similar length (the other side's limb when one limb
/// is undrawn), or grow or shrink its chain (a stroke that fits its chain only in part).
fn move_to_free_chains(solver: &mut Solver, fit: &mut ChainFit) -> bool {
    let strokes = fit.assignment.len();
    let mut improved = false;
    for s in 0..strokes {
        let Some((current, _)) = fit.assignment[s].clone() else {
            continue;
        };
        let used = solver.bones_taken(&fit.assignment, Some(s));
        let lc = solver.chain_length(&current);
        let drawn = stroke_length(&solver.setup, s);
        let mut options: Vec<&Vec<usize>> = solver
            .chains
            .iter()
            .filter(|c| **c != current && c.iter().all(|&b| !used[b]))
            .filter(|c| solver.setup.stroke_may_cover(s, c))
            .filter(|c| {
                c.iter().any(|b| current.contains(b))
                    || (solver.chain_length(c) - lc).abs() < MIRROR_LENGTH_TOLERANCE * lc
            })
            .collect();
        options.sort_by(|a, b| {
            (solver.chain_length(a) - drawn)
                .abs()
                .total_cmp(&(solver.chain_length(b) - drawn).abs())
        });
        let options: Vec<Vec<usize>> = options.into_iter().take(3).cloned().collect();
        for c in options {
            let mut trial = fit.assignment.clone();
            let reversed = better_direction(&solver.setup, &solver.fitter.pose, s, &c);
            trial[s] = Some((c, reversed));
            if solver.accept(trial, fit) {
                improved = true;
                break;
            }
        }
    }
    improved
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_stray_tries_the_best_limbs_each_at_its_length() {
        // Chains 0-2 are one limb (lengths 1, 2, 3), chain 3 another (length 2), chain 4 a
        // third; the part of the first limb that looks most like the stroke comes first.
        let candidate = |chain: usize, cost: f64| Candidate {
            cost,
            chain,
            reversed: false,
        };
        let ranked = [
            candidate(0, 0.1),
            candidate(1, 0.11),
            candidate(3, 0.12),
            candidate(2, 0.13),
            candidate(4, 0.2),
        ];
        let limb = |c: &Candidate| (if c.chain < 3 { 0 } else { c.chain }, c.reversed);
        let length = |c: &Candidate| [1.0, 2.0, 3.0, 2.0, 1.0][c.chain];
        let picks = limb_picks(&ranked, limb, length, 2.9);
        assert_eq!(
            picks.iter().map(|c| c.chain).collect::<Vec<_>>(),
            vec![2, 3]
        );
        // The same limb drawn the other way round is another trial.
        let mut turned = ranked;
        turned[2] = Candidate {
            chain: 0,
            reversed: true,
            cost: 0.12,
        };
        let picks = limb_picks(&turned, limb, length, 1.2);
        assert_eq!(
            picks
                .iter()
                .map(|c| (c.chain, c.reversed))
                .collect::<Vec<_>>(),
            vec![(0, false), (0, true)]
        );
    }
}
