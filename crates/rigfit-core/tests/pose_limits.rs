//! Joint limits choose between poses that explain the strokes alike, and never hold a limb
//! back from its stroke.

use rigfit_core::pose::{PoseOptions, PoseProblem, solve_pose};
use rigfit_core::{Joint, JointDof, JointLimits, Point3, Skeleton, Stroke, Trs, Vector3};

/// A fixed hub with two mirror-image arms of length 1 along +x and -x.
fn two_arms(left: Option<JointLimits>, right: Option<JointLimits>) -> Skeleton {
    let at = |x: f64| Trs::from_translation(Vector3::new(x, 0.0, 0.0));
    let mut joints = vec![
        Joint::new("hub", None, Trs::default()),
        Joint::new("left", Some(0), Trs::default()),
        Joint::new("left_tip", Some(1), at(1.0)),
        Joint::new("right", Some(0), Trs::default()),
        Joint::new("right_tip", Some(3), at(-1.0)),
    ];
    joints[0].dof = JointDof::Fixed;
    joints[1].limits = left;
    joints[3].limits = right;
    for tip in [2, 4] {
        joints[tip].dof = JointDof::Fixed;
    }
    Skeleton::new(joints).expect("valid")
}

/// Limits that keep an arm near its rest direction.
const NARROW: JointLimits = JointLimits {
    min: Vector3::new(-0.2, -0.2, -0.2),
    max: Vector3::new(0.2, 0.2, 0.2),
};

/// Limits that let an arm turn by up to 2 radians one way about z (the right arm, along -x,
/// turning up).
const DOWN: JointLimits = JointLimits {
    min: Vector3::new(-0.2, -0.2, -2.0),
    max: Vector3::new(0.2, 0.2, 0.2),
};

/// The limb a stroke straight up from the hub (`pinned` to those bones, if any) is matched
/// to, and where its tip ends.
fn arm_raised(skeleton: &Skeleton, pinned: Option<&str>) -> (String, Point3) {
    let stroke = Stroke {
        points: (0..=40)
            .map(|i| Point3::new(0.0, i as f64 / 40.0, 0.0))
            .collect(),
        bones: pinned.map(|bone| vec![bone.to_string()]),
    };
    let start = skeleton.rest_pose();
    let problem = PoseProblem {
        skeleton,
        start: &start,
        strokes: std::slice::from_ref(&stroke),
        movable: None,
        height: 1.0,
    };
    let result = solve_pose(&problem, &PoseOptions::default()).expect("poses");
    let bone = result.stroke_bones[0]
        .first()
        .map(|&j| skeleton.joint(j).name.clone())
        .unwrap_or_default();
    let tip = skeleton
        .find(&format!("{bone}_tip"))
        .expect("a matched arm");
    (bone, skeleton.joint_positions(&result.pose)[tip])
}

#[test]
fn limits_pick_the_arm_that_may_turn_there() {
    // Either arm reaches straight up by a quarter turn about z (left +, right -).
    let up = JointLimits {
        min: Vector3::new(-0.2, -0.2, -0.2),
        max: Vector3::new(0.2, 0.2, 2.0),
    };
    let (bone, tip) = arm_raised(&two_arms(Some(NARROW), Some(DOWN)), None);
    assert_eq!(bone, "right", "the left arm may not turn up");
    assert!(
        (tip - Point3::new(0.0, 1.0, 0.0)).norm() < 0.03,
        "tip {tip}"
    );
    let (bone, _) = arm_raised(&two_arms(Some(up), Some(NARROW)), None);
    assert_eq!(bone, "left", "the right arm may not turn up");
}

#[test]
fn limits_never_hold_a_limb_back() {
    // Both arms limited away from the stroke: one still follows it all the way.
    let (_, tip) = arm_raised(&two_arms(Some(NARROW), Some(NARROW)), None);
    assert!(
        (tip - Point3::new(0.0, 1.0, 0.0)).norm() < 0.03,
        "tip {tip}"
    );
}

#[test]
fn a_pinned_stroke_stays_on_its_bones_when_its_mirror_image_fits_better() {
    // The left arm may not turn up, the right may: unpinned, the stroke up goes right (the
    // test above); pinned to the left arm, it stays there however the mirror image scores.
    let (bone, _) = arm_raised(&two_arms(Some(NARROW), Some(DOWN)), Some("left"));
    assert_eq!(bone, "left");
}
