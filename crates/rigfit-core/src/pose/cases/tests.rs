use rand::SeedableRng;
use rand::rngs::StdRng;

use super::*;
use crate::humanoid::humanoid;
use crate::math::Trs;
use crate::rig::Rig;
use crate::skeleton::Joint;

/// The humanoid with extra joints `(name, parent, offset)` that no vertex follows.
fn humanoid_with(extra: &[(&str, &str, [f64; 3])]) -> Rig {
    let mut rig = humanoid();
    let mut joints = rig.skeleton.joints().to_vec();
    for &(name, parent, offset) in extra {
        let parent = joints.iter().position(|j| j.name == parent);
        joints.push(Joint::new(
            name,
            parent,
            Trs::from_translation(Vector3::from(offset)),
        ));
    }
    rig.skeleton = Skeleton::new(joints).expect("parents come first");
    rig.skeleton.set_default_dofs();
    rig.pose = rig.skeleton.rest_pose();
    for mesh in &mut rig.meshes {
        mesh.inverse_bind
            .resize(rig.skeleton.len(), crate::math::Matrix4::identity());
    }
    rig
}

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

/// Two fingers on the left hand and a helper (an IK pole) hanging from the hips.
fn hand_and_helper() -> Rig {
    humanoid_with(&[
        ("LeftIndex1", "LeftHand", [0.05, 0.0, 0.02]),
        ("LeftIndex2", "LeftIndex1", [0.04, 0.0, 0.0]),
        ("LeftIndex3", "LeftIndex2", [0.03, 0.0, 0.0]),
        ("LeftThumb1", "LeftHand", [0.03, 0.0, 0.04]),
        ("LeftThumb2", "LeftThumb1", [0.03, 0.0, 0.02]),
        ("IKPole", "Hips", [0.0, 0.0, 0.3]),
    ])
}

fn names(skeleton: &Skeleton, chains: &[Vec<usize>]) -> Vec<String> {
    chains
        .iter()
        .map(|c| {
            skeleton
                .joint(*c.last().expect("chains have joints"))
                .name
                .clone()
        })
        .collect()
}

/// A number that changes when any stroke point, its stroke or its order changes.
fn fingerprint(case: &Case) -> f64 {
    let mut sum = 0.0;
    for (i, s) in case.strokes.iter().enumerate() {
        for (k, p) in s.points.iter().enumerate() {
            sum += (i as f64 + 1.0) * (k as f64 + 1.0) * (p.x + 2.0 * p.y + 3.0 * p.z);
        }
    }
    sum
}

#[test]
fn default_cases_are_those_callers_were_tuned_on() {
    // Fingerprints of the cases drawn before coverage, flattening and helpers existed.
    let rig = humanoid();
    let truth = rig.animations[0].sample(&rig.pose, 0.7);
    let expected = [
        (0, 0, 6, 3.709176554008e5),
        (1, 1, 6, 2.988592508641e5),
        (2, 2, 6, 1.518054127204e5),
    ];
    for (drop, strays, count, fp) in expected {
        let mut rng = StdRng::seed_from_u64(42);
        let options = CaseOptions {
            drop_limbs: drop,
            stray_strokes: strays,
            ..Default::default()
        };
        let case = make_case(&rig.skeleton, &truth, rig.height(), &options, &mut rng);
        assert_eq!(case.strokes.len(), count);
        let got = fingerprint(&case);
        assert!((got - fp).abs() <= 1e-9 * fp.abs(), "{got:e} != {fp:e}");
        assert_eq!(case.dropped_chains.len(), drop);
    }
}

