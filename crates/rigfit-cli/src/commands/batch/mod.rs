//! `rigfit batch JOBS.json`: many independent takes (pose, track and surface jobs), each run
//! exactly as its own command line would run it. A failed take is one line and the others
//! carry on; a summary report lists every take. The job file format is in docs/batch.md.

mod jobs;

use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Instant;

use anyhow::{Context, anyhow, bail};
use clap::Parser;
use rigfit_formats::files::{check_outputs, write_atomic};
use serde_json::{Value, json};

use jobs::lexical;
pub use jobs::{JobFile, MAX_TAKES, TAKE_COMMANDS, Take, parse_jobs, read_jobs, take_from_json};

#[derive(Debug, clap::Args)]
pub struct BatchArgs {
    /// The job file: `{"takes": [{"name": ..., "command": "pose" | "track" | "surface",
    /// ...the command's arguments...}]}` (docs/batch.md). Relative paths in it are taken from
    /// its folder.
    pub jobs: PathBuf,
    /// Write the summary report (JSON): per take its name, command, status, error and seconds.
    #[arg(long)]
    pub report: Option<PathBuf>,
    /// Takes run at once, each on a thread of its own (the solvers share the cores).
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u16).range(1..=MAX_WORKERS as i64))]
    pub workers: u16,
}

/// The most takes run at once.
pub const MAX_WORKERS: u16 = 256;

/// What running one take did.
#[derive(Debug, Clone)]
pub struct TakeOutcome {
    pub name: String,
    pub command: String,
    /// The one-line error of a failed take.
    pub error: Option<String>,
    /// What the command would have printed.
    pub summary: String,
    pub seconds: f64,
}

/// What a batch did.
#[derive(Debug, Clone)]
pub struct BatchOutcome {
    pub jobs: PathBuf,
    pub takes: Vec<TakeOutcome>,
    pub workers: usize,
    pub seconds: f64,
}

impl BatchOutcome {
    /// How many takes failed.
    pub fn failed(&self) -> usize {
        self.takes.iter().filter(|t| t.error.is_some()).count()
    }

    /// The summary report (docs/batch.md).
    pub fn report(&self) -> Value {
        let takes: Vec<Value> = self.takes.iter().map(TakeOutcome::report).collect();
        json!({
            "jobs": self.jobs.display().to_string(),
            "workers": self.workers,
            "done": self.takes.len() - self.failed(),
            "failed": self.failed(),
            "seconds": self.seconds,
            "takes": takes,
        })
    }
}

impl TakeOutcome {
    /// This take's entry in the summary report.
    pub fn report(&self) -> Value {
        let mut entry = json!({
            "name": self.name,
            "command": self.command,
            "status": if self.error.is_some() { "failed" } else { "done" },
            "seconds": self.seconds,
            "attempts": 1,
        });
        match &self.error {
            Some(e) => entry["error"] = json!(e),
            None => entry["summary"] = json!(self.summary.trim_end()),
        }
        entry
    }
}

/// The commands a take may run, parsed as the command line parses them.
#[derive(Debug, Parser)]
#[command(name = "rigfit")]
enum TakeCommand {
    Pose(super::pose::PoseArgs),
    Track(super::track::TrackArgs),
    Surface(super::surface::SurfaceArgs),
}

/// Runs one take as its command line would (without progress bars or printing). A panic
/// is caught and reported as the take's error.
pub fn run_take(take: &Take) -> TakeOutcome {
    let t0 = Instant::now();
    let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| execute(take)))
        .unwrap_or_else(|_| Err(anyhow!("rigfit stopped on an internal error (a bug)")));
    let (summary, error) = match result {
        Ok(summary) => (summary, None),
        Err(e) => (
            String::new(),
            Some(format!("{e:#}").replace(['\n', '\r'], " ")),
        ),
    };
    TakeOutcome {
        name: take.name.clone(),
        command: take.command.clone(),
        error,
        summary,
        seconds: t0.elapsed().as_secs_f64(),
    }
}

fn execute(take: &Take) -> anyhow::Result<String> {
    let argv = take.command_line()?;
    let command = TakeCommand::try_parse_from(&argv)
        .map_err(|e| anyhow!("{}", super::argument_line(&e, &take.command)))?;
    // A night's outputs go to folders that may not exist yet: make them (the commands
    // alone ask for an existing folder).
    for output in take.outputs() {
        if let Some(folder) = output.parent().filter(|f| !f.as_os_str().is_empty()) {
            std::fs::create_dir_all(folder)
                .with_context(|| format!("{}: cannot create the folder", folder.display()))?;
        }
    }
    match command {
        // Posing prints nothing and shows no progress: it returns its summary.
        TakeCommand::Pose(args) => super::pose::run(&args),
        TakeCommand::Track(mut args) => {
            args.quiet = true;
            super::track::run(&args)
        }
        TakeCommand::Surface(mut args) => {
            args.quiet = true;
            super::surface::run(&args)
        }
    }
}

