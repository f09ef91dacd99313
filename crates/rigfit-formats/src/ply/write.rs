//! The PLY writer: a mesh as ascii or binary little endian PLY.

use std::path::Path;

use rigfit_core::TriMesh;

use crate::error::{FormatError, write_atomic};

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
