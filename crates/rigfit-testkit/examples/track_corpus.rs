//! Issue 23's measurement: takes tracked from where they really start, on the four tracking
//! suites and on rigs of the posing corpus (bodies, hands, quadrupeds, robots, a creature).
//! Each sequence (60 frames at 30 fps, 2 cameras, 1% noise, 25% outliers) is moved by a
//! random rigid motion and tracked by `track::Take` from the rig's stored (rest or bind)
//! pose; see `rigfit_testkit::track_corpus`. Prints a markdown row per sequence and the
//! totals per half; rigs that cannot be tracked at all are listed with the reason.
//! Errors are judged up to the rig's own symmetries (`rigfit_testkit::symmetry`): the row's
//! last column says when the take tracked the rig's twin, and the totals' last column
//! counts the sequences within the bounds without relabelling (strict). The symmetries
//! found are printed per rig to stderr.
//!
//! `cargo run --release -p rigfit-testkit --example track_corpus`
//! (`SEEDS=3` motions per rig, `RIGS=id,id` to choose rigs or suites (`RIGS=all`: the
//! suites and every corpus rig but the marker rigs), `POINTS=2000` points per frame,
//! `VERBOSE=1` prints each take's per-frame errors, root turn errors and worst joints to
//! stderr, `VERBOSE=2` also the true motion's steps and every joint's mean error,
//! `FROM_TRUTH=1` tracks from the first frame's true pose instead (the tracker's own error),
//! `TANGENTIAL=x`, `PRIOR=x`, `MAX_MOTION=x`, `ANNEAL_STEPS=n`, `LIMIT_WEIGHT=x`, `PREDICTION=x`, `FINAL_ITERATIONS=n`, `NOISE=x`, `EXPONENT=x`,
//! `RELAXATION=x` and `POINT_TO_PLANE=0`, `HOLD_FREE=0` (hold_free_joints), `VISIBLE_ONLY=0` set the tracker's options of those names,
//! `SWINGS=1` turns on the first-frame search's limb swings, `HALF_TURN=0` turns off its
//! half-turned winner, `CLIP_PLACES=0` its clip places, and `FULL_PASSES=n`,
//! `REFINE_SIGMA=x`, `REFINE_STEPS=n`, `FULL_PRIOR=x`, `KEEP=n`, `LAID_KEPT=n` and
//! `HEADINGS=n` set its options). The corpus is
//! `RIGFIT_CORPUS` over `data/corpus.json`; the suites' assets are `RIGFIT_DATA`.

#[path = "common/env_knobs.rs"]
mod env_knobs;

use rigfit_core::track::{LimbSwingOptions, TakeOptions, TrackOptions};
use rigfit_testkit::track_cases::SequenceOptions;
use rigfit_testkit::track_corpus::{
    CORPUS_RIGS, FRAME_BOUND, FROM, MEAN_BOUND, Motion, MovedSequence, SUITES, TakeOutcome,
    TakeSettings, corpus_sequence, suite_sequence, track_sequence,
};
use rigfit_testkit::{Corpus, Half, RigKind};

