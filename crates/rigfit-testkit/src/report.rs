//! Tables of a sweep's outcomes: per rig and scenario, totals per half, the worst cases,
//! and the check of the required success rates on the held-out half.

use std::fmt::Write as _;

use crate::corpus::Half;
use crate::scenario::Scenario;
use crate::sweep::Outcome;

/// The outcomes of one group of cases (a rig and scenario, or a half and scenario).
#[derive(Clone, Debug, PartialEq)]
pub struct Summary {
    /// The rig id, or `all` for a half's totals.
    pub rig: String,
    pub half: Half,
    pub scenario: Scenario,
    pub cases: usize,
    pub successes: usize,
    /// Cases that succeed judged against the truth itself, not its twin nearer the start
    /// ([`Outcome::strict_success`]).
    pub strict_successes: usize,
    /// Failures whose result fits the strokes as well as the truth ([`Outcome::ambiguous`]).
    pub ambiguous: usize,
    /// The mean over cases of each case's mean drawn-joint error (failed solves left out).
    pub mean_of_means: f64,
    /// The largest drawn-joint error of any case.
    pub worst_max: f64,
    pub median_ms: f64,
}

impl Summary {
    /// The share of cases that succeeded (0 for no cases).
    pub fn success_rate(&self) -> f64 {
        self.share(self.successes)
    }

    /// The share of cases that succeed judged against the truth itself.
    pub fn strict_success_rate(&self) -> f64 {
        self.share(self.strict_successes)
    }

    /// The share of cases that failed on an ambiguous drawing.
    pub fn ambiguous_rate(&self) -> f64 {
        self.share(self.ambiguous)
    }

    /// `count` as a share of the cases (0 for no cases).
    fn share(&self, count: usize) -> f64 {
        if self.cases == 0 {
            0.0
        } else {
            count as f64 / self.cases as f64
        }
    }

    fn of(rig: &str, half: Half, scenario: Scenario, outcomes: &[&Outcome]) -> Self {
        let finite: Vec<f64> = outcomes
            .iter()
            .map(|o| o.mean_error)
            .filter(|e| e.is_finite())
            .collect();
        let mut ms: Vec<f64> = outcomes.iter().map(|o| o.seconds * 1e3).collect();
        ms.sort_by(f64::total_cmp);
        let median_ms = match ms.len() {
            0 => f64::NAN,
            n if n % 2 == 1 => ms[n / 2],
            n => 0.5 * (ms[n / 2 - 1] + ms[n / 2]),
        };
        Self {
            rig: rig.to_string(),
            half,
            scenario,
            cases: outcomes.len(),
            successes: outcomes.iter().filter(|o| o.success()).count(),
            strict_successes: outcomes.iter().filter(|o| o.strict_success).count(),
            ambiguous: outcomes.iter().filter(|o| o.ambiguous()).count(),
            mean_of_means: if finite.is_empty() {
                f64::INFINITY
            } else {
                finite.iter().sum::<f64>() / finite.len() as f64
            },
            worst_max: outcomes.iter().map(|o| o.max_error).fold(0.0, f64::max),
            median_ms,
        }
    }
}

/// One summary per rig and scenario, rigs in the order they were swept.
pub fn per_rig(outcomes: &[Outcome]) -> Vec<Summary> {
    let mut rigs: Vec<(&str, Half)> = Vec::new();
    for o in outcomes {
        if !rigs.iter().any(|(r, _)| *r == o.rig) {
            rigs.push((&o.rig, o.half));
        }
    }
    let mut out = Vec::new();
    for (rig, half) in rigs {
        for scenario in Scenario::ALL {
            let group: Vec<&Outcome> = outcomes
                .iter()
                .filter(|o| o.rig == rig && o.scenario == scenario)
                .collect();
            if !group.is_empty() {
                out.push(Summary::of(rig, half, scenario, &group));
            }
        }
    }
    out
}

/// One summary per half and scenario over all its rigs.
pub fn per_half(outcomes: &[Outcome]) -> Vec<Summary> {
    let mut out = Vec::new();
    for half in Half::ALL {
        for scenario in Scenario::ALL {
            let group: Vec<&Outcome> = outcomes
                .iter()
                .filter(|o| o.half == half && o.scenario == scenario)
                .collect();
            if !group.is_empty() {
                out.push(Summary::of("all", half, scenario, &group));
            }
        }
    }
    out
}

fn percent(x: f64) -> String {
    if x.is_finite() {
        format!("{:.2}", 100.0 * x)
    } else {
        "failed".into()
    }
}

