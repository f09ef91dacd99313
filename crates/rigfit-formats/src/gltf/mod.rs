//! glTF 2.0 (`.gltf` with external or embedded buffers, and `.glb`): skins, inverse bind
//! matrices, skinned meshes and animations in; the same file with a new pose out.
//!
//! The document keeps the file's JSON as it was read; writing patches node transforms and
//! adds a `rigfit` animation, leaving every other part of the file intact.

mod accessor;
mod animation;
mod container;
mod mesh;
mod nodes;
mod read;
mod skin;
mod write;

use std::path::{Path, PathBuf};

use rigfit_core::Rig;
use serde_json::Value;

use crate::error::{FormatError, ParseError, extension, read_bytes, write_atomic};

pub use container::is_glb;
pub use write::{rig_to_glb, rig_to_gltf};

/// The name of the animation rigfit writes its keys to.
pub const RIGFIT_ANIMATION: &str = "rigfit";
/// Frames per second used to place `--frame N` keys in time (Blender's default).
pub const FRAMES_PER_SECOND: f64 = 24.0;

/// A parsed glTF file: its JSON, its resolved buffers, and the rig of its selected skin.
#[derive(Debug, Clone)]
pub struct GltfDocument {
    pub json: Value,
    /// The bytes of every buffer, resolved from the GLB BIN chunk, data URIs or files.
    pub buffers: Vec<Vec<u8>>,
    /// The rig of the selected skin (`None` when the file has no skin).
    pub rig: Option<Rig>,
    /// The glTF node of each skeleton joint.
    pub joint_nodes: Vec<usize>,
    /// Index of the selected skin.
    pub skin: Option<usize>,
    /// Directory external URIs were resolved against.
    pub source_dir: Option<PathBuf>,
    /// The external files read for its buffers (resolved paths).
    pub external_files: Vec<PathBuf>,
}

/// A mesh of the file, for `rigfit info`.
#[derive(Debug, Clone, PartialEq)]
pub struct MeshSummary {
    pub name: String,
    pub vertices: usize,
    pub triangles: usize,
    pub skinned: bool,
}

/// Parses glTF JSON or GLB bytes. `load_uri` supplies the bytes of external buffers.
/// `skin_name` picks a skin by name (default: the first).
pub fn parse_gltf(
    bytes: &[u8],
    load_uri: &mut dyn FnMut(&str) -> Result<Vec<u8>, String>,
    skin_name: Option<&str>,
) -> Result<GltfDocument, ParseError> {
    read::parse(bytes, &mut |uri, _| load_uri(uri), skin_name)
}

/// Supplies the bytes of an external buffer: its URI and declared byteLength.
pub(crate) type LoadUri<'a> = dyn FnMut(&str, usize) -> Result<Vec<u8>, String> + 'a;

/// [`parse_gltf`] with a loader that is also given each buffer's byteLength.
pub(crate) fn parse_gltf_with(
    bytes: &[u8],
    load_uri: &mut LoadUri<'_>,
    skin_name: Option<&str>,
) -> Result<GltfDocument, ParseError> {
    read::parse(bytes, load_uri, skin_name)
}

/// The loader of external buffers for a glTF file in `dir`: only regular files inside `dir`
/// (see [`crate::files::read_relative_uri`]), at most the buffer's byteLength read; the files
/// read are added to `files`.
pub(crate) fn file_loader<'a>(
    dir: &'a Path,
    files: &'a mut Vec<PathBuf>,
) -> impl FnMut(&str, usize) -> Result<Vec<u8>, String> + 'a {
    move |uri: &str, byte_length: usize| {
        let (bytes, real) = crate::files::read_relative_uri(dir, uri, byte_length as u64)?;
        files.push(real);
        Ok(bytes)
    }
}

/// Checks the file's image URIs by the rules of external buffers (relative, inside the
/// glTF's folder): they are never read, but a written glTF points at them.
pub(crate) fn check_image_uris(json: &Value) -> Result<(), ParseError> {
    let Some(images) = json.get("images").and_then(Value::as_array) else {
        return Ok(());
    };
    for (i, image) in images.iter().enumerate() {
        let Some(uri) = image.get("uri").and_then(Value::as_str) else {
            continue;
        };
        let lower = uri.to_ascii_lowercase();
        if lower.starts_with("data:")
            || lower.starts_with("http://")
            || lower.starts_with("https://")
        {
            continue;
        }
        crate::files::relative_uri_path(uri)
            .map_err(|e| ParseError::new(format!("images[{i}]"), e))?;
    }
    Ok(())
}