/// The take's settings: the defaults, changed by the environment (see the module's
/// documentation).
fn settings() -> TakeSettings {
    let mut track = TrackOptions::default();
    env_knobs::set("TANGENTIAL", &mut track.tangential);
    env_knobs::set("PRIOR", &mut track.prior_weight);
    env_knobs::set("MAX_MOTION", &mut track.max_motion);
    env_knobs::set("LIMIT_WEIGHT", &mut track.limit_weight);
    env_knobs::set_count("ANNEAL_STEPS", &mut track.anneal_steps);
    env_knobs::set("PREDICTION", &mut track.prediction);
    env_knobs::set_count("FINAL_ITERATIONS", &mut track.final_em_iterations);
    env_knobs::set("NOISE", &mut track.noise);
    env_knobs::set("EXPONENT", &mut track.bending_exponent);
    env_knobs::set("RELAXATION", &mut track.over_relaxation);
    if let Some(v) = env_knobs::number("POINT_TO_PLANE") {
        track.point_to_plane = v != 0.0;
    }
    if let Some(v) = env_knobs::number("VISIBLE_ONLY") {
        track.visible_only = v != 0.0;
    }
    if let Some(v) = env_knobs::number("HOLD_FREE") {
        track.hold_free_joints = v != 0.0;
    }
    let mut take = TakeOptions::default();
    if std::env::var("SWINGS").is_ok() {
        take.search.limb_swings = Some(LimbSwingOptions::default());
    }
    if let Some(v) = env_knobs::number("HALF_TURN") {
        take.search.half_turn = v != 0.0;
    }
    if let Some(v) = env_knobs::number("CLIP_PLACES") {
        take.search.clip_places = v != 0.0;
    }
    env_knobs::set_count("FULL_PASSES", &mut take.search.full_passes);
    env_knobs::set("REFINE_SIGMA", &mut take.search.refine_sigma);
    env_knobs::set_count("REFINE_STEPS", &mut take.search.refine_steps);
    env_knobs::set("FULL_PRIOR", &mut take.search.full_prior_weight);
    env_knobs::set_count("KEEP", &mut take.search.keep);
    env_knobs::set_count("LAID_KEPT", &mut take.search.laid_kept);
    env_knobs::set_count("HEADINGS", &mut take.search.headings);
    TakeSettings {
        track,
        take,
        from_truth: std::env::var("FROM_TRUTH").is_ok(),
    }
}

fn half_name(half: Option<Half>) -> &'static str {
    half.map_or("-", Half::name)
}

fn motion_name(motion: &Motion) -> String {
    match motion {
        Motion::Suite => "suite".into(),
        Motion::Clip {
            offset,
            length,
            bounced,
        } => format!(
            "clip {offset:.2}-{:.2} s{}",
            offset + length,
            if *bounced { " bounced" } else { "" }
        ),
        Motion::Synthetic => "synthetic".into(),
    }
}

/// One markdown row.
fn row(s: &MovedSequence, o: &TakeOutcome) -> String {
    let later = &o.root_angles[FROM.min(o.root_angles.len())..];
    let root_mean = later.iter().sum::<f64>() / later.len().max(1) as f64;
    let collapsed = if o.collapsed.is_empty() {
        "0".to_string()
    } else {
        format!(
            "{} ({} recovered; {:?})",
            o.collapsed.len(),
            o.recovered,
            o.collapsed
        )
    };
    format!(
        "| {} | {} | {} | {} | {} | {:.0} | {:.1} | {} | {:.2} | {:.0} / {:.0} | {:.2} | {:.2} | {} | {} | {} | {:.0} | {} |",
        s.id,
        half_name(s.half),
        s.kind,
        motion_name(&s.motion),
        s.seed,
        s.turn.to_degrees(),
        100.0 * s.max_step,
        o.start_label(),
        100.0 * o.init_error(),
        o.root_angles.first().copied().unwrap_or(0.0).to_degrees(),
        root_mean.to_degrees(),
        100.0 * o.mean_from(),
        100.0 * o.worst_from(),
        o.lost(),
        collapsed,
        if o.ok() { "yes" } else { "**no**" },
        o.ms_per_frame(),
        if o.twin { "yes" } else { "" },
    )
}

/// The rig's symmetries besides the identity, one line each: the reported joints each
/// moves, as cycles of names (`a -> b -> a`).
fn symmetry_lines(s: &MovedSequence) -> Vec<String> {
    let skeleton = &s.rig.skeleton;
    let reported: Vec<usize> = s.rig.reported_joints().collect();
    let found = rigfit_testkit::symmetry::rig_symmetries(&s.rig, &s.rig.pose, s.height);
    found
        .iter()
        .skip(1)
        .map(|p| {
            let moved = (0..p.len()).filter(|&i| p[i] != i).count();
            let mut done = vec![false; p.len()];
            let mut cycles = Vec::new();
            for &i in &reported {
                if done[i] || p[i] == i {
                    continue;
                }
                let mut cycle = vec![skeleton.joint(i).name.clone()];
                done[i] = true;
                let mut j = p[i];
                while !done[j] {
                    done[j] = true;
                    cycle.push(skeleton.joint(j).name.clone());
                    j = p[j];
                }
                cycle.push(skeleton.joint(j).name.clone());
                cycles.push(cycle.join(" -> "));
            }
            format!("{moved} joints moved: {}", cycles.join(", "))
        })
        .collect()
}

