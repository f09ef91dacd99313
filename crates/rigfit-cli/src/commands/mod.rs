//! One module per subcommand.

pub mod demo;
pub mod demo_rig;
pub mod info;
pub mod pose;
pub mod render;
pub mod serve;
pub mod surface;
pub mod track;

use std::path::Path;

use rigfit_core::TriMesh;
use rigfit_formats::error::extension;

/// Reads a mesh or point cloud by extension (.ply, .obj): the frames of `track` and
/// `surface`, the meshes `render` draws.
pub fn read_mesh(path: &Path) -> anyhow::Result<TriMesh> {
    Ok(match extension(path).as_str() {
        "ply" => rigfit_formats::ply::read_ply(path)?,
        "obj" => rigfit_formats::obj::read_obj(path)?,
        _ => {
            return Err(rigfit_formats::FormatError::Unsupported {
                path: path.to_path_buf(),
                expected: "a mesh or point cloud: .ply or .obj".into(),
            }
            .into());
        }
    })
}
