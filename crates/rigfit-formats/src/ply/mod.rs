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

mod ascii;
mod binary;
mod body;
mod header;
mod scalar;
mod write;

use std::path::Path;

use rigfit_core::TriMesh;

use crate::error::{FormatError, ParseError, read_bytes};

use ascii::AsciiSource;
use binary::BinarySource;
use body::read_body;
use header::{Format, Layout, parse_header};

pub use write::{ply_bytes, write_ply};

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

#[cfg(test)]
pub(crate) mod tests {
    use rigfit_core::TriMesh;

    use crate::error::ParseError;

    /// Parses PLY text (the unit tests' files).
    pub(crate) fn ascii(body: &str) -> Result<TriMesh, ParseError> {
        super::parse_ply(body.as_bytes())
    }
}