fn main() {
    let seeds = env_knobs::count("SEEDS", 3) as u64;
    let settings = settings();
    let points = env_knobs::count("POINTS", 2000);
    let verbose = std::env::var("VERBOSE").is_ok();
    let all_joints = std::env::var("VERBOSE").is_ok_and(|v| v == "2");
    let filter: Option<Vec<String>> = std::env::var("RIGS")
        .ok()
        .filter(|v| !v.is_empty() && v != "all")
        .map(|v| v.split(',').map(|s| s.trim().to_string()).collect());
    let everything = std::env::var("RIGS").is_ok_and(|v| v == "all");
    let chosen = |id: &str| filter.as_ref().is_none_or(|f| f.iter().any(|x| x == id));
    let options = SequenceOptions {
        points,
        ..SequenceOptions::default()
    };
    let corpus = match Corpus::load() {
        Ok(c) => Some(c),
        Err(e) => {
            eprintln!("{e}");
            None
        }
    };
    // The listed ids (suites' names aside), else the defaults.
    let mut rigs: Vec<String> = match &filter {
        Some(f) => f
            .iter()
            .filter(|id| !SUITES.iter().any(|(n, _)| n == id))
            .cloned()
            .collect(),
        None => CORPUS_RIGS.iter().map(|s| s.to_string()).collect(),
    };
    if let (true, Some(c)) = (everything, &corpus) {
        let suite_ids: Vec<&str> = SUITES.iter().map(|(_, id)| *id).collect();
        rigs = c
            .rigs
            .iter()
            .filter(|e| e.kind != RigKind::Marker && !suite_ids.contains(&e.id.as_str()))
            .map(|e| e.id.clone())
            .collect();
    }
    println!(
        "| rig | half | kind | motion | seed | turn (deg) | max step (%) | first frame | init error (%) | root turn error at 0 / mean from 5 (deg) | mean from {FROM} (%) | worst from {FROM} (%) | frames > 10% | collapsed | ok | ms/frame | twin |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    // Per half (None: not in the corpus): sequences, within the bounds, and so without
    // relabelling.
    let mut totals: Vec<(Option<Half>, usize, usize, usize)> = Vec::new();
    let mut untracked: Vec<(String, String)> = Vec::new();
    let mut record = |s: &MovedSequence, outcome: Result<TakeOutcome, String>| match outcome {
        Ok(o) => {
            println!("{}", row(s, &o));
            if verbose {
                let series: Vec<String> = o
                    .errors
                    .iter()
                    .map(|e| format!("{:.1}", 100.0 * e))
                    .collect();
                eprintln!("{} seed {}: errors (%) {}", s.id, s.seed, series.join(" "));
                let angles: Vec<String> = o
                    .root_angles
                    .iter()
                    .map(|a| format!("{:.0}", a.to_degrees()))
                    .collect();
                eprintln!("  root turn error (deg) {}", angles.join(" "));
                let start = s.model.start.clone();
                let at = s.rig.skeleton.joint_positions(&start);
                let bones: Vec<f64> = (0..at.len())
                    .map(|j| {
                        s.rig
                            .skeleton
                            .joint(j)
                            .parent
                            .map_or(0.0, |p| (at[j] - at[p]).norm() / s.height)
                    })
                    .collect();
                let worst: Vec<String> = o
                    .joint_means
                    .iter()
                    .take(6)
                    .map(|&(j, e)| {
                        let joint = s.model.skeleton.joint(j);
                        format!(
                            "{} {:.1} ({:?}, bone {:.1})",
                            joint.name,
                            100.0 * e,
                            joint.dof,
                            100.0 * bones[j]
                        )
                    })
                    .collect();
                eprintln!("  worst joints from frame {FROM} (%): {}", worst.join(", "));
                if all_joints {
                    let steps: Vec<String> = s
                        .frames
                        .windows(2)
                        .map(|w| {
                            let e = rigfit_testkit::track_suites::joint_error(
                                &s.rig,
                                &w[0].truth,
                                &w[1].truth,
                                s.height,
                            );
                            format!("{:.1}", 100.0 * e)
                        })
                        .collect();
                    eprintln!("  true steps (%) {}", steps.join(" "));
                    let every: Vec<String> = o
                        .joint_means
                        .iter()
                        .map(|&(j, e)| format!("{}={:.2}", s.rig.skeleton.joint(j).name, 100.0 * e))
                        .collect();
                    eprintln!("  all joints (%) {}", every.join(" "));
                }
            }
            match totals.iter_mut().find(|t| t.0 == s.half) {
                Some(t) => {
                    t.1 += 1;
                    t.2 += usize::from(o.ok());
                    t.3 += usize::from(o.strict_ok());
                }
                None => totals.push((s.half, 1, usize::from(o.ok()), usize::from(o.strict_ok()))),
            }
        }
        Err(e) => {
            println!(
                "| {} | {} | {} | - | {} | - | - | failed: {e} | | | | | | | **no** | | |",
                s.id,
                half_name(s.half),
                s.kind,
                s.seed
            );
            untracked.push((format!("{} seed {}", s.id, s.seed), e));
        }
    };
    for (name, _) in SUITES {
        if !chosen(name) {
            continue;
        }
        for seed in 0..seeds {
            let sequence = suite_sequence(name, seed, &options, corpus.as_ref());
            record(&sequence, track_sequence(&sequence, &settings));
        }
    }
    let mut unbuilt: Vec<(String, String)> = Vec::new();
    for id in &rigs {
        let Some(corpus) = &corpus else {
            unbuilt.push((id.clone(), "the corpus is missing".into()));
            continue;
        };
        for seed in 0..seeds {
            match corpus_sequence(corpus, id, seed, &options) {
                Ok(sequence) => {
                    if seed == 0 {
                        let model_height = sequence.model.height;
                        let extent = sequence
                            .rig
                            .bounds(&sequence.model.start)
                            .map_or(Default::default(), |b| b.extent());
                        eprintln!(
                            "{id}: height {:.4} along {:?} (search turns about {:?}; box {:.3?}), model height {model_height:.4}, {} joints reported, {} texture points",
                            sequence.height,
                            sequence.up.as_slice(),
                            sequence.search_up.as_slice(),
                            extent.as_slice(),
                            sequence.rig.reported_joints().count(),
                            sequence.model.surface_samples.len()
                        );
                        let symmetries = symmetry_lines(&sequence);
                        if symmetries.is_empty() {
                            eprintln!("  symmetries: the identity only");
                        }
                        for line in symmetries {
                            eprintln!("  symmetry: {line}");
                        }
                    }
                    record(&sequence, track_sequence(&sequence, &settings));
                }
                Err(e) => {
                    unbuilt.push((id.clone(), e));
                    break;
                }
            }
        }
    }
    println!("\n| half | sequences | within the bounds | share | within the bounds, strict |");
    println!("|---|---|---|---|---|");
    totals.sort_by_key(|t| t.0);
    let (mut all, mut all_ok, mut all_strict) = (0, 0, 0);
    for (half, n, ok, strict) in &totals {
        all += n;
        all_ok += ok;
        all_strict += strict;
        println!(
            "| {} | {n} | {ok} | {:.0}% | {strict} |",
            half_name(*half),
            100.0 * *ok as f64 / (*n).max(1) as f64
        );
    }
    println!(
        "| all | {all} | {all_ok} | {:.0}% | {all_strict} |",
        100.0 * all_ok as f64 / all.max(1) as f64
    );
    println!(
        "\nWithin the bounds: mean joint error below {:.0}% of the height from frame {FROM} on and no frame above {:.0}%.",
        100.0 * MEAN_BOUND,
        100.0 * FRAME_BOUND
    );
    println!(
        "Up to the rig's own symmetries (a twin the points cannot tell from the truth); strict: without relabelling."
    );
    if !unbuilt.is_empty() || !untracked.is_empty() {
        println!("\nNot tracked:");
        for (id, why) in unbuilt.iter().chain(&untracked) {
            println!("- {id}: {why}");
        }
    }
}
