//! The tracking accuracy table of BENCHMARKS.md: 60-frame ground-truth sequences drawn from
//! the real assets (see tests/common/track_suites.rs), tracked by the EM of Dewaele et al.
//! as published and with rigfit's additions one by one.
//!
//! `cargo run --release -p rigfit-testkit --example track_accuracy [SUITE...]` (`VERBOSE=1`
//! prints every frame, `DEFAULTS_ONLY=1` runs rigfit's defaults alone, `LIMIT_WEIGHT` sets the soft
//! limits' weight, `JOINT_MODEL=none` or `ranges` tracks without the clips' hinges, see `track_suites::tracked_rig`)

use rigfit_testkit::track_suites;

use rigfit_core::track::{TextureSource, TrackOptions};
use rigfit_testkit::track_cases::SequenceOptions;

fn main() {
    let paper = TrackOptions::paper();
    let mut rigfit = TrackOptions::default();
    if let Some(w) = std::env::var("LIMIT_WEIGHT")
        .ok()
        .and_then(|v| v.parse().ok())
    {
        rigfit.limit_weight = w;
    }
    // The paper's method, then rigfit's additions one at a time (each on top of the
    // previous), ending with rigfit's defaults.
    let no_refresh = TrackOptions {
        texture: TextureSource::ModelSurface,
        ..paper.clone()
    };
    let schedule = TrackOptions {
        max_motion: rigfit.max_motion,
        anneal_steps: rigfit.anneal_steps,
        em_iterations: rigfit.em_iterations,
        ..no_refresh.clone()
    };
    let relaxed = TrackOptions {
        over_relaxation: rigfit.over_relaxation,
        ..schedule.clone()
    };
    let predicted = TrackOptions {
        prediction: rigfit.prediction,
        ..relaxed.clone()
    };
    let visible = TrackOptions {
        visible_only: true,
        coarse_to_fine: true,
        ..predicted.clone()
    };
    let mut methods: Vec<(&str, TrackOptions)> = vec![
        ("paper (EM, texture refreshed from data)", paper.clone()),
        (
            "paper + surface fit pass (eq. 21)",
            TrackOptions {
                surface_fit_steps: 2,
                ..paper.clone()
            },
        ),
        ("+ texture kept on the model surface", no_refresh),
        ("+ shorter schedule (sigma0 4%, 4 steps)", schedule),
        ("+ over-relaxed M-steps (1.8)", relaxed),
        ("+ motion prediction (0.5)", predicted),
        ("+ view-aware, coarse-to-fine matching", visible),
        (
            "+ point-to-plane pulls",
            TrackOptions {
                tangential: 0.0,
                ..rigfit.clone()
            },
        ),
        ("rigfit (+ 0.3 of each pull along the surface)", rigfit),
    ];
    // `DEFAULTS_ONLY=1`: rigfit's defaults alone (for comparing joint models, JOINT_MODEL).
    let methods = if std::env::var("DEFAULTS_ONLY").is_ok() {
        methods.split_off(methods.len() - 1)
    } else {
        methods
    };
    let names: Vec<String> = std::env::args().skip(1).collect();
    let all = ["BCN_Epileptic", "Testwuson", "hand", "01_01"];
    let chosen: Vec<&'static str> = all
        .into_iter()
        .filter(|n| names.is_empty() || names.iter().any(|m| m == n))
        .collect();
    let suites: Vec<_> = chosen
        .iter()
        .map(|n| track_suites::suite(n, track_suites::FRAMES, &SequenceOptions::default()))
        .collect();
    println!("| method | sequence | mean joint error (% height) | worst frame (%) | ms/frame |");
    println!("|---|---|---|---|---|");
    for (mname, options) in &methods {
        for suite in &suites {
            let outcome = track_suites::track(suite, options);
            if std::env::var("VERBOSE").is_ok() {
                for (f, e) in outcome.frame_errors.iter().enumerate() {
                    eprintln!(
                        "{} {mname} frame {f}: {:.2}% ({} inliers)",
                        suite.name,
                        e * 100.0,
                        outcome.inliers[f]
                    );
                }
            }
            println!(
                "| {mname} | {} | {:.2} | {:.2} | {:.2} |",
                suite.name,
                outcome.mean() * 100.0,
                outcome.worst() * 100.0,
                outcome.ms_per_frame()
            );
        }
    }
}
