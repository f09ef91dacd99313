//! glTF 2.0 (`.gltf` with external or embedded buffers, and `.glb`): skins, inverse bind
//! matrices, skinned meshes and animations in; the same file with a new pose out.
//!
//! The document keeps the file's JSON as it was read; writing patches node transforms and
//! adds a `rigfit` animation, leaving every other part of the file intact.

mod accessor;
mod container;
mod read;
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
    read::parse(bytes, load_uri, skin_name)
}

/// Reads a `.gltf` or `.glb` file; external buffers are read relative to it.
pub fn read_gltf(path: &Path, skin_name: Option<&str>) -> Result<GltfDocument, FormatError> {
    let bytes = read_bytes(path)?;
    let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
    let mut load = |uri: &str| -> Result<Vec<u8>, String> {
        let decoded = percent_decode(uri);
        let file = dir.join(&decoded);
        std::fs::read(&file).map_err(|e| format!("cannot read '{}': {e}", file.display()))
    };
    let mut doc =
        parse_gltf(&bytes, &mut load, skin_name).map_err(|e| FormatError::parse(path, e))?;
    doc.source_dir = Some(dir);
    Ok(doc)
}

pub(crate) fn percent_decode(uri: &str) -> String {
    let bytes = uri.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        if bytes[i] == b'%' && i + 2 < bytes.len() {
            let hex = std::str::from_utf8(&bytes[i + 1..i + 3]).ok();
            if let Some(v) = hex.and_then(|h| u8::from_str_radix(h, 16).ok()) {
                out.push(v);
                i += 3;
                continue;
            }
        }
        out.push(bytes[i]);
        i += 1;
    }
    String::from_utf8_lossy(&out).into_owned()
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
        read::mesh_summaries(&self.json)
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
