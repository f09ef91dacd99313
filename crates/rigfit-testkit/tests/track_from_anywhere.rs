//! Tracking a take from the rig's rest or bind pose with the body anywhere and turned any
//! way (issue 23), on a sample of what `examples/track_corpus` sweeps: one suite, six
//! held-out corpus rigs and one of the tune half, each moved by one seed's rigid motion,
//! and the whole corpus against issue 23's bar (95% of its sequences). Bounds: mean joint
//! error below 3% of the height from frame 5 on and no frame above 10%. The whole corpus's
//! figures per sequence are in BENCHMARKS.md.

use rigfit_testkit::Corpus;
use rigfit_testkit::track_cases::SequenceOptions;
use rigfit_testkit::track_corpus::{
    CORPUS_RIGS, SUITES, TakeOutcome, TakeSettings, corpus_sequence, suite_sequence, track_sequence,
};
use rigfit_testkit::{Half, track_corpus::MovedSequence};

fn assert_within_bounds(label: &str, outcome: &TakeOutcome) {
    assert!(
        outcome.ok(),
        "{label}: mean {:.2}% from frame 5, worst {:.2}%, {} frames above 10% ({})",
        100.0 * outcome.mean_from(),
        100.0 * outcome.worst_from(),
        outcome.lost(),
        outcome.start_label()
    );
}

#[test]
fn a_skinned_character_is_found_and_tracked_from_its_bind_pose() {
    let corpus = Corpus::load().ok();
    let sequence = suite_sequence(
        "BCN_Epileptic",
        1,
        &SequenceOptions::default(),
        corpus.as_ref(),
    );
    let outcome = track_sequence(&sequence, &TakeSettings::default()).expect("tracks");
    assert_within_bounds("BCN_Epileptic", &outcome);
}

#[test]
fn a_held_out_mocap_skeleton_is_found_and_tracked_from_its_rest_pose() {
    corpus_take_within_bounds("assimp-boxing_toes", 0);
}

/// The take of corpus rig `id` moved by `seed`'s rigid motion.
fn moved_corpus_take(id: &str, seed: u64) -> MovedSequence {
    let corpus = Corpus::load().unwrap_or_else(|e| panic!("{e}"));
    corpus_sequence(&corpus, id, seed, &SequenceOptions::default()).expect("sequence")
}

/// A corpus rig (`id`) moved by `seed`'s rigid motion, tracked from its rest pose
/// within the bounds; the take's outcome.
fn corpus_take_within_bounds(id: &str, seed: u64) -> TakeOutcome {
    let sequence = moved_corpus_take(id, seed);
    let outcome = track_sequence(&sequence, &TakeSettings::default()).expect("tracks");
    assert_within_bounds(id, &outcome);
    outcome
}

#[test]
fn a_held_out_quadruped_with_a_long_tail_is_found_and_tracked_from_its_rest_pose() {
    // 1.03% from frame 5 when measured (BENCHMARKS.md, issue 23): its tips end where its
    // bones do, and its model points lie on its parts.
    corpus_take_within_bounds("dmc-dog", 1);
}

#[test]
fn a_held_out_skeleton_with_fingers_is_found_and_tracked_from_its_rest_pose() {
    // 1.96% from frame 5 when measured: its fingers' model points lie on its fingers.
    corpus_take_within_bounds("bvhtoolbox-freebvh", 0);
}

#[test]
fn a_creature_whose_hands_hang_from_ik_goals_is_found_and_tracked_from_its_rest_pose() {
    // mrfixit (tune half): its hands hang from IK goals tied to the ends of its arms (the
    // arms swing down from the rest pose and carry the hands along). 2.47% from frame 5
    // when measured (6.44% untied).
    corpus_take_within_bounds("assimp-mrfixit", 1);
}

#[test]
fn a_held_out_box_character_is_tracked_as_itself_or_its_symmetric_twin() {
    // Its body maps onto itself under a half turn with left and right swapped: the take
    // lands on the twin (16.6% strict, 0.43% up to the symmetry when measured), which no
    // points can tell from the truth.
    let outcome = corpus_take_within_bounds("minetest-character", 0);
    assert_eq!(outcome.strict_errors.len(), outcome.errors.len());
    if outcome.twin {
        assert!(!outcome.strict_ok(), "a twin is wrong without relabelling");
    }
}

