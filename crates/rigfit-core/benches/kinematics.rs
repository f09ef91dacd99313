//! Forward kinematics and point Jacobians on a 55-joint rig (the size of a full body with
//! fingers): the inner loop of every skeleton solver.

use criterion::{Criterion, black_box, criterion_group, criterion_main};
use rigfit_core::{DofLayout, ForwardKinematics, Joint, Point3, Quat, Skeleton, Trs, Vector3};

/// A 55-joint tree: a 5-joint spine, and 5 limbs of 10 joints hanging off it.
fn rig55() -> Skeleton {
    let mut joints = vec![Joint::new("root", None, Trs::IDENTITY)];
    for i in 1..5 {
        joints.push(Joint::new(
            format!("spine{i}"),
            Some(i - 1),
            Trs::from_translation(Vector3::new(0.0, 0.1, 0.0)),
        ));
    }
    for limb in 0..5 {
        let mut parent = 4 - (limb % 3);
        for k in 0..10 {
            let offset = Vector3::new(0.05 * (limb as f64 - 2.0), -0.08, 0.01 * k as f64);
            let rotation = Quat::from_euler_angles(0.1 * k as f64, 0.05 * limb as f64, 0.02);
            joints.push(Joint::new(
                format!("limb{limb}_{k}"),
                Some(parent),
                Trs::new(offset, rotation),
            ));
            parent = joints.len() - 1;
        }
    }
    let mut s = Skeleton::new(joints).expect("valid tree");
    s.set_default_dofs();
    s
}

fn bench(c: &mut Criterion) {
    let skeleton = rig55();
    assert_eq!(skeleton.len(), 55);
    let layout = DofLayout::new(&skeleton);
    let pose = skeleton.rest_pose();
    c.bench_function("fk_55_joints", |b| {
        b.iter(|| ForwardKinematics::new(black_box(&skeleton), black_box(&pose)))
    });
    let fk = ForwardKinematics::new(&skeleton, &pose);
    let points: Vec<(usize, Point3)> = (0..skeleton.len())
        .map(|j| (j, fk.point(j, &Point3::new(0.01, 0.02, 0.0))))
        .collect();
    c.bench_function("fk_plus_jacobian_55_joints_one_point_each", |b| {
        b.iter(|| {
            let fk = ForwardKinematics::new(black_box(&skeleton), black_box(&pose));
            let mut sum = Vector3::zeros();
            for (j, p) in &points {
                fk.point_jacobian(&layout, *j, p, |_, v| sum += v);
            }
            sum
        })
    });
    // A solver-sized workload: 1,000 points spread over the joints, dense J^T J accumulation.
    let many: Vec<(usize, Point3)> = (0..1000).map(|i| points[i % points.len()]).collect();
    c.bench_function("fk_jacobian_normal_equations_55_joints_1000_points", |b| {
        b.iter(|| {
            let fk = ForwardKinematics::new(black_box(&skeleton), black_box(&pose));
            let n = layout.len();
            let mut jtj = nalgebra::DMatrix::<f64>::zeros(n, n);
            let mut cols: Vec<(usize, Vector3)> = Vec::with_capacity(n);
            for (j, p) in &many {
                cols.clear();
                fk.point_jacobian(&layout, *j, p, |c, v| cols.push((c, v)));
                for &(a, va) in &cols {
                    for &(b, vb) in &cols {
                        jtj[(a, b)] += va.dot(&vb);
                    }
                }
            }
            jtj
        })
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
