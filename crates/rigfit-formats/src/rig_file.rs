//! Reading any rig file (glTF/GLB or BVH) into a [`Rig`], and writing a posed result back
//! in the format of the output path.

use std::path::{Path, PathBuf};

use rigfit_core::{Animation, Pose, Rig};

use crate::bvh::{BvhDocument, parse_bvh};
use crate::error::{FormatError, ParseError, extension, read_bytes, write_atomic};
use crate::gltf::GltfDocument;

/// The highest frame number rigfit writes beyond a file's own frames (`pose --frame N`, the
/// keys of an export): a BVH output holds a row for every frame up to it.
pub const MAX_FRAME: usize = 100_000;

/// The frame rates an animation is written at (frames per second), bounds included.
pub const FPS_RANGE: std::ops::RangeInclusive<f64> = 1e-3..=1e6;

/// What is wrong with `fps` as the frame rate of a written animation, if anything (the
/// caller names its option).
pub fn fps_problem(fps: f64) -> Option<String> {
    (!(fps.is_finite() && FPS_RANGE.contains(&fps))).then(|| {
        format!(
            "expected a number of frames per second from {} to {}, got {fps}",
            FPS_RANGE.start(),
            FPS_RANGE.end()
        )
    })
}

/// Checks a frame number to write: at most [`MAX_FRAME`], or within the `existing` frames.
fn check_frame(out: &Path, frame: usize, existing: usize) -> Result<(), FormatError> {
    if frame <= MAX_FRAME || frame < existing {
        return Ok(());
    }
    Err(FormatError::parse(
        out,
        ParseError::new(
            "frame",
            format!(
                "frame {frame} is out of range: at most {MAX_FRAME} (or a frame the file already has)"
            ),
        ),
    ))
}

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

/// A file type rigfit reads and writes rigs in.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RigFormat {
    Glb,
    Gltf,
    Bvh,
}

impl RigFormat {
    /// The format of a file name's extension (`None` for one rigfit does not read as a rig).
    pub fn from_path(path: &Path) -> Option<Self> {
        match extension(path).as_str() {
            "glb" => Some(Self::Glb),
            "gltf" => Some(Self::Gltf),
            "bvh" => Some(Self::Bvh),
            _ => None,
        }
    }

    /// The file extension (and the name `rigfit serve` reports): `glb`, `gltf` or `bvh`.
    pub fn extension(self) -> &'static str {
        match self {
            Self::Glb => "glb",
            Self::Gltf => "gltf",
            Self::Bvh => "bvh",
        }
    }
}

/// Reads a `.glb`, `.gltf` or `.bvh` rig; external glTF buffers are read relative to it.
pub fn read_rig(path: &Path, options: &RigOptions) -> Result<RigFile, FormatError> {
    // The type is checked before reading, so a wrong one is named even for a missing file.
    if RigFormat::from_path(path).is_none() {
        return Err(unsupported_rig(path));
    }
    let bytes = read_bytes(path)?;
    let _span = tracing::warn_span!("reading", file = %path.display()).entered();
    if matches!(
        RigFormat::from_path(path),
        Some(RigFormat::Glb | RigFormat::Gltf)
    ) {
        let doc = crate::gltf::parse_gltf_file(&bytes, path, options.skin.as_deref())?;
        return rig_file_from_gltf(doc, path);
    }
    let mut no_files = |_: &str, _: usize| -> Result<Vec<u8>, String> {
        Err("a BVH file has no external buffers".into())
    };
    rig_from_bytes(&bytes, path, options, &mut no_files)
}

/// Parses the bytes of a rig file held in memory (an upload); `name` is the file's name: its
/// extension gives the format and errors name it. A `.gltf` must embed its buffers (data
/// URIs): nothing is read from the file system.
pub fn parse_rig(bytes: &[u8], name: &Path, options: &RigOptions) -> Result<RigFile, FormatError> {
    let mut no_files = |uri: &str, _: usize| -> Result<Vec<u8>, String> {
        Err(format!(
            "external buffer '{uri}' cannot be read from memory (embed it as a data URI or use .glb)"
        ))
    };
    rig_from_bytes(bytes, name, options, &mut no_files)
}

