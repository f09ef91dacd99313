//! One corpus case as a picture: the true pose, the start pose and the solver's result,
//! the strokes over each in the colour of the bones they were matched to (strays grey).
//!
//! ```text
//! cargo run --release -p rigfit-testkit --example pose_case -- \
//!     --rig ID --scenario NAME --case I [--out FILE.png] [--detail yes] [--pin truth] \
//!     [--start truth]
//! ```
//! Prints the case's errors and each stroke's matched bones beside the chain it was drawn
//! along; with `--detail yes`, also each joint's turn from the start and its excess over
//! its limits (degrees) in the truth and in the answer. Two ways to tell a failure of the
//! search from one of the score: `--pin truth` pins every stroke to the chain it was drawn
//! along; `--start truth` offers the true pose as one more start (a search failure then
//! succeeds).

use std::process::ExitCode;

use rigfit_core::pose::PoseOptions;
use rigfit_render::{RenderOptions, Scene, chain_colors, render_side_by_side, stroke_colors};
use rigfit_testkit::sweep::solve_generated;
use rigfit_testkit::{Corpus, Scenario, generate_case, pinned_to_drawn_chains};

/// A flag's value that is `truth` (true) or `nothing` (false).
fn truth_or_nothing(flag: &str, value: &str) -> Result<bool, String> {
    match value {
        "truth" => Ok(true),
        "nothing" => Ok(false),
        _ => Err(format!("{flag}: '{value}' is not truth or nothing")),
    }
}

fn run() -> Result<(), String> {
    let mut rig_id = None;
    let mut scenario = Scenario::EveryChain;
    let mut index = 0usize;
    let mut out = std::path::PathBuf::from("pose_case.png");
    let mut detail = false;
    let mut pin_truth = false;
    let mut start_truth = false;
    let mut it = std::env::args().skip(1);
    while let Some(flag) = it.next() {
        let value = it.next().ok_or_else(|| format!("{flag} needs a value"))?;
        match flag.as_str() {
            "--rig" => rig_id = Some(value),
            "--scenario" => {
                scenario = Scenario::from_name(&value)
                    .ok_or_else(|| format!("--scenario: '{value}' is not a scenario"))?
            }
            "--case" => {
                index = value
                    .parse()
                    .map_err(|_| format!("--case: '{value}' is not a count"))?
            }
            "--out" => out = value.into(),
            "--detail" => {
                detail = match value.as_str() {
                    "yes" => true,
                    "no" => false,
                    _ => return Err(format!("--detail: '{value}' is not yes or no")),
                }
            }
            "--pin" => pin_truth = truth_or_nothing(&flag, &value)?,
            "--start" => start_truth = truth_or_nothing(&flag, &value)?,
            other => return Err(format!("unknown flag {other}")),
        }
    }
    let rig_id = rig_id.ok_or("--rig is required")?;
    let corpus = Corpus::load().map_err(|e| e.to_string())?;
    let entry = corpus
        .entry(&rig_id)
        .ok_or_else(|| format!("no rig {rig_id} in the corpus"))?;
    let rig = corpus.read_rig(entry).map_err(|e| e.to_string())?;
    let mut generated = generate_case(&rig, scenario, index);
    if pin_truth {
        generated.case.strokes = pinned_to_drawn_chains(rig.solver_skeleton(), &generated.case);
    }
    let skeleton = &rig.rig.skeleton;
    let mut options = PoseOptions::default();
    if start_truth {
        options.extra_starts = vec![generated.truth.clone()];
    }
    let solved = solve_generated(&rig, &generated, &options);
    let strokes = solved.strokes;
    let result = solved.result.map_err(|e| e.to_string())?;
    let errors = generated.errors(&rig, &result.pose);
    if generated.twinned() {
        println!(
            "the case expects the truth's twin under one of the rig's symmetries (it lies \
             nearer the start and draws the same strokes); against the truth itself: mean {:.2}%",
            100.0 * generated.strict_errors(&rig, &result.pose).mean
        );
    }
    println!(
        "{rig_id} {} case {index} ({} target): mean {:.2}%, max {:.2}% at {}",
        scenario.name(),
        generated.target.name(),
        100.0 * errors.mean,
        100.0 * errors.max,
        errors
            .worst
            .map_or("-", |j| skeleton.joint(j).name.as_str())
    );
    let name = |bones: &[usize]| {
        bones
            .iter()
            .map(|&j| skeleton.joint(j).name.as_str())
            .collect::<Vec<_>>()
            .join(">")
    };
    for (i, (drawn, matched)) in generated
        .case
        .stroke_chains
        .iter()
        .zip(&result.stroke_bones)
        .enumerate()
    {
        // Right when every matched bone lies on the chain the stroke was drawn along.
        let verdict = match (drawn.is_empty(), matched.is_empty()) {
            (true, true) => "ok (stray)",
            (true, false) => "WRONG (a stray matched)",
            (false, true) => "WRONG (set aside)",
            (false, false) if matched.iter().all(|j| drawn.contains(j)) => "ok",
            (false, false) => "WRONG",
        };
        println!(
            "  stroke {i}: drawn [{}] matched [{}] {verdict}",
            name(drawn),
            name(matched)
        );
    }
    if detail {
        // Per joint, how far truth and result turn from the start and lie outside limits.
        let solver_skeleton = rig.solver_skeleton();
        for j in 0..skeleton.len() {
            let joint = solver_skeleton.joint(j);
            let turn = |p: &rigfit_core::Pose| {
                (rig.start.local[j].rotation.inverse() * p.local[j].rotation).angle()
            };
            let excess = |p: &rigfit_core::Pose| {
                joint.limits.as_ref().map_or(0.0, |l| {
                    let relative =
                        (joint.rest.rotation.inverse() * p.local[j].rotation).scaled_axis();
                    rigfit_core::joint_model::limit_excess(&joint.dof, l, &relative).norm()
                })
            };
            let (tt, rt) = (turn(&generated.truth), turn(&result.pose));
            if tt > 1e-3 || rt > 1e-3 {
                println!(
                    "  {:<24} turn truth {:6.1} result {:6.1}  excess truth {:6.1} result {:6.1}",
                    joint.name,
                    tt.to_degrees(),
                    rt.to_degrees(),
                    excess(&generated.truth).to_degrees(),
                    excess(&result.pose).to_degrees()
                );
            }
        }
    }
    let joint_colors = chain_colors(skeleton);
    let colors = stroke_colors(&result.stroke_bones, &joint_colors);
    let truth_colors = stroke_colors(&generated.case.stroke_chains, &joint_colors);
    let panel = |pose: &rigfit_core::Pose, colors: &[rigfit_render::Color]| {
        let mut scene = Scene::new();
        scene
            .add_skeleton(skeleton, pose)
            .add_strokes(&strokes, colors);
        scene
    };
    let truth = panel(&generated.truth, &truth_colors);
    let start = panel(&rig.start, &colors);
    let posed = panel(&result.pose, &colors);
    let options = RenderOptions {
        tile: 300,
        ..RenderOptions::default()
    };
    let image = render_side_by_side(
        &[("truth", &truth), ("start", &start), ("result", &posed)],
        &options,
    );
    let png = image.png().map_err(|e| e.to_string())?;
    std::fs::write(&out, png).map_err(|e| format!("{}: {e}", out.display()))?;
    println!("picture: {}", out.display());
    Ok(())
}

fn main() -> ExitCode {
    match run() {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("pose_case: {e}");
            ExitCode::from(2)
        }
    }
}
