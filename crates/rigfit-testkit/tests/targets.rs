//! True poses for posing cases (`rigfit_testkit::targets`): mirror-symmetric poses, far
//! poses (limbs turned far, long chains sharing their bend, within the joint model and the
//! clips' translation ranges), poses from a clip.

use rand::SeedableRng;
use rand::rngs::StdRng;
use rigfit_core::humanoid::humanoid;
use rigfit_core::mirror::mirror_pairs;
use rigfit_core::{Joint, Point3, Pose, Skeleton, Trs, Vector3};
use rigfit_testkit::pose_suites::humanoid_with;
use rigfit_testkit::targets::{FarPoseOptions, clip_pose, far_pose, limb_roots, mirror_pose};

/// [`far_pose`] with the default options for a rig 1.75 tall with no clips, seeded.
fn far_pose_of_humanoid(skeleton: &Skeleton, start: &Pose, seed: u64) -> Pose {
    far_pose(
        skeleton,
        start,
        &[],
        1.75,
        &FarPoseOptions::default(),
        &mut StdRng::seed_from_u64(seed),
    )
}

#[test]
fn mirror_pose_is_mirror_symmetric_on_a_symmetric_rig() {
    let rig = humanoid();
    let skeleton = &rig.skeleton;
    let pairs = mirror_pairs(skeleton);
    assert_eq!(pairs.len(), 10, "{pairs:?}");
    let options = FarPoseOptions {
        heading: 0.0,
        ..Default::default()
    };
    for seed in 0..5 {
        let mut rng = StdRng::seed_from_u64(seed);
        let pose = mirror_pose(skeleton, &rig.pose, &[], 1.75, &options, &mut rng)
            .expect("the humanoid has pairs");
        let p = skeleton.joint_positions(&pose);
        let start = skeleton.joint_positions(&rig.pose);
        // The humanoid's plane of symmetry is x = 0.
        let mirror = |q: &Point3| Point3::new(-q.x, q.y, q.z);
        for &(left, right) in &pairs {
            assert!((p[right] - mirror(&p[left])).norm() < 1e-9, "seed {seed}");
        }
        let hips = skeleton.find("Hips").expect("hips");
        for (j, joint) in skeleton.joints().iter().enumerate() {
            if !pairs.iter().any(|&(l, r)| l == j || r == j) {
                assert!(p[j].x.abs() < 1e-9, "{} off the plane", joint.name);
            }
        }
        let hand = skeleton.find("LeftHand").expect("hand");
        assert!((p[hand] - start[hand]).norm() > 0.05, "the pose moved");
        assert!((p[hips] - start[hips]).norm() < 1e-12);
    }
}

#[test]
fn far_poses_turn_limbs_by_large_angles() {
    let rig = humanoid();
    let skeleton = &rig.skeleton;
    let roots = limb_roots(skeleton, &rig.pose, 0.175);
    let root_names: Vec<&str> = roots
        .iter()
        .map(|&j| skeleton.joint(j).name.as_str())
        .collect();
    assert_eq!(
        root_names,
        ["LeftUpLeg", "RightUpLeg", "Head", "LeftArm", "RightArm"],
        "limb roots"
    );
    let options = FarPoseOptions::default();
    let mut angles = Vec::new();
    for seed in 0..10 {
        let pose = far_pose_of_humanoid(skeleton, &rig.pose, seed);
        for &j in &roots {
            angles.push(rig.pose.local[j].rotation.angle_to(&pose.local[j].rotation));
        }
        for j in 0..skeleton.len() {
            let bend = rig.pose.local[j].rotation.angle_to(&pose.local[j].rotation);
            let limit = if roots.contains(&j) || skeleton.joint(j).parent.is_none() {
                std::f64::consts::PI
            } else {
                options.bend
            };
            assert!(
                bend <= limit + 1e-9,
                "{} bent {bend}",
                skeleton.joint(j).name
            );
        }
    }
    let mean = angles.iter().sum::<f64>() / angles.len() as f64;
    let max = angles.iter().copied().fold(0.0, f64::max);
    assert!(mean > 60f64.to_radians(), "mean limb turn {mean}");
    assert!(max > 150f64.to_radians(), "largest limb turn {max}");
}

#[test]
fn clip_poses_come_from_the_clip() {
    let rig = humanoid();
    let mut rng = StdRng::seed_from_u64(3);
    let pose = clip_pose(&rig.animations, &rig.pose, &mut rng).expect("the wave lasts");
    let clip = &rig.animations[0];
    let close = (0..=200).any(|k| {
        let t = clip.start() + clip.duration() * k as f64 / 200.0;
        let sample = clip.sample(&rig.pose, t);
        (0..rig.skeleton.len())
            .all(|j| sample.local[j].rotation.angle_to(&pose.local[j].rotation) < 0.05)
    });
    assert!(close);
    assert!(clip_pose(&[], &rig.pose, &mut rng).is_none());
}

