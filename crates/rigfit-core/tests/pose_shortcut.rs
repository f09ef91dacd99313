//! The shortcut of a solve (`PoseOptions::search_every_start`): when the character where it
//! stands explains the strokes convincingly, the rigid placements and turns are not
//! searched; otherwise the search is the whole one.

use rigfit_core::humanoid::humanoid;
use rigfit_core::pose::sketch::CaseOptions;
use rigfit_core::pose::{PoseOptions, PoseProblem, PoseResult, solve_pose};
use rigfit_core::{Pose, Quat, Rig, Vector3};
use rigfit_testkit::pose_suites::strokes_of_size;

/// Poses `rig` from 6 limb strokes drawn on `truth`, searching every start or not.
fn solve(rig: &Rig, truth: &Pose, search_every_start: bool) -> PoseResult {
    let options = CaseOptions {
        min_chain_length: 0.03,
        ..Default::default()
    };
    let strokes = strokes_of_size(rig, truth, 6, 100, &options);
    let problem = PoseProblem {
        skeleton: &rig.skeleton,
        start: &rig.pose,
        strokes: &strokes,
        movable: None,
        height: rig.height(),
    };
    let options = PoseOptions {
        search_every_start,
        ..PoseOptions::default()
    };
    solve_pose(&problem, &options).expect("poses")
}

#[test]
fn strokes_near_the_character_are_posed_as_by_the_whole_search_with_less_work() {
    let rig = humanoid();
    let truth = rig.animations[0].sample(&rig.pose, 1.0);
    let (short, whole) = (solve(&rig, &truth, false), solve(&rig, &truth, true));
    assert!(
        short.iterations < whole.iterations,
        "the shortcut ran {} iterations, the whole search {}",
        short.iterations,
        whole.iterations
    );
    assert_eq!(short.stroke_bones, whole.stroke_bones);
    let (a, b) = (
        rig.skeleton.joint_positions(&short.pose),
        rig.skeleton.joint_positions(&whole.pose),
    );
    let apart = a
        .iter()
        .zip(&b)
        .map(|(p, q)| (p - q).norm())
        .fold(0.0, f64::max);
    assert!(apart < 0.01 * rig.height(), "{apart}");
}

#[test]
fn a_character_turned_about_is_searched_for_as_before() {
    let rig = humanoid();
    let mut truth = rig.animations[0].sample(&rig.pose, 1.0);
    let root = rig.skeleton.roots().next().expect("a root");
    let turn = Quat::from_axis_angle(&Vector3::y_axis(), std::f64::consts::PI);
    truth.local[root].rotation = turn * truth.local[root].rotation;
    let (short, whole) = (solve(&rig, &truth, false), solve(&rig, &truth, true));
    assert_eq!(short.pose, whole.pose);
    assert_eq!(short.iterations, whole.iterations);
}
