//! Hostile posing problems: extreme sizes and counts must give a pose or a clear error
//! quickly and in bounded memory, never an abort or a hang. Each family is generated here;
//! the bounds (seconds) are generous hang detectors, not speed claims (speed lives in the
//! benches).

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use rigfit_core::pose::{
    MAX_POSE_JOINTS, MAX_STROKE_POINTS, MAX_STROKES, PoseError, PoseOptions, PoseProblem,
    solve_pose, solve_pose_interruptible,
};
use rigfit_core::{Interrupt, Joint, Point3, Pose, Skeleton, Stroke, Trs, Vector3};

/// The bound every hostile case must finish within.
const HANG: Duration = Duration::from_secs(5);

fn solve_timed(
    skeleton: &Skeleton,
    start: &Pose,
    strokes: &[Stroke],
    height: f64,
) -> (Result<Vec<Vec<usize>>, PoseError>, Duration) {
    let problem = PoseProblem {
        skeleton,
        start,
        strokes,
        movable: None,
        height,
    };
    let began = Instant::now();
    let result = solve_pose(&problem, &PoseOptions::default()).map(|r| {
        assert!(
            r.pose
                .local
                .iter()
                .all(|t| t.rotation.coords.iter().all(|v| v.is_finite())),
            "the pose stays finite"
        );
        r.stroke_bones
    });
    (result, began.elapsed())
}

/// A chain of `n` joints going up in steps of `step`.
fn chain(n: usize, step: f64) -> Skeleton {
    let joints = (0..n)
        .map(|i| {
            let offset = if i == 0 {
                Vector3::zeros()
            } else {
                Vector3::new(0.0, step, 0.0)
            };
            Joint::new(
                format!("j{i}"),
                i.checked_sub(1),
                Trs::from_translation(offset),
            )
        })
        .collect();
    let mut s = Skeleton::new(joints).expect("a chain is a tree");
    s.set_default_dofs();
    s
}

/// A root with `n` children on a circle of radius 1.
fn star(n: usize) -> Skeleton {
    let mut joints = vec![Joint::new("root", None, Trs::default())];
    for i in 0..n {
        let a = i as f64 / n as f64 * std::f64::consts::TAU;
        joints.push(Joint::new(
            format!("leaf{i}"),
            Some(0),
            Trs::from_translation(Vector3::new(a.cos(), a.sin(), 0.0)),
        ));
    }
    let mut s = Skeleton::new(joints).expect("a star is a tree");
    s.set_default_dofs();
    s
}

fn line(from: Point3, to: Point3, points: usize) -> Stroke {
    Stroke {
        points: (0..points)
            .map(|i| from + (to - from) * (i as f64 / (points - 1) as f64))
            .collect(),
        bones: None,
    }
}

#[test]
fn deep_chains_pose_in_bounded_time() {
    for n in [1_000, 10_000, MAX_POSE_JOINTS] {
        let skeleton = chain(n, 1.0 / n as f64);
        let start = skeleton.rest_pose();
        // The top tenth of the chain drawn bent sideways.
        let strokes = [line(
            Point3::new(0.0, 0.9, 0.0),
            Point3::new(0.1, 1.0, 0.0),
            50,
        )];
        let (result, took) = solve_timed(&skeleton, &start, &strokes, 1.0);
        assert!(result.is_ok(), "{n} joints: {result:?}");
        eprintln!("{n}-joint chain: {took:?}");
        assert!(took < HANG, "{n}-joint chain took {took:?}");
    }
}

#[test]
fn wide_stars_pose_in_bounded_time() {
    for n in [1_000, MAX_POSE_JOINTS - 1] {
        let skeleton = star(n);
        let start = skeleton.rest_pose();
        let strokes = [line(Point3::origin(), Point3::new(0.0, 0.0, 1.0), 20)];
        let (result, took) = solve_timed(&skeleton, &start, &strokes, 2.0);
        assert!(result.is_ok(), "{n} leaves: {result:?}");
        eprintln!("{n}-leaf star: {took:?}");
        assert!(took < HANG, "{n}-leaf star took {took:?}");
    }
}

#[test]
fn rigs_over_the_joint_limit_are_refused() {
    let skeleton = chain(MAX_POSE_JOINTS + 1, 1e-3);
    let start = skeleton.rest_pose();
    let strokes = [line(Point3::origin(), Point3::new(0.0, 1.0, 0.0), 5)];
    let (result, took) = solve_timed(&skeleton, &start, &strokes, 1.0);
    assert!(
        matches!(result, Err(PoseError::TooManyJoints { .. })),
        "{result:?}"
    );
    assert!(took < HANG);
}

