//! Errors of the readers and writers: every one names the file, the place in it and the
//! problem, so the command line can print it as one clear line.

use std::fmt;
use std::path::{Path, PathBuf};

/// A problem found while parsing bytes: where (a line, a byte offset, a JSON path) and what.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ParseError {
    pub place: String,
    pub problem: String,
}

impl ParseError {
    pub fn new(place: impl Into<String>, problem: impl Into<String>) -> Self {
        Self {
            place: place.into(),
            problem: problem.into(),
        }
    }

    /// An error at line `line` (1-based).
    pub fn at_line(line: usize, problem: impl Into<String>) -> Self {
        Self::new(format!("line {line}"), problem)
    }
}

impl fmt::Display for ParseError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.place.is_empty() {
            write!(f, "{}", self.problem)
        } else {
            write!(f, "{}: {}", self.place, self.problem)
        }
    }
}

impl std::error::Error for ParseError {}

/// An error of a file operation.
#[derive(Debug, thiserror::Error)]
pub enum FormatError {
    /// The file's content is wrong.
    #[error("{}: {error}", path.display())]
    Parse { path: PathBuf, error: ParseError },
    /// The file could not be read or written. The I/O error is part of the one line (not a
    /// `source`), so that printing the error chain does not repeat it.
    #[error("{}: {error}", path.display())]
    Io {
        path: PathBuf,
        error: std::io::Error,
    },
    /// The file's extension names no format rigfit knows for this use.
    #[error("{}: unsupported file type (expected {expected})", path.display())]
    Unsupported { path: PathBuf, expected: String },
}

impl FormatError {
    pub fn parse(path: &Path, error: ParseError) -> Self {
        Self::Parse {
            path: path.to_path_buf(),
            error,
        }
    }

    pub fn io(path: &Path, error: std::io::Error) -> Self {
        Self::Io {
            path: path.to_path_buf(),
            error,
        }
    }
}

// The readers and writers of every format read and write through `files` (regular inputs of
// bounded size; exclusive temporaries renamed into place).
pub use crate::files::{read_input as read_bytes, write_atomic};

/// The lower-case extension of a path ("" when none).
pub fn extension(path: &Path) -> String {
    path.extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default()
}

/// The most joints a rig may have (a glTF skeleton's nodes, a BVH's joints and End Sites):
/// rigs have hundreds; past this bound a file is refused with one line instead of taking
/// seconds and gigabytes.
pub const MAX_JOINTS: usize = 250_000;

/// The error of a rig with more than [`MAX_JOINTS`] joints.
pub fn too_many_joints(place: impl Into<String>, count: usize) -> ParseError {
    ParseError::new(
        place,
        format!("{count} joints is too many (rigfit reads rigs of at most {MAX_JOINTS} joints)"),
    )
}

/// The largest coordinate magnitude rigfit reads (positions, offsets, translations, scales,
/// motion values): beyond it, squares and sums of squares lose all meaning or overflow.
pub const MAX_COORDINATE: f64 = rigfit_core::math::MAX_COORDINATE;

/// What is wrong with a coordinate (`None` when nothing): not a finite number, or too large.
pub fn coordinate_problem(x: f64) -> Option<String> {
    if !x.is_finite() {
        Some("coordinate is not a finite number (NaN or infinity)".into())
    } else if x.abs() > MAX_COORDINATE {
        Some(format!(
            "coordinate {x:e} is too large (out of range: at most {MAX_COORDINATE:e} in magnitude)"
        ))
    } else {
        None
    }
}

/// Checks that every coordinate is finite and in range ([`MAX_COORDINATE`]); names the first
/// point (`what` and index) that is not.
pub fn check_finite<'a>(
    what: &str,
    points: impl IntoIterator<Item = &'a rigfit_core::Point3>,
) -> Result<(), ParseError> {
    for (i, p) in points.into_iter().enumerate() {
        if let Some(problem) = p.iter().find_map(|&x| coordinate_problem(x)) {
            return Err(ParseError::new(format!("{what} {i}"), problem));
        }
    }
    Ok(())
}
