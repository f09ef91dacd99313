//! Local moves between mirror-image limbs: swap the strokes of two limbs (judged from the
//! current pose, then from the start pose, then with the strokes below the limbs carried
//! across), turn the body round at a fork (a chest, a pelvis) with every stroke below it
//! mirrored, give a stroke on the undrawn side's limb its own limb back from a shorter
//! stroke holding part of it, and move a limb's strokes to its free mirror image. Every
//! move is judged by the local moves' accept step.

use super::bones::Bone;
use super::chains::{Assignment, better_direction, covers_a_bone_twice};
use super::fitting::FULL_FIT_STEPS;
use super::local_moves::MIRROR_LENGTH_TOLERANCE;
use super::mirror_image::{chain_image, mirrored};
use super::row_shift::judge_from_start;
use super::solver::{ChainFit, Solver};
use crate::kinematics::ForwardKinematics;
use crate::math::Quat;
use nalgebra::Unit;
use std::f64::consts::PI;

/// A swap of limbs whose quick judge scores within this factor of the fit is judged again
/// from the start pose (on the tuning half, retrying every swap gained one case at a
/// quarter more time on mrfixit).
const SWAP_FROM_START_WITHIN: f64 = 1.3;

/// Swap the chains of two strokes on mirror-image limbs when that explains them better.
pub(super) fn swap_mirror_limbs(solver: &mut Solver, fit: &mut ChainFit) -> bool {
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
            // Judged from the current pose first. On a skeleton that names its sides, a swap
            // whose quick judge came near is judged again with both limbs back at their start
            // pose (two limbs crossing over each other to trade places stop half way), then
            // with the strokes below them carried across.
            if solver.accept(trial.clone(), fit) {
                improved = true;
                continue;
            }
            if solver.bone_mirrors.is_none()
                || solver.last_judged > SWAP_FROM_START_WITHIN * fit.score
            {
                continue;
            }
            if judge_from_start(solver, &trial, fit) {
                improved = true;
                continue;
            }
            let carried = solver.bone_mirrors.as_ref().and_then(|mirrors| {
                carried_across(
                    &trial,
                    [&cs, &ct],
                    mirrors,
                    &solver.setup.model.next_bones,
                    |u, c| solver.setup.stroke_may_cover(u, c),
                )
            });
            if let Some(carried) = carried {
                improved |=
                    solver.accept(carried.clone(), fit) || judge_from_start(solver, &carried, fit);
            }
        }
    }
    improved
}

/// Move a stroke to the mirror image of its limb when no stroke covers a bone of that image,
/// the strokes on the bones below the limb (a hand's) carried across with it: an arm that
/// reached across the chest for the other arm's stroke gives it back, with its hand's.
/// Judged from the current pose, then with the limbs back at their start pose.
pub(super) fn move_to_free_mirror_limbs(solver: &mut Solver, fit: &mut ChainFit) -> bool {
    let Some(mirrors) = solver.bone_mirrors.clone() else {
        return false;
    };
    let mut improved = false;
    for s in 0..fit.assignment.len() {
        let Some((chain, reversed)) = fit.assignment[s].clone() else {
            continue;
        };
        let Some(image) = chain_image(&chain, &mirrors) else {
            continue;
        };
        // A chain on the middle (a spine) is its own image.
        if image.iter().any(|b| chain.contains(b)) || !solver.setup.stroke_may_cover(s, &image) {
            continue;
        }
        let taken = solver.bones_taken(&fit.assignment, None);
        if image.iter().any(|&b| taken[b]) {
            continue;
        }
        let mut trial = fit.assignment.clone();
        // The image runs the same way along its limb (where it is now says nothing).
        trial[s] = Some((image.clone(), reversed));
        let carried = carried_across(
            &trial,
            [&chain, &image],
            &mirrors,
            &solver.setup.model.next_bones,
            |u, c| solver.setup.stroke_may_cover(u, c),
        )
        .unwrap_or(trial);
        if solver.accept(carried.clone(), fit) || judge_from_start(solver, &carried, fit) {
            improved = true;
        }
    }
    improved
}

/// `swapped` (two strokes traded between the mirror-image `limbs`) with every stroke on the
/// bones below either limb moved to its mirror image as well (`mirrors`: one
/// entry per bone; `next_bones`: each bone's continuations; `may_cover(stroke, chain)`: a
/// stroke pinned to bones goes only where it may): the hand's strokes go with the arm.
/// `None` when no stroke lies below them, a bone has no mirror or an image would cover a
/// bone twice.
fn carried_across(
    swapped: &[Assignment],
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
        // The traded strokes lie on the limbs themselves, which are not below them.
        if !chain.iter().all(|&b| below[b]) {
            continue;
        }
        let image = chain_image(chain, mirrors)?;
        if !may_cover(u, &image) {
            return None;
        }
        *a = Some((image, *reversed));
        moved = true;
    }
    (moved && !covers_a_bone_twice(&carried, mirrors.len())).then_some(carried)
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

