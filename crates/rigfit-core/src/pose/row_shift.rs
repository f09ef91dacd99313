//! Local moves for rows of alike limbs fanning out of one joint (fingers from a palm, toes
//! from a foot, a quadruped's legs):
//! - when one limb of the row is undrawn, the strokes of its neighbours may each have been
//!   taken by the next limb over (fingers curled into a fist, every stroke one finger off).
//!   No single move undoes that; shifting the whole run of strokes one limb towards the free
//!   one does ([`shift_along_rows`]);
//! - when the joint itself is turned wrong (a palm face down), the wrong limbs are the
//!   nearest to the strokes and any placement of them fits as well as the next. The limbs'
//!   bases (the knuckles), spread across the joint, tell the turn and the placement
//!   together ([`turn_row_joints`]).

use super::bones::BoneModel;
use super::chains::{Assignment, SAMPLES, better_direction};
use super::fitting::FULL_FIT_STEPS;
use super::solver::{ChainFit, Solver};
use crate::kinematics::ForwardKinematics;
use crate::math::{Matrix3, Point3, Vector3, nearest_rotation, rotation_quat};

/// The fewest limbs fanning out of one joint that make a row.
const ROW_LIMBS: usize = 3;

/// Shifts runs of strokes on a row of limbs one limb towards a free limb of the row, when
/// that explains the strokes better (each run judged after a full fit).
pub(super) fn shift_along_rows(solver: &mut Solver, fit: &mut ChainFit) -> bool {
    let mut improved = false;
    for row in rows(solver) {
        let occupant = |assignment: &[Assignment], top: usize| {
            assignment
                .iter()
                .position(|a| a.as_ref().is_some_and(|(c, _)| c[0] == top))
        };
        for free in 0..row.len() {
            let taken = solver.bones_taken(&fit.assignment, None);
            if taken[row[free]] {
                continue;
            }
            for step in [1isize, -1] {
                let mut trial = fit.assignment.clone();
                let mut into = free;
                loop {
                    let from = into as isize + step;
                    if from < 0 || from as usize >= row.len() {
                        break;
                    }
                    let from = from as usize;
                    let Some(s) = occupant(&fit.assignment, row[from]) else {
                        break;
                    };
                    let Some(chain) = like_chain(solver, &trial, s, row[into]) else {
                        break;
                    };
                    let reversed = better_direction(&solver.setup, &solver.fitter.pose, s, &chain);
                    trial[s] = Some((chain, reversed));
                    into = from;
                    // One stroke moved to a free chain is another move's; a run of two or more
                    // is this one's.
                    if into.abs_diff(free) >= 2 && judge_from_start(solver, &trial, fit) {
                        improved = true;
                        break;
                    }
                }
            }
        }
    }
    improved
}

/// The most placements of a row's strokes on its limbs searched: six strokes on seven
/// limbs (on the tuning half, a cap of 720 lost two of mrfixit's cases). A fan of many
/// short bones (a face's) is left alone.
const MAX_PLACEMENTS: usize = 5040;

/// A turn of a row's joint smaller than this (radians) with the strokes where they are is
/// no new trial.
const MIN_ROW_TURN: f64 = 0.35;

