//! Hostile input to articulated tracking: degenerate clouds (every point at one place),
//! extreme but finite coordinates, extreme options (as the Python package passes them). Each
//! gives a finite pose or a clear error quickly; the bounds are hang detectors.

use std::time::{Duration, Instant};

use rigfit_core::Point3;
use rigfit_core::track::{ArticulatedModel, TrackOptions, Tracker};

const HANG: Duration = Duration::from_secs(5);

/// Tracks `frames` with the humanoid from its stored pose; every frame must give a finite
/// pose or a one-line error, and the whole run must end within the bound.
fn track_all(options: TrackOptions, frames: &[Vec<Point3>]) -> Vec<Result<(), String>> {
    let rig = rigfit_core::humanoid::humanoid();
    let model =
        ArticulatedModel::from_rig(&rig, options.model_points).expect("the humanoid has parts");
    let mut tracker = Tracker::new(model, options).expect("a tracker");
    tracker.set_pose(&rig.pose);
    let began = Instant::now();
    let outcomes = frames
        .iter()
        .map(|frame| match tracker.track(frame) {
            Ok(_) => {
                let finite = tracker.pose().local.iter().all(|t| {
                    t.rotation
                        .coords
                        .iter()
                        .chain(t.translation.iter())
                        .all(|v| v.is_finite())
                });
                assert!(finite, "the pose stays finite");
                Ok(())
            }
            Err(e) => {
                let line = e.to_string();
                assert!(!line.is_empty() && !line.contains('\n'), "{line:?}");
                Err(line)
            }
        })
        .collect();
    let took = began.elapsed();
    assert!(took < HANG, "took {took:?}");
    outcomes
}

fn body_cloud() -> Vec<Point3> {
    let rig = rigfit_core::humanoid::humanoid();
    rig.extent_points(&rig.pose)
}

#[test]
fn copies_of_one_point_are_tracked_in_bounded_time() {
    let frames = vec![vec![Point3::new(0.0, 1.0, 0.0); 300_000]; 2];
    let outcomes = track_all(TrackOptions::default(), &frames);
    assert!(outcomes.iter().all(Result::is_ok), "{outcomes:?}");
}

#[test]
fn extreme_coordinates_are_refused() {
    for far in [1e13, 1e150, f64::MAX] {
        let mut cloud = body_cloud();
        cloud.push(Point3::new(far, 0.0, -far));
        let outcomes = track_all(
            TrackOptions::default(),
            &[cloud, vec![Point3::new(far, far, far); 50]],
        );
        for outcome in outcomes {
            let line = outcome.expect_err("out of range");
            assert!(line.contains("out of range"), "{line}");
        }
    }
}

#[test]
fn extreme_options_stay_bounded() {
    let cloud = body_cloud();
    for (noise, max_motion) in [
        (1e-300, 0.04),
        (0.01, 1e300),
        (1e-300, 1e300),
        (1e300, 1e-300),
    ] {
        let options = TrackOptions {
            noise,
            max_motion,
            ..TrackOptions::default()
        };
        let _ = track_all(options, &[cloud.clone(), cloud.clone()]);
    }
}
