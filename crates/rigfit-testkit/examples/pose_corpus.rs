//! The posing solver over the corpus of real rigs: per rig and scenario, the share of cases
//! within the bounds (mean drawn-joint error at most 3% of the height, no drawn joint over
//! 10%), the mean error, the worst joint error and the median solve time; totals per half.
//!
//! ```text
//! cargo run --release -p rigfit-testkit --example pose_corpus -- \
//!     [--half tune|held-out|all] [--scenario NAME|all] [--cases N] [--case I] [--rig ID[,ID]]
//!     [--method default|joint-model|global|greedy|paper] [--threads N] [--worst K] [--markdown]
//!     [--offer nothing|truth|truth-root]
//! ```
//! Scenarios: every-chain, limbs-only, few-limbs, flattened, far. The corpus is
//! `RIGFIT_CORPUS_MANIFEST` (default `data/corpus.json`) over the folder `RIGFIT_CORPUS`.
//! A case of `--worst` reruns alone with the `--rig`, `--scenario` and `--case` it prints.
//! `--offer` gives every solve one more start, the true pose or the start pose with the root
//! placed as in the truth: a diagnostic (what remains failing, the score chose; what it
//! fixes, the search missed).

use std::process::ExitCode;

use rigfit_core::pose::PoseOptions;
use rigfit_testkit::report::{
    check_held_out, markdown_table, per_half, per_rig, text_table, worst_cases, worst_table,
};
use rigfit_testkit::sweep::Offer;
use rigfit_testkit::{Corpus, Half, Scenario, SweepOptions, sweep};

const USAGE: &str = "usage: pose_corpus [--half tune|held-out|all] [--scenario NAME|all] \
[--cases N] [--case I] [--rig ID[,ID...]] [--method default|joint-model|global|greedy|paper] [--threads N] [--worst K] \
[--markdown] [--offer nothing|truth|truth-root]";

struct Args {
    sweep: SweepOptions,
    method: &'static str,
    worst: usize,
    markdown: bool,
}

/// The options, or `None` when `--help` was asked for.
fn parse_args() -> Result<Option<Args>, String> {
    let mut args = Args {
        sweep: SweepOptions {
            cases: 6,
            ..SweepOptions::default()
        },
        method: "default",
        worst: 0,
        markdown: false,
    };
    let mut it = std::env::args().skip(1);
    while let Some(flag) = it.next() {
        if flag == "--markdown" {
            args.markdown = true;
            continue;
        }
        if flag == "-h" || flag == "--help" {
            return Ok(None);
        }
        let value = it
            .next()
            .ok_or_else(|| format!("{flag} needs a value\n{USAGE}"))?;
        let number = |v: &str| {
            v.parse::<usize>()
                .map_err(|_| format!("{flag}: '{v}' is not a count"))
        };
        match flag.as_str() {
            "--half" => {
                args.sweep.half =
                    match value.as_str() {
                        "all" => None,
                        name => Some(Half::from_name(name).ok_or_else(|| {
                            format!("--half: '{name}' is not tune, held-out or all")
                        })?),
                    }
            }
            "--offer" => {
                args.sweep.offer = Offer::from_name(&value).ok_or_else(|| {
                    format!("--offer: '{value}' is not nothing, truth or truth-root")
                })?
            }
            "--scenario" => {
                args.sweep.scenarios = match value.as_str() {
                    "all" => Scenario::ALL.to_vec(),
                    names => names
                        .split(',')
                        .map(|n| {
                            Scenario::from_name(n).ok_or_else(|| {
                                let all: Vec<&str> =
                                    Scenario::ALL.iter().map(|s| s.name()).collect();
                                format!("--scenario: '{n}' is none of {} or all", all.join(", "))
                            })
                        })
                        .collect::<Result<_, _>>()?,
                }
            }
            "--cases" => args.sweep.cases = number(&value)?,
            "--case" => args.sweep.only_case = Some(number(&value)?),
            "--rig" => args.sweep.rigs = value.split(',').map(str::to_string).collect(),
            "--threads" => args.sweep.threads = Some(number(&value)?.max(1)),
            "--worst" => args.worst = number(&value)?,
            "--method" => {
                (args.sweep.pose, args.method) = match value.as_str() {
                    "default" => (PoseOptions::default(), "default"),
                    // The solver given the rig's joint model (`rigfit pose --joints`).
                    "joint-model" => {
                        args.sweep.joint_model = true;
                        (PoseOptions::default(), "joint-model")
                    }
                    "paper" => (PoseOptions::paper(), "paper"),
                    // The ablation steps of BENCHMARKS.md: the chain step as it was (greedy,
                    // by distance at the current pose), then with the global assignment.
                    "greedy" => (
                        PoseOptions {
                            global_assignment: false,
                            shape_matching: false,
                            ..PoseOptions::default()
                        },
                        "greedy",
                    ),
                    "global" => (
                        PoseOptions {
                            shape_matching: false,
                            ..PoseOptions::default()
                        },
                        "global",
                    ),
                    other => {
                        return Err(format!(
                            "--method: '{other}' is not default, joint-model, global, greedy or paper"
                        ));
                    }
                }
            }
            other => return Err(format!("unknown option '{other}'\n{USAGE}")),
        }
    }
    Ok(Some(args))
}

fn main() -> ExitCode {
    let args = match parse_args() {
        Ok(Some(args)) => args,
        Ok(None) => {
            println!("{USAGE}");
            return ExitCode::SUCCESS;
        }
        Err(message) => {
            eprintln!("{message}");
            return ExitCode::from(2);
        }
    };
    let corpus = match Corpus::load() {
        Ok(corpus) => corpus,
        Err(e) => {
            eprintln!("{e}");
            return ExitCode::from(2);
        }
    };
    let cases = args.sweep.only_case.map_or(args.sweep.cases, |_| 1);
    eprintln!(
        "pose_corpus: {} method, {cases} case(s) per rig and scenario, corpus {}",
        args.method,
        corpus.manifest.display()
    );
    let result = sweep(&corpus, &args.sweep, |rig, outcomes| {
        let ok = outcomes.iter().filter(|o| o.success()).count();
        eprintln!(
            "  {} ({} joints, height {:.4}): {ok}/{} within bounds",
            rig.entry.id,
            rig.rig.skeleton.len(),
            rig.height,
            outcomes.len()
        );
    });
    let outcomes = match result {
        Ok(outcomes) => outcomes,
        Err(e) => {
            eprintln!("{e}");
            return ExitCode::from(2);
        }
    };
    let rigs = per_rig(&outcomes);
    let halves = per_half(&outcomes);
    if args.markdown {
        println!(
            "Method `{}`, {cases} case(s) per rig and scenario.\n",
            args.method
        );
        println!("{}", markdown_table(&rigs));
        println!("Totals per half:\n");
        println!("{}", markdown_table(&halves));
    } else {
        println!("{}", text_table(&rigs));
        println!("totals per half:");
        println!("{}", text_table(&halves));
    }
    if outcomes.iter().any(|o| o.half == Half::HeldOut) {
        match check_held_out(&outcomes, &args.sweep.scenarios) {
            Ok(()) => println!("held-out half: every scenario meets its required success rate"),
            Err(message) => println!(
                "held-out half short of the required success rates:\n{}",
                message.split("\n\n").next().unwrap_or_default()
            ),
        }
    }
    if args.worst > 0 {
        println!("\nworst {} case(s):", args.worst);
        print!("{}", worst_table(&worst_cases(&outcomes, args.worst)));
    }
    ExitCode::SUCCESS
}
