//! PLY (the Stanford polygon file format): a reader for ascii and binary files and a writer.
//!
//! The reader takes the `vertex` element's `x`, `y`, `z` (and `nx`, `ny`, `nz` when all three
//! are present) and the `face` element's `vertex_indices` (or `vertex_index`) list, fanning
//! polygons into triangles. Every other element and property is skipped.
//!
//! Coordinates that are NaN or infinite are an error. A normal that is makes the whole mesh
//! have no normals (the caller then estimates them), since scanners write NaN normals where
//! their estimation failed.
//!
//! The header's counts are never trusted for allocation: reservations are capped by the
//! bytes that remain, and a header that declares more rows than the data holds is reported
//! with the element and the row.

use std::path::Path;

use rigfit_core::{Point3, TriMesh, Vector3};

use crate::error::{
    FormatError, MAX_COORDINATE, ParseError, check_finite, read_bytes, write_atomic,
};

/// Parses a PLY file (ascii 1.0, binary_little_endian 1.0 or binary_big_endian 1.0).
///
/// A file with no vertices is valid (an empty cloud); the caller decides what to do with it.
pub fn parse_ply(bytes: &[u8]) -> Result<TriMesh, ParseError> {
    let header = parse_header(bytes)?;
    let layout = Layout::new(&header)?;
    let data = bytes.get(header.data_start..).unwrap_or_default();
    match header.format {
        Format::Ascii => {
            let mut src = AsciiSource {
                data,
                pos: 0,
                line: header.lines,
            };
            read_body(&header, &layout, &mut src)
        }
        Format::BinaryLe | Format::BinaryBe => {
            let mut src = BinarySource {
                data,
                pos: 0,
                base: header.data_start,
                big_endian: header.format == Format::BinaryBe,
            };
            read_body(&header, &layout, &mut src)
        }
    }
}

/// Reads a PLY file, naming it in any error.
pub fn read_ply(path: &Path) -> Result<TriMesh, FormatError> {
    let bytes = read_bytes(path)?;
    let _span = tracing::warn_span!("reading", file = %path.display()).entered();
    parse_ply(&bytes).map_err(|e| FormatError::parse(path, e))
}

/// Writes a PLY file atomically, as binary little endian.
pub fn write_ply(path: &Path, mesh: &TriMesh) -> Result<(), FormatError> {
    write_atomic(path, &ply_bytes(mesh, true))
}

/// The bytes of a PLY file holding `mesh`: `binary_little_endian 1.0` when `binary`, else
/// `ascii 1.0`. Coordinates (and normals, when the mesh has one per vertex) are written as
/// `float`; faces, when there are any, as `list uchar int vertex_indices`.
pub fn ply_bytes(mesh: &TriMesh, binary: bool) -> Vec<u8> {
    let normals = mesh
        .normals
        .as_ref()
        .filter(|n| n.len() == mesh.vertices.len());
    let mut header = String::from("ply\n");
    header.push_str(if binary {
        "format binary_little_endian 1.0\n"
    } else {
        "format ascii 1.0\n"
    });
    header.push_str("comment written by rigfit\n");
    header.push_str(&format!("element vertex {}\n", mesh.vertices.len()));
    header.push_str("property float x\nproperty float y\nproperty float z\n");
    if normals.is_some() {
        header.push_str("property float nx\nproperty float ny\nproperty float nz\n");
    }
    if !mesh.triangles.is_empty() {
        header.push_str(&format!("element face {}\n", mesh.triangles.len()));
        header.push_str("property list uchar int vertex_indices\n");
    }
    header.push_str("end_header\n");

    let mut out = header.into_bytes();
    let per_vertex = if normals.is_some() { 24 } else { 12 };
    if binary {
        out.reserve(mesh.vertices.len() * per_vertex + mesh.triangles.len() * 13);
        for (i, p) in mesh.vertices.iter().enumerate() {
            for c in p.iter() {
                out.extend_from_slice(&(*c as f32).to_le_bytes());
            }
            if let Some(n) = normals {
                for c in n[i].iter() {
                    out.extend_from_slice(&(*c as f32).to_le_bytes());
                }
            }
        }
        for t in &mesh.triangles {
            out.push(3);
            for &i in t {
                out.extend_from_slice(&(i as i32).to_le_bytes());
            }
        }
    } else {
        use std::fmt::Write as _;
        let mut text = String::new();
        for (i, p) in mesh.vertices.iter().enumerate() {
            let _ = write!(text, "{} {} {}", p.x as f32, p.y as f32, p.z as f32);
            if let Some(n) = normals {
                let n = n[i];
                let _ = write!(text, " {} {} {}", n.x as f32, n.y as f32, n.z as f32);
            }
            text.push('\n');
        }
        for t in &mesh.triangles {
            let _ = writeln!(text, "3 {} {} {}", t[0], t[1], t[2]);
        }
        out.extend_from_slice(text.as_bytes());
    }
    out
}

