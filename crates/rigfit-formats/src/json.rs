//! JSON text in: one-line errors placed at a line and column, with plain words for what
//! JSON cannot hold (NaN, Infinity, numbers out of range).

use serde_json::Value;

use crate::error::ParseError;

/// Parses JSON text (a UTF-8 byte-order mark is skipped); a syntax error names its line and
/// column.
pub fn parse_json(bytes: &[u8]) -> Result<Value, ParseError> {
    let bytes = bytes.strip_prefix(b"\xef\xbb\xbf").unwrap_or(bytes);
    serde_json::from_slice(bytes).map_err(|e| json_error(bytes, &e))
}

/// Turns a serde_json error into a one-line error placed at its line and column.
fn json_error(bytes: &[u8], e: &serde_json::Error) -> ParseError {
    let place = format!("line {}, column {}", e.line(), e.column());
    let full = e.to_string();
    let suffix = format!(" at line {} column {}", e.line(), e.column());
    let mut problem = full
        .strip_suffix(&suffix)
        .unwrap_or(&full)
        .replace('\n', " ");
    if e.is_syntax() && non_finite_literal_at(bytes, e.line(), e.column()) {
        problem = "not a finite number: JSON has no NaN or Infinity".to_string();
    } else if problem == "number out of range" {
        problem = "a number is out of range (too large to be finite)".to_string();
    } else if !e.is_eof() {
        problem = format!("not valid JSON: {problem}");
    } else {
        problem = format!("not valid JSON (it ends early): {problem}");
    }
    ParseError::new(place, problem)
}

/// True when a `NaN` / `Infinity` literal (which JSON does not allow) is at or just before
/// the 1-based `line` and `column` serde_json reported.
fn non_finite_literal_at(bytes: &[u8], line: usize, column: usize) -> bool {
    let Some(text) = bytes.split(|&b| b == b'\n').nth(line.saturating_sub(1)) else {
        return false;
    };
    let col = column.min(text.len());
    (col.saturating_sub(3)..=col).any(|start| {
        let tail = &text[start..];
        [&b"NaN"[..], b"nan", b"Infinity", b"inf"]
            .iter()
            .any(|lit| tail.starts_with(lit))
    })
}
