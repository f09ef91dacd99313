//! The PLY header: the format, the elements and their properties, and where the vertex
//! coordinates, normals and face indices are among them.

use crate::error::ParseError;

use super::scalar::Scalar;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Format {
    Ascii,
    BinaryLe,
    BinaryBe,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum PropKind {
    Scalar(Scalar),
    List { count: Scalar, item: Scalar },
}

#[derive(Clone, Debug)]
pub(super) struct Property {
    pub(super) name: String,
    pub(super) kind: PropKind,
}

#[derive(Clone, Debug)]
pub(super) struct Element {
    pub(super) name: String,
    pub(super) count: usize,
    pub(super) props: Vec<Property>,
    /// The header line declaring it (1-based), for errors about the header.
    pub(super) line: usize,
}

impl Element {
    pub(super) fn scalar(&self, name: &str) -> Option<usize> {
        self.props
            .iter()
            .position(|p| p.name == name && matches!(p.kind, PropKind::Scalar(_)))
    }

    /// The fewest bytes one row can take in the given format (at least 1).
    pub(super) fn min_row_bytes(&self, format: Format) -> usize {
        let n = match format {
            // Each value is at least one character plus a separator.
            Format::Ascii => self.props.len() * 2,
            Format::BinaryLe | Format::BinaryBe => self
                .props
                .iter()
                .map(|p| match p.kind {
                    PropKind::Scalar(s) => s.size(),
                    PropKind::List { count, .. } => count.size(),
                })
                .sum(),
        };
        n.max(1)
    }
}

#[derive(Debug)]
pub(super) struct Header {
    pub(super) format: Format,
    pub(super) elements: Vec<Element>,
    /// The byte offset where the body starts.
    pub(super) data_start: usize,
    /// The number of header lines (the body's first line is `lines + 1`).
    pub(super) lines: usize,
}

fn header_err(line: usize, problem: impl Into<String>) -> ParseError {
    ParseError::new(format!("header line {line}"), problem)
}

pub(super) fn parse_header(bytes: &[u8]) -> Result<Header, ParseError> {
    let first_line_end = bytes
        .iter()
        .position(|&b| b == b'\n')
        .unwrap_or(bytes.len());
    let first = &bytes[..first_line_end];
    if first.trim_ascii() != b"ply" {
        return Err(header_err(
            1,
            "not a PLY file (the first line is not \"ply\")",
        ));
    }
    let mut pos = (first_line_end + 1).min(bytes.len());
    let mut line_no = 1;
    let mut format = None;
    let mut elements: Vec<Element> = Vec::new();
    loop {
        if pos >= bytes.len() {
            return Err(ParseError::new(
                "header",
                "the header has no end_header line",
            ));
        }
        let end = bytes[pos..]
            .iter()
            .position(|&b| b == b'\n')
            .map_or(bytes.len(), |i| pos + i);
        let raw = &bytes[pos..end];
        pos = (end + 1).min(bytes.len());
        line_no += 1;
        let Ok(line) = std::str::from_utf8(raw) else {
            return Err(header_err(line_no, "the header line is not text"));
        };
        let mut toks = line.split_ascii_whitespace();
        let Some(keyword) = toks.next() else {
            continue;
        };
        let rest: Vec<&str> = toks.collect();
        match keyword {
            "comment" | "obj_info" => {}
            "end_header" => break,
            "format" => {
                if format.is_some() {
                    return Err(header_err(line_no, "a second format line"));
                }
                let [name, version] = rest[..] else {
                    return Err(header_err(
                        line_no,
                        "expected \"format ascii|binary_little_endian|binary_big_endian 1.0\"",
                    ));
                };
                if version != "1.0" && version != "1" {
                    return Err(header_err(
                        line_no,
                        format!("unsupported PLY version {version:?} (expected 1.0)"),
                    ));
                }
                format = Some(match name {
                    "ascii" => Format::Ascii,
                    "binary_little_endian" => Format::BinaryLe,
                    "binary_big_endian" => Format::BinaryBe,
                    other => {
                        return Err(header_err(
                            line_no,
                            format!(
                                "unknown format {other:?} (expected ascii, binary_little_endian or binary_big_endian)"
                            ),
                        ));
                    }
                });
            }
            "element" => {
                let [name, count] = rest[..] else {
                    return Err(header_err(line_no, "expected \"element NAME COUNT\""));
                };
                let count = count
                    .parse::<u64>()
                    .ok()
                    .and_then(|c| usize::try_from(c).ok())
                    .ok_or_else(|| {
                        header_err(
                            line_no,
                            format!("element {name:?} has an invalid count {count:?}"),
                        )
                    })?;
                elements.push(Element {
                    name: name.to_string(),
                    count,
                    props: Vec::new(),
                    line: line_no,
                });
            }
            "property" => {
                let Some(element) = elements.last_mut() else {
                    return Err(header_err(line_no, "a property before any element"));
                };
                let scalar = |name: &str| {
                    Scalar::from_name(name).ok_or_else(|| {
                        header_err(line_no, format!("unknown property type {name:?}"))
                    })
                };
                let prop = match rest[..] {
                    ["list", count, item, name] => {
                        let count = scalar(count)?;
                        if !count.is_integer() {
                            return Err(header_err(
                                line_no,
                                format!("list {name:?} has a non-integer count type"),
                            ));
                        }
                        Property {
                            name: name.to_string(),
                            kind: PropKind::List {
                                count,
                                item: scalar(item)?,
                            },
                        }
                    }
                    [ty, name] if ty != "list" => Property {
                        name: name.to_string(),
                        kind: PropKind::Scalar(scalar(ty)?),
                    },
                    _ => {
                        return Err(header_err(
                            line_no,
                            "expected \"property TYPE NAME\" or \"property list COUNT_TYPE ITEM_TYPE NAME\"",
                        ));
                    }
                };
                element.props.push(prop);
            }
            other => {
                let hint = if other.starts_with(|c: char| c.is_ascii_digit() || c == '-') {
                    " (is the end_header line missing?)"
                } else {
                    ""
                };
                return Err(header_err(
                    line_no,
                    format!("unknown header keyword {other:?}{hint}"),
                ));
            }
        }
    }
    let format =
        format.ok_or_else(|| ParseError::new("header", "the header has no format line"))?;
    Ok(Header {
        format,
        elements,
        data_start: pos,
        lines: line_no,
    })
}

/// Where the parts the reader wants are in the header.
#[derive(Debug)]
pub(super) struct Layout {
    pub(super) vertex: usize,
    pub(super) xyz: [usize; 3],
    pub(super) normals: Option<[usize; 3]>,
    /// The face element and its index list property.
    pub(super) face: Option<(usize, usize)>,
}

impl Layout {
    pub(super) fn new(header: &Header) -> Result<Self, ParseError> {
        let mut vertex = None;
        let mut face = None;
        for (i, el) in header.elements.iter().enumerate() {
            match el.name.as_str() {
                "vertex" => {
                    if vertex.is_some() {
                        return Err(header_err(el.line, "a second vertex element"));
                    }
                    vertex = Some(i);
                }
                "face" => {
                    if face.is_some() {
                        return Err(header_err(el.line, "a second face element"));
                    }
                    let list = el.props.iter().position(|p| {
                        (p.name == "vertex_indices" || p.name == "vertex_index")
                            && matches!(p.kind, PropKind::List { .. })
                    });
                    let Some(list) = list else {
                        return Err(header_err(
                            el.line,
                            "the face element has no \"vertex_indices\" list property",
                        ));
                    };
                    let integer_items = match el.props[list].kind {
                        PropKind::List { item, .. } => item.is_integer(),
                        PropKind::Scalar(_) => false,
                    };
                    if !integer_items {
                        return Err(header_err(
                            el.line,
                            "the face vertex indices are not of an integer type",
                        ));
                    }
                    face = Some((i, list));
                }
                _ => {}
            }
        }
        let Some(vertex) = vertex else {
            return Err(ParseError::new(
                "header",
                "the header has no vertex element",
            ));
        };
        let el = &header.elements[vertex];
        let find = |name: &str| {
            el.scalar(name).ok_or_else(|| {
                header_err(
                    el.line,
                    format!("the vertex element has no {name:?} property"),
                )
            })
        };
        let xyz = [find("x")?, find("y")?, find("z")?];
        let normals = match (el.scalar("nx"), el.scalar("ny"), el.scalar("nz")) {
            (Some(a), Some(b), Some(c)) => Some([a, b, c]),
            _ => None,
        };
        Ok(Self {
            vertex,
            xyz,
            normals,
            face,
        })
    }
}

#[cfg(test)]
mod tests {
    use crate::ply::tests::ascii;

    #[test]
    fn header_errors_name_the_line() {
        let e = ascii("ply\nformat ascii 1.0\nelement vertex 1\nproperty foo x\nend_header\n")
            .expect_err("bad type");
        assert_eq!(e.place, "header line 4");
        assert!(e.problem.contains("unknown property type"), "{e}");
        let e = ascii("ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n")
            .expect_err("no end");
        assert!(e.problem.contains("end_header"), "{e}");
        let e = ascii("plx\n").expect_err("magic");
        assert!(e.to_string().contains("not a PLY file"), "{e}");
    }
}
