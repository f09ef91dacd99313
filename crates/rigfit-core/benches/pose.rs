//! Posing speed: a 55-joint rig (BCN_Epileptic: 54 skin joints and its root node) with 10
//! strokes of 100 points, the corpus's 75-joint mrfixit with 30 strokes of 100 points on
//! every chain (three poses of its clip), its largest rig (the 82-joint fruit fly) with 17,
//! and the built-in humanoid with its 6 limb strokes. The goal is live feedback while a
//! stroke is drawn. BCN and mrfixit at 1 s are also solved as the extensions solve while
//! an animator draws: one stroke added to the pose solved from the others.
//!
//! `cargo bench -p rigfit-core --bench pose`

use criterion::{Criterion, criterion_group, criterion_main};
use rand::SeedableRng;
use rigfit_core::joint_model::with_clip_ranges;
use rigfit_core::pose::sketch::CaseOptions;
use rigfit_core::pose::{PoseOptions, PoseProblem, solve_pose};
use rigfit_core::{Pose, Rig, Skeleton, Stroke};
use rigfit_formats::rig_file::{RigOptions, read_rig};
use rigfit_testkit::pose_suites::strokes_of_size;
use rigfit_testkit::targets::{FarPoseOptions, far_pose};

/// A rig of the posing corpus with `joints` joints, or `None` (with a note) when the corpus
/// is not on this machine.
fn corpus_rig(file: &str, joints: usize) -> Option<Rig> {
    let corpus = std::env::var("RIGFIT_CORPUS").unwrap_or_else(|_| {
        concat!(env!("CARGO_MANIFEST_DIR"), "/../../target/test-data/corpus").to_string()
    });
    match read_rig(
        &std::path::Path::new(&corpus).join(file),
        &RigOptions::default(),
    ) {
        Ok(read) => {
            assert_eq!(read.rig.skeleton.len(), joints, "{file}");
            Some(read.rig)
        }
        Err(e) => {
            eprintln!("skipping {file}: {e} (run scripts/fetch-data.sh)");
            None
        }
    }
}

/// `strokes` strokes of 100 points drawn on the chains of `truth` at least
/// `min_chain_length` of the height long, and the skeleton `rigfit pose` uses for `rig`.
fn drawn_on(
    name: &str,
    rig: &Rig,
    truth: &Pose,
    (strokes, min_chain_length): (usize, f64),
) -> (Vec<Stroke>, Skeleton) {
    let options = CaseOptions {
        min_chain_length,
        ..Default::default()
    };
    let drawn = strokes_of_size(rig, truth, strokes, 100, &options);
    assert_eq!(drawn.len(), strokes, "{name}");
    assert!(drawn.iter().all(|s| s.points.len() == 100), "{name}");
    (drawn, with_clip_ranges(&rig.skeleton, &rig.animations))
}

/// Benches posing `rig` from the strokes [`drawn_on`] `truth`; with `paper_too`, the
/// published method as well (`NAME_paper`).
fn bench_rig(
    group: &mut criterion::BenchmarkGroup<'_, criterion::measurement::WallTime>,
    name: &str,
    rig: &Rig,
    truth: &Pose,
    strokes: (usize, f64),
    paper_too: bool,
) {
    let (drawn, skeleton) = drawn_on(name, rig, truth, strokes);
    let problem = PoseProblem {
        skeleton: &skeleton,
        start: &rig.pose,
        strokes: &drawn,
        movable: None,
        height: rig.height(),
    };
    group.bench_function(name, |b| {
        b.iter(|| solve_pose(&problem, &PoseOptions::default()).expect("solves"))
    });
    if paper_too {
        group.bench_function(format!("{name}_paper"), |b| {
            b.iter(|| solve_pose(&problem, &PoseOptions::paper()).expect("solves"))
        });
    }
}

/// Benches drawing one stroke more, as the Blender extension and the web page solve: the
/// pose solved from all strokes but the last is the start of the solve with all of them
/// (`NAME_one_more_stroke`).
fn bench_one_more_stroke(
    group: &mut criterion::BenchmarkGroup<'_, criterion::measurement::WallTime>,
    name: &str,
    rig: &Rig,
    truth: &Pose,
    strokes: (usize, f64),
) {
    let (drawn, skeleton) = drawn_on(name, rig, truth, strokes);
    let before = PoseProblem {
        skeleton: &skeleton,
        start: &rig.pose,
        strokes: &drawn[..drawn.len() - 1],
        movable: None,
        height: rig.height(),
    };
    let posed = solve_pose(&before, &PoseOptions::default())
        .expect("solves")
        .pose;
    let problem = PoseProblem {
        start: &posed,
        strokes: &drawn,
        ..before
    };
    group.bench_function(format!("{name}_one_more_stroke"), |b| {
        b.iter(|| solve_pose(&problem, &PoseOptions::default()).expect("solves"))
    });
}

fn bench(c: &mut Criterion) {
    let file = read_rig(
        &rigfit_testkit::assets::asset("assimp/BCN_Epileptic.glb"),
        &RigOptions::default(),
    )
    .expect("rig");
    let rig = &file.rig;
    assert_eq!(rig.skeleton.len(), 55);
    let mut group = c.benchmark_group("pose");
    group.sample_size(20);
    let truth = rig.animations[0].sample(&rig.pose, 1.5);
    let name = "bcn_55_joints_10_strokes_x100";
    bench_rig(&mut group, name, rig, &truth, (10, 0.03), true);
    bench_one_more_stroke(&mut group, name, rig, &truth, (10, 0.03));
    let humanoid = rigfit_core::humanoid::humanoid();
    let truth = humanoid.animations[0].sample(&humanoid.pose, 1.0);
    let name = "humanoid_26_joints_6_strokes_x100";
    bench_rig(&mut group, name, &humanoid, &truth, (6, 0.03), false);
    // The corpus's big rigs (scripts/fetch-data.sh; RIGFIT_CORPUS or target/test-data): the
    // 75-joint Blender character with its own clip, and the largest, the 82-joint MuJoCo
    // fruit fly (no clip: a far pose).
    if let Some(rig) = corpus_rig("assimp/mrfixit.glb", 75) {
        // Three poses of its clip: one solve's time follows the assignments its search
        // lands on, so the bar is judged on their median.
        for (t, name) in [
            (1.0, "mrfixit_75_joints_30_strokes_x100"),
            (0.5, "mrfixit_75_joints_30_strokes_x100_at_0.5s"),
            (1.5, "mrfixit_75_joints_30_strokes_x100_at_1.5s"),
        ] {
            let truth = rig.animations[0].sample(&rig.pose, t);
            bench_rig(&mut group, name, &rig, &truth, (30, 0.005), false);
            if t == 1.0 {
                bench_one_more_stroke(&mut group, name, &rig, &truth, (30, 0.005));
            }
        }
    }
    if let Some(rig) = corpus_rig("dm_control/fruitfly.glb", 82) {
        let mut rng = rand::rngs::StdRng::seed_from_u64(5);
        let options = FarPoseOptions::default();
        let truth = far_pose(
            &rig.skeleton,
            &rig.pose,
            &[],
            rig.height(),
            &options,
            &mut rng,
        );
        let name = "fruitfly_82_joints_17_strokes_x100";
        bench_rig(&mut group, name, &rig, &truth, (17, 0.005), false);
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