/// Move a stroke to the mirror-image limb of its chain when one shorter stroke holds part
/// of that limb, and set that one aside: a stroke drawn on the limb that is not there takes
/// the other side's, and a stray or a fragment takes a piece of the limb it left.
pub(super) fn take_mirror_limbs_held_in_part(solver: &mut Solver, fit: &mut ChainFit) -> bool {
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

/// Turn the body round at a fork (a joint that mirror-image limbs branch from: a chest, a
/// pelvis): every stroke on the bones below it moved to its mirror image, the fork turned
/// half about the bone that leads to it, judged from the start pose. A chest turned round
/// on a spine trades its arms, and its hands and ears with them, which no swap of one pair
/// explains better.
pub(super) fn turn_round_at_forks(solver: &mut Solver, fit: &mut ChainFit) -> bool {
    let Some(mirrors) = solver.bone_mirrors.clone() else {
        return false;
    };
    let mut improved = false;
    for fork in forks(&solver.setup.model.bones, &mirrors) {
        if !solver.setup.movable[fork] {
            continue;
        }
        let skeleton = solver.setup.skeleton;
        let bones = &solver.setup.model.bones;
        let below: Vec<bool> = (bones.iter())
            .map(|b| skeleton.is_ancestor_or_self(fork, b.joint))
            .collect();
        // Only a stroke on the middle below the fork (a neck, a head) shows which way it
        // faces: limbs alone fit a body turned round at the fork as well.
        let middle_drawn =
            fit.assignment.iter().flatten().any(|(c, _)| {
                c.iter().all(|&b| below[b]) && c.iter().any(|&b| mirrors[b] == Some(b))
            });
        if !middle_drawn {
            continue;
        }
        let Some(trial) = mirrored(&fit.assignment, &below, &mirrors, |u, c| {
            solver.setup.stroke_may_cover(u, c)
        }) else {
            continue;
        };
        let fk = ForwardKinematics::new(skeleton, &solver.fitter.pose);
        let Some(parent) = fk.parent(fork) else {
            continue;
        };
        // In the fork's own frame: its rotation turns by a rotation applied on the right.
        let axis = fk.frame_linear_inv(fork) * (fk.position(fork) - fk.position(parent));
        let Some(axis) = Unit::try_new(axis, f64::MIN_POSITIVE) else {
            continue;
        };
        let saved = solver.fitter.pose.clone();
        solver.fitter.pose.local[fork].rotation *= Quat::from_axis_angle(&axis, PI);
        if judge_from_start(solver, &trial, fit) {
            improved = true;
        } else {
            solver.fitter.pose = saved;
        }
    }
    improved
}

/// The joints that a bone and its mirror image both start from (`mirrors`: one entry per
/// bone), in order.
fn forks(bones: &[Bone], mirrors: &[Option<usize>]) -> Vec<usize> {
    let mut forks: Vec<usize> = (bones.iter().zip(mirrors))
        .filter(|(bone, m)| m.is_some_and(|m| bones[m].joint == bone.joint && bones[m] != **bone))
        .map(|(bone, _)| bone.joint)
        .collect();
    forks.sort_unstable();
    forks.dedup();
    forks
}

#[cfg(test)]
mod tests {
    use super::*;

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
        let carry = |assignment: &[Assignment], may_cover: &dyn Fn(usize, &[usize]) -> bool| {
            carried_across(
                assignment,
                [&left, &right],
                &mirrors,
                &next_bones,
                may_cover,
            )
        };
        let everywhere = |_: usize, _: &[usize]| true;
        let carried = carry(&swapped, &everywhere).expect("a stroke lies below the arms");
        assert_eq!(carried[2], Some((vec![4, 5], true)));
        assert_eq!(carried[..2], swapped[..2]);
        assert_eq!(carried[3..], swapped[3..]);
        // Nothing below the arms: nothing to carry.
        let bare = [swapped[0].clone(), swapped[1].clone(), None];
        assert!(carry(&bare, &everywhere).is_none());
        // A pinned stroke that may not go across stops the move.
        let pinned = |u: usize, c: &[usize]| u != 2 || c.contains(&1);
        assert!(carry(&swapped, &pinned).is_none());
    }

    #[test]
    fn a_body_turned_round_at_its_chest_mirrors_every_stroke_below() {
        let bone = |joint: usize, child: usize| Bone {
            joint,
            child,
            length: 1.0,
            tip_translates: false,
        };
        // Joints: 0 pelvis, 1 chest, 2 left arm, 3 right arm, 4 head. Bones: 0 spine (0-1),
        // 1 left arm (1-2), 2 right arm (1-3), 3 neck (1-4).
        let bones = [bone(0, 1), bone(1, 2), bone(1, 3), bone(1, 4)];
        let mirrors = [Some(0), Some(2), Some(1), Some(3)];
        assert_eq!(forks(&bones, &mirrors), vec![1]);
        let below = [false, true, true, true];
        let assignment: Vec<Assignment> = vec![
            Some((vec![1], false)),
            Some((vec![3], true)),
            Some((vec![0], false)),
            None,
        ];
        let everywhere = |_: usize, _: &[usize]| true;
        let turned = mirrored(&assignment, &below, &mirrors, everywhere).expect("an arm moves");
        assert_eq!(turned[0], Some((vec![2], false)));
        assert_eq!(turned[1..], assignment[1..]);
        // Below the pelvis, the spine's stroke keeps its chain (its own mirror image).
        let everything = [true; 4];
        let turned = mirrored(&assignment, &everything, &mirrors, everywhere).expect("moves");
        assert_eq!(turned[2], assignment[2]);
        // Nothing but the middle drawn: nothing to turn.
        assert!(mirrored(&assignment[1..], &below, &mirrors, everywhere).is_none());
    }

    /// A chest with an arm and a hand on each side, named left and right, arms out along x.
    fn two_armed() -> crate::skeleton::Skeleton {
        use crate::skeleton::{Joint, Skeleton};
        use crate::{Trs, Vector3};
        let at = |x: f64, y: f64| Trs::from_translation(Vector3::new(x, y, 0.0));
        let joints = vec![
            Joint::new("hips", None, Trs::default()),
            Joint::new("chest", Some(0), at(0.0, 1.0)),
            Joint::new("head", Some(1), at(0.0, 0.4)),
            Joint::new("shoulder_left", Some(1), at(0.15, 0.0)),
            Joint::new("elbow_left", Some(3), at(0.3, 0.0)),
            Joint::new("wrist_left", Some(4), at(0.3, 0.0)),
            Joint::new("finger_left", Some(5), at(0.12, 0.0)),
            Joint::new("shoulder_right", Some(1), at(-0.15, 0.0)),
            Joint::new("elbow_right", Some(7), at(-0.3, 0.0)),
            Joint::new("wrist_right", Some(8), at(-0.3, 0.0)),
            Joint::new("finger_right", Some(9), at(-0.12, 0.0)),
        ];
        Skeleton::new(joints).expect("valid")
    }

    /// `n` points from `a` to `b`.
    fn drawn(a: [f64; 3], b: [f64; 3], n: usize) -> crate::Stroke {
        let (a, b) = (crate::Point3::from(a), crate::Point3::from(b));
        crate::Stroke {
            points: (0..n)
                .map(|i| a + (b - a) * (i as f64 / (n - 1) as f64))
                .collect(),
            bones: None,
        }
    }

    #[test]
    fn an_arm_that_took_the_other_arms_stroke_gives_it_back_with_the_hands_stroke() {
        use super::super::setup::Setup;
        use crate::interrupt::Interrupt;
        use crate::pose::{PoseOptions, PoseProblem};
        let skeleton = two_armed();
        let start = skeleton.rest_pose();
        // The right arm hangs down, its hand below it, and the head is drawn where it is.
        let strokes = vec![
            drawn([-0.15, 1.0, 0.0], [-0.15, 0.4, 0.0], 40),
            drawn([-0.15, 0.4, 0.0], [-0.15, 0.28, 0.0], 10),
            drawn([0.0, 1.0, 0.0], [0.0, 1.4, 0.0], 20),
        ];
        let problem = PoseProblem {
            skeleton: &skeleton,
            start: &start,
            strokes: &strokes,
            movable: None,
            height: 1.4,
        };
        let options = PoseOptions::default();
        let interrupt = Interrupt::never();
        let setup = Setup::new(&problem, &options, &interrupt).expect("a setup");
        let mut solver = Solver::new(setup);
        let bones = solver.setup.model.bones.clone();
        let named = |tip: &str| {
            let j = skeleton.find(tip).expect("a joint");
            bones.iter().position(|b| b.child == j).expect("a bone")
        };
        let (left_arm, left_hand) = (
            vec![named("elbow_left"), named("wrist_left")],
            vec![named("finger_left")],
        );
        let (right_arm, right_hand) = (
            vec![named("elbow_right"), named("wrist_right")],
            vec![named("finger_right")],
        );
        // The left arm reached across the chest for the right arm's stroke, its hand with it.
        let assignment: Vec<Assignment> = vec![
            Some((left_arm, false)),
            Some((left_hand, false)),
            Some((vec![named("head")], false)),
        ];
        let layout = solver
            .fitter
            .keep_unexplained_at_start(&solver.setup, &assignment);
        let setup = std::sync::Arc::clone(&solver.setup);
        solver
            .fitter
            .fit_arclength(&setup, &layout, &assignment, FULL_FIT_STEPS);
        let mut fit = ChainFit {
            score: solver.score(&assignment, &layout),
            pose: solver.fitter.pose.clone(),
            assignment,
            layout,
            by_shape: true,
        };
        assert!(move_to_free_mirror_limbs(&mut solver, &mut fit));
        assert_eq!(fit.assignment[0], Some((right_arm, false)));
        assert_eq!(fit.assignment[1], Some((right_hand, false)));
        // Nothing is left to move back.
        assert!(!move_to_free_mirror_limbs(&mut solver, &mut fit));
    }
}
