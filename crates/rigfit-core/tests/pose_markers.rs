//! Posing joints that translate: markers hanging from one hub, each pinned stroke drawn
//! from the hub to where its marker should go.

use rigfit_core::pose::{PoseError, PoseOptions, PoseProblem, solve_pose};
use rigfit_core::{Joint, JointDof, Point3, Skeleton, Stroke, Trs, Vector3};

fn markers() -> Skeleton {
    let mut joints = vec![Joint::new("hub", None, Trs::default())];
    for (name, at) in [
        ("a", Vector3::new(0.0, 1.0, 0.0)),
        ("b", Vector3::new(0.5, 0.5, 0.0)),
        ("c", Vector3::new(-0.5, 0.6, 0.2)),
    ] {
        joints.push(Joint::new(name, Some(0), Trs::from_translation(at)));
    }
    for j in &mut joints {
        j.dof = JointDof::Free;
    }
    Skeleton::new(joints).expect("valid")
}

fn line(to: Point3, pinned: Option<&str>) -> Stroke {
    Stroke {
        points: (0..=20)
            .map(|i| Point3::from(to.coords * (i as f64 / 20.0)))
            .collect(),
        bones: pinned.map(|b| vec![b.to_string()]),
    }
}

#[test]
fn pinned_strokes_move_markers_to_their_ends() {
    let skeleton = markers();
    let start = skeleton.rest_pose();
    let goals = [
        ("a", Point3::new(0.3, 0.9, 0.2)),
        ("b", Point3::new(0.7, 0.2, -0.1)),
        ("c", Point3::new(-0.4, 0.9, 0.0)),
    ];
    let strokes: Vec<Stroke> = goals.iter().map(|(n, p)| line(*p, Some(n))).collect();
    let problem = PoseProblem {
        skeleton: &skeleton,
        start: &start,
        strokes: &strokes,
        movable: None,
        height: 1.0,
    };
    let result = solve_pose(&problem, &PoseOptions::default()).expect("poses");
    let solved = skeleton.joint_positions(&result.pose);
    for (name, goal) in goals {
        let j = skeleton.find(name).expect("marker");
        let miss = (solved[j] - goal).norm();
        assert!(miss < 0.02, "{name} missed its stroke's end by {miss}");
    }
    // The hub stays.
    assert!(solved[0].coords.norm() < 1e-9);
}

#[test]
fn markers_without_a_pinned_stroke_are_refused() {
    let skeleton = markers();
    let start = skeleton.rest_pose();
    let strokes = vec![line(Point3::new(0.3, 0.9, 0.2), None)];
    let problem = PoseProblem {
        skeleton: &skeleton,
        start: &start,
        strokes: &strokes,
        movable: None,
        height: 1.0,
    };
    let error = solve_pose(&problem, &PoseOptions::default()).expect_err("refused");
    assert!(
        matches!(error, PoseError::UnpinnedMarkers { .. }),
        "{error}"
    );
}

#[test]
fn a_noisy_stroke_places_its_marker_better_than_its_last_point_does() {
    let skeleton = markers();
    let start = skeleton.rest_pose();
    let goal = Point3::new(0.3, 0.9, 0.2);
    // A jitter of 0.03 (3% of the height) across the stroke, its end point off by the most.
    let mut stroke = line(goal, Some("a"));
    for (i, p) in stroke.points.iter_mut().enumerate() {
        let sign = if i % 2 == 0 { 1.0 } else { -1.0 };
        *p += Vector3::new(0.03 * sign, -0.03 * sign, 0.0);
    }
    let end_miss = (stroke.points.last().expect("points") - goal).norm();
    let problem = PoseProblem {
        skeleton: &skeleton,
        start: &start,
        strokes: &[stroke],
        movable: None,
        height: 1.0,
    };
    let result = solve_pose(&problem, &PoseOptions::default()).expect("poses");
    let j = skeleton.find("a").expect("marker");
    let miss = (skeleton.joint_positions(&result.pose)[j] - goal).norm();
    assert!(
        miss < 0.5 * end_miss,
        "missed by {miss}, the stroke's last point by {end_miss}"
    );
}