/// The rig of a parsed glTF (a flat WebXR hand rebuilt as a tree).
fn rig_file_from_gltf(doc: GltfDocument, path: &Path) -> Result<RigFile, FormatError> {
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

fn unsupported_rig(path: &Path) -> FormatError {
    FormatError::Unsupported {
        path: path.to_path_buf(),
        expected: "a rig: .glb, .gltf or .bvh".into(),
    }
}

/// The one code path of [`read_rig`] and [`parse_rig`]: `load_uri` supplies external glTF
/// buffers.
fn rig_from_bytes(
    bytes: &[u8],
    path: &Path,
    options: &RigOptions,
    load_uri: &mut crate::gltf::LoadUri<'_>,
) -> Result<RigFile, FormatError> {
    match RigFormat::from_path(path) {
        Some(RigFormat::Glb | RigFormat::Gltf) => {
            let doc = crate::gltf::parse_gltf_with(bytes, load_uri, options.skin.as_deref())
                .map_err(|e| FormatError::parse(path, e))?;
            rig_file_from_gltf(doc, path)
        }
        Some(RigFormat::Bvh) => {
            let doc = parse_bvh(bytes).map_err(|e| FormatError::parse(path, e))?;
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
        None => Err(unsupported_rig(path)),
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

    /// Checks that frame `frame` may be written to `out` (see [`MAX_FRAME`]).
    pub fn check_frame(&self, out: &Path, frame: usize) -> Result<(), FormatError> {
        let existing = match &self.source {
            RigSource::Bvh(doc) => doc.frames.len(),
            RigSource::Gltf(_) => 0,
        };
        check_frame(out, frame, existing)
    }

    /// Writes the rig posed as `pose` to `out` (the bytes of [`Self::pose_bytes`]).
    pub fn write_pose(
        &self,
        out: &Path,
        pose: &Pose,
        frame: Option<usize>,
    ) -> Result<(), FormatError> {
        write_atomic(out, &self.pose_bytes(out, pose, frame)?)
    }

    /// The bytes of the rig posed as `pose`, in the format of `out`'s extension:
    /// - `.glb`/`.gltf` from a glTF source: the input file with the pose as node transforms
    ///   and as a key of the `rigfit` animation: at `frame` (at 24 frames per second, keeping
    ///   the animation's other keys) or, without a frame, as its only key at time 0;
    /// - `.bvh` from a BVH source: the file's skeleton and channels with the pose as frame
    ///   `frame` (other frames kept) or, without a frame, as the only frame;
    /// - `.bvh` from a glTF source, `.glb` from a BVH source: the rig written anew.
    ///
    /// `out` names the output in errors; relative image paths of a glTF are made reachable
    /// from its directory.
    pub fn pose_bytes(
        &self,
        out: &Path,
        pose: &Pose,
        frame: Option<usize>,
    ) -> Result<Vec<u8>, FormatError> {
        let _span = tracing::warn_span!("writing", file = %out.display()).entered();
        if let Some(n) = frame {
            self.check_frame(out, n)?;
        }
        match (RigFormat::from_path(out), &self.source) {
            (Some(format @ (RigFormat::Glb | RigFormat::Gltf)), RigSource::Gltf(doc)) => {
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
                Ok(doc.to_bytes(format == RigFormat::Glb, &file_pose, &keys, output_dir(out)))
            }
            (Some(RigFormat::Bvh), RigSource::Bvh(doc)) => {
                let mut doc = doc.clone();
                match frame {
                    Some(n) => doc.set_frame_from_pose(n, pose),
                    None => {
                        doc.frames.clear();
                        doc.set_frame_from_pose(0, pose);
                    }
                }
                Ok(doc.to_bvh_string().into_bytes())
            }
            (Some(RigFormat::Bvh), RigSource::Gltf(_)) => Ok(BvhDocument::from_skeleton(
                &self.rig.skeleton,
                std::slice::from_ref(pose),
                1.0 / crate::gltf::FRAMES_PER_SECOND,
            )
            .to_bvh_string()
            .into_bytes()),
            (Some(RigFormat::Glb), RigSource::Bvh(_)) => {
                let mut rig = self.rig.clone();
                rig.pose = pose.clone();
                Ok(crate::gltf::rig_to_glb(&rig))
            }
            _ => Err(self.unsupported_output(out)),
        }
    }

    /// Checks, before any work, that `out`'s extension names a format this rig can be
    /// written in (the formats of [`Self::pose_bytes`] and [`Self::poses_bytes`]).
    pub fn check_output_format(&self, out: &Path) -> Result<(), FormatError> {
        match (RigFormat::from_path(out), &self.source) {
            (Some(_), RigSource::Gltf(_)) | (Some(RigFormat::Bvh | RigFormat::Glb), _) => Ok(()),
            _ => Err(self.unsupported_output(out)),
        }
    }

    fn unsupported_output(&self, out: &Path) -> FormatError {
        FormatError::Unsupported {
            path: out.to_path_buf(),
            expected: match self.source {
                RigSource::Gltf(_) => "an output rig: .glb, .gltf or .bvh".into(),
                RigSource::Bvh(_) => "an output rig: .bvh or .glb".into(),
            },
        }
    }
}

/// The directory of an output path (`None` for a bare file name).
fn output_dir(out: &Path) -> Option<&Path> {
    out.parent().filter(|d| !d.as_os_str().is_empty())
}

impl RigFile {
    /// The bytes of the rig with one pose per time step, `1 / fps` seconds apart, in the
    /// format of `out`'s extension:
    /// - `.glb`/`.gltf` from a glTF source: the input file with the last pose as node
    ///   transforms and every pose as a key of the `rigfit` animation (replacing it);
    /// - `.bvh` from a BVH source: the file's skeleton and channels, one frame per pose;
    /// - `.bvh` from a glTF source, `.glb` from a BVH source: the rig written anew (a glTF
    ///   written anew holds the last pose).
    pub fn poses_bytes(
        &self,
        out: &Path,
        poses: &[Pose],
        fps: f64,
    ) -> Result<Vec<u8>, FormatError> {
        let _span = tracing::warn_span!("writing", file = %out.display()).entered();
        let Some(last) = poses.last() else {
            return Err(FormatError::parse(
                out,
                ParseError::new("poses", "nothing to write: no pose"),
            ));
        };
        match (RigFormat::from_path(out), &self.source) {
            (Some(format @ (RigFormat::Glb | RigFormat::Gltf)), RigSource::Gltf(doc)) => {
                let keys: Vec<(f64, Pose)> = poses
                    .iter()
                    .enumerate()
                    .map(|(k, p)| (k as f64 / fps, self.file_pose(p)))
                    .collect();
                Ok(doc.to_bytes(
                    format == RigFormat::Glb,
                    &self.file_pose(last),
                    &keys,
                    output_dir(out),
                ))
            }
            (Some(RigFormat::Bvh), RigSource::Bvh(doc)) => {
                let mut doc = doc.clone();
                doc.frames.clear();
                doc.frame_time = 1.0 / fps;
                for (k, pose) in poses.iter().enumerate() {
                    doc.set_frame_from_pose(k, pose);
                }
                Ok(doc.to_bvh_string().into_bytes())
            }
            (Some(RigFormat::Bvh), RigSource::Gltf(_)) => {
                Ok(
                    BvhDocument::from_skeleton(&self.rig.skeleton, poses, 1.0 / fps)
                        .to_bvh_string()
                        .into_bytes(),
                )
            }
            _ => self.pose_bytes(out, last, None),
        }
    }

    /// The rig as a `format` file with `pose` as its stored pose and `keys` (frame number,
    /// pose), sorted by frame with no frame twice, as the `rigfit` animation at
    /// `frame / fps` seconds:
    /// - glTF (`.glb`/`.gltf`) from a glTF source: the input file with `pose` as node
    ///   transforms and the keys as its `rigfit` animation (none when there are no keys);
    /// - glTF from a BVH source: the rig written anew, its motion kept and the keys added as
    ///   the `rigfit` animation;
    /// - `.bvh`: one frame per frame number from 0 to the last key, the poses between keys
    ///   interpolated (before the first key, the first key's pose); with no keys, `pose` as
    ///   the only frame. A BVH source keeps its skeleton and channels.
    ///
    /// `name` names the output in errors.
    pub fn keyed_bytes(
        &self,
        format: RigFormat,
        name: &Path,
        pose: &Pose,
        keys: &[(usize, Pose)],
        fps: f64,
    ) -> Result<Vec<u8>, FormatError> {
        if !(fps.is_finite() && fps > 0.0) {
            return Err(FormatError::parse(
                name,
                ParseError::new("fps", format!("must be a positive number, not {fps}")),
            ));
        }
        if let Some((last, _)) = keys.last() {
            check_frame(name, *last, 0)?;
        }
        let _span = tracing::warn_span!("writing", file = %name.display()).entered();
        let timed: Vec<(f64, Pose)> = keys
            .iter()
            .map(|(frame, p)| (*frame as f64 / fps, p.clone()))
            .collect();
        match (format, &self.source) {
            (RigFormat::Glb | RigFormat::Gltf, RigSource::Gltf(doc)) => {
                let file_keys: Vec<(f64, Pose)> =
                    timed.iter().map(|(t, p)| (*t, self.file_pose(p))).collect();
                Ok(doc.to_bytes(
                    format == RigFormat::Glb,
                    &self.file_pose(pose),
                    &file_keys,
                    None,
                ))
            }
            (RigFormat::Glb | RigFormat::Gltf, RigSource::Bvh(_)) => {
                let mut rig = self.rig.clone();
                rig.pose = pose.clone();
                rig.animations
                    .retain(|a| a.name != crate::gltf::RIGFIT_ANIMATION);
                if !timed.is_empty() {
                    rig.animations.push(Animation::through_poses(
                        crate::gltf::RIGFIT_ANIMATION,
                        &timed,
                    ));
                }
                Ok(match format {
                    RigFormat::Glb => crate::gltf::rig_to_glb(&rig),
                    _ => crate::gltf::rig_to_gltf(&rig),
                })
            }
            (RigFormat::Bvh, _) => {
                let frames = match keys.last() {
                    None => vec![pose.clone()],
                    Some((last, _)) => {
                        let animation = Animation::through_poses("keys", &timed);
                        (0..=*last)
                            .map(|k| animation.sample(pose, k as f64 / fps))
                            .collect()
                    }
                };
                match &self.source {
                    RigSource::Bvh(doc) => {
                        let mut doc = doc.clone();
                        doc.frames.clear();
                        doc.frame_time = 1.0 / fps;
                        for (k, frame) in frames.iter().enumerate() {
                            doc.set_frame_from_pose(k, frame);
                        }
                        Ok(doc.to_bvh_string().into_bytes())
                    }
                    RigSource::Gltf(_) => {
                        Ok(
                            BvhDocument::from_skeleton(&self.rig.skeleton, &frames, 1.0 / fps)
                                .to_bvh_string()
                                .into_bytes(),
                        )
                    }
                }
            }
        }
    }

    /// A `.glb` to show the rig in its stored pose: the glTF file itself (as GLB) when its
    /// hierarchy is the rig's, else the rig written anew (a BVH; a flat hand rebuilt as a
    /// tree). Joint `j` of [`Self::rig`] is its node `display_nodes()[j]`.
    pub fn display_glb(&self) -> Vec<u8> {
        match (&self.source, &self.file_index) {
            (RigSource::Gltf(doc), None) => doc.to_glb(),
            _ => crate::gltf::rig_to_glb(&self.rig),
        }
    }

    /// For each joint of [`Self::rig`], its node in [`Self::display_glb`].
    pub fn display_nodes(&self) -> Vec<usize> {
        match (&self.source, &self.file_index) {
            (RigSource::Gltf(doc), None) => doc.joint_nodes.clone(),
            // rig_to_glb writes joint j as node j.
            _ => (0..self.rig.skeleton.len()).collect(),
        }
    }
}
