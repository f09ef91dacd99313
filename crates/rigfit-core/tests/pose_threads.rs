//! A solve fits its hypotheses and improves the best in parallel: its answer must not depend
//! on how many threads it is given (one in the benches, every core in the extensions).

use rand::SeedableRng;
use rigfit_core::humanoid::humanoid;
use rigfit_core::pose::sketch::CaseOptions;
use rigfit_core::pose::{PoseOptions, PoseProblem, PoseResult, solve_pose};
use rigfit_testkit::pose_suites::strokes_of_size;
use rigfit_testkit::targets::{FarPoseOptions, far_pose};

/// Solves `problem` on a pool of `threads` threads.
fn solved_on(threads: usize, problem: &PoseProblem) -> PoseResult {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("a thread pool")
        .install(|| solve_pose(problem, &PoseOptions::default()).expect("a valid problem"))
}

#[test]
fn a_solve_gives_the_same_answer_on_one_thread_and_on_several() {
    let rig = humanoid();
    // Far poses: the strokes do not convince from where the character stands, so every
    // placement and turn is fitted, and several hypotheses are improved.
    for seed in 0..3 {
        let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
        let truth = far_pose(
            &rig.skeleton,
            &rig.pose,
            &rig.animations,
            rig.height(),
            &FarPoseOptions::default(),
            &mut rng,
        );
        let strokes = strokes_of_size(&rig, &truth, 6, 60, &CaseOptions::default());
        let problem = PoseProblem {
            skeleton: &rig.skeleton,
            start: &rig.pose,
            strokes: &strokes,
            movable: None,
            height: rig.height(),
        };
        let (one, three) = (solved_on(1, &problem), solved_on(3, &problem));
        assert_eq!(one.pose, three.pose, "seed {seed}");
        assert_eq!(one.stroke_bones, three.stroke_bones, "seed {seed}");
        assert_eq!(one.iterations, three.iterations, "seed {seed}");
    }
}
