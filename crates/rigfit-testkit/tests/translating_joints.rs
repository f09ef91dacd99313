//! Joints that translate (issue 20): a rig whose animation moves a joint's translation gets
//! translation degrees of freedom, and posing moves it; a marker rig (every joint a child
//! of one root, moved by translation alone) is posed from strokes pinned to its markers and
//! refused, with one line saying why, when no stroke says which marker it draws; and a
//! marker rig is tracked by its markers' translations (issue 23).

use rigfit_core::JointDof;
use rigfit_core::pose::{PoseError, PoseOptions, PoseProblem, solve_pose};
use rigfit_core::track::{ArticulatedModel, TrackOptions, Tracker};
use rigfit_testkit::track_cases::{SequenceOptions, clip_poses, make_sequence};
use rigfit_testkit::track_suites::joint_error;
use rigfit_testkit::{Corpus, CorpusRig, Scenario, generate_case, pinned_to_markers};

fn corpus_rig(id: &str) -> CorpusRig {
    let corpus = Corpus::load().unwrap_or_else(|e| panic!("{e}"));
    let entry = corpus
        .entry(id)
        .unwrap_or_else(|| panic!("{id} is not in the corpus manifest"));
    corpus.read_rig(entry).unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn animated_translations_become_translation_dofs() {
    let markers = corpus_rig("markers-boxing_toes");
    let skeleton = &markers.rig.skeleton;
    let free = skeleton
        .joints()
        .iter()
        .filter(|j| j.dof == JointDof::Free)
        .count();
    // The root and every marker.
    assert_eq!(
        free,
        skeleton.len(),
        "every joint of the marker rig translates"
    );
    // mrfixit's elbow-rotation helpers are animated by translation; its IK goals (helpers
    // above the character) stay fixed.
    let mrfixit = corpus_rig("assimp-mrfixit");
    let s = &mrfixit.rig.skeleton;
    let dof = |name: &str| s.joint(s.find(name).expect("joint")).dof;
    assert_eq!(dof("ElbowRot.L"), JointDof::Free);
    // Its hands hang from IK goals (ArmIK.*, skin joints under the spine) that its clip
    // keeps at the ends of its arms: each is tied there.
    for side in ["L", "R"] {
        let goal = s.find(&format!("ArmIK.{side}")).expect("goal");
        let tie = s.joint(goal).tie.expect("tied");
        assert_eq!(s.joint(tie.to).name, format!("Hand.{side}"));
    }
    // A BVH without position channels below its root keeps ball joints.
    let cmu = corpus_rig("cmu-01_01");
    let s = &cmu.rig.skeleton;
    assert_eq!(
        s.joints()
            .iter()
            .filter(|j| j.dof == JointDof::Free)
            .count(),
        1
    );
}

#[test]
fn markers_without_pinned_strokes_are_refused_with_one_line() {
    let markers = corpus_rig("markers-boxing_toes");
    let generated = generate_case(&markers, Scenario::LimbsOnly, 0);
    let problem = PoseProblem {
        skeleton: &markers.rig.skeleton,
        start: &markers.start,
        strokes: &generated.case.strokes,
        movable: None,
        height: markers.height,
    };
    let error = solve_pose(&problem, &PoseOptions::default()).expect_err("refused");
    assert!(
        matches!(error, PoseError::UnpinnedMarkers { .. }),
        "{error}"
    );
    assert!(error.is_rig_problem());
    let text = error.to_string();
    assert!(
        !text.contains('\n') && text.contains("'Vicon'") && text.contains("pin"),
        "{text}"
    );
}

#[test]
fn pinned_strokes_move_markers_by_translation() {
    let markers = corpus_rig("markers-boxing_toes");
    let skeleton = &markers.rig.skeleton;
    let generated = generate_case(&markers, Scenario::LimbsOnly, 0);
    // Each stroke pinned to the marker it was drawn to, as the corpus sweep pins them.
    let strokes = pinned_to_markers(skeleton, &generated.case);
    let problem = PoseProblem {
        skeleton,
        start: &markers.start,
        strokes: &strokes,
        movable: None,
        height: markers.height,
    };
    let result = solve_pose(&problem, &PoseOptions::default()).expect("poses");
    let start = skeleton.joint_positions(&markers.start);
    let solved = skeleton.joint_positions(&result.pose);
    let moved = (0..skeleton.len())
        .filter(|&j| (solved[j] - start[j]).norm() > 0.01 * markers.height)
        .count();
    assert!(
        moved * 2 > skeleton.len(),
        "only {moved} of {} markers moved",
        skeleton.len()
    );
    assert!(result.stroke_bones.iter().all(|b| !b.is_empty()));
}

/// A marker rig's scans, seen as a depth camera sees its markers (a blob each, carried by
/// the marker's own translation), are tracked from the first frame's true pose with the
/// markers' translation degrees of freedom: 60 frames of its clip, 1% noise, 25% outliers.
#[test]
fn a_marker_rig_is_tracked_by_its_markers_translations() {
    let markers = corpus_rig("markers-boxing_toes");
    let rig = &markers.rig;
    let poses = clip_poses(rig, 0, 60, 30.0, 1.0);
    let model = ArticulatedModel::from_rig(rig, TrackOptions::default().model_points)
        .expect("a model of the markers");
    let frames = make_sequence(rig, &model.parts, &poses, &SequenceOptions::default());
    let mut tracker = Tracker::new(model, TrackOptions::default()).expect("tracker");
    tracker.set_pose(&frames[0].truth);
    let height = rig.height();
    let errors: Vec<f64> = frames
        .iter()
        .map(|frame| {
            let fit = tracker.track(&frame.points).expect("tracks");
            joint_error(rig, &fit.pose, &frame.truth, height)
        })
        .collect();
    let mean = errors.iter().sum::<f64>() / errors.len() as f64;
    eprintln!("markers: mean {:.2}%", 100.0 * mean);
    // Measured: 1.84% mean (before the markers carried their own blobs: 11.4%).
    assert!(
        mean < 0.03,
        "mean joint error {:.2}% of the height",
        100.0 * mean
    );
}

#[test]
fn inner_joints_a_clip_translates_do_not_wander_while_tracked() {
    // mrfixit (tune half): its hands hang from IK goals its clip translates, under the
    // spine. From the first frame's truth, the prior holds them where each frame starts
    // where the data does not pin them, and their ties keep them at the ends of the arms:
    // 0.97-1.01% from frame 5 over seeds 0-2 when measured, 2.8-4.1% with neither
    // (`FROM_TRUTH=1 RIGS=assimp-mrfixit` in examples/track_corpus, BENCHMARKS.md).
    use rigfit_testkit::track_corpus::{TakeSettings, corpus_sequence, track_sequence};
    let corpus = Corpus::load().unwrap_or_else(|e| panic!("{e}"));
    let sequence = corpus_sequence(&corpus, "assimp-mrfixit", 0, &SequenceOptions::default())
        .expect("sequence");
    let settings = TakeSettings {
        from_truth: true,
        ..TakeSettings::default()
    };
    let outcome = track_sequence(&sequence, &settings).expect("tracks");
    assert!(
        outcome.mean_from() < 0.02 && outcome.lost() == 0,
        "mean {:.2}% from frame 5, worst {:.2}%",
        100.0 * outcome.mean_from(),
        100.0 * outcome.worst_from()
    );
}
