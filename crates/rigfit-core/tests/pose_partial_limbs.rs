//! A user may draw only part of a limb (a forearm, a shin): the limb above it, undrawn,
//! follows to put the drawn part on its stroke, whatever else is drawn. (A rule that scored
//! a stroke on the end of a swung limb like a stray, tried in session 24 to set aside strays
//! taken by the end of a leg, failed the last two: BENCHMARKS.md.)

use rigfit_core::humanoid::humanoid;
use rigfit_core::pose::{PoseOptions, PoseProblem, solve_pose};
use rigfit_core::{Point3, Pose, Quat, Stroke, Vector3};

/// The built-in humanoid with its arms turned down and its elbows bent: the pose whose
/// forearms the strokes are drawn along.
fn target() -> (rigfit_core::Rig, Pose) {
    let rig = humanoid();
    let mut pose = rig.pose.clone();
    for (arm, forearm, side) in [
        ("LeftArm", "LeftForeArm", 1.0),
        ("RightArm", "RightForeArm", -1.0),
    ] {
        let turn = |axis: Vector3, angle: f64| Quat::from_scaled_axis(axis * angle);
        let (a, f) = (
            rig.skeleton.find(arm).expect("built-in joint"),
            rig.skeleton.find(forearm).expect("built-in joint"),
        );
        pose.local[a].rotation = turn(Vector3::z(), -side * 0.9);
        pose.local[f].rotation = turn(Vector3::y(), side * 1.0);
    }
    (rig, pose)
}

/// A stroke along the bone from joint `from` to joint `to` of `pose`.
fn along(rig: &rigfit_core::Rig, pose: &Pose, from: &str, to: &str) -> Stroke {
    let positions = rig.skeleton.joint_positions(pose);
    let (a, b) = (
        positions[rig.skeleton.find(from).expect("built-in joint")],
        positions[rig.skeleton.find(to).expect("built-in joint")],
    );
    Stroke {
        points: (0..=20)
            .map(|i| a + (b - a) * (i as f64 / 20.0))
            .collect::<Vec<Point3>>(),
        bones: None,
    }
}

/// How far (fraction of the height) the solved `joints` lie from the target's.
fn worst_error(rig: &rigfit_core::Rig, target: &Pose, strokes: &[Stroke], joints: &[&str]) -> f64 {
    let problem = PoseProblem {
        skeleton: &rig.skeleton,
        start: &rig.pose,
        strokes,
        movable: None,
        height: rig.height(),
    };
    let solved = solve_pose(&problem, &PoseOptions::default()).expect("a valid problem");
    let (now, truth) = (
        rig.skeleton.joint_positions(&solved.pose),
        rig.skeleton.joint_positions(target),
    );
    joints
        .iter()
        .map(|name| {
            let j = rig.skeleton.find(name).expect("built-in joint");
            (now[j] - truth[j]).norm() / rig.height()
        })
        .fold(0.0, f64::max)
}

#[test]
fn a_forearm_drawn_alone_far_from_it_brings_the_arm() {
    let (rig, target) = target();
    let strokes = [along(&rig, &target, "LeftForeArm", "LeftHand")];
    let error = worst_error(&rig, &target, &strokes, &["LeftForeArm", "LeftHand"]);
    assert!(
        error < 0.03,
        "forearm {:.1}% of the height off",
        100.0 * error
    );
}

#[test]
fn a_forearm_drawn_with_the_whole_other_arm_brings_its_arm() {
    let (rig, target) = target();
    let strokes = [
        along(&rig, &target, "LeftForeArm", "LeftHand"),
        along(&rig, &target, "RightShoulder", "RightArm"),
        along(&rig, &target, "RightArm", "RightForeArm"),
        along(&rig, &target, "RightForeArm", "RightHand"),
    ];
    let joined: Vec<Point3> = strokes[1..].iter().flat_map(|s| s.points.clone()).collect();
    let strokes = [
        strokes[0].clone(),
        // Pinned: by shape alone the bent arm's stroke passes for a leg's.
        Stroke {
            points: joined,
            bones: Some(
                ["RightShoulder", "RightArm", "RightForeArm"]
                    .map(String::from)
                    .to_vec(),
            ),
        },
    ];
    let error = worst_error(&rig, &target, &strokes, &["LeftForeArm", "LeftHand"]);
    assert!(
        error < 0.03,
        "forearm {:.1}% of the height off",
        100.0 * error
    );
}

#[test]
fn both_forearms_drawn_alone_bring_both_arms() {
    let (rig, target) = target();
    let strokes = [
        along(&rig, &target, "LeftForeArm", "LeftHand"),
        along(&rig, &target, "RightForeArm", "RightHand"),
    ];
    let joints = ["LeftForeArm", "LeftHand", "RightForeArm", "RightHand"];
    let error = worst_error(&rig, &target, &strokes, &joints);
    assert!(
        error < 0.03,
        "forearms {:.1}% of the height off",
        100.0 * error
    );
}
