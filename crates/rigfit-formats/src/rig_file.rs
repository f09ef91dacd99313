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
    /// Frame `k` of the motion.
    Frame(usize),
    /// Frame 0 when the file has frames, else the rest pose.
    #[default]
    First,
    /// All channels zero.
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
    /// The rig as rigfit works with it (a flat WebXR hand rebuilt as a tree).
    pub rig: Rig,
    pub source: RigSource,
    /// When the hierarchy was rebuilt: for each joint of `rig`, its index in the file's own
    /// skeleton (the one in `source`).
    pub file_index: Option<Vec<usize>>,
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
            let rig = doc.require_rig().map_err(|e| FormatError::parse(path, e))?;
            let rebuilt = rigfit_core::hierarchy::webxr_hand_parents(&rig.skeleton)
                .and_then(|parents| rigfit_core::hierarchy::reparent(rig, &parents));
            let (rig, file_index) = match rebuilt {
                Some((rig, index)) => (rig, Some(index)),
                None => (rig.clone(), None),
            };
            Ok(RigFile {
                path: path.to_path_buf(),
                rig,
                source: RigSource::Gltf(Box::new(doc)),
                file_index,
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
                file_index: None,
            })
        }
        _ => Err(FormatError::Unsupported {
            path: path.to_path_buf(),
            expected: "a rig: .glb, .gltf or .bvh".into(),
        }),
    }
}

impl RigFile {
    /// `pose` (of [`Self::rig`]) expressed in the file's own skeleton.
    pub fn file_pose(&self, pose: &Pose) -> Pose {
        match (&self.file_index, &self.source) {
            (Some(index), RigSource::Gltf(doc)) => {
                let file_skeleton = &doc
                    .rig
                    .as_ref()
                    .expect("a glTF rig source has a skin")
                    .skeleton;
                let world = self.rig.skeleton.world_matrices(pose);
                let mut file_world = vec![rigfit_core::Matrix4::identity(); world.len()];
                for (j, &f) in index.iter().enumerate() {
                    file_world[f] = world[j];
                }
                file_skeleton.pose_from_world(&file_world)
            }
            _ => pose.clone(),
        }
    }

    /// Writes the rig posed as `pose` to `out`:
    /// - `.glb`/`.gltf` from a glTF source: the input file with the pose as node transforms
    ///   and as a key of the `rigfit` animation: at `frame` (at 24 frames per second, keeping
    ///   the animation's other keys) or, without a frame, as its only key at time 0;
    /// - `.bvh` from a BVH source: the file's skeleton and channels with the pose as frame
    ///   `frame` (other frames kept) or, without a frame, as the only frame;
    /// - `.bvh` from a glTF source, `.glb` from a BVH source: the rig written anew.
    pub fn write_pose(
        &self,
        out: &Path,
        pose: &Pose,
        frame: Option<usize>,
    ) -> Result<(), FormatError> {
        match (extension(out).as_str(), &self.source) {
            ("glb" | "gltf", RigSource::Gltf(doc)) => {
                let file_pose = self.file_pose(pose);
                let keys = match frame {
                    Some(n) => {
                        let t = n as f64 / crate::gltf::FRAMES_PER_SECOND;
                        let mut keys: Vec<(f64, Pose)> = doc
                            .rigfit_keys()
                            .into_iter()
                            .filter(|(k, _)| (k - t).abs() > 1e-6)
                            .collect();
                        keys.push((t, file_pose.clone()));
                        keys.sort_by(|a, b| a.0.total_cmp(&b.0));
                        keys
                    }
                    None => vec![(0.0, file_pose.clone())],
                };
                doc.write(out, &file_pose, &keys)
            }
            ("bvh", RigSource::Bvh(doc)) => {
                let mut doc = doc.clone();
                match frame {
                    Some(n) => doc.set_frame_from_pose(n, pose),
                    None => {
                        doc.frames.clear();
                        doc.set_frame_from_pose(0, pose);
                    }
                }
                doc.write(out)
            }
            ("bvh", RigSource::Gltf(_)) => BvhDocument::from_skeleton(
                &self.rig.skeleton,
                std::slice::from_ref(pose),
                1.0 / crate::gltf::FRAMES_PER_SECOND,
            )
            .write(out),
            ("glb", RigSource::Bvh(_)) => {
                let mut rig = self.rig.clone();
                rig.pose = pose.clone();
                crate::gltf::write_rig_glb(out, &rig)
            }
            _ => Err(FormatError::Unsupported {
                path: out.to_path_buf(),
                expected: match self.source {
                    RigSource::Gltf(_) => "an output rig: .glb, .gltf or .bvh".into(),
                    RigSource::Bvh(_) => "an output rig: .bvh or .glb".into(),
                },
            }),
        }
    }
}

impl RigFile {
    /// Writes the rig with one pose per time step to `out`, `1 / fps` seconds apart:
    /// - `.glb`/`.gltf` from a glTF source: the input file with the last pose as node
    ///   transforms and every pose as a key of the `rigfit` animation (replacing it);
    /// - `.bvh` from a BVH source: the file's skeleton and channels, one frame per pose;
    /// - `.bvh` from a glTF source, `.glb` from a BVH source: the rig written anew (a glTF
    ///   written anew holds the last pose).
    pub fn write_poses(&self, out: &Path, poses: &[Pose], fps: f64) -> Result<(), FormatError> {
        let Some(last) = poses.last() else {
            return Err(FormatError::parse(
                out,
                ParseError::new("poses", "nothing to write: no pose"),
            ));
        };
        match (extension(out).as_str(), &self.source) {
            ("glb" | "gltf", RigSource::Gltf(doc)) => {
                let keys: Vec<(f64, Pose)> = poses
                    .iter()
                    .enumerate()
                    .map(|(k, p)| (k as f64 / fps, self.file_pose(p)))
                    .collect();
                doc.write(out, &self.file_pose(last), &keys)
            }
            ("bvh", RigSource::Bvh(doc)) => {
                let mut doc = doc.clone();
                doc.frames.clear();
                doc.frame_time = 1.0 / fps;
                for (k, pose) in poses.iter().enumerate() {
                    doc.set_frame_from_pose(k, pose);
                }
                doc.write(out)
            }
            ("bvh", RigSource::Gltf(_)) => {
                BvhDocument::from_skeleton(&self.rig.skeleton, poses, 1.0 / fps).write(out)
            }
            _ => self.write_pose(out, last, None),
        }
    }
}
