//! The reader of a BVH file's `HIERARCHY` section: the joints, their offsets and channels.

use rigfit_core::Vector3;

use crate::error::{MAX_COORDINATE, ParseError};

use super::lexer::{Lexer, quote};
use super::{BvhChannel, BvhJoint};

/// A joint being read: its index and what its block has held so far.
struct Open {
    joint: usize,
    line: usize,
    has_offset: bool,
    has_channels: bool,
    has_children: bool,
}

impl Open {
    fn new(joint: usize, line: usize) -> Self {
        Self {
            joint,
            line,
            has_offset: false,
            has_channels: false,
            has_children: false,
        }
    }
}

/// "joint \"Name\"" or "End Site of \"Parent\"".
fn describe(joints: &[BvhJoint], index: usize) -> String {
    let j = &joints[index];
    if j.end_site {
        match j.parent {
            Some(p) => format!("End Site of {}", quote(&joints[p].name)),
            None => "End Site".into(),
        }
    } else {
        format!("joint {}", quote(&j.name))
    }
}

fn is_keyword(tok: &str) -> bool {
    [
        "{",
        "}",
        "ROOT",
        "JOINT",
        "End",
        "OFFSET",
        "CHANNELS",
        "MOTION",
        "HIERARCHY",
    ]
    .iter()
    .any(|k| k.eq_ignore_ascii_case(tok))
}

/// Reads `ROOT`/`JOINT`'s name (the rest of the line) and the `{` after it; pushes the
/// joint and returns its index.
fn begin_joint(
    lx: &mut Lexer<'_>,
    joints: &mut Vec<BvhJoint>,
    parent: Option<usize>,
    keyword: &str,
    line: usize,
) -> Result<usize, ParseError> {
    if joints.len() >= crate::error::MAX_JOINTS {
        return Err(crate::error::too_many_joints(
            format!("line {line}"),
            joints.len() + 1,
        ));
    }
    let mut name = lx.rest_of_line().trim();
    let mut brace = false;
    if let Some(stripped) = name.strip_suffix('{') {
        name = stripped.trim_end();
        brace = true;
    }
    if name.is_empty() {
        return Err(ParseError::at_line(
            line,
            format!("{keyword} without a name (the name must be on the same line)"),
        ));
    }
    if !brace {
        match lx.next_token() {
            Some(("{", _)) => {}
            Some((tok, l)) => {
                return Err(ParseError::at_line(
                    l,
                    format!(
                        "expected '{{' after {keyword} {}, found {}",
                        quote(name),
                        quote(tok)
                    ),
                ));
            }
            None => {
                return Err(ParseError::at_line(
                    lx.eof_line(),
                    format!(
                        "unexpected end of file after {keyword} {} (the file is truncated)",
                        quote(name)
                    ),
                ));
            }
        }
    }
    joints.push(BvhJoint {
        name: name.to_string(),
        parent,
        offset: Vector3::zeros(),
        channels: Vec::new(),
        end_site: false,
    });
    Ok(joints.len() - 1)
}

/// Reads a finite number of an OFFSET.
fn read_offset_number(lx: &mut Lexer<'_>, what: &str) -> Result<f64, ParseError> {
    match lx.next_token() {
        None => Err(ParseError::at_line(
            lx.eof_line(),
            format!("unexpected end of file in the OFFSET of {what} (the file is truncated)"),
        )),
        Some((tok, line)) => match tok.parse::<f64>() {
            Ok(v) if v.is_finite() && v.abs() <= MAX_COORDINATE => Ok(v),
            Ok(v) if v.is_finite() => Err(ParseError::at_line(
                line,
                format!(
                    "OFFSET of {what}: {} is too large (out of range: at most 1e12 in magnitude)",
                    quote(tok)
                ),
            )),
            Ok(_) => Err(ParseError::at_line(
                line,
                format!("OFFSET of {what}: {} is not a finite number", quote(tok)),
            )),
            Err(_) if is_keyword(tok) => Err(ParseError::at_line(
                line,
                format!("OFFSET of {what} needs 3 numbers, found {}", quote(tok)),
            )),
            Err(_) => Err(ParseError::at_line(
                line,
                format!("OFFSET of {what}: {} is not a number", quote(tok)),
            )),
        },
    }
}

