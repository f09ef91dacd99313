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

/// Reads a whole file, naming it in the error.
pub fn read_bytes(path: &Path) -> Result<Vec<u8>, FormatError> {
    std::fs::read(path).map_err(|e| FormatError::io(path, e))
}

/// Writes a file atomically: the bytes go to a temporary file beside it, which is then
/// renamed over the target, so a failure never leaves a half-written file.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), FormatError> {
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "out".into());
    let tmp = dir.join(format!(".{name}.rigfit-tmp-{}", std::process::id()));
    let result = std::fs::write(&tmp, bytes).and_then(|()| std::fs::rename(&tmp, path));
    if let Err(e) = result {
        let _ = std::fs::remove_file(&tmp);
        return Err(FormatError::io(path, e));
    }
    Ok(())
}

/// The lower-case extension of a path ("" when none).
pub fn extension(path: &Path) -> String {
    path.extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default()
}

/// Checks that every coordinate is finite; names the first point (`what` and index) that is
/// not.
pub fn check_finite<'a>(
    what: &str,
    points: impl IntoIterator<Item = &'a rigfit_core::Point3>,
) -> Result<(), ParseError> {
    for (i, p) in points.into_iter().enumerate() {
        if p.iter().any(|x| !x.is_finite()) {
            return Err(ParseError::new(
                format!("{what} {i}"),
                "coordinate is not a finite number (NaN or infinity)",
            ));
        }
    }
    Ok(())
}
