//! Tests of the subtree moments against dense point-by-point sums, and of the tree solver
//! and its dense fallback that take them.

use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};

use super::*;
use crate::engine::{
    ArticulatedNormalEquations, NormalEquations, SkeletonNormalEquations, TreeNormalEquations,
};
use crate::math::{Quat, Trs};
use crate::skeleton::{Joint, Pose, Skeleton};

fn random_vector(rng: &mut StdRng, size: f64) -> Vector3 {
    Vector3::new(
        rng.random_range(-size..size),
        rng.random_range(-size..size),
        rng.random_range(-size..size),
    )
}

fn random_rotation(rng: &mut StdRng) -> Quat {
    Quat::from_scaled_axis(random_vector(rng, 1.5))
}

/// A random tree with every kind of joint, two roots and a free joint below another;
/// scales are non-uniform one time in `uniform_odds`, else uniform or one.
fn random_skeleton(rng: &mut StdRng, joints: usize, uniform_odds: u32) -> Skeleton {
    let mut list = Vec::with_capacity(joints);
    for i in 0..joints {
        let parent = match i {
            0 => None,
            5 => None,
            _ => Some(rng.random_range(0..i)),
        };
        let rest = Trs {
            translation: random_vector(rng, 0.5),
            rotation: random_rotation(rng),
            scale: match rng.random_range(0..uniform_odds) {
                0 => Vector3::new(
                    rng.random_range(0.6..1.5),
                    rng.random_range(0.6..1.5),
                    rng.random_range(0.6..1.5),
                ),
                1 => Vector3::repeat(rng.random_range(0.6..1.5)),
                _ => Vector3::repeat(1.0),
            },
        };
        let mut joint = Joint::new(format!("j{i}"), parent, rest);
        joint.dof = match i {
            0 | 7 => JointDof::Free,
            _ => match rng.random_range(0..5) {
                0 => JointDof::Fixed,
                1 => JointDof::Hinge {
                    axis: random_vector(rng, 1.0),
                },
                _ => JointDof::Ball,
            },
        };
        list.push(joint);
    }
    Skeleton::new(list).expect("parents first")
}

fn random_pose(rng: &mut StdRng, skeleton: &Skeleton) -> Pose {
    let mut pose = skeleton.rest_pose();
    for local in &mut pose.local {
        local.rotation = random_rotation(rng);
    }
    pose
}

/// Max |a - b| over max |b|.
fn relative(a: &[f64], b: &[f64]) -> f64 {
    let scale = b.iter().fold(0.0f64, |m, x| m.max(x.abs())).max(1e-300);
    a.iter()
        .zip(b)
        .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()))
        / scale
}

#[test]
fn moments_match_the_dense_point_by_point_sums() {
    let mut rng = StdRng::seed_from_u64(7);
    for round in 0..12 {
        // Non-uniform scales everywhere, then now and then (frames are a mix of
        // conformal and not), then never (conformal frames only).
        let odds = [1, 8, u32::MAX][round % 3];
        let skeleton = random_skeleton(&mut rng, 16, odds);
        let pose = random_pose(&mut rng, &skeleton);
        let layout = if round % 4 < 2 {
            DofLayout::new(&skeleton)
        } else {
            let active: Vec<bool> = (0..skeleton.len()).map(|_| rng.random_bool(0.6)).collect();
            DofLayout::with_active(&skeleton, &active)
        };
        let fk = ForwardKinematics::new(&skeleton, &pose);
        let height = 1.7;
        let parent = |j: usize| skeleton.joint(j).parent;
        let mut dense = NormalEquations::new(layout.len());
        let mut via_moments = NormalEquations::new(layout.len());
        let mut tree = TreeNormalEquations::new(&layout, parent).expect("parents first");
        let mut articulated = ArticulatedNormalEquations::new();
        let mut chosen = SkeletonNormalEquations::new(&layout, parent);
        assert!(chosen.is_tree());
        chosen.clear();
        let mut moments = SubtreeMoments::new();
        moments.reset(skeleton.len());
        let mut cols = Vec::new();
        for _ in 0..80 {
            let joint = rng.random_range(0..skeleton.len());
            let p = fk.point(joint, &Point3::from(random_vector(&mut rng, 0.4)));
            let target = p + random_vector(&mut rng, 0.2);
            let w = rng.random_range(0.1..2.0);
            let r = (p - target) / height;
            cols.clear();
            fk.point_jacobian(&layout, joint, &p, |c, v| cols.push((c, v / height)));
            dense.add_point(&r, w, &cols);
            moments.add_point(&fk, joint, &p, &r, w);
        }
        let scale = 1.0 / height;
        moments
            .clone()
            .assemble(&fk, &layout, scale, &mut via_moments);
        moments.clone().assemble(&fk, &layout, scale, &mut tree);
        let conformal = moments
            .clone()
            .assemble_articulated(&fk, &layout, scale, &mut articulated);
        // Rotating frames below a non-uniform scale are not conformal.
        match odds {
            1 => assert!(!conformal, "round {round}"),
            u32::MAX => assert!(conformal, "round {round}"),
            _ => {}
        }
        chosen.assemble_points(&mut moments, &fk, scale);
        assert_eq!(chosen.is_articulated(), conformal);
        // The same scalar terms on every side.
        for (col, r) in [(0, 0.3), (layout.len() / 2, -0.2)] {
            if col < layout.len() {
                dense.add_scalar(r, 0.5, col, 1.0);
                via_moments.add_scalar(r, 0.5, col, 1.0);
                tree.add_scalar(r, 0.5, col, 1.0);
                if conformal {
                    articulated.add_scalar(r, 0.5, col, 1.0);
                }
                chosen.add_scalar(r, 0.5, col, 1.0);
            }
        }
        let expected = dense.jtj();
        let mut sides = vec![
            (
                via_moments.jtj(),
                via_moments.jtr.as_slice().to_vec(),
                via_moments.cost,
            ),
            (tree.jtj(), tree.jtr().to_vec(), tree.cost()),
            (chosen.jtj(), chosen.jtr(), chosen.cost()),
        ];
        if conformal {
            sides.push((
                articulated.jtj(),
                articulated.jtr().to_vec(),
                articulated.cost(),
            ));
        }
        for (jtj, jtr, cost) in &sides {
            let e = relative(jtj.as_slice(), expected.as_slice());
            assert!(e < 1e-9, "round {round}: J^T J off by {e}");
            let e = relative(jtr, dense.jtr.as_slice());
            assert!(e < 1e-9, "round {round}: J^T r off by {e}");
            assert!((cost - dense.cost).abs() <= 1e-12 * dense.cost);
        }
        for lambda in [0.0, 1e-3, 10.0] {
            let expected = dense.solve(lambda).expect("positive definite");
            let mut steps = vec![
                tree.solve(lambda).expect("positive definite").to_vec(),
                chosen.solve(lambda).expect("positive definite").to_vec(),
            ];
            if conformal {
                steps.push(
                    articulated
                        .solve(lambda)
                        .expect("positive definite")
                        .to_vec(),
                );
            }
            for got in steps {
                let e = relative(&got, expected.as_slice());
                assert!(e < 1e-7, "round {round}, lambda {lambda}: step off by {e}");
            }
        }
    }
}