/// Parses the bytes of a glTF file at `path` with its external buffers read from its
/// folder; the document records that folder and the files read.
pub(crate) fn parse_gltf_file(
    bytes: &[u8],
    path: &Path,
    skin_name: Option<&str>,
) -> Result<GltfDocument, FormatError> {
    let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
    let mut files = Vec::new();
    let mut doc = read::parse(bytes, &mut file_loader(&dir, &mut files), skin_name)
        .and_then(|doc| check_image_uris(&doc.json).map(|()| doc))
        .map_err(|e| FormatError::parse(path, e))?;
    doc.source_dir = Some(dir);
    doc.external_files = files;
    Ok(doc)
}

/// Reads a `.gltf` or `.glb` file; external buffers are read relative to it (inside its
/// folder only).
pub fn read_gltf(path: &Path, skin_name: Option<&str>) -> Result<GltfDocument, FormatError> {
    let bytes = read_bytes(path)?;
    let _span = tracing::warn_span!("reading", file = %path.display()).entered();
    parse_gltf_file(&bytes, path, skin_name)
}

impl GltfDocument {
    /// The rig, or an error naming the problem when the file has no skin.
    pub fn require_rig(&self) -> Result<&Rig, ParseError> {
        self.rig.as_ref().ok_or_else(|| {
            ParseError::new(
                "skins",
                "the file has no skin (no skeleton to pose or track)",
            )
        })
    }

    /// Every mesh of the file with its vertex and triangle counts.
    pub fn mesh_summaries(&self) -> Vec<MeshSummary> {
        mesh::mesh_summaries(&self.json)
    }

    /// The keys of the `rigfit` animation already in the file, as (time, pose) pairs.
    pub fn rigfit_keys(&self) -> Vec<(f64, rigfit_core::Pose)> {
        let Some(rig) = &self.rig else {
            return Vec::new();
        };
        let Some(anim) = rig.animations.iter().find(|a| a.name == RIGFIT_ANIMATION) else {
            return Vec::new();
        };
        let mut times: Vec<f64> = anim
            .channels
            .iter()
            .flat_map(|c| c.times.iter().copied())
            .collect();
        times.sort_by(f64::total_cmp);
        times.dedup_by(|a, b| (*a - *b).abs() < 1e-6);
        times
            .into_iter()
            .map(|t| (t, anim.sample(&rig.pose, t)))
            .collect()
    }

    /// The file with `pose` as its node transforms and `keys` (time, pose) as the `rigfit`
    /// animation (replacing an earlier one), as GLB or as `.gltf` JSON with embedded buffers.
    pub fn to_bytes(
        &self,
        glb: bool,
        pose: &rigfit_core::Pose,
        keys: &[(f64, rigfit_core::Pose)],
        out_dir: Option<&Path>,
    ) -> Vec<u8> {
        write::to_bytes(self, glb, pose, keys, out_dir)
    }

    /// The file as it was read, as GLB (a `.gltf` gets its buffer 0 as the binary chunk).
    pub fn to_glb(&self) -> Vec<u8> {
        write::encode(self.json.clone(), &self.buffers, true)
    }

    /// Writes the file with a new pose (see [`Self::to_bytes`]); `.glb` or `.gltf` by the
    /// extension of `path`.
    pub fn write(
        &self,
        path: &Path,
        pose: &rigfit_core::Pose,
        keys: &[(f64, rigfit_core::Pose)],
    ) -> Result<(), FormatError> {
        let glb = match extension(path).as_str() {
            "glb" => true,
            "gltf" => false,
            _ => {
                return Err(FormatError::Unsupported {
                    path: path.to_path_buf(),
                    expected: ".glb or .gltf".into(),
                });
            }
        };
        let dir = path.parent().filter(|d| !d.as_os_str().is_empty());
        write_atomic(path, &self.to_bytes(glb, pose, keys, dir))
    }
}

/// Writes a rig (skeleton, pose, skinned meshes, animations) as a new `.glb` file.
pub fn write_rig_glb(path: &Path, rig: &Rig) -> Result<(), FormatError> {
    write_atomic(path, &rig_to_glb(rig))
}