#[test]
fn a_held_out_flat_hand_turned_over_is_found_palm_for_palm() {
    // The Adroit hand lies flat: with its fingers at rest, every placement's root-alone fit
    // lands it back for palm (8.5% at the first frame when measured). The winner turned
    // half about its own up axis and fitted again explains more and wins (0.91%).
    let sequence = moved_corpus_take("gymr-adroit_hand", 1);
    let mut settings = TakeSettings::default();
    let mut first = Vec::new();
    for half_turn in [true, false] {
        settings.take.search.half_turn = half_turn;
        let outcome = track_sequence(&sequence, &settings).expect("tracks");
        first.push(outcome.errors[0]);
    }
    assert!(
        first[0] < 0.02 && first[1] > 0.05,
        "first frame {:.2}% with the half turn, {:.2}% without",
        100.0 * first[0],
        100.0 * first[1]
    );
}

#[test]
fn a_held_out_robot_sitting_with_its_legs_dropped_to_the_floor_is_found() {
    // The maidroid's sit clip drops its hip nodes (translating helpers, one tied to the
    // other) a quarter of its height and lays the legs on the floor: beyond the fit's reach
    // from the rest pose (9.7% at the first frame when measured, the legs hung through the
    // floor). Tried at the places its clips put them (the rig's own clip places), the hips
    // drop and the take is found (1.6%).
    let sequence = moved_corpus_take("minetest-maidroid", 1);
    let mut settings = TakeSettings::default();
    let with = track_sequence(&sequence, &settings).expect("tracks");
    assert_within_bounds("minetest-maidroid", &with);
    settings.take.search.clip_places = false;
    let without = track_sequence(&sequence, &settings).expect("tracks");
    assert!(
        with.errors[0] < 0.03 && without.errors[0] > 0.05,
        "first frame {:.2}% at the clip places, {:.2}% without",
        100.0 * with.errors[0],
        100.0 * without.errors[0]
    );
}

/// Sequences within the bounds over the whole corpus (the suites and [`CORPUS_RIGS`], seeds
/// 0-2, as `examples/track_corpus` runs them): issue 23's bar, at least 95% of them (27/27
/// tune and 16/18 held-out when measured, 43/45), and per half no more than one sequence
/// under what was measured.
#[test]
fn the_whole_corpus_meets_the_bar_of_95_percent() {
    const BAR: f64 = 0.95;
    const TUNE_FLOOR: usize = 26;
    const HELD_OUT_FLOOR: usize = 15;
    let corpus = Corpus::load().unwrap_or_else(|e| panic!("{e}"));
    let options = SequenceOptions::default();
    let mut sequences: Vec<MovedSequence> = Vec::new();
    for (name, _) in SUITES {
        for seed in 0..3 {
            sequences.push(suite_sequence(name, seed, &options, Some(&corpus)));
        }
    }
    for id in CORPUS_RIGS {
        for seed in 0..3 {
            sequences.push(corpus_sequence(&corpus, id, seed, &options).expect("sequence"));
        }
    }
    let (mut tune, mut held_out, mut failed) = (0, 0, Vec::new());
    for sequence in &sequences {
        let outcome = track_sequence(sequence, &TakeSettings::default()).expect("tracks");
        let label = format!("{} seed {}", sequence.id, sequence.seed);
        match (outcome.ok(), sequence.half) {
            (true, Some(Half::HeldOut)) => held_out += 1,
            (true, _) => tune += 1,
            (false, _) => failed.push(format!("{label}: {:.2}%", 100.0 * outcome.mean_from())),
        }
    }
    eprintln!(
        "tune {tune}, held-out {held_out}; outside the bounds: {}",
        failed.join(", ")
    );
    let share = (tune + held_out) as f64 / sequences.len() as f64;
    assert!(
        share >= BAR && tune >= TUNE_FLOOR && held_out >= HELD_OUT_FLOOR,
        "{:.1}% of {} (bar 95%), tune {tune} (floor {TUNE_FLOOR}), held-out {held_out} \
         (floor {HELD_OUT_FLOOR}); outside the bounds: {}",
        100.0 * share,
        sequences.len(),
        failed.join(", ")
    );
}
