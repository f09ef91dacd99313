//! `rigfit.run_take`, `rigfit.read_jobs` and `rigfit.run_batch`: the takes of a job file
//! (docs/batch.md) run by the command line's own code, so a take's outputs are the same
//! whether `rigfit batch`, Python or a cluster worker (`rigfit.cluster`) runs it.

use std::path::PathBuf;

use pyo3::prelude::*;
use rigfit_cli::commands::batch::{self, Take};
use serde_json::{Map, Value};

use crate::error;

/// A Python object (dicts, lists, strings, numbers) as JSON.
fn to_json(py: Python<'_>, object: &Bound<'_, PyAny>, what: &str) -> PyResult<Value> {
    let text: String = py
        .import("json")?
        .call_method1("dumps", (object,))
        .and_then(|t| t.extract())
        .map_err(|e| error(format!("{what}: not JSON data: {e}")))?;
    serde_json::from_str(&text).map_err(|e| error(format!("{what}: {e}")))
}

/// JSON as a Python object.
fn to_python(py: Python<'_>, value: &Value) -> PyResult<Py<PyAny>> {
    Ok(py
        .import("json")?
        .call_method1("loads", (value.to_string(),))?
        .unbind())
}

/// A take as written in a job file, with its name filled in.
fn take_json(take: &Take) -> Value {
    let mut object = Map::new();
    object.insert("name".into(), Value::String(take.name.clone()));
    object.insert("command".into(), Value::String(take.command.clone()));
    object.extend(take.arguments.clone());
    Value::Object(object)
}

/// Runs one take (a dict as in a job file: ``name``, ``command`` and the command's
/// arguments) as ``rigfit COMMAND`` would; relative paths start from ``base_dir`` (default:
/// the current folder). Returns ``{"name", "command", "status", "summary", "seconds",
/// "attempts"}``; raises ``RigfitError`` with the take's one line when it fails.
#[pyfunction]
#[pyo3(signature = (take, base_dir=None))]
pub fn run_take(
    py: Python<'_>,
    take: &Bound<'_, PyAny>,
    base_dir: Option<PathBuf>,
) -> PyResult<Py<PyAny>> {
    let value = to_json(py, take, "take")?;
    let base = base_dir.unwrap_or_default();
    let take =
        batch::take_from_json(&value, 0, &base).map_err(|e| error(format!("take: {e:#}")))?;
    let outcome = py.detach(|| batch::run_take(&take));
    if let Some(e) = &outcome.error {
        return Err(error(format!("take '{}': {e}", outcome.name)));
    }
    to_python(py, &outcome.report())
}

/// Reads and checks a job file (its structure, names, commands, and that no two takes
/// write the same output). Returns ``(takes, base_dir)``: the takes as dicts with their
/// names filled in, and the folder their relative paths start from.
#[pyfunction]
pub fn read_jobs(py: Python<'_>, path: PathBuf) -> PyResult<(Py<PyAny>, PathBuf)> {
    let file = py
        .detach(|| batch::read_jobs(&path))
        .map_err(|e| error(format!("{e:#}")))?;
    let takes = Value::Array(file.takes.iter().map(take_json).collect());
    Ok((to_python(py, &takes)?, file.base))
}

/// Runs every take of a job file on ``workers`` threads, as ``rigfit batch`` does: a line
/// on stderr per failed take, the others carrying on, the summary report written to
/// ``report`` (if given) and returned as a dict (``done``, ``failed``, ``takes`` with each
/// take's ``status``, ``error``, ``seconds``). Raises ``RigfitError`` only for a bad job
/// file, report path or worker count (1 to 256).
#[pyfunction]
#[pyo3(signature = (path, *, workers=1, report=None, progress=false))]
pub fn run_batch(
    py: Python<'_>,
    path: PathBuf,
    workers: usize,
    report: Option<PathBuf>,
    progress: bool,
) -> PyResult<Py<PyAny>> {
    let outcome = py
        .detach(|| batch::run_batch(&path, report.as_deref(), workers, progress))
        .map_err(|e| error(format!("{e:#}")))?;
    to_python(py, &outcome.report())
}
