//! The PLY ascii body: one row a line, values as text.

use crate::error::ParseError;

use super::body::{Row, RowSource, ends_early};
use super::header::{Element, PropKind};
use super::scalar::{Scalar, Value};

pub(super) struct AsciiSource<'a> {
    pub(super) data: &'a [u8],
    pub(super) pos: usize,
    /// The number of the last line read (1-based, counting the header).
    pub(super) line: usize,
}

impl<'a> AsciiSource<'a> {
    /// The next line that holds anything but whitespace.
    fn next_line(&mut self) -> Option<&'a [u8]> {
        let data = self.data;
        while self.pos < data.len() {
            let rest = &data[self.pos..];
            let len = rest.iter().position(|&b| b == b'\n').unwrap_or(rest.len());
            self.pos += (len + 1).min(rest.len());
            self.line += 1;
            let line = &rest[..len];
            if !line.trim_ascii().is_empty() {
                return Some(line);
            }
        }
        None
    }
}

impl RowSource for AsciiSource<'_> {
    fn read_row(
        &mut self,
        el: &Element,
        row: usize,
        capture: Option<usize>,
        out: &mut Row,
    ) -> Result<(), ParseError> {
        let Some(line) = self.next_line() else {
            return Err(ends_early(el, row, "before this row".to_string()));
        };
        let line_no = self.line;
        let place = || format!("{} {row} (line {line_no})", el.name);
        let mut toks = line
            .split(|b| b.is_ascii_whitespace())
            .filter(|t| !t.is_empty());
        let mut found = 0usize;
        let mut next = |what: &str, ty: Scalar| -> Result<Value, ParseError> {
            let Some(tok) = toks.next() else {
                return Err(ParseError::new(
                    place(),
                    format!("too few values: the row ends after {found} values, before {what}"),
                ));
            };
            found += 1;
            ty.parse_text(tok).ok_or_else(|| {
                ParseError::new(
                    place(),
                    format!(
                        "{:?} is not a valid {ty:?} value for {what}",
                        String::from_utf8_lossy(tok)
                    ),
                )
            })
        };
        out.scalars.clear();
        out.list.clear();
        for (pi, prop) in el.props.iter().enumerate() {
            match prop.kind {
                PropKind::Scalar(ty) => {
                    let v = next(&format!("property {:?}", prop.name), ty)?;
                    out.scalars.push(v.as_f64());
                }
                PropKind::List { count, item } => {
                    out.scalars.push(0.0);
                    let what = format!("the length of list {:?}", prop.name);
                    let n = match next(&what, count)? {
                        Value::Int(n) if n >= 0 => n,
                        _ => {
                            return Err(ParseError::new(
                                place(),
                                format!("list {:?} has an invalid length", prop.name),
                            ));
                        }
                    };
                    let what = format!("the items of list {:?}", prop.name);
                    for _ in 0..n {
                        let v = next(&what, item)?;
                        if let (true, Value::Int(i)) = (capture == Some(pi), v) {
                            out.list.push(i);
                        }
                    }
                }
            }
        }
        if toks.next().is_some() {
            return Err(ParseError::new(
                place(),
                format!("too many values: the row holds more than the {found} the header declares"),
            ));
        }
        Ok(())
    }

    fn remaining(&self) -> usize {
        self.data.len() - self.pos
    }
}

#[cfg(test)]
mod tests {
    use crate::ply::tests::ascii;

    #[test]
    fn short_and_long_rows() {
        let head = "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\n\
                    property float y\nproperty float z\nend_header\n";
        let e = ascii(&format!("{head}1 2 3\n4 5\n")).expect_err("short");
        assert_eq!(e.place, "vertex 1 (line 9)");
        assert!(e.problem.contains("too few values"), "{e}");
        let e = ascii(&format!("{head}1 2 3\n4 5 6 7\n")).expect_err("long");
        assert!(e.problem.contains("too many values"), "{e}");
        let e = ascii(&format!("{head}1 2 3\n")).expect_err("missing row");
        assert_eq!(e.place, "vertex 1");
        assert!(e.problem.contains("ends early"), "{e}");
    }
}