/// Turns the joint a row fans out of (a palm) and places the row's strokes anew on its limbs
/// at once. For every placement of the strokes on the limbs, the turn about the joint that
/// best brings each limb's base (where its first bone ends, the knuckle) onto its stroke at
/// that arclength (Kabsch); the placement whose bases fit best is judged after a full fit,
/// from that turn with the row's limbs at their start. A palm turned wrong makes the wrong
/// fingers the nearest to the strokes; the knuckles, spread across the palm, tell the turn
/// and the placement together.
pub(super) fn turn_row_joints(solver: &mut Solver, fit: &mut ChainFit) -> bool {
    let mut improved = false;
    for row in rows(solver) {
        let Some(limbs) = unbranched_limbs(solver, &row) else {
            continue;
        };
        let Some(on_row) = strokes_on_row(&fit.assignment, &limbs) else {
            continue;
        };
        let placements = (limbs.len() + 1 - on_row.len().min(limbs.len())..=limbs.len())
            .try_fold(1usize, |n, k| n.checked_mul(k));
        if on_row.len() < 2 || placements.is_none_or(|n| n > MAX_PLACEMENTS) {
            continue;
        }
        let bones = &solver.setup.model.bones;
        let fan = bones[row[0]].joint;
        if !solver.setup.movable[fan] {
            continue;
        }
        let fk = ForwardKinematics::new(solver.setup.skeleton, &solver.fitter.pose);
        let pivot = fk.position(fan);
        // In the joint's own frame: its rotation turns by a rotation applied on the right.
        let to_frame = *fk.frame_linear_inv(fan);
        let bases: Vec<Vector3> = limbs
            .iter()
            .map(|l| to_frame * (fk.position(bones[l[0]].child) - pivot))
            .collect();
        let strokes = &solver.setup.strokes.by_arclength;
        // Stroke `i` of the row from its root end to where it has run limb `l`'s base.
        let reach: Vec<Vec<Vector3>> = on_row
            .iter()
            .map(|p| {
                let (samples, length) = &strokes[p.stroke];
                limbs
                    .iter()
                    .map(|l| {
                        let run = bones[l[0]].length / length.max(f64::MIN_POSITIVE);
                        let (root, at) = if p.reversed {
                            (samples[SAMPLES - 1], along(samples, 1.0 - run))
                        } else {
                            (samples[0], along(samples, run))
                        };
                        to_frame * (at - root)
                    })
                    .collect()
            })
            .collect();
        // A stroke pinned to bones goes only where it may.
        let may_go: Vec<Vec<bool>> = on_row
            .iter()
            .map(|p| {
                limbs
                    .iter()
                    .map(|l| solver.setup.stroke_may_cover(p.stroke, &placed_chain(l, p)))
                    .collect()
            })
            .collect();
        let mut best: Option<(f64, Vec<usize>, Matrix3)> = None;
        for placement in injections(on_row.len(), limbs.len()) {
            if placement.iter().enumerate().any(|(i, &l)| !may_go[i][l]) {
                continue;
            }
            let pairs = || {
                placement
                    .iter()
                    .enumerate()
                    .map(|(i, &l)| (bases[l], reach[i][l]))
            };
            let correlation: Matrix3 = pairs().map(|(b, r)| r * b.transpose()).sum();
            let turn = nearest_rotation(&correlation);
            let misfit: f64 = pairs().map(|(b, r)| (turn * b - r).norm_squared()).sum();
            if best.as_ref().is_none_or(|(m, _, _)| misfit < *m) {
                best = Some((misfit, placement, turn));
            }
        }
        let Some((_, placement, turn)) = best else {
            continue;
        };
        let turn = rotation_quat(&turn);
        let unchanged = placement.iter().zip(&on_row).all(|(&l, p)| l == p.limb);
        if unchanged && turn.angle() < MIN_ROW_TURN {
            continue;
        }
        let mut trial = fit.assignment.clone();
        for (&l, p) in placement.iter().zip(&on_row) {
            trial[p.stroke] = Some((placed_chain(&limbs[l], p), p.reversed));
        }
        let saved = solver.fitter.pose.clone();
        let pose = &mut solver.fitter.pose;
        pose.local[fan].rotation *= turn;
        for &b in limbs.iter().flat_map(|l| &l[1..]) {
            let j = bones[b].joint;
            pose.local[j].rotation = solver.setup.start.local[j].rotation;
        }
        if solver.accept_judged_after(trial, fit, FULL_FIT_STEPS) {
            improved = true;
        } else {
            solver.fitter.pose = saved;
        }
    }
    improved
}

/// The point a fraction `u` of the way along arclength samples (evenly spaced).
fn along(samples: &[Point3; SAMPLES], u: f64) -> Point3 {
    let x = u.clamp(0.0, 1.0) * (SAMPLES - 1) as f64;
    let i = (x.floor() as usize).min(SAMPLES - 2);
    samples[i] + (samples[i + 1] - samples[i]) * (x - i as f64)
}

/// Every placement of `items` things on `slots` slots, no two on one slot.
fn injections(items: usize, slots: usize) -> Vec<Vec<usize>> {
    let mut all = Vec::new();
    let mut picked = Vec::with_capacity(items);
    fn extend(items: usize, used: &mut [bool], picked: &mut Vec<usize>, all: &mut Vec<Vec<usize>>) {
        if picked.len() == items {
            all.push(picked.clone());
            return;
        }
        for slot in 0..used.len() {
            if !used[slot] {
                used[slot] = true;
                picked.push(slot);
                extend(items, used, picked, all);
                picked.pop();
                used[slot] = false;
            }
        }
    }
    extend(items, &mut vec![false; slots], &mut picked, &mut all);
    all
}

/// A stroke on a row: which limb, and over how many of its bones from the top.
struct RowStroke {
    stroke: usize,
    limb: usize,
    bones: usize,
    reversed: bool,
}