#[test]
fn flattening_removes_the_depth_of_each_stroke() {
    let rig = humanoid();
    let truth = rig.animations[0].sample(&rig.pose, 0.7);
    let view = Vector3::new(1.0, 0.2, 2.0);
    let depth_spread = |case: &Case| {
        let n = view.normalize();
        case.strokes
            .iter()
            .map(|s| {
                let depths: Vec<f64> = s.points.iter().map(|p| p.coords.dot(&n)).collect();
                let lo = depths.iter().copied().fold(f64::INFINITY, f64::min);
                let hi = depths.iter().copied().fold(f64::NEG_INFINITY, f64::max);
                hi - lo
            })
            .fold(0.0, f64::max)
    };
    let mut options = CaseOptions {
        stray_strokes: 1,
        ..Default::default()
    };
    let drawn = make_case(
        &rig.skeleton,
        &truth,
        1.75,
        &options,
        &mut StdRng::seed_from_u64(1),
    );
    options.flatten = Some(view);
    let flat = make_case(
        &rig.skeleton,
        &truth,
        1.75,
        &options,
        &mut StdRng::seed_from_u64(1),
    );
    assert!(depth_spread(&drawn) > 0.1, "{}", depth_spread(&drawn));
    assert!(depth_spread(&flat) < 1e-9, "{}", depth_spread(&flat));
    // Across the view, the strokes are the ones drawn.
    for (a, b) in drawn.strokes.iter().zip(&flat.strokes) {
        for (p, q) in a.points.iter().zip(&b.points) {
            assert!((p - q).cross(&view).norm() < 1e-9);
        }
    }
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
fn coverage_chooses_limbs_every_chain_or_a_few_limbs() {
    let rig = hand_and_helper();
    let skeleton = &rig.skeleton;
    let deforming = deforming_joints(&rig);
    assert!(!deforming[skeleton.find("IKPole").expect("pole")]);
    assert!(deforming[skeleton.find("LeftArm").expect("arm")]);
    let draw = |coverage, seed| {
        let options = CaseOptions {
            coverage,
            ..Default::default()
        };
        let mut rng = StdRng::seed_from_u64(seed);
        draw_case(skeleton, &deforming, &rig.pose, 1.75, &options, &mut rng)
    };
    let ends = |case: &Case| {
        let mut chains: Vec<Vec<usize>> = case
            .stroke_chains
            .iter()
            .filter(|c| !c.is_empty())
            .cloned()
            .collect();
        for c in &mut chains {
            if skeleton.is_ancestor_or_self(c[c.len() - 1], c[0]) {
                c.reverse();
            }
        }
        let mut n = names(skeleton, &chains);
        n.sort();
        n
    };
    let limbs = ends(&draw(Coverage::Limbs, 1));
    assert_eq!(
        limbs,
        [
            "Chest",
            "HeadTop",
            "LeftHand",
            "LeftToeTip",
            "RightHandTip",
            "RightToeTip"
        ]
    );
    let every = ends(&draw(Coverage::EveryChain, 1));
    for name in [
        "IKPole",
        "LeftIndex3",
        "LeftThumb2",
        "LeftHandTip",
        "LeftHand",
    ] {
        assert!(every.iter().any(|n| n == name), "{name} in {every:?}");
    }
    for seed in 0..8 {
        let few = ends(&draw(Coverage::FewLimbs, seed));
        assert!(FEW_LIMBS.contains(&few.len()), "{few:?}");
        assert!(
            !few.iter().any(|n| n == "Chest"),
            "the spine is no outer limb"
        );
    }
}

#[test]
fn dropping_an_arm_drops_its_fingers() {
    let rig = hand_and_helper();
    let skeleton = &rig.skeleton;
    let deforming = deforming_joints(&rig);
    let hand = skeleton.find("LeftHand").expect("hand");
    let index = skeleton.find("LeftIndex3").expect("finger");
    let mut dropped_arm = false;
    for seed in 0..20 {
        let options = CaseOptions {
            coverage: Coverage::EveryChain,
            drop_limbs: 1,
            ..Default::default()
        };
        let mut rng = StdRng::seed_from_u64(seed);
        let case = draw_case(skeleton, &deforming, &rig.pose, 1.75, &options, &mut rng);
        let dropped: Vec<usize> = case.dropped_chains.iter().flatten().copied().collect();
        if dropped.contains(&hand) && case.dropped_chains[0].last() == Some(&hand) {
            dropped_arm = true;
            assert!(dropped.contains(&index), "the fingers go with the arm");
            assert!(!case.drawn_joints.contains(&index));
        }
        let drawn = case.stroke_chains.iter().filter(|c| !c.is_empty()).count();
        assert_eq!(drawn + case.dropped_chains.len(), 10, "seed {seed}");
    }
    assert!(dropped_arm, "some seed drops the left arm");
}

#[test]
fn joint_errors_give_mean_max_and_worst() {
    let rig = humanoid();
    let skeleton = &rig.skeleton;
    let mut moved = rig.pose.clone();
    let head = skeleton.find("HeadTop").expect("head top");
    moved.local[head].translation.y += 0.35;
    let joints: Vec<usize> = (0..skeleton.len()).collect();
    let errors = joint_errors(skeleton, &moved, &rig.pose, &joints, 1.75);
    assert!((errors.max - 0.2).abs() < 1e-12);
    assert_eq!(errors.worst, Some(head));
    assert!((errors.mean - 0.2 / joints.len() as f64).abs() < 1e-12);
    let mean = mean_joint_error(skeleton, &moved, &rig.pose, &joints, 1.75);
    assert_eq!(mean, errors.mean);
}

#[test]
fn far_poses_move_translating_joints_within_their_range() {
    use crate::animation::{Animation, AnimationChannel, ChannelTarget, Interpolation};
    use crate::skeleton::JointDof;
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
    use crate::joint_model::limit_excess;
    use crate::skeleton::{JointDof, JointLimits};
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