/// Reads `HIERARCHY` up to and including `MOTION`.
pub(super) fn parse_hierarchy(lx: &mut Lexer<'_>) -> Result<Vec<BvhJoint>, ParseError> {
    let mut joints: Vec<BvhJoint> = Vec::new();
    let mut stack: Vec<Open> = Vec::new();
    let mut first = true;
    loop {
        let Some((tok, line)) = lx.next_token() else {
            let problem = match stack.last() {
                Some(open) => format!(
                    "unexpected end of file inside {} opened on line {} (missing '}}'; the file is truncated)",
                    describe(&joints, open.joint),
                    open.line
                ),
                None if first => "empty file: expected a BVH HIERARCHY".to_string(),
                None if joints.is_empty() => {
                    "the HIERARCHY has no ROOT joint and there is no MOTION section".to_string()
                }
                None => "missing MOTION section: the file ends after the hierarchy".to_string(),
            };
            return Err(ParseError::at_line(lx.eof_line(), problem));
        };
        let was_first = std::mem::replace(&mut first, false);
        let Some(open) = stack.last_mut() else {
            if was_first && tok.eq_ignore_ascii_case("HIERARCHY") {
                continue;
            }
            if tok.eq_ignore_ascii_case("ROOT") {
                let j = begin_joint(lx, &mut joints, None, "ROOT", line)?;
                stack.push(Open::new(j, line));
                continue;
            }
            if tok.eq_ignore_ascii_case("MOTION") {
                if joints.is_empty() {
                    return Err(ParseError::at_line(line, "the HIERARCHY has no ROOT joint"));
                }
                return Ok(joints);
            }
            let problem = if tok == "}" {
                "unmatched '}' (a joint block is closed twice)".to_string()
            } else if was_first {
                format!("not a BVH file: expected HIERARCHY, found {}", quote(tok))
            } else {
                format!("expected ROOT or MOTION, found {}", quote(tok))
            };
            return Err(ParseError::at_line(line, problem));
        };
        let index = open.joint;
        let end_site = joints[index].end_site;
        if tok.eq_ignore_ascii_case("OFFSET") {
            if open.has_offset {
                return Err(ParseError::at_line(
                    line,
                    format!("second OFFSET in {}", describe(&joints, index)),
                ));
            }
            open.has_offset = true;
            let what = describe(&joints, index);
            let x = read_offset_number(lx, &what)?;
            let y = read_offset_number(lx, &what)?;
            let z = read_offset_number(lx, &what)?;
            joints[index].offset = Vector3::new(x, y, z);
        } else if tok.eq_ignore_ascii_case("CHANNELS") {
            let what = describe(&joints, index);
            if open.has_channels {
                return Err(ParseError::at_line(
                    line,
                    format!("second CHANNELS in {what}"),
                ));
            }
            if open.has_children {
                return Err(ParseError::at_line(
                    line,
                    format!("CHANNELS of {what} must come before its child joints"),
                ));
            }
            open.has_channels = true;
            let count = match lx.next_token() {
                Some((t, l)) => t.parse::<usize>().map_err(|_| {
                    ParseError::at_line(
                        l,
                        format!(
                            "CHANNELS of {what} expects a channel count, found {}",
                            quote(t)
                        ),
                    )
                })?,
                None => {
                    return Err(ParseError::at_line(
                        lx.eof_line(),
                        format!(
                            "unexpected end of file in the CHANNELS of {what} (the file is truncated)"
                        ),
                    ));
                }
            };
            if end_site && count > 0 {
                return Err(ParseError::at_line(
                    line,
                    format!("{what} cannot have channels"),
                ));
            }
            let mut channels: Vec<BvhChannel> = Vec::new();
            while channels.len() < count {
                let Some((t, l)) = lx.peek_token() else {
                    return Err(ParseError::at_line(
                        lx.eof_line(),
                        format!(
                            "unexpected end of file in the CHANNELS of {what} (the file is truncated)"
                        ),
                    ));
                };
                match BvhChannel::from_name(t) {
                    Some(c) if channels.contains(&c) => {
                        return Err(ParseError::at_line(
                            l,
                            format!("channel {c} listed twice in the CHANNELS of {what}"),
                        ));
                    }
                    Some(c) => {
                        lx.next_token();
                        channels.push(c);
                    }
                    None if is_keyword(t) || t.parse::<f64>().is_ok() => {
                        return Err(ParseError::at_line(
                            line,
                            format!(
                                "CHANNELS {count} of {what} lists only {} channel names (next is {})",
                                channels.len(),
                                quote(t)
                            ),
                        ));
                    }
                    None => {
                        return Err(ParseError::at_line(
                            l,
                            format!(
                                "unknown channel {} in {what} (expected Xposition, Yposition, Zposition, Xrotation, Yrotation or Zrotation)",
                                quote(t)
                            ),
                        ));
                    }
                }
            }
            joints[index].channels = channels;
        } else if tok.eq_ignore_ascii_case("JOINT") {
            if end_site {
                return Err(ParseError::at_line(
                    line,
                    format!("JOINT inside the {}", describe(&joints, index)),
                ));
            }
            open.has_children = true;
            let j = begin_joint(lx, &mut joints, Some(index), "JOINT", line)?;
            stack.push(Open::new(j, line));
        } else if tok.eq_ignore_ascii_case("End") {
            match lx.next_token() {
                Some((t, _)) if t.eq_ignore_ascii_case("Site") => {}
                Some((t, l)) => {
                    return Err(ParseError::at_line(
                        l,
                        format!(
                            "expected 'End Site', found 'End {}'",
                            t.chars().take(40).collect::<String>()
                        ),
                    ));
                }
                None => {
                    return Err(ParseError::at_line(
                        lx.eof_line(),
                        "unexpected end of file after 'End' (the file is truncated)",
                    ));
                }
            }
            if end_site {
                return Err(ParseError::at_line(
                    line,
                    format!("End Site inside the {}", describe(&joints, index)),
                ));
            }
            open.has_children = true;
            match lx.next_token() {
                Some(("{", _)) => {}
                Some((t, l)) => {
                    return Err(ParseError::at_line(
                        l,
                        format!("expected '{{' after End Site, found {}", quote(t)),
                    ));
                }
                None => {
                    return Err(ParseError::at_line(
                        lx.eof_line(),
                        "unexpected end of file after End Site (the file is truncated)",
                    ));
                }
            }
            if joints.len() >= crate::error::MAX_JOINTS {
                return Err(crate::error::too_many_joints(
                    format!("line {line}"),
                    joints.len() + 1,
                ));
            }
            joints.push(BvhJoint {
                name: String::new(),
                parent: Some(index),
                offset: Vector3::zeros(),
                channels: Vec::new(),
                end_site: true,
            });
            stack.push(Open::new(joints.len() - 1, line));
        } else if tok == "}" {
            if !open.has_offset {
                return Err(ParseError::at_line(
                    line,
                    format!(
                        "{} (line {}) has no OFFSET",
                        describe(&joints, index),
                        open.line
                    ),
                ));
            }
            stack.pop();
        } else if tok.eq_ignore_ascii_case("MOTION") || tok.eq_ignore_ascii_case("ROOT") {
            return Err(ParseError::at_line(
                line,
                format!(
                    "{tok} inside {} opened on line {}: a '}}' is missing before it",
                    describe(&joints, index),
                    open.line
                ),
            ));
        } else {
            return Err(ParseError::at_line(
                line,
                format!("unexpected {} in {}", quote(tok), describe(&joints, index)),
            ));
        }
    }
}
