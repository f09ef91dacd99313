//! Meshes and point clouds by file type: the frames and references of surface tracking (the
//! command line's and the Python package's, so both read and write the same).

use std::path::Path;

use rigfit_core::TriMesh;

use crate::error::{FormatError, ParseError, extension};
use crate::rig_file::{RigOptions, read_rig};

/// Reads a mesh or point cloud by extension: `.ply` or `.obj`.
pub fn read_mesh(path: &Path) -> Result<TriMesh, FormatError> {
    match extension(path).as_str() {
        "ply" => crate::ply::read_ply(path),
        "obj" => crate::obj::read_obj(path),
        _ => Err(FormatError::Unsupported {
            path: path.to_path_buf(),
            expected: "a mesh or point cloud: .ply or .obj".into(),
        }),
    }
}

/// Reads a reference surface: a `.ply` or `.obj` mesh, or the skinned meshes of a `.glb` /
/// `.gltf` rig in its stored pose (concatenated, with normals from the faces).
pub fn read_surface(path: &Path) -> Result<TriMesh, FormatError> {
    match extension(path).as_str() {
        "glb" | "gltf" => {
            let file = read_rig(path, &RigOptions::default())?;
            if file.rig.meshes.iter().all(|m| m.positions.is_empty()) {
                return Err(FormatError::parse(
                    path,
                    ParseError::new("", "the skin has no mesh"),
                ));
            }
            Ok(file.rig.skinned_surface(&file.rig.pose))
        }
        "ply" | "obj" => read_mesh(path),
        _ => Err(FormatError::Unsupported {
            path: path.to_path_buf(),
            expected: "a reference mesh: .ply, .obj, .glb or .gltf".into(),
        }),
    }
}

/// The bytes of `mesh` as the file type of `path`: binary little-endian `.ply` (coordinates
/// as 32-bit floats, as `rigfit surface` writes its frames) or `.obj` (full precision).
pub fn mesh_bytes(path: &Path, mesh: &TriMesh) -> Result<Vec<u8>, FormatError> {
    match extension(path).as_str() {
        "ply" => Ok(crate::ply::ply_bytes(mesh, true)),
        "obj" => Ok(crate::obj::obj_string(mesh).into_bytes()),
        _ => Err(FormatError::Unsupported {
            path: path.to_path_buf(),
            expected: "a mesh: .ply or .obj".into(),
        }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unknown_types_are_named() {
        let e = read_mesh(Path::new("a.stl")).expect_err("stl");
        assert_eq!(
            e.to_string(),
            "a.stl: unsupported file type (expected a mesh or point cloud: .ply or .obj)"
        );
        let e = read_surface(Path::new("a.bvh")).expect_err("bvh");
        assert!(e.to_string().contains(".ply, .obj, .glb or .gltf"), "{e}");
        let e = mesh_bytes(Path::new("a.glb"), &TriMesh::default()).expect_err("glb");
        assert!(e.to_string().contains("a mesh: .ply or .obj"), "{e}");
    }
}
