//! `rigfit.load_mesh`, `rigfit.load_cloud` and `rigfit.save_mesh`: meshes and point clouds
//! read and written by rigfit-formats, as `rigfit surface` reads its reference and frames and
//! writes its output frames.

use std::path::PathBuf;

use numpy::PyArray2;
use pyo3::prelude::*;
use rigfit_core::{Point3, TriMesh, Vector3};
use rigfit_formats::files::write_atomic;
use rigfit_formats::mesh_file::{mesh_bytes, read_mesh, read_surface};

use crate::arrays::{Rows, point_rows, rows, to_rows, to_triangles, triangles, vector_rows};
use crate::error;

/// A `TriMesh` from Python arrays: `vertices` (n, 3), optional `normals` (n, 3) and `faces`
/// (k, 3) (vertex indices); `vertices_name` names the vertices in errors. Coordinates beyond
/// rigfit's range ([`rigfit_core::math::MAX_COORDINATE`]) are refused, as the readers refuse
/// them.
pub fn tri_mesh(
    vertices: &Bound<'_, PyAny>,
    vertices_name: &str,
    normals: Option<&Bound<'_, PyAny>>,
    faces: Option<&Bound<'_, PyAny>>,
) -> PyResult<TriMesh> {
    let vertices: Vec<Point3> = rows::<3>(vertices, vertices_name, None)?
        .into_iter()
        .map(Point3::from)
        .collect();
    if let Some(i) = rigfit_core::math::first_out_of_range(&vertices) {
        return Err(error(format!(
            "{vertices_name}[{i}]: a coordinate is beyond +-{:e} (rigfit's range)",
            rigfit_core::math::MAX_COORDINATE
        )));
    }
    let n = vertices.len();
    let normals = match normals {
        Some(normals) => Some(
            rows::<3>(normals, "normals", Some(n))?
                .into_iter()
                .map(Vector3::from)
                .collect(),
        ),
        None => None,
    };
    let triangles = match faces {
        Some(faces) => triangles(faces, "faces", n)?,
        None => Vec::new(),
    };
    Ok(TriMesh {
        vertices,
        normals,
        triangles,
    })
}

/// Reads a mesh: ``.ply`` or ``.obj`` (polygons fanned into triangles), or the skinned meshes
/// of a ``.glb`` / ``.gltf`` rig in its stored pose (what ``rigfit surface`` takes as its
/// reference). Returns ``(vertices (n, 3) float64, faces (k, 3) int64)``; a point cloud has
/// no faces ((0, 3)). Raises ``RigfitError`` with one line naming the file and the problem.
#[pyfunction]
pub fn load_mesh<'py>(
    py: Python<'py>,
    path: PathBuf,
) -> PyResult<(Rows<'py>, Bound<'py, PyArray2<i64>>)> {
    let mesh = py
        .detach(|| read_surface(&path))
        .map_err(|e| error(e.to_string()))?;
    Ok((
        to_rows(py, &point_rows(&mesh.vertices))?,
        to_triangles(py, &mesh.triangles)?,
    ))
}

/// Reads a point cloud (or a mesh's vertices): ``.ply`` or ``.obj``. Returns
/// ``(points (n, 3), normals (n, 3) or None)``: the file's normals when it has one per point
/// (a PLY with any normal that is not finite has none). Raises ``RigfitError`` with one line
/// naming the file and the problem.
#[pyfunction]
pub fn load_cloud<'py>(py: Python<'py>, path: PathBuf) -> PyResult<(Rows<'py>, Option<Rows<'py>>)> {
    let mesh = py
        .detach(|| read_mesh(&path))
        .map_err(|e| error(e.to_string()))?;
    let normals = match mesh
        .normals
        .as_ref()
        .filter(|n| n.len() == mesh.vertices.len())
    {
        Some(n) => Some(to_rows(py, &vector_rows(n))?),
        None => None,
    };
    Ok((to_rows(py, &point_rows(&mesh.vertices))?, normals))
}

/// Writes a mesh or point cloud: ``vertices`` (n, 3), ``faces`` (k, 3) vertex indices (none:
/// a point cloud), ``normals`` (n, 3). The type is the extension's: ``.ply`` (binary, with
/// 32-bit float coordinates, as ``rigfit surface`` writes its frames) or ``.obj`` (full
/// precision). The file is written to a temporary beside it and renamed into place, so it is
/// never left half-written. Raises ``RigfitError`` naming the argument or the file.
#[pyfunction]
#[pyo3(signature = (path, vertices, faces=None, normals=None))]
pub fn save_mesh(
    py: Python<'_>,
    path: PathBuf,
    vertices: &Bound<'_, PyAny>,
    faces: Option<&Bound<'_, PyAny>>,
    normals: Option<&Bound<'_, PyAny>>,
) -> PyResult<()> {
    let mesh = tri_mesh(vertices, "vertices", normals, faces)?;
    let bytes = mesh_bytes(&path, &mesh).map_err(|e| error(e.to_string()))?;
    py.detach(|| write_atomic(&path, &bytes))
        .map_err(|e| error(e.to_string()))
}
