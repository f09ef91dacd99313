//! Wavefront OBJ: a reader for the geometry (`v`, `vn`, `f`) and a writer.
//!
//! Faces may be written `i`, `i/t`, `i//n` or `i/t/n`, with positive or negative (relative)
//! indices; polygons are fanned into triangles. Texture coordinates, groups, objects,
//! smoothing groups, materials, lines, points and unknown statements are ignored.
//!
//! Per-vertex normals: when faces reference normals, each vertex gets the normal it is first
//! referenced with (a vertex no face gives a normal to gets the area-weighted normal of its
//! faces, or zero when it has none); when no face references normals and there are exactly as
//! many `vn` as `v`, they are taken in order; otherwise the mesh has no normals.

use std::path::Path;

use rigfit_core::{Point3, TriMesh, Vector3};

use crate::error::{FormatError, ParseError, read_bytes, write_atomic};

/// One corner of a face: a vertex (0-based) and maybe a normal (0-based), both unchecked.
#[derive(Clone, Copy, Debug)]
struct Corner {
    v: usize,
    n: Option<usize>,
}

/// A face: its line and its corners in `corners[start..start + len]`.
#[derive(Clone, Copy, Debug)]
struct Face {
    line: usize,
    start: usize,
    len: usize,
}

/// Parses an OBJ file.
pub fn parse_obj(bytes: &[u8]) -> Result<TriMesh, ParseError> {
    let mut vertices: Vec<Point3> = Vec::new();
    let mut vn: Vec<Vector3> = Vec::new();
    let mut vt_count = 0usize;
    let mut corners: Vec<Corner> = Vec::new();
    let mut faces: Vec<Face> = Vec::new();

    for (i, raw) in bytes.split(|&b| b == b'\n').enumerate() {
        let line_no = i + 1;
        // A '#' starts a comment anywhere on the line.
        let raw = match raw.iter().position(|&b| b == b'#') {
            Some(p) => &raw[..p],
            None => raw,
        };
        let mut toks = raw
            .split(|b| b.is_ascii_whitespace())
            .filter(|t| !t.is_empty());
        let Some(keyword) = toks.next() else {
            continue;
        };
        match keyword {
            b"v" => {
                let p = three_numbers(&mut toks, line_no, "a vertex")?;
                vertices.push(Point3::from(p));
            }
            b"vn" => vn.push(three_numbers(&mut toks, line_no, "a normal")?),
            b"vt" => vt_count += 1,
            b"f" => {
                let start = corners.len();
                for tok in toks {
                    corners.push(parse_corner(
                        tok,
                        line_no,
                        vertices.len(),
                        vt_count,
                        vn.len(),
                    )?);
                }
                let len = corners.len() - start;
                if len < 3 {
                    return Err(ParseError::at_line(
                        line_no,
                        format!("a face needs at least 3 vertices (this one has {len})"),
                    ));
                }
                faces.push(Face {
                    line: line_no,
                    start,
                    len,
                });
            }
            _ => {}
        }
    }

    let nv = vertices.len();
    let mut triangles = Vec::with_capacity(corners.len().saturating_sub(2 * faces.len()));
    let mut assigned: Vec<Option<Vector3>> = Vec::new();
    let faces_have_normals = corners.iter().any(|c| c.n.is_some());
    if faces_have_normals {
        assigned = vec![None; nv];
    }
    for face in &faces {
        let cs = &corners[face.start..face.start + face.len];
        let mut idx = Vec::with_capacity(cs.len());
        for c in cs {
            let v = u32::try_from(c.v)
                .ok()
                .filter(|_| c.v < nv)
                .ok_or_else(|| {
                    ParseError::at_line(
                        face.line,
                        format!(
                            "vertex index {} is out of range (the file has {nv} vertices)",
                            c.v as u128 + 1
                        ),
                    )
                })?;
            if let Some(n) = c.n {
                let Some(normal) = vn.get(n) else {
                    return Err(ParseError::at_line(
                        face.line,
                        format!(
                            "normal index {} is out of range (the file has {} normals)",
                            n as u128 + 1,
                            vn.len()
                        ),
                    ));
                };
                let slot = &mut assigned[c.v];
                if slot.is_none() {
                    *slot = Some(*normal);
                }
            }
            idx.push(v);
        }
        for k in 1..idx.len() - 1 {
            triangles.push([idx[0], idx[k], idx[k + 1]]);
        }
    }

    let mut mesh = TriMesh {
        vertices,
        normals: None,
        triangles,
    };
    if faces_have_normals {
        let fallback = if assigned.iter().any(Option::is_none) {
            mesh.vertex_normals_from_faces()
        } else {
            Vec::new()
        };
        mesh.normals = Some(
            assigned
                .iter()
                .enumerate()
                .map(|(i, n)| n.unwrap_or_else(|| fallback[i]))
                .collect(),
        );
    } else if nv > 0 && vn.len() == nv {
        mesh.normals = Some(vn);
    }
    Ok(mesh)
}

/// Reads the first three numbers after a `v` / `vn` keyword; the rest of the line is ignored.
fn three_numbers<'a>(
    toks: &mut impl Iterator<Item = &'a [u8]>,
    line: usize,
    what: &str,
) -> Result<Vector3, ParseError> {
    let mut xyz = [0.0; 3];
    for x in &mut xyz {
        let Some(tok) = toks.next() else {
            return Err(ParseError::at_line(
                line,
                format!("{what} needs 3 numbers (x y z)"),
            ));
        };
        *x = std::str::from_utf8(tok)
            .ok()
            .and_then(|s| s.parse::<f64>().ok())
            .ok_or_else(|| {
                ParseError::at_line(
                    line,
                    format!(
                        "{:?} is not a number ({what} needs 3 numbers x y z)",
                        String::from_utf8_lossy(tok)
                    ),
                )
            })?;
        if let Some(problem) = crate::error::coordinate_problem(*x) {
            return Err(ParseError::at_line(line, problem));
        }
    }
    Ok(Vector3::from(xyz))
}

