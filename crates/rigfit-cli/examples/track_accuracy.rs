//! The tracking accuracy table of BENCHMARKS.md: 60-frame ground-truth sequences drawn from
//! the real assets (see tests/common/track_suites.rs), tracked by the EM of Dewaele et al.
//! as published and with rigfit's additions one by one.
//!
//! `cargo run --release -p rigfit-cli --example track_accuracy [SUITE...]` (`VERBOSE=1`
//! prints every frame)

#[path = "../tests/common/track_suites.rs"]
mod track_suites;

use rigfit_core::track::cases::SequenceOptions;
use rigfit_core::track::{TextureSource, TrackOptions};

fn main() {
    let paper = TrackOptions::paper();
    let methods: Vec<(&str, TrackOptions)> = vec![
        ("paper (EM, texture refreshed from data)", paper.clone()),
        (
            "+ surface fit (eq. 21)",
            TrackOptions {
                surface_fit_steps: 2,
                ..paper.clone()
            },
        ),
        (
            "+ model-surface texture",
            TrackOptions {
                texture: TextureSource::ModelSurface,
                ..paper.clone()
            },
        ),
        (
            "+ motion prediction",
            TrackOptions {
                texture: TextureSource::ModelSurface,
                prediction: 0.5,
                ..paper.clone()
            },
        ),
        ("rigfit (+ coarse-to-fine)", TrackOptions::default()),
    ];
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