/// The row's alike limbs as their bones from the top down, when every limb of the row is
/// one unbranched run to its end and at least [`ROW_LIMBS`] are alike: within one bone of
/// the row's median count and half to twice its median length (a neck beside two arms is
/// no row; the arms alone are mirror images, another move's).
fn unbranched_limbs(solver: &Solver, row: &[usize]) -> Option<Vec<Vec<usize>>> {
    let model = &solver.setup.model;
    let limbs: Vec<Vec<usize>> = row
        .iter()
        .map(|&top| {
            let limb = limb_run(model, top);
            let last = *limb.last().expect("a run holds its top");
            model.next_bones[last].is_empty().then_some(limb)
        })
        .collect::<Option<_>>()?;
    let length = |limb: &Vec<usize>| limb.iter().map(|&b| model.bones[b].length).sum::<f64>();
    let median = |mut values: Vec<f64>| {
        values.sort_by(f64::total_cmp);
        values[values.len() / 2]
    };
    let bones = median(limbs.iter().map(|l| l.len() as f64).collect());
    let long = median(limbs.iter().map(length).collect());
    let alike: Vec<Vec<usize>> = limbs
        .into_iter()
        .filter(|l| (l.len() as f64 - bones).abs() <= 1.0)
        .filter(|l| (0.5 * long..=2.0 * long).contains(&length(l)))
        .collect();
    (alike.len() >= ROW_LIMBS).then_some(alike)
}

/// The strokes whose chains run down a limb of the row from its top, at most one a limb;
/// `None` when a stroke covers part of the row otherwise (across limbs, from lower down the
/// limb, or with more above the row).
fn strokes_on_row(assignment: &[Assignment], limbs: &[Vec<usize>]) -> Option<Vec<RowStroke>> {
    let mut on_row = Vec::new();
    let mut taken = vec![false; limbs.len()];
    for (s, a) in assignment.iter().enumerate() {
        let Some((chain, reversed)) = a else {
            continue;
        };
        let Some(&top) = chain.first() else {
            continue;
        };
        let Some(limb) = limbs.iter().position(|l| l[0] == top) else {
            if chain.iter().any(|b| limbs.iter().any(|l| l.contains(b))) {
                return None;
            }
            continue;
        };
        if !limbs[limb].starts_with(chain) || taken[limb] {
            return None;
        }
        taken[limb] = true;
        on_row.push(RowStroke {
            stroke: s,
            limb,
            bones: chain.len(),
            reversed: *reversed,
        });
    }
    Some(on_row)
}

/// The chain `stroke` takes on `limb`: from its top down as many bones (fewer when the limb
/// is shorter).
fn placed_chain(limb: &[usize], stroke: &RowStroke) -> Vec<usize> {
    limb[..stroke.bones.min(limb.len())].to_vec()
}

/// The bones down from `top` while each has one continuation (a limb, or a limb's run down
/// to where it branches).
fn limb_run(model: &BoneModel, top: usize) -> Vec<usize> {
    let mut run = vec![top];
    while run.len() < model.bones.len() {
        match model.next_bones[run[run.len() - 1]][..] {
            [only] => run.push(only),
            _ => break,
        }
    }
    run
}

/// Judges `trial` (by [`Solver::accept_judged_after`] a full fit) with the limbs whose
/// strokes it moves back at their start pose: a finger curled for one stroke is no start for
/// its neighbour's. The pose is restored when it is not taken.
pub(super) fn judge_from_start(
    solver: &mut Solver,
    trial: &[Assignment],
    fit: &mut ChainFit,
) -> bool {
    let saved = solver.fitter.pose.clone();
    let bones = &solver.setup.model.bones;
    let moved = trial
        .iter()
        .zip(&fit.assignment)
        .filter(|(t, a)| t != a)
        .flat_map(|(t, a)| t.iter().chain(a.iter()).flat_map(|(c, _)| &c[1..]));
    for &b in moved {
        let j = bones[b].joint;
        solver.fitter.pose.local[j].rotation = solver.setup.start.local[j].rotation;
    }
    if solver.accept_judged_after(trial.to_vec(), fit, FULL_FIT_STEPS) {
        return true;
    }
    solver.fitter.pose = saved;
    false
}

/// The chain from bone `top` with as many bones as stroke `s`'s chain in `assignment` (or
/// fewer when the limb is shorter) that no other stroke's bones overlap and `s` may cover.
fn like_chain(
    solver: &Solver,
    assignment: &[Assignment],
    s: usize,
    top: usize,
) -> Option<Vec<usize>> {
    let (current, _) = assignment[s].as_ref()?;
    let taken = solver.bones_taken(assignment, Some(s));
    solver
        .chains
        .iter()
        .filter(|c| c[0] == top && c.len() <= current.len())
        .filter(|c| c.iter().all(|&b| !taken[b]) && solver.setup.stroke_may_cover(s, c))
        .max_by_key(|c| c.len())
        .cloned()
}

