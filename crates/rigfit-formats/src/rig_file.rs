//! Reading any rig file (glTF/GLB or BVH) into a [`Rig`], and writing a posed result back
//! in the format of the output path.

use std::path::{Path, PathBuf};

use rigfit_core::{Pose, Rig};

use crate::bvh::{BvhDocument, read_bvh};
use crate::error::{FormatError, ParseError, extension};
use crate::gltf::{GltfDocument, read_gltf};

/// Which BVH frame a rig starts from.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum StartFrame {
    /// Frame `k` of the motion (frame 0 by default).
    Frame(usize),
    /// All channels zero.
    #[default]
    First,
    Rest,
}

/// The document a rig was read from, kept so the output can preserve it.
#[derive(Debug, Clone)]
pub enum RigSource {
    Gltf(Box<GltfDocument>),
    Bvh(BvhDocument),
}

/// A rig and the file it came from.
#[derive(Debug, Clone)]
pub struct RigFile {
    pub path: PathBuf,
    pub rig: Rig,
    pub source: RigSource,
}

/// Options for reading a rig.
#[derive(Debug, Clone, Default)]
pub struct RigOptions {
    /// The glTF skin to use (by name); the first when `None`.
    pub skin: Option<String>,
    /// The BVH frame the stored pose is taken from.
    pub start_frame: StartFrame,
}

/// Reads a `.glb`, `.gltf` or `.bvh` rig.
pub fn read_rig(path: &Path, options: &RigOptions) -> Result<RigFile, FormatError> {
    match extension(path).as_str() {
        "glb" | "gltf" => {
            let doc = read_gltf(path, options.skin.as_deref())?;
            let rig = doc
                .require_rig()
                .map_err(|e| FormatError::parse(path, e))?
                .clone();
            Ok(RigFile {
                path: path.to_path_buf(),
                rig,
                source: RigSource::Gltf(Box::new(doc)),
            })
        }
        "bvh" => {
            let doc = read_bvh(path)?;
            let start = match options.start_frame {
                StartFrame::Rest => None,
                StartFrame::First => (!doc.frames.is_empty()).then_some(0),
                StartFrame::Frame(k) => {
                    if k >= doc.frames.len() {
                        return Err(FormatError::parse(
                            path,
                            ParseError::new(
                                "MOTION",
                                format!(
                                    "start frame {k} does not exist ({} frames)",
                                    doc.frames.len()
                                ),
                            ),
                        ));
                    }
                    Some(k)
                }
            };
            let rig = doc.to_rig(start);
            Ok(RigFile {
                path: path.to_path_buf(),
                rig,
                source: RigSource::Bvh(doc),
            })
        }
        _ => Err(FormatError::Unsupported {
            path: path.to_path_buf(),
            expected: "a rig: .glb, .gltf or .bvh".into(),
        }),
    }
}

impl RigFile {
    /// Writes the rig with `pose` to `out`: `.glb`/`.gltf` (only from a glTF source: the
    /// input file with the pose as node transforms and `keys` as its `rigfit` animation) or
    /// `.bvh` (a BVH source keeps its channels; `keys` become its frames, or `pose` alone).
    pub fn write(&self, out: &Path, pose: &Pose, keys: &[(f64, Pose)]) -> Result<(), FormatError> {
        match (extension(out).as_str(), &self.source) {
            ("glb" | "gltf", RigSource::Gltf(doc)) => doc.write(out, pose, keys),
            ("bvh", RigSource::Bvh(doc)) => {
                let mut doc = doc.clone();
                doc.frames.clear();
                if keys.is_empty() {
                    doc.set_frame_from_pose(0, pose);
                } else {
                    for (k, (_, p)) in keys.iter().enumerate() {
                        doc.set_frame_from_pose(k, p);
                    }
                }
                doc.write(out)
            }
            ("bvh", RigSource::Gltf(_)) => {
                let poses: Vec<Pose> = if keys.is_empty() {
                    vec![pose.clone()]
                } else {
                    keys.iter().map(|(_, p)| p.clone()).collect()
                };
                BvhDocument::from_skeleton(
                    &self.rig.skeleton,
                    &poses,
                    1.0 / crate::gltf::FRAMES_PER_SECOND,
                )
                .write(out)
            }
            ("glb", RigSource::Bvh(_)) => {
                let mut rig = self.rig.clone();
                rig.pose = pose.clone();
                crate::gltf::write_rig_glb(out, &rig)
            }
            _ => Err(FormatError::Unsupported {
                path: out.to_path_buf(),
                expected: match self.source {
                    RigSource::Gltf(_) => ".glb, .gltf or .bvh".into(),
                    RigSource::Bvh(_) => ".bvh or .glb".into(),
                },
            }),
        }
    }
}