/// Runs `takes` on `workers` threads; `done` is called as each take ends (from its thread).
/// The outcomes come back in the takes' order.
pub fn run_takes(
    takes: &[Take],
    workers: usize,
    done: &(dyn Fn(&TakeOutcome) + Sync),
) -> Vec<TakeOutcome> {
    let next = AtomicUsize::new(0);
    let outcomes: Mutex<Vec<Option<TakeOutcome>>> = Mutex::new(vec![None; takes.len()]);
    std::thread::scope(|scope| {
        for _ in 0..workers.clamp(1, takes.len().max(1)) {
            scope.spawn(|| {
                loop {
                    let i = next.fetch_add(1, Ordering::Relaxed);
                    let Some(take) = takes.get(i) else { break };
                    let outcome = run_take(take);
                    done(&outcome);
                    if let Ok(mut all) = outcomes.lock() {
                        all[i] = Some(outcome);
                    }
                }
            });
        }
    });
    outcomes
        .into_inner()
        .unwrap_or_default()
        .into_iter()
        .zip(takes)
        .map(|(outcome, take)| {
            outcome.unwrap_or_else(|| TakeOutcome {
                name: take.name.clone(),
                command: take.command.clone(),
                error: Some("the take did not run".into()),
                summary: String::new(),
                seconds: 0.0,
            })
        })
        .collect()
}

/// Runs a job file: every take on `workers` threads (1 to [`MAX_WORKERS`]), a progress bar,
/// a line per failed take on stderr, the report. Errors only for a bad job file, report
/// path or worker count.
pub fn run_batch(
    jobs: &Path,
    report: Option<&Path>,
    workers: usize,
    show_progress: bool,
) -> anyhow::Result<BatchOutcome> {
    if !(1..=usize::from(MAX_WORKERS)).contains(&workers) {
        bail!("workers: expected 1 to {MAX_WORKERS}, got {workers}");
    }
    let file = read_jobs(jobs)?;
    if let Some(report) = report {
        check_outputs(&[jobs], &[report])?;
        if file
            .takes
            .iter()
            .any(|t| t.outputs().iter().any(|o| lexical(o) == lexical(report)))
        {
            bail!(
                "{}: a take writes this file too; the report needs a name of its own",
                report.display()
            );
        }
    }
    let progress = if show_progress {
        indicatif::ProgressBar::new(file.takes.len() as u64)
    } else {
        indicatif::ProgressBar::hidden()
    };
    progress.set_style(
        indicatif::ProgressStyle::with_template("takes {bar:30} {pos}/{len} {msg}")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    let failed = AtomicUsize::new(0);
    let t0 = Instant::now();
    let takes = run_takes(&file.takes, workers, &|outcome| {
        if let Some(error) = &outcome.error {
            let n = failed.fetch_add(1, Ordering::Relaxed) + 1;
            progress.suspend(|| {
                eprintln!(
                    "rigfit: take '{}' ({}) failed: {error}",
                    outcome.name, outcome.command
                );
            });
            progress.set_message(format!("({n} failed)"));
        }
        progress.inc(1);
    });
    progress.finish_and_clear();
    let outcome = BatchOutcome {
        jobs: jobs.to_path_buf(),
        takes,
        workers,
        seconds: t0.elapsed().as_secs_f64(),
    };
    if let Some(report) = report {
        let text = serde_json::to_string_pretty(&outcome.report()).context("the report")? + "\n";
        write_atomic(report, text.as_bytes())?;
    }
    Ok(outcome)
}

/// `rigfit batch`: prints the summary line; the caller turns failed takes into exit status 1.
pub fn run(args: &BatchArgs) -> anyhow::Result<BatchOutcome> {
    let outcome = run_batch(
        &args.jobs,
        args.report.as_deref(),
        args.workers.into(),
        true,
    )?;
    println!(
        "{} takes from {} in {:.1} s on {} worker(s): {} done, {} failed{}",
        outcome.takes.len(),
        args.jobs.display(),
        outcome.seconds,
        outcome.workers,
        outcome.takes.len() - outcome.failed(),
        outcome.failed(),
        args.report
            .as_ref()
            .map(|r| format!(" (report: {})", r.display()))
            .unwrap_or_default()
    );
    Ok(outcome)
}
