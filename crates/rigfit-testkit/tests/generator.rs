//! The case generator on the real rigs of ../shared/data (or `RIGFIT_DATA`): finger, face
//! and helper chains drawn when every chain is, mirror pairs by the rigs' own names, far and
//! flattened cases.

use rand::SeedableRng;
use rand::rngs::StdRng;
use rigfit_core::mirror::mirror_pairs;
use rigfit_core::pose::sketch::{CaseOptions, Coverage, deforming_joints, draw_case};
use rigfit_core::{Rig, Skeleton};
use rigfit_testkit::targets::limb_roots;

use rigfit_testkit::assets::asset_rig as rig;

/// The names of the joints the strokes of a case with `coverage` run through.
fn drawn_names(rig: &Rig, coverage: Coverage, seed: u64) -> Vec<String> {
    let options = CaseOptions {
        coverage,
        ..CaseOptions::default()
    };
    let mut rng = StdRng::seed_from_u64(seed);
    let case = draw_case(
        &rig.skeleton,
        &deforming_joints(rig),
        &rig.pose,
        rig.height(),
        &options,
        &mut rng,
    );
    names(&rig.skeleton, &case.drawn_joints)
}

fn names(skeleton: &Skeleton, joints: &[usize]) -> Vec<String> {
    joints
        .iter()
        .map(|&j| skeleton.joint(j).name.clone())
        .collect()
}

#[test]
fn every_chain_draws_fingers_and_face_of_bcn() {
    let bcn = rig("assimp/BCN_Epileptic.glb");
    let every = drawn_names(&bcn, Coverage::EveryChain, 1);
    for joint in [
        "B_Finger3_Left",
        "B_Thumb2_Right",
        "B_Jaw",
        "B_PTail3",
        "B_Toe_Left",
    ] {
        assert!(
            every.iter().any(|n| n == joint),
            "{joint} not drawn: {every:?}"
        );
    }
    let limbs = drawn_names(&bcn, Coverage::Limbs, 1);
    assert!(!limbs.iter().any(|n| n.contains("Finger")), "{limbs:?}");
    assert!(limbs.iter().any(|n| n == "B_Toe_Left"), "{limbs:?}");
}

#[test]
fn every_chain_draws_every_finger_of_the_hand() {
    let hand = rig("webxr_hand/left.glb");
    let every = drawn_names(&hand, Coverage::EveryChain, 1);
    for finger in [
        "thumb",
        "index-finger",
        "middle-finger",
        "ring-finger",
        "pinky-finger",
    ] {
        assert!(
            every
                .iter()
                .any(|n| n.starts_with(finger) && n.ends_with("phalanx-distal")),
            "{finger} not drawn: {every:?}"
        );
    }
}

#[test]
fn mirror_pairs_and_limb_roots_follow_the_rigs_names() {
    let bcn = rig("assimp/BCN_Epileptic.glb");
    let pairs = mirror_pairs(&bcn.skeleton);
    let pair_names: Vec<(String, String)> = pairs
        .iter()
        .map(|&(l, r)| {
            (
                bcn.skeleton.joint(l).name.clone(),
                bcn.skeleton.joint(r).name.clone(),
            )
        })
        .collect();
    assert!(
        pair_names.contains(&("B_Hip_Left".into(), "B_Hip_Right".into())),
        "{pair_names:?}"
    );
    assert_eq!(pairs.len(), 19, "{pair_names:?}");
    let roots = names(
        &bcn.skeleton,
        &limb_roots(&bcn.skeleton, &bcn.pose, 0.1 * bcn.height()),
    );
    for limb in [
        "B_UpperArm_Left",
        "B_UpperArm_Right",
        "B_Hip_Left",
        "B_Hip_Right",
    ] {
        assert!(
            roots.iter().any(|n| n == limb),
            "{limb} not a limb root: {roots:?}"
        );
    }
    let wuson = rig("assimp/Testwuson.glb");
    let pairs = mirror_pairs(&wuson.skeleton);
    assert!(pairs.len() >= 10, "{pairs:?}");
    let hand = rig("webxr_hand/left.glb");
    assert!(mirror_pairs(&hand.skeleton).is_empty());
}

/// A synthetic motion keeps every limited joint within its limits between its keys: Fetch's
/// wrist, keyed 2 radians one way and then the other, turns back through its rest, not
/// through the half turn (a slerp's short way, 0.8 radians past its limits, was the truth
/// that tracker lost Fetch's gripper on).
#[test]
fn synthetic_motions_keep_the_joints_within_their_limits() {
    use rigfit_core::joint_model::limit_excess;
    use rigfit_testkit::Corpus;
    use rigfit_testkit::track_corpus::synthetic_motion;
    let corpus = Corpus::load().unwrap_or_else(|e| panic!("{e}"));
    let entry = corpus.entry("gymr-fetch").expect("fetch in the corpus");
    let read = corpus.read_rig(entry).unwrap_or_else(|e| panic!("{e}"));
    let skeleton = &read.rig.skeleton;
    for seed in 0..40 {
        let mut rng = StdRng::seed_from_u64(seed);
        for (f, pose) in synthetic_motion(&read, 60, &mut rng).iter().enumerate() {
            for (j, joint) in skeleton.joints().iter().enumerate() {
                let Some(limits) = &joint.limits else {
                    continue;
                };
                let relative =
                    (joint.rest.rotation.inverse() * pose.local[j].rotation).scaled_axis();
                let excess = limit_excess(&joint.dof, limits, &relative).norm();
                assert!(
                    excess < 1e-6,
                    "seed {seed} frame {f}: {} {excess:.3} rad past its limits",
                    joint.name
                );
            }
        }
    }
}
