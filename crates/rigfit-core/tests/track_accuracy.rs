//! Tracking accuracy on ground truth drawn from the real assets (see
//! common/track_suites.rs): 60 frames, ~2,000 points a frame from two cameras, 1% noise,
//! 25% outliers. Mean joint error below 3% of the height over each sequence, and no frame
//! above 10% (no lost track).

use rigfit_testkit::track_suites;

use rigfit_core::track::TrackOptions;
use rigfit_testkit::track_cases::SequenceOptions;

fn check(name: &'static str) {
    let suite = track_suites::suite(name, track_suites::FRAMES, &SequenceOptions::default());
    let outcome = track_suites::track(&suite, &TrackOptions::default());
    println!(
        "{name}: mean {:.2}% worst {:.2}% of the height",
        outcome.mean() * 100.0,
        outcome.worst() * 100.0
    );
    assert!(
        outcome.mean() < 0.03,
        "{name}: mean joint error {:.4}",
        outcome.mean()
    );
    assert!(
        outcome.worst() < 0.10,
        "{name}: worst frame {:.4}",
        outcome.worst()
    );
}

#[test]
fn bcn_epileptic_clip() {
    check("BCN_Epileptic");
}

#[test]
fn testwuson_run() {
    check("Testwuson");
}

#[test]
fn webxr_hand_finger_motion() {
    check("hand");
}

#[test]
fn cmu_01_01_with_ellipsoids_from_bone_lengths() {
    check("01_01");
}
