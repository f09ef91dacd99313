//! The reader of a BVH file's `MOTION` section: the frame count, the frame time and the
//! rows of channel values.

use crate::error::{MAX_COORDINATE, ParseError};

use super::BvhJoint;
use super::lexer::{Lexer, quote};

/// Reads a header label such as `Frames:` or `Frame Time:` (split into tokens anyhow) and
/// returns its value token.
fn expect_label(
    lx: &mut Lexer<'_>,
    label: &str,
    shown: &str,
) -> Result<(String, usize), ParseError> {
    let compact: String = label.chars().filter(|c| !c.is_whitespace()).collect();
    let mut acc = String::new();
    loop {
        let Some((tok, line)) = lx.next_token() else {
            return Err(ParseError::at_line(
                lx.eof_line(),
                format!("missing '{shown}' in the MOTION section (the file is truncated)"),
            ));
        };
        acc.push_str(tok);
        let matches_so_far = |n: usize| {
            acc.get(..n)
                .zip(compact.get(..n))
                .is_some_and(|(a, b)| a.eq_ignore_ascii_case(b))
        };
        if acc.len() < compact.len() {
            if !matches_so_far(acc.len()) {
                return Err(ParseError::at_line(
                    line,
                    format!(
                        "expected '{shown}' in the MOTION section, found {}",
                        quote(&acc)
                    ),
                ));
            }
            continue;
        }
        if !matches_so_far(compact.len()) {
            return Err(ParseError::at_line(
                line,
                format!(
                    "expected '{shown}' in the MOTION section, found {}",
                    quote(&acc)
                ),
            ));
        }
        let rest = acc.get(compact.len()..).unwrap_or("");
        if !rest.is_empty() {
            return Ok((rest.to_string(), line));
        }
        return match lx.next_token() {
            Some((value, l)) => Ok((value.to_string(), l)),
            None => Err(ParseError::at_line(
                lx.eof_line(),
                format!("missing value after '{shown}' (the file is truncated)"),
            )),
        };
    }
}

/// The joint and channel of value `index` of a frame, for messages.
fn describe_value(joints: &[BvhJoint], index: usize) -> String {
    let mut start = 0;
    for j in joints {
        if index < start + j.channels.len() {
            return format!("{} {}", j.name, j.channels[index - start]);
        }
        start += j.channels.len();
    }
    String::new()
}

/// Reads `Frames:`, `Frame Time:` and the rows after them.
pub(super) fn parse_motion(
    lx: &mut Lexer<'_>,
    joints: &[BvhJoint],
) -> Result<(f64, Vec<Vec<f64>>), ParseError> {
    let (frames_tok, frames_line) = expect_label(lx, "Frames:", "Frames:")?;
    let declared: usize = frames_tok.parse().map_err(|_| {
        ParseError::at_line(
            frames_line,
            format!(
                "'Frames:' expects a whole number, found {}",
                quote(&frames_tok)
            ),
        )
    })?;
    let (time_tok, time_line) = expect_label(lx, "Frame Time:", "Frame Time:")?;
    let frame_time: f64 = match time_tok.parse::<f64>() {
        Ok(t) if t.is_finite() && t > 0.0 => t,
        Ok(_) => {
            return Err(ParseError::at_line(
                time_line,
                format!(
                    "'Frame Time:' must be a positive number of seconds, found {}",
                    quote(&time_tok)
                ),
            ));
        }
        Err(_) => {
            return Err(ParseError::at_line(
                time_line,
                format!("'Frame Time:' expects a number, found {}", quote(&time_tok)),
            ));
        }
    };
    let tail = lx.rest_of_line().trim();
    if !tail.is_empty() {
        return Err(ParseError::at_line(
            lx.line,
            format!(
                "unexpected {} after the frame time (frames start on the next line)",
                quote(tail)
            ),
        ));
    }
    let count: usize = joints.iter().map(|j| j.channels.len()).sum();
    let mut frames: Vec<Vec<f64>> = Vec::new();
    let remaining = lx.text.get(lx.pos..).unwrap_or("");
    for (i, row) in remaining.split('\n').enumerate().skip(1) {
        let line = lx.line + i;
        let n = row.split_ascii_whitespace().count();
        if n == 0 {
            continue;
        }
        if n != count {
            return Err(ParseError::at_line(
                line,
                format!("frame {} has {n} values, expected {count}", frames.len()),
            ));
        }
        let mut values = Vec::with_capacity(count);
        for (k, tok) in row.split_ascii_whitespace().enumerate() {
            match tok.parse::<f64>() {
                Ok(v) if v.is_finite() && v.abs() <= MAX_COORDINATE => values.push(v),
                parsed => {
                    let what = match parsed {
                        Ok(v) if v.is_finite() => {
                            "is too large (out of range: at most 1e12 in magnitude)"
                        }
                        Ok(_) => "is not a finite number",
                        Err(_) => "is not a number",
                    };
                    return Err(ParseError::at_line(
                        line,
                        format!(
                            "frame {}, value {} ({}): {} {what}",
                            frames.len(),
                            k + 1,
                            describe_value(joints, k),
                            quote(tok)
                        ),
                    ));
                }
            }
        }
        frames.push(values);
    }
    if count == 0 {
        // No channels: rows are empty, so the header is all there is.
        const MAX_EMPTY_FRAMES: usize = 1 << 20;
        if declared > MAX_EMPTY_FRAMES {
            return Err(ParseError::at_line(
                frames_line,
                format!("'Frames: {declared}' is too many for a motion without channels"),
            ));
        }
        frames = vec![Vec::new(); declared];
    } else if frames.len() != declared {
        tracing::warn!(
            "BVH 'Frames: {declared}' (line {frames_line}) but the file holds {} data rows; reading the rows present",
            frames.len()
        );
    }
    Ok((frame_time, frames))
}
