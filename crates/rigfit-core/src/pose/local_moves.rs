//! Local moves on a fitted hypothesis: swap the chains of mirror-image limbs, trade a stray
//! for an assigned stroke, give a stray the free limbs most like it ([`limb_picks`]), give a
//! stroke another close chain (the strokes that lose bones pick again), move a stroke to a
//! free chain of about its length, shift a run of strokes
//! along a row of alike limbs ([`shift_along_rows`]), and turn the joint a row fans out of
//! with the row's strokes placed anew ([`turn_row_joints`]). Every move is judged
//! by one accept step ([`Solver::accept`]): a quick fit, then a full one when it explains
//! the strokes better.

use super::assignment::complete_greedily;
use super::candidates::{Candidate, Candidates, STRAY_COST, candidates};
use super::chains::{Assignment, better_direction, stroke_length};
use super::fitting::FULL_FIT_STEPS;
use super::row_shift::{judge_from_start, shift_along_rows, turn_row_joints};
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
const MIRROR_LENGTH_TOLERANCE: f64 = 0.15;

/// Improves `fit` by local moves until none helps.
pub(super) fn improve(solver: &mut Solver, mut fit: ChainFit) -> ChainFit {
    solver.fitter.pose = fit.pose.clone();
    solver.by_shape = fit.by_shape;
    for _pass in 0..PASSES {
        if solver.setup.interrupt.is_set() {
            break;
        }
        let mut improved = swap_mirror_limbs(solver, &mut fit);
        improved |= trade_strays(solver, &mut fit);
        improved |= give_strays_free_chains(solver, &mut fit);
        improved |= take_close_chains(solver, &mut fit);
        improved |= move_to_free_chains(solver, &mut fit);
        improved |= take_mirror_limbs_held_in_part(solver, &mut fit);
        improved |= shift_along_rows(solver, &mut fit);
        improved |= turn_row_joints(solver, &mut fit);
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
    fn accept(&mut self, trial: Vec<Assignment>, fit: &mut ChainFit) -> bool {
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
            return false;
        }
        self.trials_left -= 1;
        let saved = self.fitter.pose.clone();
        let layout = self.fitter.keep_unexplained_at_start(&self.setup, &trial);
        self.fitter
            .fit_arclength(&self.setup, &layout, &trial, judge_steps);
        if self.score(&trial, &layout) < fit.score {
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
    fn bone_owners(&self, assignment: &[Assignment]) -> Vec<Option<usize>> {
        let mut owner = vec![None; self.setup.model.bones.len()];
        for (t, a) in assignment.iter().enumerate() {
            a.iter()
                .flat_map(|a| &a.0)
                .for_each(|&b| owner[b] = Some(t));
        }
        owner
    }

    fn chain_length(&self, chain: &[usize]) -> f64 {
        chain
            .iter()
            .map(|&b| self.setup.model.bones[b].length)
            .sum()
    }
}

/// Swap the chains of two strokes on mirror-image limbs when that explains them better.
fn swap_mirror_limbs(solver: &mut Solver, fit: &mut ChainFit) -> bool {
    let strokes = fit.assignment.len();
    let mut improved = false;
    for s in 0..strokes {
        for t in s + 1..strokes {
            let (Some((cs, _)), Some((ct, _))) = (&fit.assignment[s], &fit.assignment[t]) else {
                continue;
            };
            if !solver.setup.stroke_may_cover(s, ct) || !solver.setup.stroke_may_cover(t, cs) {
                continue;
            }
            let (ls, lt) = (solver.chain_length(cs), solver.chain_length(ct));
            if cs.len() != ct.len() || (ls - lt).abs() > MIRROR_LENGTH_TOLERANCE * ls.max(lt) {
                continue;
            }
            let (cs, ct) = (cs.clone(), ct.clone());
            let pose = &solver.fitter.pose;
            let mut trial = fit.assignment.clone();
            trial[s] = Some((ct.clone(), better_direction(&solver.setup, pose, s, &ct)));
            trial[t] = Some((cs.clone(), better_direction(&solver.setup, pose, t, &cs)));
            let carried = solver.bone_mirrors.as_ref().and_then(|mirrors| {
                carried_across(
                    &trial,
                    [s, t],
                    [&cs, &ct],
                    mirrors,
                    &solver.setup.model.next_bones,
                    |u, c| solver.setup.stroke_may_cover(u, c),
                )
            });
            // Judged from the current pose first, then with both limbs back at their start
            // pose: two limbs crossing over each other to trade places stop half way.
            if solver.accept(trial.clone(), fit) || judge_from_start(solver, &trial, fit) {
                improved = true;
            } else if let Some(carried) = carried {
                improved |=
                    solver.accept(carried.clone(), fit) || judge_from_start(solver, &carried, fit);
            }
        }
    }
    improved
}

/// `swapped` (strokes `pair` traded between the mirror-image `limbs`) with every other
/// stroke on the bones below either limb moved to its mirror image as well (`mirrors`: one
/// entry per bone; `next_bones`: each bone's continuations; `may_cover(stroke, chain)`: a
/// stroke pinned to bones goes only where it may): the hand's strokes go with the arm.
/// `None` when no stroke lies below them, a bone has no mirror or an image would cover a
/// bone twice.
fn carried_across(
    swapped: &[Assignment],
    pair: [usize; 2],
    limbs: [&[usize]; 2],
    mirrors: &[Option<usize>],
    next_bones: &[Vec<usize>],
    may_cover: impl Fn(usize, &[usize]) -> bool,
) -> Option<Vec<Assignment>> {
    let below = bones_below(next_bones, &limbs);
    let mut carried = swapped.to_vec();
    let mut moved = false;
    for (u, a) in carried.iter_mut().enumerate() {
        let Some((chain, reversed)) = a.as_ref() else {
            continue;
        };
        if pair.contains(&u) || !chain.iter().all(|&b| below[b]) {
            continue;
        }
        let image: Vec<usize> = chain.iter().map(|&b| mirrors[b]).collect::<Option<_>>()?;
        if !may_cover(u, &image) {
            return None;
        }
        *a = Some((image, *reversed));
        moved = true;
    }
    let mut taken = vec![false; mirrors.len()];
    for &b in carried.iter().flatten().flat_map(|(c, _)| c) {
        if std::mem::replace(&mut taken[b], true) {
            return None;
        }
    }
    moved.then_some(carried)
}

/// The bones hanging below `limbs` (reached through the bones' continuations
/// `next_bones`), the limbs' own bones left out.
fn bones_below(next_bones: &[Vec<usize>], limbs: &[&[usize]]) -> Vec<bool> {
    let mut below = vec![false; next_bones.len()];
    let mut stack: Vec<usize> = limbs.iter().flat_map(|l| l.iter().copied()).collect();
    while let Some(b) = stack.pop() {
        for &n in &next_bones[b] {
            if !below[n] && !limbs.iter().any(|l| l.contains(&n)) {
                below[n] = true;
                stack.push(n);
            }
        }
    }
    below
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

/// Move a stroke to the mirror-image limb of its chain when one shorter stroke holds part
/// of that limb, and set that one aside: a stroke drawn on the limb that is not there takes
/// the other side's, and a stray or a fragment takes a piece of the limb it left.
fn take_mirror_limbs_held_in_part(solver: &mut Solver, fit: &mut ChainFit) -> bool {
    let strokes = fit.assignment.len();
    let mut improved = false;
    for s in 0..strokes {
        let Some((current, _)) = fit.assignment[s].clone() else {
            continue;
        };
        let lc = solver.chain_length(&current);
        let owner = solver.bone_owners(&fit.assignment);
        let holders = |c: &[usize]| -> Vec<usize> {
            let mut held: Vec<usize> = c.iter().filter_map(|&b| owner[b]).collect();
            held.sort_unstable();
            held.dedup();
            held
        };
        let mut options: Vec<(Vec<usize>, usize)> = solver
            .chains
            .iter()
            .filter(|c| c.len() == current.len() && c.iter().all(|b| !current.contains(b)))
            .filter(|c| (solver.chain_length(c) - lc).abs() < MIRROR_LENGTH_TOLERANCE * lc)
            .filter(|c| solver.setup.stroke_may_cover(s, c))
            .filter_map(|c| match holders(c)[..] {
                [t] if t != s
                    && fit.assignment[t]
                        .as_ref()
                        .is_some_and(|(ct, _)| ct.len() < c.len()) =>
                {
                    Some((c.clone(), t))
                }
                _ => None,
            })
            .collect();
        options.sort_by(|a, b| {
            (solver.chain_length(&a.0) - lc)
                .abs()
                .total_cmp(&(solver.chain_length(&b.0) - lc).abs())
        });
        for (c, t) in options.into_iter().take(MIRROR_LIMBS_HELD_TRIED) {
            let mut trial = fit.assignment.clone();
            let reversed = better_direction(&solver.setup, &solver.fitter.pose, s, &c);
            trial[s] = Some((c, reversed));
            trial[t] = None;
            if solver.accept_judged_after(trial, fit, FULL_FIT_STEPS) {
                improved = true;
                break;
            }
        }
    }
    improved
}

/// Mirror-image limbs held in part that are tried for a stroke.
const MIRROR_LIMBS_HELD_TRIED: usize = 1;

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

    #[test]
    fn a_swap_of_arms_carries_the_hands_strokes_across() {
        // Bones: 0 left arm, 1 left hand, 2 left finger; 3 right arm, 4 right hand, 5
        // right finger; 6 the head (below neither arm).
        let next_bones = vec![vec![1], vec![2], vec![], vec![4], vec![5], vec![], vec![]];
        let mirrors = [Some(3), Some(4), Some(5), Some(0), Some(1), Some(2), None];
        let left = [0usize];
        let right = [3usize];
        // Strokes: 0 and 1 traded between the arms; 2 on the left hand and finger; 3 on the
        // head; 4 a stray.
        let swapped: Vec<Assignment> = vec![
            Some((vec![3], false)),
            Some((vec![0], false)),
            Some((vec![1, 2], true)),
            Some((vec![6], false)),
            None,
        ];
        let everywhere = |_: usize, _: &[usize]| true;
        let carried = carried_across(
            &swapped,
            [0, 1],
            [&left, &right],
            &mirrors,
            &next_bones,
            everywhere,
        )
        .expect("a stroke lies below the arms");
        assert_eq!(carried[2], Some((vec![4, 5], true)));
        assert_eq!(carried[..2], swapped[..2]);
        assert_eq!(carried[3..], swapped[3..]);
        // Nothing below the arms: nothing to carry.
        let bare = [swapped[0].clone(), swapped[1].clone(), None];
        assert!(
            carried_across(
                &bare,
                [0, 1],
                [&left, &right],
                &mirrors,
                &next_bones,
                everywhere
            )
            .is_none()
        );
        // A pinned stroke that may not go across stops the move.
        let pinned = |u: usize, c: &[usize]| u != 2 || c.contains(&1);
        assert!(
            carried_across(
                &swapped,
                [0, 1],
                [&left, &right],
                &mirrors,
                &next_bones,
                pinned
            )
            .is_none()
        );
    }
}
