//! The posing solver over the whole corpus (both halves), with the bounds of issue 20 per
//! scenario on the held-out half. The corpus is `RIGFIT_CORPUS_MANIFEST` (default
//! `data/corpus.json`) over the folder `RIGFIT_CORPUS` (default `target/test-data/corpus`,
//! filled by scripts/fetch-data.sh). The figures per rig are the `pose_corpus` example's.

use std::sync::OnceLock;

use rigfit_core::pose::PoseOptions;
use rigfit_testkit::report::{check_held_out, per_half, text_table};
use rigfit_testkit::{Corpus, Half, Outcome, Scenario, SweepOptions, sweep};

/// Cases per rig and scenario: small enough for a few minutes in the dev profile on two
/// cores over the whole corpus.
const CASES_PER_RIG: usize = 3;

fn corpus() -> Corpus {
    Corpus::load().unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn manifest_parses_and_every_listed_file_exists() {
    let corpus = corpus();
    for half in Half::ALL {
        assert!(
            corpus.rigs.iter().any(|r| r.half == half),
            "{}: no rig in the {} half",
            corpus.manifest.display(),
            half.name()
        );
    }
}

#[test]
fn rigs_get_their_joint_model_from_a_joints_file_or_their_clips() {
    use rigfit_core::JointDof;
    let corpus = corpus();
    let read = |id: &str| {
        let entry = corpus.entry(id).unwrap_or_else(|| panic!("no rig {id}"));
        corpus.read_rig(entry).unwrap_or_else(|e| panic!("{e}"))
    };
    let dof = |rig: &rigfit_testkit::CorpusRig, name: &str| {
        let j = rig
            .rig
            .skeleton
            .find(name)
            .unwrap_or_else(|| panic!("no {name}"));
        (
            rig.rig.skeleton.joint(j).dof,
            rig.rig.skeleton.joint(j).limits,
        )
    };
    // MuJoCo's knee hinge with its range (degrees -60..50), from the converter's joints file.
    let quadruped = read("dmc-quadruped");
    let (knee, limits) = dof(&quadruped, "knee_front_left");
    assert!(matches!(knee, JointDof::Hinge { .. }), "{knee:?}");
    let limits = limits.expect("the knee has a range");
    assert!(
        (limits.min.x - (-60f64).to_radians()).abs() < 1e-6,
        "{limits:?}"
    );
    assert!(
        (limits.max.x - 50f64.to_radians()).abs() < 1e-6,
        "{limits:?}"
    );
    // The solver is given the file's skeleton unless asked for the model.
    assert_ne!(quadruped.solver_skeleton(), &quadruped.rig.skeleton);
    // A mocap take's knee turns about one axis: a hinge; its hip a limited ball.
    let take = read("cmu-01_01");
    assert!(matches!(dof(&take, "LeftLeg").0, JointDof::Hinge { .. }));
    let (hip, hip_limits) = dof(&take, "LeftUpLeg");
    assert_eq!(hip, JointDof::Ball);
    assert!(hip_limits.is_some());
}

#[test]
fn few_limbs_cases_move_only_the_drawn_limbs() {
    let corpus = corpus();
    let entry = corpus.entry("cmu-01_01").expect("cmu-01_01 in the corpus");
    let rig = corpus.read_rig(entry).unwrap_or_else(|e| panic!("{e}"));
    let skeleton = &rig.rig.skeleton;
    let mut limbs_moved = 0;
    for index in 0..6 {
        let generated = rigfit_testkit::generate_case(&rig, Scenario::FewLimbs, index);
        // Below each drawn chain's attachment, the target; elsewhere, the start pose.
        let mut below = vec![false; skeleton.len()];
        for chain in generated
            .case
            .stroke_chains
            .iter()
            .filter(|c| !c.is_empty())
        {
            let attach = chain
                .iter()
                .copied()
                .find(|&j| chain.iter().all(|&k| skeleton.is_ancestor_or_self(j, k)))
                .expect("a chain runs from its attachment");
            for j in 0..skeleton.len() {
                below[j] |= j != attach && skeleton.is_ancestor_or_self(attach, j);
            }
        }
        for j in (0..skeleton.len()).filter(|&j| !below[j]) {
            assert_eq!(
                generated.truth.local[j],
                rig.start.local[j],
                "case {index}: {} moved but is not drawn",
                skeleton.joint(j).name
            );
        }
        limbs_moved += usize::from(
            (0..skeleton.len()).any(|j| below[j] && generated.truth.local[j] != rig.start.local[j]),
        );
    }
    assert!(
        limbs_moved >= 5,
        "only {limbs_moved} of 6 cases moved a drawn limb"
    );
}

#[test]
fn sweep_gives_finite_errors_on_two_rigs() {
    let corpus = corpus();
    // The first rig of each half.
    let rigs: Vec<String> = Half::ALL
        .iter()
        .filter_map(|&h| corpus.rigs.iter().find(|r| r.half == h))
        .map(|r| r.id.clone())
        .collect();
    let options = SweepOptions {
        rigs: rigs.clone(),
        cases: 1,
        ..SweepOptions::default()
    };
    let outcomes = sweep(&corpus, &options, |_, _| {}).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(outcomes.len(), rigs.len() * Scenario::ALL.len());
    for o in &outcomes {
        assert!(
            o.failure.is_none(),
            "{} {}: {:?}",
            o.rig,
            o.scenario.name(),
            o.failure
        );
        assert!(o.strokes > 0 && o.drawn_joints > 0, "{o:?}");
        assert!(
            o.mean_error.is_finite() && o.max_error >= o.mean_error,
            "{o:?}"
        );
        assert!(o.seconds > 0.0, "{o:?}");
    }
}

/// Two tuning-half cases where a limb's stroke took the mirror-image limb (left undrawn)
/// and a stray or a fragment took part of its own: the local moves give the stroke its limb
/// back and set the other aside (`take_mirror_limbs_held_in_part`).
#[test]
fn a_stroke_on_the_undrawn_mirror_limb_takes_its_own_back() {
    let corpus = corpus();
    for (rig, case) in [("bvhtoolbox-mocapbank", 25), ("assimp-testwuson", 29)] {
        let options = SweepOptions {
            rigs: vec![rig.to_string()],
            scenarios: vec![Scenario::EveryChain],
            cases: case + 1,
            only_case: Some(case),
            ..SweepOptions::default()
        };
        let outcomes = sweep(&corpus, &options, |_, _| {}).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(outcomes.len(), 1);
        assert!(
            outcomes[0].success(),
            "{rig} case {case}: {:?}",
            outcomes[0]
        );
    }
}

/// The whole corpus swept once for the bound tests below.
fn whole_corpus() -> &'static [Outcome] {
    static OUTCOMES: OnceLock<Vec<Outcome>> = OnceLock::new();
    OUTCOMES.get_or_init(|| {
        let options = SweepOptions {
            cases: CASES_PER_RIG,
            pose: PoseOptions::default(),
            ..SweepOptions::default()
        };
        let outcomes = sweep(&corpus(), &options, |_, _| {}).unwrap_or_else(|e| panic!("{e}"));
        eprintln!("{}", text_table(&per_half(&outcomes)));
        outcomes
    })
}