#[test]
fn many_strokes_pose_in_bounded_time() {
    let rig = rigfit_core::humanoid::humanoid();
    let height = rig.height();
    let joints = rig.skeleton.joint_positions(&rig.pose);
    // Strokes along random pairs of joints, plus clutter: the most the solver takes.
    let mut state = 12345u64;
    let mut next = || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (state >> 33) as usize
    };
    let strokes: Vec<Stroke> = (0..MAX_STROKES)
        .map(|_| {
            let a = joints[next() % joints.len()];
            let b = joints[next() % joints.len()] + Vector3::new(0.0, 0.01 * height, 0.0);
            line(a, b, 10)
        })
        .collect();
    let (result, took) = solve_timed(&rig.skeleton, &rig.pose, &strokes, height);
    assert!(result.is_ok(), "{result:?}");
    eprintln!("{} strokes: {took:?}", strokes.len());
    assert!(took < HANG, "{} strokes took {took:?}", strokes.len());

    let too_many = vec![strokes[0].clone(); MAX_STROKES + 1];
    let (result, _) = solve_timed(&rig.skeleton, &rig.pose, &too_many, height);
    assert!(
        matches!(result, Err(PoseError::TooManyStrokes { .. })),
        "{result:?}"
    );
}

#[test]
fn stroke_points_are_bounded() {
    let rig = rigfit_core::humanoid::humanoid();
    let height = rig.height();
    // A stroke zig-zagging across the body: huge arclength from a bounded box.
    let zigzag = Stroke {
        points: (0..MAX_STROKE_POINTS)
            .map(|i| {
                let x = if i % 2 == 0 { -0.5 } else { 0.5 } * height;
                Point3::new(x, height * (i as f64 / MAX_STROKE_POINTS as f64), 0.0)
            })
            .collect(),
        bones: None,
    };
    let (result, took) = solve_timed(
        &rig.skeleton,
        &rig.pose,
        std::slice::from_ref(&zigzag),
        height,
    );
    assert!(result.is_ok(), "{result:?}");
    eprintln!("a {MAX_STROKE_POINTS}-point stroke: {took:?}");
    assert!(
        took < HANG,
        "a {MAX_STROKE_POINTS}-point stroke took {took:?}"
    );

    let mut over = zigzag;
    over.points.push(Point3::origin());
    let (result, _) = solve_timed(&rig.skeleton, &rig.pose, &[over], height);
    assert!(
        matches!(result, Err(PoseError::TooManyPoints { .. })),
        "{result:?}"
    );
}

#[test]
fn extreme_bone_lengths_and_heights_stay_bounded() {
    let rig = rigfit_core::humanoid::humanoid();
    let height = rig.height();
    let hand = rig
        .skeleton
        .find("LeftHand")
        .expect("the humanoid has a left hand");
    let shoulder = rig
        .skeleton
        .find("LeftArm")
        .expect("the humanoid has a left arm");
    let positions = rig.skeleton.joint_positions(&rig.pose);
    let stroke = line(positions[shoulder], positions[hand], 30);
    for (far, scale) in [(1e9, 1.0), (1e300, 1.0), (1.0, 1e-7), (1.0, 1e7)] {
        // One joint moved far away (a node translation of 1e9 in a request), and the whole
        // rig scaled to odd units.
        let mut pose = rig.pose.clone();
        pose.local[hand].translation *= far;
        for t in &mut pose.local {
            t.translation *= scale;
        }
        let strokes = [Stroke {
            points: stroke.points.iter().map(|p| p * scale).collect(),
            bones: None,
        }];
        let (result, took) = solve_timed(&rig.skeleton, &pose, &strokes, height * scale);
        // A pose or a clear error, quickly: never an unbounded allocation.
        if let Err(e) = &result {
            assert!(!e.to_string().is_empty());
        }
        assert!(took < HANG, "far {far}, scale {scale}: {took:?}");
    }
}

#[test]
fn interrupts_stop_a_solve() {
    let rig = rigfit_core::humanoid::humanoid();
    let height = rig.height();
    let joints = rig.skeleton.joint_positions(&rig.pose);
    let strokes: Vec<Stroke> = (0..200)
        .map(|i| {
            line(
                joints[i % joints.len()],
                joints[(i * 7 + 3) % joints.len()],
                40,
            )
        })
        .collect();
    let problem = PoseProblem {
        skeleton: &rig.skeleton,
        start: &rig.pose,
        strokes: &strokes,
        movable: None,
        height,
    };
    // A deadline already passed: stopped at once.
    let past = Interrupt::never().with_deadline(Instant::now());
    let result = solve_pose_interruptible(&problem, &PoseOptions::paper(), &past);
    assert!(matches!(result, Err(PoseError::Interrupted)), "{result:?}");

    // A flag raised from another thread while the solve runs.
    let flag = Arc::new(AtomicBool::new(false));
    let raiser = {
        let flag = flag.clone();
        std::thread::spawn(move || {
            std::thread::sleep(Duration::from_millis(20));
            flag.store(true, Ordering::Relaxed);
            Instant::now()
        })
    };
    let interrupt = Interrupt::never().with_flag(flag);
    let result = solve_pose_interruptible(&problem, &PoseOptions::paper(), &interrupt);
    let stopped = Instant::now();
    let raised = raiser.join().expect("the raising thread ends");
    assert!(matches!(result, Err(PoseError::Interrupted)), "{result:?}");
    assert!(
        stopped.duration_since(raised) < Duration::from_secs(1),
        "stopped {:?} after the flag",
        stopped.duration_since(raised)
    );
}
