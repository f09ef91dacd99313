//! The PLY body: rows read one at a time from an ascii or binary source into a mesh.

use rigfit_core::{Point3, TriMesh, Vector3};

use crate::error::{MAX_COORDINATE, ParseError, check_finite};

use super::header::{Element, Header, Layout};

/// One decoded row: the scalar values by property index (0 for lists) and the items of the
/// one list the caller asked for.
#[derive(Debug, Default)]
pub(super) struct Row {
    pub(super) scalars: Vec<f64>,
    pub(super) list: Vec<i64>,
}

pub(super) trait RowSource {
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

pub(super) fn ends_early(el: &Element, row: usize, at: String) -> ParseError {
    let rows = if el.count == 1 { "row" } else { "rows" };
    ParseError::new(
        format!("{} {row}", el.name),
        format!(
            "the data ends early: the header declares {} {:?} {rows} but the file ends {at}",
            el.count, el.name
        ),
    )
}

pub(super) fn read_body(
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
    use crate::ply::tests::ascii;

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
}