/// The rows of the skeleton: for every joint turning at least [`ROW_LIMBS`] bones, those
/// bones in order across the row, by the direction of each limb's end from the joint at the
/// start pose ([`order_across`]).
fn rows(solver: &Solver) -> Vec<Vec<usize>> {
    let model = &solver.setup.model;
    let fk = ForwardKinematics::new(solver.setup.skeleton, solver.setup.start);
    let mut by_joint: Vec<Vec<usize>> = vec![Vec::new(); solver.setup.skeleton.len()];
    for (b, bone) in model.bones.iter().enumerate() {
        by_joint[bone.joint].push(b);
    }
    // A limb's end: down its bones while each has one continuation.
    let limb_end = |top: usize| {
        let run = limb_run(model, top);
        fk.position(model.bones[run[run.len() - 1]].child)
    };
    by_joint
        .into_iter()
        .enumerate()
        .filter(|(_, tops)| tops.len() >= ROW_LIMBS)
        .map(|(joint, tops)| {
            let from = fk.position(joint);
            let directions: Vec<Vector3> = tops
                .iter()
                .map(|&b| {
                    (limb_end(b) - from)
                        .try_normalize(0.0)
                        .unwrap_or_else(Vector3::zeros)
                })
                .collect();
            order_across(&tops, &directions)
        })
        .collect()
}

/// `items` ordered across their fan: by their `directions`' components off the mean
/// direction, along the line those spread most on.
fn order_across(items: &[usize], directions: &[Vector3]) -> Vec<usize> {
    let mean = directions.iter().sum::<Vector3>();
    let Some(mean) = mean.try_normalize(1e-12) else {
        return items.to_vec();
    };
    let off: Vec<Vector3> = directions.iter().map(|d| d - mean * d.dot(&mean)).collect();
    let axis = spread_axis(&off);
    let mut along: Vec<(f64, usize)> = items
        .iter()
        .zip(&off)
        .map(|(&item, o)| (o.dot(&axis), item))
        .collect();
    along.sort_by(|a, b| a.0.total_cmp(&b.0));
    along.into_iter().map(|(_, item)| item).collect()
}

/// The direction along which `vectors` spread most about their mean (the principal axis of
/// their scatter, by power iteration).
fn spread_axis(vectors: &[Vector3]) -> Vector3 {
    let mean = vectors.iter().sum::<Vector3>() / vectors.len().max(1) as f64;
    let scatter = vectors
        .iter()
        .map(|v| (v - mean) * (v - mean).transpose())
        .sum::<Matrix3>();
    // Any start not at right angles to the principal axis; three tried.
    let starts = [Vector3::x(), Vector3::y(), Vector3::z()];
    let mut axis = starts
        .into_iter()
        .max_by(|a, b| (scatter * a).norm().total_cmp(&(scatter * b).norm()))
        .expect("three starts");
    for _ in 0..50 {
        match (scatter * axis).try_normalize(1e-300) {
            Some(next) => axis = next,
            None => break,
        }
    }
    axis
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_fan_is_ordered_across() {
        // Five limbs pointing up (+z), spread about x by -60 (a thumb), then -10, 0, 10
        // and 20 degrees, given out of order.
        let angles = [0.0_f64, 20.0, -60.0, 10.0, -10.0];
        let directions: Vec<Vector3> = angles
            .iter()
            .map(|a| {
                let a = a.to_radians();
                Vector3::new(a.sin(), 0.0, a.cos())
            })
            .collect();
        let order = order_across(&[0, 1, 2, 3, 4], &directions);
        let forwards = vec![2, 4, 0, 3, 1];
        let backwards: Vec<usize> = forwards.iter().rev().copied().collect();
        assert!(order == forwards || order == backwards, "{order:?}");
    }

    #[test]
    fn every_placement_of_strokes_on_limbs_is_listed_once() {
        let all = injections(3, 5);
        assert_eq!(all.len(), 5 * 4 * 3);
        let mut unique = all.clone();
        unique.sort();
        unique.dedup();
        assert_eq!(unique.len(), all.len());
        assert!(
            all.iter()
                .all(|p| p[0] != p[1] && p[1] != p[2] && p[0] != p[2])
        );
        assert_eq!(injections(0, 4), vec![Vec::<usize>::new()]);
    }

    #[test]
    fn a_point_along_samples_is_interpolated_by_arclength() {
        let samples: [Point3; SAMPLES] = std::array::from_fn(|i| Point3::new(i as f64, 0.0, 0.0));
        let end = (SAMPLES - 1) as f64;
        assert_eq!(along(&samples, 0.0), Point3::origin());
        assert_eq!(along(&samples, 1.0), Point3::new(end, 0.0, 0.0));
        assert!((along(&samples, 0.5).x - end / 2.0).abs() < 1e-12);
        assert_eq!(along(&samples, 2.0), Point3::new(end, 0.0, 0.0));
    }

    #[test]
    fn limbs_all_one_way_keep_their_order() {
        let directions = vec![Vector3::z(); 3];
        assert_eq!(order_across(&[7, 8, 9], &directions).len(), 3);
    }
}