// ---------------------------------------------------------------------------------------
// Header
// ---------------------------------------------------------------------------------------

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Format {
    Ascii,
    BinaryLe,
    BinaryBe,
}

/// A PLY scalar type.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Scalar {
    fn from_name(name: &str) -> Option<Self> {
        Some(match name {
            "char" | "int8" => Self::I8,
            "uchar" | "uint8" => Self::U8,
            "short" | "int16" => Self::I16,
            "ushort" | "uint16" => Self::U16,
            "int" | "int32" => Self::I32,
            "uint" | "uint32" => Self::U32,
            "float" | "float32" => Self::F32,
            "double" | "float64" => Self::F64,
            _ => return None,
        })
    }

    fn size(self) -> usize {
        match self {
            Self::I8 | Self::U8 => 1,
            Self::I16 | Self::U16 => 2,
            Self::I32 | Self::U32 | Self::F32 => 4,
            Self::F64 => 8,
        }
    }

    fn is_integer(self) -> bool {
        !matches!(self, Self::F32 | Self::F64)
    }

    /// Decodes one value; `b` must hold at least `self.size()` bytes.
    fn decode(self, b: &[u8], big_endian: bool) -> Value {
        fn arr<const N: usize>(b: &[u8], big_endian: bool) -> [u8; N] {
            let mut a = [0u8; N];
            a.copy_from_slice(&b[..N]);
            if big_endian {
                a.reverse();
            }
            a
        }
        match self {
            Self::I8 => Value::Int(i64::from(b[0] as i8)),
            Self::U8 => Value::Int(i64::from(b[0])),
            Self::I16 => Value::Int(i64::from(i16::from_le_bytes(arr(b, big_endian)))),
            Self::U16 => Value::Int(i64::from(u16::from_le_bytes(arr(b, big_endian)))),
            Self::I32 => Value::Int(i64::from(i32::from_le_bytes(arr(b, big_endian)))),
            Self::U32 => Value::Int(i64::from(u32::from_le_bytes(arr(b, big_endian)))),
            Self::F32 => Value::Float(f64::from(f32::from_le_bytes(arr(b, big_endian)))),
            Self::F64 => Value::Float(f64::from_le_bytes(arr(b, big_endian))),
        }
    }

    /// Parses one ascii value.
    fn parse_text(self, token: &[u8]) -> Option<Value> {
        let s = std::str::from_utf8(token).ok()?;
        if self.is_integer() {
            s.parse::<i64>().ok().map(Value::Int)
        } else {
            s.parse::<f64>().ok().map(Value::Float)
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Value {
    Int(i64),
    Float(f64),
}

impl Value {
    fn as_f64(self) -> f64 {
        match self {
            Value::Int(i) => i as f64,
            Value::Float(f) => f,
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum PropKind {
    Scalar(Scalar),
    List { count: Scalar, item: Scalar },
}

#[derive(Clone, Debug)]
struct Property {
    name: String,
    kind: PropKind,
}

#[derive(Clone, Debug)]
struct Element {
    name: String,
    count: usize,
    props: Vec<Property>,
    /// The header line declaring it (1-based), for errors about the header.
    line: usize,
}

impl Element {
    fn scalar(&self, name: &str) -> Option<usize> {
        self.props
            .iter()
            .position(|p| p.name == name && matches!(p.kind, PropKind::Scalar(_)))
    }

    /// The fewest bytes one row can take in the given format (at least 1).
    fn min_row_bytes(&self, format: Format) -> usize {
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
struct Header {
    format: Format,
    elements: Vec<Element>,
    /// The byte offset where the body starts.
    data_start: usize,
    /// The number of header lines (the body's first line is `lines + 1`).
    lines: usize,
}

fn header_err(line: usize, problem: impl Into<String>) -> ParseError {
    ParseError::new(format!("header line {line}"), problem)
}

fn parse_header(bytes: &[u8]) -> Result<Header, ParseError> {
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
struct Layout {
    vertex: usize,
    xyz: [usize; 3],
    normals: Option<[usize; 3]>,
    /// The face element and its index list property.
    face: Option<(usize, usize)>,
}

impl Layout {
    fn new(header: &Header) -> Result<Self, ParseError> {
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

// ---------------------------------------------------------------------------------------
// Body
// ---------------------------------------------------------------------------------------

/// One decoded row: the scalar values by property index (0 for lists) and the items of the
/// one list the caller asked for.
#[derive(Debug, Default)]
struct Row {
    scalars: Vec<f64>,
    list: Vec<i64>,
}

trait RowSource {
    /// Reads row `row` of `el`, keeping the items of list property `capture`.
    fn read_row(
        &mut self,
        el: &Element,
        row: usize,
        capture: Option<usize>,
        out: &mut Row,
    ) -> Result<(), ParseError>;

    /// The bytes not read yet.
    fn remaining(&self) -> usize;
}

fn ends_early(el: &Element, row: usize, at: String) -> ParseError {
    let rows = if el.count == 1 { "row" } else { "rows" };
    ParseError::new(
        format!("{} {row}", el.name),
        format!(
            "the data ends early: the header declares {} {:?} {rows} but the file ends {at}",
            el.count, el.name
        ),
    )
}

struct AsciiSource<'a> {
    data: &'a [u8],
    pos: usize,
    /// The number of the last line read (1-based, counting the header).
    line: usize,
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

struct BinarySource<'a> {
    data: &'a [u8],
    pos: usize,
    /// The offset of `data` in the file, for error places.
    base: usize,
    big_endian: bool,
}

impl BinarySource<'_> {
    fn take(&mut self, n: usize) -> Option<&[u8]> {
        let end = self.pos.checked_add(n)?;
        let b = self.data.get(self.pos..end)?;
        self.pos = end;
        Some(b)
    }
}

impl RowSource for BinarySource<'_> {
    fn read_row(
        &mut self,
        el: &Element,
        row: usize,
        capture: Option<usize>,
        out: &mut Row,
    ) -> Result<(), ParseError> {
        let big_endian = self.big_endian;
        let eof = |s: &Self| {
            ends_early(
                el,
                row,
                format!("inside it, at byte {}", s.base + s.data.len()),
            )
        };
        out.scalars.clear();
        out.list.clear();
        for (pi, prop) in el.props.iter().enumerate() {
            match prop.kind {
                PropKind::Scalar(ty) => {
                    let Some(b) = self.take(ty.size()) else {
                        return Err(eof(self));
                    };
                    out.scalars.push(ty.decode(b, big_endian).as_f64());
                }
                PropKind::List { count, item } => {
                    out.scalars.push(0.0);
                    let at = self.base + self.pos;
                    let Some(b) = self.take(count.size()) else {
                        return Err(eof(self));
                    };
                    let n = match count.decode(b, big_endian) {
                        Value::Int(n) => usize::try_from(n).ok(),
                        Value::Float(_) => None,
                    };
                    let Some(n) = n else {
                        return Err(ParseError::new(
                            format!("{} {row} (byte {at})", el.name),
                            format!("list {:?} has a negative length", prop.name),
                        ));
                    };
                    let Some(items) = n.checked_mul(item.size()).and_then(|len| self.take(len))
                    else {
                        return Err(ParseError::new(
                            format!("{} {row}", el.name),
                            format!(
                                "the data ends early: list {:?} at byte {at} declares {n} items \
                                 but only {} bytes are left",
                                prop.name,
                                self.remaining()
                            ),
                        ));
                    };
                    if capture == Some(pi) {
                        out.list
                            .extend(items.chunks_exact(item.size()).filter_map(|c| {
                                match item.decode(c, big_endian) {
                                    Value::Int(i) => Some(i),
                                    Value::Float(_) => None,
                                }
                            }));
                    }
                }
            }
        }
        Ok(())
    }

    fn remaining(&self) -> usize {
        self.data.len() - self.pos
    }
}

fn read_body(
    header: &Header,
    layout: &Layout,
    src: &mut impl RowSource,
) -> Result<TriMesh, ParseError> {
    let vertex_count = header.elements[layout.vertex].count;
    let mut vertices: Vec<Point3> = Vec::new();
    let mut normals: Vec<Vector3> = Vec::new();
    let mut triangles: Vec<[u32; 3]> = Vec::new();
    let mut row_buf = Row::default();
    // The first vertex whose normal is NaN or infinite (scanners write these for points
    // where normal estimation failed): the normals are then dropped as a whole.
    let mut bad_normal: Option<usize> = None;
    for (ei, el) in header.elements.iter().enumerate() {
        if el.props.is_empty() {
            // Rows of nothing take no bytes; there is nothing to read.
            continue;
        }
        let cap = el
            .count
            .min(src.remaining() / el.min_row_bytes(header.format));
        if ei == layout.vertex {
            vertices.reserve(cap);
            if layout.normals.is_some() {
                normals.reserve(cap);
            }
            for row in 0..el.count {
                src.read_row(el, row, None, &mut row_buf)?;
                let s = &row_buf.scalars;
                let [x, y, z] = layout.xyz;
                vertices.push(Point3::new(s[x], s[y], s[z]));
                if let Some([a, b, c]) = layout.normals {
                    let n = Vector3::new(s[a], s[b], s[c]);
                    if bad_normal.is_none()
                        && n.iter().any(|v| !v.is_finite() || v.abs() > MAX_COORDINATE)
                    {
                        bad_normal = Some(row);
                    }
                    normals.push(n);
                }
            }
        } else if let Some((_, list)) = layout.face.filter(|&(f, _)| f == ei) {
            triangles.reserve(cap);
            for row in 0..el.count {
                src.read_row(el, row, Some(list), &mut row_buf)?;
                let idx = &row_buf.list;
                if idx.len() < 3 {
                    return Err(ParseError::new(
                        format!("face {row}"),
                        format!(
                            "a face needs at least 3 vertex indices (this one has {})",
                            idx.len()
                        ),
                    ));
                }
                let mut fixed = [0u32; 3];
                let check = |i: i64| -> Result<u32, ParseError> {
                    usize::try_from(i)
                        .ok()
                        .filter(|&u| u < vertex_count)
                        .and_then(|u| u32::try_from(u).ok())
                        .ok_or_else(|| {
                            ParseError::new(
                                format!("face {row}"),
                                format!(
                                    "vertex index {i} is out of range (the file has {vertex_count} vertices)"
                                ),
                            )
                        })
                };
                fixed[0] = check(idx[0])?;
                let mut prev = check(idx[1])?;
                for &i in &idx[2..] {
                    let cur = check(i)?;
                    fixed[1] = prev;
                    fixed[2] = cur;
                    triangles.push(fixed);
                    prev = cur;
                }
            }
        } else {
            tracing::debug!(element = %el.name, rows = el.count, "skipping PLY element");
            for row in 0..el.count {
                src.read_row(el, row, None, &mut row_buf)?;
            }
        }
    }
    check_finite("vertex", &vertices)?;
    let normals = match (layout.normals, bad_normal) {
        (Some(_), None) => Some(normals),
        (Some(_), Some(row)) => {
            tracing::warn!(
                vertex = row,
                "PLY normals dropped: a normal is not a finite number (NaN or infinity) or is out of range"
            );
            None
        }
        (None, _) => None,
    };
    Ok(TriMesh {
        vertices,
        normals,
        triangles,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ascii(body: &str) -> Result<TriMesh, ParseError> {
        parse_ply(body.as_bytes())
    }

    #[test]
    fn scalar_decoding_both_endians() {
        assert_eq!(Scalar::I16.decode(&[0xff, 0xfe], false), Value::Int(-257));
        assert_eq!(Scalar::I16.decode(&[0xfe, 0xff], true), Value::Int(-257));
        assert_eq!(Scalar::U16.decode(&[0x01, 0x02], true), Value::Int(0x0102));
        assert_eq!(Scalar::I8.decode(&[0x80], false), Value::Int(-128));
        assert_eq!(
            Scalar::U32.decode(&[0xff, 0xff, 0xff, 0xff], false),
            Value::Int(u32::MAX as i64)
        );
        assert_eq!(
            Scalar::F32.decode(&1.5f32.to_be_bytes(), true),
            Value::Float(1.5)
        );
        assert_eq!(
            Scalar::F64.decode(&(-2.25f64).to_le_bytes(), false),
            Value::Float(-2.25)
        );
    }

    #[test]
    fn quad_is_fanned_and_crlf_header_tolerated() {
        let text = "ply\r\nformat ascii 1.0\r\ncomment hi\r\nobj_info x\r\nelement vertex 5\r\n\
            property float x\r\nproperty float y\r\nproperty float z\r\n\
            element face 1\r\nproperty list uchar int vertex_index\r\nend_header\r\n\
            0 0 0\r\n1 0 0\r\n1 1 0\r\n0 1 0\r\n0 2 0\r\n5 0 1 2 3 4\r\n";
        let m = ascii(text).expect("parses");
        assert_eq!(m.vertices.len(), 5);
        assert_eq!(m.triangles, vec![[0, 1, 2], [0, 2, 3], [0, 3, 4]]);
        assert!(m.normals.is_none());
    }

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

    #[test]
    fn huge_counts_do_not_allocate_or_hang() {
        for fmt in ["ascii", "binary_little_endian"] {
            let text = format!(
                "ply\nformat {fmt} 1.0\nelement vertex 18446744073709551615\n\
                 property float x\nproperty float y\nproperty float z\n\
                 element empty 18446744073709551615\nend_header\n1 2 3\n"
            );
            assert!(ascii(&text).is_err());
        }
        let e =
            ascii("ply\nformat ascii 1.0\nelement vertex 99999999999999999999999\nend_header\n")
                .expect_err("overflow");
        assert!(e.problem.contains("invalid count"), "{e}");
    }

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
