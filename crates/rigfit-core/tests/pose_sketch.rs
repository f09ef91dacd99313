//! Strokes sketched through a pose (`pose::sketch`): the default cases are the ones callers
//! were tuned on, flattening, which chains each coverage draws, dropped limbs, joint errors.

use rand::SeedableRng;
use rand::rngs::StdRng;
use rigfit_core::humanoid::humanoid;
use rigfit_core::pose::sketch::{
    Case, CaseOptions, Coverage, FEW_LIMBS, deforming_joints, draw_case, joint_errors, make_case,
    mean_joint_error,
};
use rigfit_core::{Rig, Skeleton, Vector3};
use rigfit_testkit::pose_suites::humanoid_with;

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