#[test]
fn tree_solver_matches_dense_cholesky() {
    let mut rng = StdRng::seed_from_u64(3);
    let skeleton = random_skeleton(&mut rng, 20, 1);
    let layout = DofLayout::new(&skeleton);
    let n = layout.len();
    let mut tree =
        TreeNormalEquations::new(&layout, |j| skeleton.joint(j).parent).expect("parents first");
    let mut dense = NormalEquations::new(n);
    // Random structural entries, made diagonally dominant.
    for i in 0..n {
        for j in 0..=i {
            if tree.is_structural(i, j) && i != j {
                let v = rng.random_range(-1.0..1.0);
                tree.add_jtj(i, j, v);
                dense.add_jtj(i, j, v);
            }
        }
        let g = rng.random_range(-1.0..1.0);
        tree.add_jtr(i, g);
        NormalSink::add_jtr(&mut dense, i, g);
        tree.add_jtj(i, i, n as f64);
        dense.add_jtj(i, i, n as f64);
    }
    assert_eq!(tree.jtj(), dense.jtj());
    for lambda in [0.0, 0.1] {
        let expected = dense.solve(lambda).expect("positive definite");
        let got = tree.solve(lambda).expect("positive definite");
        assert!(relative(got, expected.as_slice()) < 1e-10);
    }
    // Not positive definite: both refuse.
    tree.add_jtj(n - 1, n - 1, -1e6);
    dense.add_jtj(n - 1, n - 1, -1e6);
    assert!(tree.solve(0.0).is_none() && dense.solve(0.0).is_none());
}

#[test]
fn layouts_out_of_parent_order_fall_back_to_dense() {
    let mut rng = StdRng::seed_from_u64(5);
    let skeleton = random_skeleton(&mut rng, 6, 1);
    let layout = DofLayout::new(&skeleton);
    // A made-up tree where joint 1 hangs below joint 4.
    let parent = |j: usize| if j == 1 { Some(4) } else { None };
    assert!(TreeNormalEquations::new(&layout, parent).is_none());
    let mut ne = SkeletonNormalEquations::new(&layout, parent);
    assert!(!ne.is_tree());
    // The dense fallback still takes the points' moments.
    ne.set_allow_articulated(false);
    ne.clear();
    let fk = ForwardKinematics::new(&skeleton, &random_pose(&mut rng, &skeleton));
    let mut dense = NormalEquations::new(layout.len());
    let mut moments = SubtreeMoments::new();
    moments.reset(skeleton.len());
    let mut cols = Vec::new();
    for _ in 0..30 {
        let joint = rng.random_range(0..skeleton.len());
        let p = fk.point(joint, &Point3::from(random_vector(&mut rng, 0.4)));
        let r = random_vector(&mut rng, 0.2);
        cols.clear();
        fk.point_jacobian(&layout, joint, &p, |c, v| cols.push((c, v)));
        dense.add_point(&r, 1.0, &cols);
        moments.add_point(&fk, joint, &p, &r, 1.0);
    }
    ne.assemble_points(&mut moments, &fk, 1.0);
    assert!(!ne.is_articulated());
    let e = relative(ne.jtj().as_slice(), dense.jtj().as_slice());
    assert!(e < 1e-9, "J^T J off by {e}");
    let expected = dense.solve(1e-3).expect("positive definite");
    let e = relative(
        ne.solve(1e-3).expect("positive definite"),
        expected.as_slice(),
    );
    assert!(e < 1e-9, "step off by {e}");
}
