//! The BVH writer: a document as text, numbers in their shortest round-trip form.

use std::fmt::Write as _;
use std::path::Path;

use crate::error::{FormatError, write_atomic};

use super::BvhDocument;

impl BvhDocument {
    /// Writes the document as BVH text: tab-indented hierarchy, then the frames. Numbers
    /// use the shortest form that reads back to the same `f64`. Joints may be in any
    /// parents-first order; the file lists them depth first, with each frame's values in
    /// that order.
    pub fn to_bvh_string(&self) -> String {
        let n = self.joints.len();
        let mut children = vec![Vec::new(); n];
        let mut roots = Vec::new();
        for (i, j) in self.joints.iter().enumerate() {
            match j.parent {
                Some(p) if p < i => children[p].push(i),
                _ => roots.push(i),
            }
        }
        enum Step {
            Enter(usize, usize),
            Exit(usize),
        }
        let row_chars = self.channel_count().saturating_mul(10).saturating_add(1);
        let mut out = String::with_capacity(
            (64 * n).saturating_add(self.frames.len().saturating_mul(row_chars)),
        );
        out.push_str("HIERARCHY\n");
        let mut order = Vec::with_capacity(n);
        let mut stack: Vec<Step> = roots.iter().rev().map(|&r| Step::Enter(r, 0)).collect();
        while let Some(step) = stack.pop() {
            match step {
                Step::Exit(depth) => {
                    indent(&mut out, depth);
                    out.push_str("}\n");
                }
                Step::Enter(i, depth) => {
                    order.push(i);
                    let j = &self.joints[i];
                    let as_end_site =
                        j.end_site && j.channels.is_empty() && children[i].is_empty() && depth > 0;
                    indent(&mut out, depth);
                    if as_end_site {
                        out.push_str("End Site\n");
                    } else {
                        let keyword = if depth == 0 { "ROOT" } else { "JOINT" };
                        let _ = writeln!(out, "{keyword} {}", clean_name(&j.name, i));
                    }
                    indent(&mut out, depth);
                    out.push_str("{\n");
                    indent(&mut out, depth + 1);
                    let o = j.offset;
                    let _ = writeln!(out, "OFFSET {} {} {}", o.x, o.y, o.z);
                    if !as_end_site {
                        indent(&mut out, depth + 1);
                        let _ = write!(out, "CHANNELS {}", j.channels.len());
                        for c in &j.channels {
                            let _ = write!(out, " {c}");
                        }
                        out.push('\n');
                    }
                    stack.push(Step::Exit(depth));
                    for &c in children[i].iter().rev() {
                        stack.push(Step::Enter(c, depth + 1));
                    }
                }
            }
        }
        let starts = self.channel_starts();
        let _ = write!(
            out,
            "MOTION\nFrames: {}\nFrame Time: {}\n",
            self.frames.len(),
            self.frame_time
        );
        for frame in &self.frames {
            let mut first = true;
            for &i in &order {
                for k in 0..self.joints[i].channels.len() {
                    let v = frame.get(starts[i] + k).copied().unwrap_or(0.0);
                    if !first {
                        out.push(' ');
                    }
                    first = false;
                    let _ = write!(out, "{v}");
                }
            }
            out.push('\n');
        }
        out
    }

    /// Writes the document to a file (atomically: a temporary file, then a rename).
    pub fn write(&self, path: &Path) -> Result<(), FormatError> {
        write_atomic(path, self.to_bvh_string().as_bytes())
    }
}

/// Indentation of a hierarchy line: one tab per level up to [`MAX_INDENT`] (readers ignore
/// it; capped so that a deep chain's file grows linearly with its depth).
fn indent(out: &mut String, depth: usize) {
    for _ in 0..depth.min(MAX_INDENT) {
        out.push('\t');
    }
}

/// The deepest indentation the writer uses.
const MAX_INDENT: usize = 32;

/// A joint name that reads back as one line.
fn clean_name(name: &str, index: usize) -> String {
    let cleaned: String = name
        .chars()
        .map(|c| if c.is_control() { ' ' } else { c })
        .collect();
    let trimmed = cleaned.trim().trim_end_matches('{').trim_end();
    if trimmed.is_empty() {
        format!("joint{index}")
    } else {
        trimmed.to_string()
    }
}