#[test]
fn far_poses_move_translating_joints_within_their_range() {
    use rigfit_core::animation::{Animation, AnimationChannel, ChannelTarget, Interpolation};
    use rigfit_core::skeleton::JointDof;
    // A marker rig: a root and two markers, one translated by a clip, one free.
    let joints = vec![
        Joint::new("Root", None, Trs::default()),
        Joint::new(
            "Keyed",
            Some(0),
            Trs::from_translation(Vector3::new(0.0, 1.0, 0.0)),
        ),
        Joint::new(
            "Loose",
            Some(0),
            Trs::from_translation(Vector3::new(0.5, 0.0, 0.0)),
        ),
    ];
    let mut skeleton = Skeleton::new(joints).expect("tree");
    skeleton.set_default_dofs();
    skeleton.set_dof(2, JointDof::Free, None);
    let clip = Animation {
        name: "markers".into(),
        channels: vec![AnimationChannel {
            joint: 1,
            target: ChannelTarget::Translation,
            interpolation: Interpolation::Linear,
            times: vec![0.0, 1.0],
            values: vec![[0.0, 1.0, 0.0, 0.0], [0.4, 1.0, -0.2, 0.0]],
        }],
        frame_time: None,
    };
    let start = skeleton.rest_pose();
    let options = FarPoseOptions::default();
    let mut moved = false;
    for seed in 0..10 {
        let mut rng = StdRng::seed_from_u64(seed);
        let pose = far_pose(
            &skeleton,
            &start,
            std::slice::from_ref(&clip),
            2.0,
            &options,
            &mut rng,
        );
        let keyed = pose.local[1].translation;
        assert!((0.0..=0.4).contains(&keyed.x) && (-0.2..=0.0).contains(&keyed.z));
        assert_eq!(keyed.y, 1.0);
        let loose = pose.local[2].translation - start.local[2].translation;
        assert!(loose.amax() <= options.translation * 2.0 + 1e-12);
        moved |= keyed.x > 0.05 && loose.norm() > 0.01;
    }
    assert!(moved);
}

#[test]
fn long_chains_share_their_bend() {
    // A tail of 20 vertebrae hanging from the hips: each bends a fifth as far as an arm
    // joint may, so the whole tail curls about as far as a four-joint limb.
    let tail: Vec<(String, String, [f64; 3])> = (0..20)
        .map(|k| {
            let parent = if k == 0 {
                "Hips".to_string()
            } else {
                format!("Tail{}", k - 1)
            };
            (format!("Tail{k}"), parent, [0.0, 0.0, -0.04])
        })
        .collect();
    let extra: Vec<(&str, &str, [f64; 3])> = tail
        .iter()
        .map(|(n, p, o)| (n.as_str(), p.as_str(), *o))
        .collect();
    let rig = humanoid_with(&extra);
    let skeleton = &rig.skeleton;
    let options = FarPoseOptions::default();
    let vertebra = skeleton.find("Tail10").expect("Tail10");
    let elbow = skeleton.find("LeftForeArm").expect("LeftForeArm");
    let (mut tail_max, mut elbow_max) = (0.0f64, 0.0f64);
    for seed in 0..20 {
        let pose = far_pose_of_humanoid(skeleton, &rig.pose, seed);
        let turn = |j: usize| rig.pose.local[j].rotation.angle_to(&pose.local[j].rotation);
        tail_max = tail_max.max(turn(vertebra));
        elbow_max = elbow_max.max(turn(elbow));
    }
    assert!(
        tail_max <= options.bend / 5.0 + 1e-9,
        "vertebra bent {tail_max}"
    );
    assert!(elbow_max > options.bend / 2.0, "elbow bent {elbow_max}");
}

#[test]
fn far_poses_keep_within_the_joint_model() {
    use rigfit_core::joint_model::limit_excess;
    use rigfit_core::skeleton::{JointDof, JointLimits};
    let mut rig = humanoid();
    let knee = rig.skeleton.find("LeftLeg").expect("a left knee");
    let elbow = rig.skeleton.find("LeftForeArm").expect("a left elbow");
    let arm = rig.skeleton.find("LeftArm").expect("a left arm");
    let knee_limits = JointLimits {
        min: Vector3::new(0.0, 0.0, 0.0),
        max: Vector3::new(2.4, 0.0, 0.0),
    };
    let arm_limits = JointLimits {
        min: Vector3::new(-0.4, -0.3, -1.2),
        max: Vector3::new(0.4, 0.3, 1.2),
    };
    let hinge = JointDof::Hinge { axis: Vector3::x() };
    rig.skeleton.set_dof(knee, hinge, Some(knee_limits));
    rig.skeleton.set_dof(elbow, JointDof::Fixed, None);
    rig.skeleton.set_dof(arm, JointDof::Ball, Some(arm_limits));
    let mut knee_angles = Vec::new();
    for seed in 0..20 {
        let pose = far_pose_of_humanoid(&rig.skeleton, &rig.pose, seed);
        let relative =
            |j: usize| rig.skeleton.joint(j).rest.rotation.inverse() * pose.local[j].rotation;
        // The knee turns about its axis only, within its range.
        let knee_turn = relative(knee).scaled_axis();
        assert!(
            knee_turn.y.abs() < 1e-9 && knee_turn.z.abs() < 1e-9,
            "{knee_turn}"
        );
        assert_eq!(
            limit_excess(&hinge, &knee_limits, &knee_turn),
            Vector3::zeros()
        );
        knee_angles.push(knee_turn.x);
        // The fixed elbow does not turn; the arm stays in its box.
        assert!(relative(elbow).angle() < 1e-12);
        let arm_turn = relative(arm).scaled_axis();
        let excess = limit_excess(&JointDof::Ball, &arm_limits, &arm_turn);
        assert!(excess.norm() < 1e-9, "arm {arm_turn} outside its limits");
    }
    // The knee's range is used, not only its rest.
    let spread = knee_angles.iter().copied().fold(0.0, f64::max)
        - knee_angles.iter().copied().fold(f64::INFINITY, f64::min);
    assert!(spread > 1.2, "knee angles {knee_angles:?}");
}