// Measured on 2026-11-28 (tune / held-out), session 24, with three hypotheses improved by
// the local moves: every-chain 97.2 / 100%, limbs-only 97.2 / 100%, few-limbs 100 / 90.0%, flattened 8.3 / 13.3%, far 97.2 /
// 93.3% (36 and 30 cases); each floor is two cases under it.
const TUNE_EVERY: f64 = 0.91;
const HELD_EVERY: f64 = 0.93;
const TUNE_LIMBS: f64 = 0.91;
const HELD_LIMBS: f64 = 0.93;
const TUNE_FEW: f64 = 0.94;
const HELD_FEW: f64 = 0.83;
const TUNE_FLAT: f64 = 0.02;
const HELD_FLAT: f64 = 0.06;
const TUNE_FAR: f64 = 0.91;
const HELD_FAR: f64 = 0.86;

/// The success rates the solver reaches today on this sample (3 cases per rig and
/// scenario), per half: a floor that a change must not lower. Measured with the whole-corpus
/// sweep below; BENCHMARKS.md has the figures per rig. Issue 20's bounds are the tests
/// below (those not yet met on the whole corpus are ignored).
const MEASURED_FLOORS: [(Scenario, f64, f64); 5] = [
    // (scenario, tune half, held-out half)
    (Scenario::EveryChain, TUNE_EVERY, HELD_EVERY),
    (Scenario::LimbsOnly, TUNE_LIMBS, HELD_LIMBS),
    (Scenario::FewLimbs, TUNE_FEW, HELD_FEW),
    (Scenario::Flattened, TUNE_FLAT, HELD_FLAT),
    (Scenario::Far, TUNE_FAR, HELD_FAR),
];

#[test]
fn the_corpus_stays_above_its_measured_floors() {
    let totals = per_half(whole_corpus());
    let mut short = Vec::new();
    for (scenario, tune, held_out) in MEASURED_FLOORS {
        for (half, floor) in [(Half::Tune, tune), (Half::HeldOut, held_out)] {
            let rate = totals
                .iter()
                .find(|s| s.half == half && s.scenario == scenario)
                .map_or(0.0, |s| s.success_rate());
            if rate < floor {
                short.push(format!(
                    "{} {}: {:.1}% succeeded, the floor is {:.1}%",
                    half.name(),
                    scenario.name(),
                    100.0 * rate,
                    100.0 * floor
                ));
            }
        }
    }
    assert!(
        short.is_empty(),
        "{}\n{}",
        short.join("\n"),
        text_table(&totals)
    );
}

fn assert_held_out(scenarios: &[Scenario]) {
    if let Err(message) = check_held_out(whole_corpus(), scenarios) {
        panic!("{message}");
    }
}

#[test]
#[ignore = "a bound of issue 20 not yet met on the whole corpus (BENCHMARKS.md)"]
fn every_chain_drawn_succeeds_on_95_percent_of_the_held_out_half() {
    assert_held_out(&[Scenario::EveryChain]);
}

/// Met on the whole corpus's 36 cases a rig (98.3%, BENCHMARKS.md); checked here on the
/// sample.
#[test]
fn limbs_only_succeeds_on_98_percent_of_the_held_out_half() {
    assert_held_out(&[Scenario::LimbsOnly]);
}

#[test]
#[ignore = "a bound of issue 20 not yet met on the whole corpus (BENCHMARKS.md)"]
fn few_limbs_flattened_and_far_meet_their_bounds_on_the_held_out_half() {
    assert_held_out(&[Scenario::FewLimbs, Scenario::Flattened, Scenario::Far]);
}
