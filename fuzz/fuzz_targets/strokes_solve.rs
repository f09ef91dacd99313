//! A strokes file through the posing solver, as `rigfit pose` runs it: whatever the strokes
//! reader accepts is posed on the built-in humanoid. The solve must end with a finite pose or
//! a one-line error, within its deadline (a solve still running then is a finding: a hang or
//! a cost that grows without bound).
#![no_main]

use std::sync::OnceLock;
use std::time::{Duration, Instant};

use libfuzzer_sys::fuzz_target;
use rigfit_core::pose::{PoseError, PoseOptions, PoseProblem, solve_pose_interruptible};
use rigfit_core::{Interrupt, Rig};

/// Longer than any solve of the limits' size takes (see crates/rigfit-core/tests/hostile_pose.rs).
const DEADLINE: Duration = Duration::from_secs(10);

static HUMANOID: OnceLock<Rig> = OnceLock::new();

fuzz_target!(|data: &[u8]| {
    let Ok(strokes) = rigfit_formats::strokes::parse_strokes(data) else {
        return;
    };
    let rig = HUMANOID.get_or_init(rigfit_core::humanoid::humanoid);
    let problem = PoseProblem {
        skeleton: &rig.skeleton,
        start: &rig.pose,
        strokes: &strokes,
        movable: None,
        height: rig.height(),
    };
    let interrupt = Interrupt::never().with_deadline(Instant::now() + DEADLINE);
    for options in [PoseOptions::default(), PoseOptions::paper()] {
        match solve_pose_interruptible(&problem, &options, &interrupt) {
            Ok(result) => {
                assert_eq!(result.pose.local.len(), rig.skeleton.len());
                assert!(
                    result.pose.local.iter().all(|t| t
                        .rotation
                        .coords
                        .iter()
                        .chain(t.translation.iter())
                        .all(|v| v.is_finite())),
                    "a solve returned a non-finite pose"
                );
                assert_eq!(result.stroke_bones.len(), strokes.len());
            }
            Err(PoseError::Interrupted) => panic!("a solve ran past {DEADLINE:?}"),
            Err(e) => assert!(!e.to_string().contains('\n'), "one line: {e}"),
        }
    }
});
