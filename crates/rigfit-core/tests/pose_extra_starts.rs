//! Extra starts (`PoseOptions::extra_starts`): tried beside the solver's own, and ignored
//! when they are not poses of the skeleton.

use rigfit_core::pose::{PoseOptions, PoseProblem, solve_pose};
use rigfit_core::{Joint, JointDof, Point3, Pose, Quat, Skeleton, Stroke, Trs, Vector3};

/// A fixed hub with one arm of length 1 along +x.
fn one_arm() -> Skeleton {
    let mut joints = vec![
        Joint::new("hub", None, Trs::default()),
        Joint::new("arm", Some(0), Trs::default()),
        Joint::new(
            "arm_tip",
            Some(1),
            Trs::from_translation(Vector3::new(1.0, 0.0, 0.0)),
        ),
    ];
    joints[0].dof = JointDof::Fixed;
    joints[2].dof = JointDof::Fixed;
    Skeleton::new(joints).expect("valid")
}

/// A stroke from the hub straight up, one unit long.
fn stroke_up() -> Stroke {
    Stroke {
        points: (0..=40)
            .map(|i| Point3::new(0.0, i as f64 / 40.0, 0.0))
            .collect(),
        bones: None,
    }
}

fn solve(skeleton: &Skeleton, extra_starts: Vec<Pose>) -> Pose {
    let start = skeleton.rest_pose();
    let stroke = stroke_up();
    let problem = PoseProblem {
        skeleton,
        start: &start,
        strokes: std::slice::from_ref(&stroke),
        movable: None,
        height: 1.0,
    };
    let options = PoseOptions {
        extra_starts,
        ..PoseOptions::default()
    };
    solve_pose(&problem, &options).expect("poses").pose
}

#[test]
fn a_start_of_another_skeleton_is_ignored() {
    let skeleton = one_arm();
    let alone = solve(&skeleton, Vec::new());
    let foreign = Pose {
        local: vec![Trs::default()],
    };
    assert_eq!(solve(&skeleton, vec![foreign]), alone);
}

#[test]
fn the_answer_offered_as_a_start_is_kept() {
    let skeleton = one_arm();
    let mut raised = skeleton.rest_pose();
    raised.local[1].rotation =
        Quat::from_axis_angle(&Vector3::z_axis(), std::f64::consts::FRAC_PI_2);
    let posed = solve(&skeleton, vec![raised]);
    let tip = skeleton.joint_positions(&posed)[2];
    assert!(
        (tip - Point3::new(0.0, 1.0, 0.0)).norm() < 0.03,
        "tip {tip}"
    );
}
