//! A local move for rows of alike limbs fanning out of one joint (fingers from a palm, toes
//! from a foot): when one limb of the row is undrawn, the strokes of its neighbours may each
//! have been taken by the next limb over (fingers curled into a fist, every stroke one finger
//! off). No single move undoes that; shifting the whole run of strokes one limb towards the
//! free one does.

use super::chains::{Assignment, better_direction};
use super::fitting::FULL_FIT_STEPS;
use super::solver::{ChainFit, Solver};
use crate::kinematics::ForwardKinematics;
use crate::math::{Matrix3, Vector3};

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

/// Judges `trial` (by [`Solver::accept_judged_after`] a full fit) with the limbs whose
/// strokes it moves back at their start pose: a finger curled for one stroke is no start for
/// its neighbour's. The pose is restored when it is not taken.
fn judge_from_start(solver: &mut Solver, trial: &[Assignment], fit: &mut ChainFit) -> bool {
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
        let mut bone = top;
        for _ in 0..model.bones.len() {
            match model.next_bones[bone][..] {
                [only] => bone = only,
                _ => break,
            }
        }
        fk.position(model.bones[bone].child)
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
    fn limbs_all_one_way_keep_their_order() {
        let directions = vec![Vector3::z(); 3];
        assert_eq!(order_across(&[7, 8, 9], &directions).len(), 3);
    }
}