/// A plain-text table of summaries (errors in percent of the height).
pub fn text_table(summaries: &[Summary]) -> String {
    let width = summaries
        .iter()
        .map(|s| s.rig.len())
        .max()
        .unwrap_or(3)
        .max(3);
    let mut out = format!(
        "{:width$}  {:8}  {:11}  {:>5}  {:>9}  {:>8}  {:>10}  {:>10}  {:>9}  {:>9}\n",
        "rig",
        "half",
        "scenario",
        "cases",
        "success%",
        "strict%",
        "ambiguous%",
        "mean err%",
        "worst max%",
        "median ms"
    );
    for s in summaries {
        let _ = writeln!(
            out,
            "{:width$}  {:8}  {:11}  {:>5}  {:>9.1}  {:>8.1}  {:>10.1}  {:>10}  {:>9}  {:>9.1}",
            s.rig,
            s.half.name(),
            s.scenario.name(),
            s.cases,
            100.0 * s.success_rate(),
            100.0 * s.strict_success_rate(),
            100.0 * s.ambiguous_rate(),
            percent(s.mean_of_means),
            percent(s.worst_max),
            s.median_ms,
        );
    }
    out
}

/// A Markdown table of summaries, ready for BENCHMARKS.md.
pub fn markdown_table(summaries: &[Summary]) -> String {
    let mut out = String::from(
        "| rig | half | scenario | cases | success | strict | ambiguous | mean error | worst max error | median ms |\n\
         |---|---|---|---:|---:|---:|---:|---:|---:|---:|\n",
    );
    for s in summaries {
        let _ = writeln!(
            out,
            "| {} | {} | {} | {} | {:.0}% | {:.0}% | {:.0}% | {}% | {}% | {:.1} |",
            s.rig,
            s.half.name(),
            s.scenario.name(),
            s.cases,
            100.0 * s.success_rate(),
            100.0 * s.strict_success_rate(),
            100.0 * s.ambiguous_rate(),
            percent(s.mean_of_means),
            percent(s.worst_max),
            s.median_ms,
        );
    }
    out
}

/// The `count` cases furthest past the bounds, worst first.
pub fn worst_cases(outcomes: &[Outcome], count: usize) -> Vec<&Outcome> {
    let mut sorted: Vec<&Outcome> = outcomes.iter().collect();
    sorted.sort_by(|a, b| b.badness().total_cmp(&a.badness()));
    sorted.truncate(count);
    sorted
}

/// One line per case: what it was, what it gave, and the options that rerun it alone.
pub fn worst_table(cases: &[&Outcome]) -> String {
    let mut out = String::new();
    for o in cases {
        let result = match &o.failure {
            Some(failure) => format!("solve failed: {failure}"),
            None => {
                format!(
                    "mean {}%  max {}% at {}  undrawn motion {}%  misfit {}% (its own chains {}%, truth {}%){}",
                    percent(o.mean_error),
                    percent(o.max_error),
                    o.worst_joint,
                    percent(o.undrawn_motion),
                    percent(o.misfit),
                    percent(o.own_misfit),
                    percent(o.truth_misfit),
                    if o.ambiguous() { "  ambiguous" } else { "" },
                ) + if o.twinned {
                    "  (expects the twin)"
                } else {
                    ""
                }
            }
        };
        let _ = writeln!(
            out,
            "{} {} case {} ({} target, {} strokes, {} drawn joints): {}  {:.0} ms  [--rig {} --scenario {} --case {}]",
            o.rig,
            o.scenario.name(),
            o.case,
            o.target.name(),
            o.strokes,
            o.drawn_joints,
            result,
            o.seconds * 1e3,
            o.rig,
            o.scenario.name(),
            o.case,
        );
    }
    out
}

/// How many of the worst held-out cases a failed check lists.
const HELD_OUT_WORST_SHOWN: usize = 5;

/// Checks each scenario's required success rate on the held-out half. The error names the
/// scenarios short of it and holds both halves' totals and the worst held-out cases.
pub fn check_held_out(outcomes: &[Outcome], scenarios: &[Scenario]) -> Result<(), String> {
    let totals = per_half(outcomes);
    let mut short = Vec::new();
    let mut short_scenarios = Vec::new();
    for &scenario in scenarios {
        let held_out = totals
            .iter()
            .find(|s| s.half == Half::HeldOut && s.scenario == scenario);
        match held_out {
            None => short.push(format!("{}: no held-out cases", scenario.name())),
            Some(s) if s.success_rate() < scenario.required_success() => {
                short_scenarios.push(scenario);
                short.push(format!(
                    "{}: {:.1}% of {} held-out cases succeeded, {:.0}% required",
                    scenario.name(),
                    100.0 * s.success_rate(),
                    s.cases,
                    100.0 * scenario.required_success()
                ));
            }
            Some(_) => {}
        }
    }
    if short.is_empty() {
        Ok(())
    } else {
        let failed: Vec<Outcome> = outcomes
            .iter()
            .filter(|o| o.half == Half::HeldOut && short_scenarios.contains(&o.scenario))
            .cloned()
            .collect();
        Err(format!(
            "{}\n\nboth halves:\n{}\nworst held-out cases:\n{}",
            short.join("\n"),
            text_table(&totals),
            worst_table(&worst_cases(&failed, HELD_OUT_WORST_SHOWN))
        ))
    }
}