/// Parses `i`, `i/t`, `i//n` or `i/t/n`, resolving negative indices against the counts so
/// far. Positive indices are only checked once the whole file is read.
fn parse_corner(
    tok: &[u8],
    line: usize,
    nv: usize,
    nt: usize,
    nn: usize,
) -> Result<Corner, ParseError> {
    let text = String::from_utf8_lossy(tok);
    let parts: Vec<&str> = text.split('/').collect();
    if parts.len() > 3 {
        return Err(ParseError::at_line(
            line,
            format!("face corner {text:?} is not of the form v, v/t, v//n or v/t/n"),
        ));
    }
    let index = |s: &str, what: &str, count: usize| -> Result<usize, ParseError> {
        let i: i64 = s.parse().map_err(|_| {
            ParseError::at_line(line, format!("{what} index {s:?} is not an integer"))
        })?;
        if i > 0 {
            usize::try_from(i - 1)
                .map_err(|_| ParseError::at_line(line, format!("{what} index {i} is out of range")))
        } else if i < 0 {
            usize::try_from(i.unsigned_abs())
                .ok()
                .and_then(|back| count.checked_sub(back))
                .ok_or_else(|| {
                    ParseError::at_line(
                        line,
                        format!(
                            "{what} index {i} is out of range (only {count} {what} entries come before this line)"
                        ),
                    )
                })
        } else {
            Err(ParseError::at_line(
                line,
                format!("{what} index 0 is not valid (OBJ indices start at 1)"),
            ))
        }
    };
    let v = index(parts[0], "vertex", nv)?;
    if let Some(t) = parts.get(1).filter(|t| !t.is_empty()) {
        // Texture coordinates are not used, but a malformed index is still an error.
        index(t, "texture", nt)?;
    }
    let n = match parts.get(2).filter(|n| !n.is_empty()) {
        Some(n) => Some(index(n, "normal", nn)?),
        None => None,
    };
    Ok(Corner { v, n })
}

/// Reads an OBJ file, naming it in any error.
pub fn read_obj(path: &Path) -> Result<TriMesh, FormatError> {
    let bytes = read_bytes(path)?;
    let _span = tracing::warn_span!("reading", file = %path.display()).entered();
    parse_obj(&bytes).map_err(|e| FormatError::parse(path, e))
}

/// Writes an OBJ file atomically.
pub fn write_obj(path: &Path, mesh: &TriMesh) -> Result<(), FormatError> {
    write_atomic(path, obj_string(mesh).as_bytes())
}

/// The text of an OBJ file holding `mesh`: `v` lines, `vn` lines when the mesh has one normal
/// per vertex (faces then reference them as `i//i`), and `f` lines. Numbers are written in
/// full precision.
pub fn obj_string(mesh: &TriMesh) -> String {
    use std::fmt::Write as _;
    let normals = mesh
        .normals
        .as_ref()
        .filter(|n| n.len() == mesh.vertices.len());
    let mut s = String::from("# written by rigfit\n");
    for p in &mesh.vertices {
        let _ = writeln!(s, "v {} {} {}", p.x, p.y, p.z);
    }
    if let Some(normals) = normals {
        for n in normals {
            let _ = writeln!(s, "vn {} {} {}", n.x, n.y, n.z);
        }
    }
    for t in &mesh.triangles {
        let [a, b, c] = t.map(|i| u64::from(i) + 1);
        if normals.is_some() {
            let _ = writeln!(s, "f {a}//{a} {b}//{b} {c}//{c}");
        } else {
            let _ = writeln!(s, "f {a} {b} {c}");
        }
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn corner_forms_and_relative_indices() {
        let text = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvn 0 0 1\n\
                    f 1 2/1 3//1 4/1/1\nf -4 -3 -2\n";
        let m = parse_obj(text.as_bytes()).expect("parses");
        assert_eq!(m.triangles, vec![[0, 1, 2], [0, 2, 3], [0, 1, 2]]);
        // Vertices 0 and 1 are referenced without normals only; they get face normals.
        let n = m.normals.expect("normals");
        assert_eq!(n[2], Vector3::new(0.0, 0.0, 1.0));
        assert!((n[0] - Vector3::new(0.0, 0.0, 1.0)).norm() < 1e-12);
    }

    #[test]
    fn errors_name_the_line() {
        let e = parse_obj(b"v 0 0 0\nv 1 0 0\nf 1 2 3\n").expect_err("range");
        assert_eq!(e.place, "line 3");
        assert!(e.problem.contains("out of range"), "{e}");
        let e = parse_obj(b"v 0 0 0\nf -2 1 1\n").expect_err("relative");
        assert_eq!(e.place, "line 2");
        let e = parse_obj(b"v 0 0 0\nf 0 1 1\n").expect_err("zero");
        assert!(e.problem.contains("index 0"), "{e}");
        let e = parse_obj(b"v 0 0 inf\n").expect_err("inf");
        assert!(e.problem.contains("finite"), "{e}");
        let e = parse_obj(b"v 0 0 0\nf 1/2/3/4 1 1\n").expect_err("form");
        assert!(e.problem.contains("form"), "{e}");
    }
}
