//! BVH (Biovision Hierarchy) motion files: a tree of joints with offsets and channels, and
//! a block of frames that holds every channel's value.
//!
//! A joint's local transform is `T(offset + position channels) * R`, where `R` is the
//! product of its rotation channels in the order the file lists them, angles in degrees:
//! `CHANNELS 3 Zrotation Xrotation Yrotation` means `R = Rz(z) * Rx(x) * Ry(y)`. Scale is
//! always 1. `End Site`s are joints too (no channels), named after their parent
//! (`LeftHand` -> `LeftHand_End`). Joints are kept in file order, which is parents first.
//!
//! The parser copes with what real files do (any channel order or subset, several roots,
//! names with colons and spaces, CRLF, a `Frames:` header that disagrees with the rows
//! present) and fails with one line naming the place for anything else. The writer prints
//! every number with Rust's shortest round-trip formatting, so read -> write -> read keeps
//! every value exactly.

use std::collections::{HashMap, HashSet};
use std::fmt::{self, Write as _};
use std::path::Path;

use rigfit_core::animation::quat_to_xyzw;
use rigfit_core::{
    Animation, AnimationChannel, ChannelTarget, Interpolation, Joint, JointDof, JointKind, Pose,
    Quat, Rig, Skeleton, SkeletonError, Trs, Vector3,
};

use crate::error::{FormatError, MAX_COORDINATE, ParseError, read_bytes, write_atomic};

/// One channel of a BVH joint: a translation or a rotation (degrees) along an axis.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum BvhChannel {
    Xposition,
    Yposition,
    Zposition,
    Xrotation,
    Yrotation,
    Zrotation,
}

impl BvhChannel {
    /// Every channel, positions first.
    pub const ALL: [BvhChannel; 6] = [
        BvhChannel::Xposition,
        BvhChannel::Yposition,
        BvhChannel::Zposition,
        BvhChannel::Xrotation,
        BvhChannel::Yrotation,
        BvhChannel::Zrotation,
    ];

    /// The name used in files (`Xposition`, ..., `Zrotation`).
    pub fn name(self) -> &'static str {
        match self {
            BvhChannel::Xposition => "Xposition",
            BvhChannel::Yposition => "Yposition",
            BvhChannel::Zposition => "Zposition",
            BvhChannel::Xrotation => "Xrotation",
            BvhChannel::Yrotation => "Yrotation",
            BvhChannel::Zrotation => "Zrotation",
        }
    }

    /// The channel with this name (ASCII case ignored).
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL
            .into_iter()
            .find(|c| c.name().eq_ignore_ascii_case(name))
    }

    /// The axis: 0 for x, 1 for y, 2 for z.
    pub fn axis(self) -> usize {
        match self {
            BvhChannel::Xposition | BvhChannel::Xrotation => 0,
            BvhChannel::Yposition | BvhChannel::Yrotation => 1,
            BvhChannel::Zposition | BvhChannel::Zrotation => 2,
        }
    }

    pub fn is_position(self) -> bool {
        matches!(
            self,
            BvhChannel::Xposition | BvhChannel::Yposition | BvhChannel::Zposition
        )
    }

    pub fn is_rotation(self) -> bool {
        !self.is_position()
    }

    /// The position channel along `axis` (0, 1, 2; larger values give z).
    pub fn position(axis: usize) -> Self {
        [
            BvhChannel::Xposition,
            BvhChannel::Yposition,
            BvhChannel::Zposition,
        ][axis.min(2)]
    }

    /// The rotation channel about `axis` (0, 1, 2; larger values give z).
    pub fn rotation(axis: usize) -> Self {
        [
            BvhChannel::Xrotation,
            BvhChannel::Yrotation,
            BvhChannel::Zrotation,
        ][axis.min(2)]
    }
}

impl fmt::Display for BvhChannel {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// One joint of a BVH hierarchy (an `End Site` too).
#[derive(Clone, Debug, PartialEq)]
pub struct BvhJoint {
    pub name: String,
    /// The parent's index; always smaller than this joint's own index.
    pub parent: Option<usize>,
    pub offset: Vector3,
    /// The joint's channels in file order; their values sit in each frame in this order.
    pub channels: Vec<BvhChannel>,
    /// An `End Site`: a tip with an offset and no channels.
    pub end_site: bool,
}

impl BvhJoint {
    /// The joint's local transform for its channel values (`values[k]` belongs to
    /// `channels[k]`; missing values count as zero).
    pub fn local_transform(&self, values: &[f64]) -> Trs {
        let mut translation = self.offset;
        let mut rotation = Quat::identity();
        for (k, channel) in self.channels.iter().enumerate() {
            let v = values.get(k).copied().unwrap_or(0.0);
            if channel.is_position() {
                translation[channel.axis()] += v;
            } else {
                rotation *= axis_rotation(channel.axis(), v.to_radians());
            }
        }
        Trs::new(translation, rotation)
    }
}

/// A whole BVH file.
#[derive(Clone, Debug, PartialEq)]
pub struct BvhDocument {
    /// Joints in file order (parents first).
    pub joints: Vec<BvhJoint>,
    /// Seconds per frame.
    pub frame_time: f64,
    /// Each frame holds every joint's channel values, joints in order.
    pub frames: Vec<Vec<f64>>,
}

/// Reads a BVH file.
pub fn read_bvh(path: &Path) -> Result<BvhDocument, FormatError> {
    let bytes = read_bytes(path)?;
    let _span = tracing::warn_span!("reading", file = %path.display()).entered();
    parse_bvh(&bytes).map_err(|e| FormatError::parse(path, e))
}

/// Parses the bytes of a BVH file. Never panics; every error names a line.
pub fn parse_bvh(text: &[u8]) -> Result<BvhDocument, ParseError> {
    let text = String::from_utf8_lossy(text);
    let text = text.strip_prefix('\u{feff}').unwrap_or(&text);
    let text = if text.contains('\r') {
        text.replace("\r\n", "\n").replace('\r', "\n")
    } else {
        text.to_string()
    };
    let mut lx = Lexer {
        text: &text,
        pos: 0,
        line: 1,
    };
    let mut joints = parse_hierarchy(&mut lx)?;
    let (frame_time, frames) = parse_motion(&mut lx, &joints)?;
    name_end_sites(&mut joints);
    Ok(BvhDocument {
        joints,
        frame_time,
        frames,
    })
}

impl BvhDocument {
    /// The number of values in each frame.
    pub fn channel_count(&self) -> usize {
        self.joints.iter().map(|j| j.channels.len()).sum()
    }

    /// For each joint, the index of its first channel value in a frame.
    pub fn channel_starts(&self) -> Vec<usize> {
        let mut start = 0;
        self.joints
            .iter()
            .map(|j| {
                let s = start;
                start += j.channels.len();
                s
            })
            .collect()
    }

    /// The index of the joint with this name.
    pub fn find(&self, name: &str) -> Option<usize> {
        self.joints.iter().position(|j| j.name == name)
    }

    /// Writes the document as BVH text: tab-indented hierarchy, then the frames. Numbers
    /// use the shortest form that reads back to the same `f64`. Joints may be in any
    /// parents-first order; the file lists them depth first, with each frame's values in
    /// that order.
    pub fn to_bvh_string(&self) -> String {
        let n = self.joints.len();
        let mut children = vec![Vec::new(); n];
        let mut roots = Vec::new();
        for (i, j) in self.joints.iter().enumerate() {
            match j.parent {
                Some(p) if p < i => children[p].push(i),
                _ => roots.push(i),
            }
        }
        enum Step {
            Enter(usize, usize),
            Exit(usize),
        }
        let row_chars = self.channel_count().saturating_mul(10).saturating_add(1);
        let mut out = String::with_capacity(
            (64 * n).saturating_add(self.frames.len().saturating_mul(row_chars)),
        );
        out.push_str("HIERARCHY\n");
        let mut order = Vec::with_capacity(n);
        let mut stack: Vec<Step> = roots.iter().rev().map(|&r| Step::Enter(r, 0)).collect();
        while let Some(step) = stack.pop() {
            match step {
                Step::Exit(depth) => {
                    indent(&mut out, depth);
                    out.push_str("}\n");
                }
                Step::Enter(i, depth) => {
                    order.push(i);
                    let j = &self.joints[i];
                    let as_end_site =
                        j.end_site && j.channels.is_empty() && children[i].is_empty() && depth > 0;
                    indent(&mut out, depth);
                    if as_end_site {
                        out.push_str("End Site\n");
                    } else {
                        let keyword = if depth == 0 { "ROOT" } else { "JOINT" };
                        let _ = writeln!(out, "{keyword} {}", clean_name(&j.name, i));
                    }
                    indent(&mut out, depth);
                    out.push_str("{\n");
                    indent(&mut out, depth + 1);
                    let o = j.offset;
                    let _ = writeln!(out, "OFFSET {} {} {}", o.x, o.y, o.z);
                    if !as_end_site {
                        indent(&mut out, depth + 1);
                        let _ = write!(out, "CHANNELS {}", j.channels.len());
                        for c in &j.channels {
                            let _ = write!(out, " {c}");
                        }
                        out.push('\n');
                    }
                    stack.push(Step::Exit(depth));
                    for &c in children[i].iter().rev() {
                        stack.push(Step::Enter(c, depth + 1));
                    }
                }
            }
        }
        let starts = self.channel_starts();
        let _ = write!(
            out,
            "MOTION\nFrames: {}\nFrame Time: {}\n",
            self.frames.len(),
            self.frame_time
        );
        for frame in &self.frames {
            let mut first = true;
            for &i in &order {
                for k in 0..self.joints[i].channels.len() {
                    let v = frame.get(starts[i] + k).copied().unwrap_or(0.0);
                    if !first {
                        out.push(' ');
                    }
                    first = false;
                    let _ = write!(out, "{v}");
                }
            }
            out.push('\n');
        }
        out
    }

    /// Writes the document to a file (atomically: a temporary file, then a rename).
    pub fn write(&self, path: &Path) -> Result<(), FormatError> {
        write_atomic(path, self.to_bvh_string().as_bytes())
    }

    /// The skeleton of the hierarchy, or why it is not a valid tree (only possible for a
    /// document built by hand: the parser checks all of this).
    pub fn try_skeleton(&self) -> Result<Skeleton, SkeletonError> {
        let joints = self
            .joints
            .iter()
            .map(|j| {
                let mut joint =
                    Joint::new(j.name.clone(), j.parent, Trs::from_translation(j.offset));
                if j.end_site {
                    joint.kind = JointKind::EndSite;
                }
                joint
            })
            .collect();
        let mut skeleton = Skeleton::new(joints)?;
        skeleton.set_default_dofs();
        Ok(skeleton)
    }

    /// The skeleton: one joint per BVH joint (End Sites with [`JointKind::EndSite`]), rest
    /// transforms the offsets, default degrees of freedom.
    ///
    /// # Panics
    /// If the document has no joints, a parent that does not come before its child or a
    /// non-finite offset; [`parse_bvh`] never returns such a document (see
    /// [`Self::try_skeleton`]).
    pub fn skeleton(&self) -> Skeleton {
        self.try_skeleton()
            .expect("a BVH document has joints, parents first, with finite offsets")
    }

    /// The local transforms for one row of channel values.
    pub fn pose_from_values(&self, values: &[f64]) -> Pose {
        let mut start = 0;
        let local = self
            .joints
            .iter()
            .map(|j| {
                let n = j.channels.len();
                let slice = values.get(start..start + n).unwrap_or(&[]);
                start += n;
                j.local_transform(slice)
            })
            .collect();
        Pose { local }
    }

    /// The pose of frame `frame`. A frame past the end gives the last frame (with a
    /// warning); a document without frames gives the rest pose.
    pub fn pose_at_frame(&self, frame: usize) -> Pose {
        match self.frames.get(frame) {
            Some(values) => self.pose_from_values(values),
            None => {
                tracing::warn!(
                    "BVH frame {frame} requested but the motion has {} frames; using the last",
                    self.frames.len()
                );
                match self.frames.last() {
                    Some(values) => self.pose_from_values(values),
                    None => self.rest_pose(),
                }
            }
        }
    }

    /// The pose with every channel zero: each joint at its offset, unrotated.
    pub fn rest_pose(&self) -> Pose {
        Pose {
            local: self
                .joints
                .iter()
                .map(|j| Trs::from_translation(j.offset))
                .collect(),
        }
    }

    /// The motion as an animation named "motion": for each joint with rotation channels a
    /// linear rotation channel with one key per frame at `i * frame_time`, and a
    /// translation channel for joints with position channels. Joints without channels
    /// (End Sites, fixed joints) never move and get no keys, so the animation's size is that
    /// of the motion data.
    pub fn animation(&self) -> Animation {
        let times: Vec<f64> = (0..self.frames.len())
            .map(|i| i as f64 * self.frame_time)
            .collect();
        let starts = self.channel_starts();
        let mut channels = Vec::new();
        for (j, joint) in self.joints.iter().enumerate() {
            if joint.channels.is_empty() {
                continue;
            }
            let n = joint.channels.len();
            let locals: Vec<Trs> = self
                .frames
                .iter()
                .map(|f| joint.local_transform(f.get(starts[j]..starts[j] + n).unwrap_or(&[])))
                .collect();
            let mut previous: Option<Quat> = None;
            let rotations = locals
                .iter()
                .map(|t| {
                    // Keep neighbouring keys in one hemisphere so interpolation takes the
                    // short way.
                    let mut q = t.rotation;
                    if let Some(p) = previous {
                        if p.coords.dot(&q.coords) < 0.0 {
                            q = Quat::new_unchecked(-q.into_inner());
                        }
                    }
                    previous = Some(q);
                    quat_to_xyzw(&q)
                })
                .collect();
            if joint.channels.iter().any(|c| c.is_rotation()) {
                channels.push(AnimationChannel {
                    joint: j,
                    target: ChannelTarget::Rotation,
                    interpolation: Interpolation::Linear,
                    times: times.clone(),
                    values: rotations,
                });
            }
            if joint.channels.iter().any(|c| c.is_position()) {
                channels.push(AnimationChannel {
                    joint: j,
                    target: ChannelTarget::Translation,
                    interpolation: Interpolation::Linear,
                    times: times.clone(),
                    values: locals
                        .iter()
                        .map(|t| [t.translation.x, t.translation.y, t.translation.z, 0.0])
                        .collect(),
                });
            }
        }
        Animation {
            name: "motion".into(),
            channels,
            frame_time: Some(self.frame_time),
        }
    }

    /// The document as a rig: the skeleton, the stored pose (`None`: the rest pose with
    /// every channel zero; `Some(k)`: frame `k`), no meshes, and the motion as one
    /// animation named "motion" (none when there are no frames).
    ///
    /// # Panics
    /// As [`Self::skeleton`].
    pub fn to_rig(&self, start_frame: Option<usize>) -> Rig {
        let pose = match start_frame {
            None => self.rest_pose(),
            Some(k) => self.pose_at_frame(k),
        };
        let animations = if self.frames.is_empty() {
            Vec::new()
        } else {
            vec![self.animation()]
        };
        Rig {
            skeleton: self.skeleton(),
            pose,
            meshes: Vec::new(),
            animations,
        }
    }

    /// Stores `pose` as frame `frame`: each joint's local rotation becomes Euler angles in
    /// its own channel order, and its translation minus its offset the position channels.
    /// `frame == frames.len()` appends a frame (a larger index pads with all-zero frames).
    /// What the channels cannot hold (scale, a translation of a joint without position
    /// channels, a rotation about a missing axis) is dropped with a warning.
    pub fn set_frame_from_pose(&mut self, frame: usize, pose: &Pose) {
        let loss = self.set_frame_quiet(frame, pose);
        loss.warn();
    }

    fn set_frame_quiet(&mut self, frame: usize, pose: &Pose) -> Loss {
        let count = self.channel_count();
        if frame > self.frames.len() {
            tracing::warn!(
                "BVH frame {frame} set while the motion has {} frames; padding with zero frames",
                self.frames.len()
            );
        }
        while self.frames.len() <= frame {
            self.frames.push(vec![0.0; count]);
        }
        let mut row = std::mem::take(&mut self.frames[frame]);
        row.resize(count, 0.0);
        let mut loss = Loss::default();
        let mut start = 0;
        for (j, joint) in self.joints.iter().enumerate() {
            let n = joint.channels.len();
            if let Some(trs) = pose.local.get(j) {
                joint_values(joint, trs, &mut row[start..start + n], &mut loss);
            }
            start += n;
        }
        self.frames[frame] = row;
        loss
    }

    /// Any rig as BVH, one frame per pose. Every joint gets the channels `Zrotation
    /// Xrotation Yrotation` (End Sites none, and are written as `End Site` when they are
    /// leaves); roots, free joints and joints whose translation some pose changes get
    /// `Xposition Yposition Zposition` first. Offsets are the rest translations; helper
    /// joints (glTF armature nodes) are ordinary joints. BVH has no scale: uniform scales
    /// are folded into the translations below them (exact), other scales are dropped with a
    /// warning. The document keeps the skeleton's joint order, so its joint `i` is the
    /// skeleton's joint `i` (the file is written depth first).
    pub fn from_skeleton(skeleton: &Skeleton, poses: &[Pose], frame_time: f64) -> BvhDocument {
        let (rest, mut inexact_scale) = fold_scale(skeleton, &skeleton.rest_pose());
        let folded: Vec<Pose> = poses
            .iter()
            .map(|p| {
                let (pose, inexact) = fold_scale(skeleton, p);
                inexact_scale |= inexact;
                pose
            })
            .collect();
        let joints = skeleton
            .joints()
            .iter()
            .enumerate()
            .map(|(i, joint)| {
                let offset = rest.local[i].translation;
                let end_site = joint.kind == JointKind::EndSite && skeleton.children(i).is_empty();
                let mut channels = Vec::new();
                if !end_site {
                    let moves = joint.parent.is_none()
                        || joint.dof == JointDof::Free
                        || folded.iter().any(|p| {
                            p.local
                                .get(i)
                                .is_some_and(|t| translation_differs(&t.translation, &offset))
                        });
                    if moves {
                        channels.extend([
                            BvhChannel::Xposition,
                            BvhChannel::Yposition,
                            BvhChannel::Zposition,
                        ]);
                    }
                    channels.extend([
                        BvhChannel::Zrotation,
                        BvhChannel::Xrotation,
                        BvhChannel::Yrotation,
                    ]);
                }
                BvhJoint {
                    name: joint.name.clone(),
                    parent: joint.parent,
                    offset,
                    channels,
                    end_site,
                }
            })
            .collect();
        let mut doc = BvhDocument {
            joints,
            frame_time,
            frames: Vec::with_capacity(poses.len()),
        };
        let mut loss = Loss::default();
        for (k, pose) in folded.iter().enumerate() {
            loss.merge(doc.set_frame_quiet(k, pose));
        }
        if inexact_scale {
            tracing::warn!(
                "BVH has no scale: a non-uniform, negative or zero joint scale was dropped"
            );
        }
        loss.warn();
        doc
    }
}

/// What [`BvhDocument::set_frame_from_pose`] could not store: the first joint of each kind.
#[derive(Default)]
struct Loss {
    translation: Option<String>,
    rotation: Option<String>,
    scale: Option<String>,
}

impl Loss {
    fn merge(&mut self, other: Loss) {
        self.translation = self.translation.take().or(other.translation);
        self.rotation = self.rotation.take().or(other.rotation);
        self.scale = self.scale.take().or(other.scale);
    }

    fn warn(&self) {
        if let Some(name) = &self.translation {
            tracing::warn!(
                "BVH: joint '{name}' (maybe others) moved along an axis it has no position channel for; the move is dropped"
            );
        }
        if let Some(name) = &self.rotation {
            tracing::warn!(
                "BVH: the rotation of joint '{name}' (maybe others) needs an axis it has no rotation channel for; stored approximately"
            );
        }
        if let Some(name) = &self.scale {
            tracing::warn!(
                "BVH has no scale: the scale of joint '{name}' (maybe others) is dropped"
            );
        }
    }
}

fn translation_differs(a: &Vector3, b: &Vector3) -> bool {
    (0..3).any(|k| (a[k] - b[k]).abs() > 1e-9 * (1.0 + b[k].abs()))
}

/// Fills `out` (the joint's channel values) from a local transform.
fn joint_values(joint: &BvhJoint, trs: &Trs, out: &mut [f64], loss: &mut Loss) {
    let mut has_position = [false; 3];
    let mut rotation_slots: Vec<(usize, usize)> = Vec::new();
    for (k, c) in joint.channels.iter().enumerate() {
        let a = c.axis();
        if c.is_position() {
            if has_position[a] {
                out[k] = 0.0;
            } else {
                out[k] = trs.translation[a] - joint.offset[a];
                has_position[a] = true;
            }
        } else if rotation_slots.iter().any(|&(_, b)| b == a) {
            out[k] = 0.0;
        } else {
            rotation_slots.push((k, a));
        }
    }
    for a in 0..3 {
        let d = trs.translation[a] - joint.offset[a];
        if !has_position[a]
            && d.abs() > 1e-9 * (1.0 + joint.offset[a].abs())
            && loss.translation.is_none()
        {
            loss.translation = Some(joint.name.clone());
        }
    }
    if trs.scale.iter().any(|s| (s - 1.0).abs() > 1e-9) && loss.scale.is_none() {
        loss.scale = Some(joint.name.clone());
    }
    let axes: Vec<usize> = rotation_slots.iter().map(|&(_, a)| a).collect();
    let q = &trs.rotation;
    let angles: Vec<f64> = match axes.as_slice() {
        [] => Vec::new(),
        [a] => vec![single_axis_angle(q, *a)],
        [a, b] => euler2(q, *a, *b).to_vec(),
        [a, b, c, ..] => euler3(q, [*a, *b, *c]).to_vec(),
    };
    for (&(k, _), angle) in rotation_slots.iter().zip(angles) {
        out[k] = wrap_angle(angle).to_degrees();
    }
    if !joint.end_site && loss.rotation.is_none() {
        let back = joint.local_transform(out).rotation;
        if back.angle_to(q) > 1e-9 {
            loss.rotation = Some(joint.name.clone());
        }
    }
}

/// The pose with every uniform scale folded into the translations below it (each joint's
/// translation multiplied by its parent's accumulated scale) and scale 1; true when some
/// scale was not uniform and positive (then it is dropped).
fn fold_scale(skeleton: &Skeleton, pose: &Pose) -> (Pose, bool) {
    let mut acc: Vec<f64> = Vec::with_capacity(skeleton.len());
    let mut local = Vec::with_capacity(skeleton.len());
    let mut inexact = false;
    for (i, joint) in skeleton.joints().iter().enumerate() {
        let t = pose.local.get(i).copied().unwrap_or(joint.rest);
        let parent_scale = joint
            .parent
            .and_then(|p| acc.get(p).copied())
            .unwrap_or(1.0);
        let s = t.scale;
        let uniform = s.x > 0.0
            && s.x.is_finite()
            && (s.y - s.x).abs() <= 1e-9 * s.x
            && (s.z - s.x).abs() <= 1e-9 * s.x;
        let sigma = if uniform {
            s.x
        } else {
            inexact = true;
            1.0
        };
        acc.push(parent_scale * sigma);
        local.push(Trs::new(t.translation * parent_scale, t.rotation));
    }
    (Pose { local }, inexact)
}

/// A rotation of `radians` about coordinate axis `axis`.
fn axis_rotation(axis: usize, radians: f64) -> Quat {
    Quat::from_axis_angle(&Vector3::ith_axis(axis.min(2)), radians)
}

/// An angle in (-pi, pi].
fn wrap_angle(a: f64) -> f64 {
    use std::f64::consts::{PI, TAU};
    if !a.is_finite() {
        return 0.0;
    }
    let mut r = a % TAU;
    if r > PI {
        r -= TAU;
    } else if r <= -PI {
        r += TAU;
    }
    r
}

/// The angle (radians) of the rotation about `axis` closest to `q`'s twist about it; exact
/// when `q` is such a rotation.
fn single_axis_angle(q: &Quat, axis: usize) -> f64 {
    2.0 * q.imag()[axis.min(2)].atan2(q.w)
}

/// Angles (radians) `[a, b]` with `R_p(a) * R_q(b)` equal to `q` when it can be, for two
/// different axes `p`, `q`.
fn euler2(rot: &Quat, p: usize, q: usize) -> [f64; 2] {
    let m = rot.to_rotation_matrix().into_inner();
    let ep = Vector3::ith(p, 1.0);
    let eq = Vector3::ith(q, 1.0);
    let n = ep.cross(&eq);
    // R e_q = R_p(a) e_q and R^T e_p = R_q(-b) e_p.
    let v = m * eq;
    let w = m.transpose() * ep;
    [n.dot(&v).atan2(eq.dot(&v)), n.dot(&w).atan2(ep.dot(&w))]
}

/// Angles (radians) `[a, b, c]` with `R_i(a) * R_j(b) * R_k(c) == q` for distinct axes.
fn euler3(rot: &Quat, [i, j, k]: [usize; 3]) -> [f64; 3] {
    let m = rot.to_rotation_matrix().into_inner();
    let s = if j == (i + 1) % 3 { 1.0 } else { -1.0 };
    let cb = m[(i, i)].hypot(m[(i, j)]);
    let b = (s * m[(i, k)]).atan2(cb);
    let a = if cb > 1e-9 {
        (-s * m[(j, k)]).atan2(m[(k, k)])
    } else {
        // Gimbal lock: only a + c or a - c is defined; take c from what is left.
        (s * m[(k, j)]).atan2(m[(j, j)])
    };
    let rest = (axis_rotation(i, a) * axis_rotation(j, b)).inverse() * rot;
    let c = single_axis_angle(&rest, k);
    [a, b, c]
}

/// Indentation of a hierarchy line: one tab per level up to [`MAX_INDENT`] (readers ignore
/// it; capped so that a deep chain's file grows linearly with its depth).
fn indent(out: &mut String, depth: usize) {
    for _ in 0..depth.min(MAX_INDENT) {
        out.push('\t');
    }
}

/// The deepest indentation the writer uses.
const MAX_INDENT: usize = 32;

/// A joint name that reads back as one line.
fn clean_name(name: &str, index: usize) -> String {
    let cleaned: String = name
        .chars()
        .map(|c| if c.is_control() { ' ' } else { c })
        .collect();
    let trimmed = cleaned.trim().trim_end_matches('{').trim_end();
    if trimmed.is_empty() {
        format!("joint{index}")
    } else {
        trimmed.to_string()
    }
}

/// A piece of the input for an error message: quoted, escaped, at most 40 characters.
fn quote(s: &str) -> String {
    let mut short: String = s.chars().take(40).collect();
    if short.len() < s.len() {
        short.push_str("...");
    }
    format!("{short:?}")
}

/// Whitespace-separated tokens with line numbers; `{` and `}` are tokens by themselves.
#[derive(Clone, Copy)]
struct Lexer<'a> {
    text: &'a str,
    pos: usize,
    line: usize,
}

fn is_space(b: u8) -> bool {
    matches!(b, b' ' | b'\t' | b'\n' | b'\x0b' | b'\x0c')
}

impl<'a> Lexer<'a> {
    fn next_token(&mut self) -> Option<(&'a str, usize)> {
        let b = self.text.as_bytes();
        while self.pos < b.len() && is_space(b[self.pos]) {
            if b[self.pos] == b'\n' {
                self.line += 1;
            }
            self.pos += 1;
        }
        if self.pos >= b.len() {
            return None;
        }
        let start = self.pos;
        if b[start] == b'{' || b[start] == b'}' {
            self.pos += 1;
        } else {
            while self.pos < b.len()
                && !is_space(b[self.pos])
                && b[self.pos] != b'{'
                && b[self.pos] != b'}'
            {
                self.pos += 1;
            }
        }
        // Token boundaries are ASCII bytes, so they are character boundaries.
        self.text.get(start..self.pos).map(|t| (t, self.line))
    }

    fn peek_token(&self) -> Option<(&'a str, usize)> {
        let mut copy = *self;
        copy.next_token()
    }

    /// The rest of the current line (without the newline, which stays unread).
    /// The number of the last line of the text, for errors at its end.
    fn eof_line(&self) -> usize {
        let newlines = self.text.bytes().filter(|&b| b == b'\n').count();
        if self.text.ends_with('\n') {
            newlines.max(1)
        } else {
            newlines + 1
        }
    }

    fn rest_of_line(&mut self) -> &'a str {
        let b = self.text.as_bytes();
        let start = self.pos;
        while self.pos < b.len() && b[self.pos] != b'\n' {
            self.pos += 1;
        }
        self.text.get(start..self.pos).unwrap_or("")
    }
}

/// A joint being read: its index and what its block has held so far.
struct Open {
    joint: usize,
    line: usize,
    has_offset: bool,
    has_channels: bool,
    has_children: bool,
}

impl Open {
    fn new(joint: usize, line: usize) -> Self {
        Self {
            joint,
            line,
            has_offset: false,
            has_channels: false,
            has_children: false,
        }
    }
}

/// "joint \"Name\"" or "End Site of \"Parent\"".
fn describe(joints: &[BvhJoint], index: usize) -> String {
    let j = &joints[index];
    if j.end_site {
        match j.parent {
            Some(p) => format!("End Site of {}", quote(&joints[p].name)),
            None => "End Site".into(),
        }
    } else {
        format!("joint {}", quote(&j.name))
    }
}

fn is_keyword(tok: &str) -> bool {
    [
        "{",
        "}",
        "ROOT",
        "JOINT",
        "End",
        "OFFSET",
        "CHANNELS",
        "MOTION",
        "HIERARCHY",
    ]
    .iter()
    .any(|k| k.eq_ignore_ascii_case(tok))
}

/// Reads `ROOT`/`JOINT`'s name (the rest of the line) and the `{` after it; pushes the
/// joint and returns its index.
fn begin_joint(
    lx: &mut Lexer<'_>,
    joints: &mut Vec<BvhJoint>,
    parent: Option<usize>,
    keyword: &str,
    line: usize,
) -> Result<usize, ParseError> {
    if joints.len() >= crate::error::MAX_JOINTS {
        return Err(crate::error::too_many_joints(
            format!("line {line}"),
            joints.len() + 1,
        ));
    }
    let mut name = lx.rest_of_line().trim();
    let mut brace = false;
    if let Some(stripped) = name.strip_suffix('{') {
        name = stripped.trim_end();
        brace = true;
    }
    if name.is_empty() {
        return Err(ParseError::at_line(
            line,
            format!("{keyword} without a name (the name must be on the same line)"),
        ));
    }
    if !brace {
        match lx.next_token() {
            Some(("{", _)) => {}
            Some((tok, l)) => {
                return Err(ParseError::at_line(
                    l,
                    format!(
                        "expected '{{' after {keyword} {}, found {}",
                        quote(name),
                        quote(tok)
                    ),
                ));
            }
            None => {
                return Err(ParseError::at_line(
                    lx.eof_line(),
                    format!(
                        "unexpected end of file after {keyword} {} (the file is truncated)",
                        quote(name)
                    ),
                ));
            }
        }
    }
    joints.push(BvhJoint {
        name: name.to_string(),
        parent,
        offset: Vector3::zeros(),
        channels: Vec::new(),
        end_site: false,
    });
    Ok(joints.len() - 1)
}

/// Reads a finite number of an OFFSET.
fn read_offset_number(lx: &mut Lexer<'_>, what: &str) -> Result<f64, ParseError> {
    match lx.next_token() {
        None => Err(ParseError::at_line(
            lx.eof_line(),
            format!("unexpected end of file in the OFFSET of {what} (the file is truncated)"),
        )),
        Some((tok, line)) => match tok.parse::<f64>() {
            Ok(v) if v.is_finite() && v.abs() <= MAX_COORDINATE => Ok(v),
            Ok(v) if v.is_finite() => Err(ParseError::at_line(
                line,
                format!(
                    "OFFSET of {what}: {} is too large (out of range: at most 1e12 in magnitude)",
                    quote(tok)
                ),
            )),
            Ok(_) => Err(ParseError::at_line(
                line,
                format!("OFFSET of {what}: {} is not a finite number", quote(tok)),
            )),
            Err(_) if is_keyword(tok) => Err(ParseError::at_line(
                line,
                format!("OFFSET of {what} needs 3 numbers, found {}", quote(tok)),
            )),
            Err(_) => Err(ParseError::at_line(
                line,
                format!("OFFSET of {what}: {} is not a number", quote(tok)),
            )),
        },
    }
}

/// Reads `HIERARCHY` up to and including `MOTION`.
fn parse_hierarchy(lx: &mut Lexer<'_>) -> Result<Vec<BvhJoint>, ParseError> {
    let mut joints: Vec<BvhJoint> = Vec::new();
    let mut stack: Vec<Open> = Vec::new();
    let mut first = true;
    loop {
        let Some((tok, line)) = lx.next_token() else {
            let problem = match stack.last() {
                Some(open) => format!(
                    "unexpected end of file inside {} opened on line {} (missing '}}'; the file is truncated)",
                    describe(&joints, open.joint),
                    open.line
                ),
                None if first => "empty file: expected a BVH HIERARCHY".to_string(),
                None if joints.is_empty() => {
                    "the HIERARCHY has no ROOT joint and there is no MOTION section".to_string()
                }
                None => "missing MOTION section: the file ends after the hierarchy".to_string(),
            };
            return Err(ParseError::at_line(lx.eof_line(), problem));
        };
        let was_first = std::mem::replace(&mut first, false);
        let Some(open) = stack.last_mut() else {
            if was_first && tok.eq_ignore_ascii_case("HIERARCHY") {
                continue;
            }
            if tok.eq_ignore_ascii_case("ROOT") {
                let j = begin_joint(lx, &mut joints, None, "ROOT", line)?;
                stack.push(Open::new(j, line));
                continue;
            }
            if tok.eq_ignore_ascii_case("MOTION") {
                if joints.is_empty() {
                    return Err(ParseError::at_line(line, "the HIERARCHY has no ROOT joint"));
                }
                return Ok(joints);
            }
            let problem = if tok == "}" {
                "unmatched '}' (a joint block is closed twice)".to_string()
            } else if was_first {
                format!("not a BVH file: expected HIERARCHY, found {}", quote(tok))
            } else {
                format!("expected ROOT or MOTION, found {}", quote(tok))
            };
            return Err(ParseError::at_line(line, problem));
        };
        let index = open.joint;
        let end_site = joints[index].end_site;
        if tok.eq_ignore_ascii_case("OFFSET") {
            if open.has_offset {
                return Err(ParseError::at_line(
                    line,
                    format!("second OFFSET in {}", describe(&joints, index)),
                ));
            }
            open.has_offset = true;
            let what = describe(&joints, index);
            let x = read_offset_number(lx, &what)?;
            let y = read_offset_number(lx, &what)?;
            let z = read_offset_number(lx, &what)?;
            joints[index].offset = Vector3::new(x, y, z);
        } else if tok.eq_ignore_ascii_case("CHANNELS") {
            let what = describe(&joints, index);
            if open.has_channels {
                return Err(ParseError::at_line(
                    line,
                    format!("second CHANNELS in {what}"),
                ));
            }
            if open.has_children {
                return Err(ParseError::at_line(
                    line,
                    format!("CHANNELS of {what} must come before its child joints"),
                ));
            }
            open.has_channels = true;
            let count = match lx.next_token() {
                Some((t, l)) => t.parse::<usize>().map_err(|_| {
                    ParseError::at_line(
                        l,
                        format!(
                            "CHANNELS of {what} expects a channel count, found {}",
                            quote(t)
                        ),
                    )
                })?,
                None => {
                    return Err(ParseError::at_line(
                        lx.eof_line(),
                        format!(
                            "unexpected end of file in the CHANNELS of {what} (the file is truncated)"
                        ),
                    ));
                }
            };
            if end_site && count > 0 {
                return Err(ParseError::at_line(
                    line,
                    format!("{what} cannot have channels"),
                ));
            }
            let mut channels: Vec<BvhChannel> = Vec::new();
            while channels.len() < count {
                let Some((t, l)) = lx.peek_token() else {
                    return Err(ParseError::at_line(
                        lx.eof_line(),
                        format!(
                            "unexpected end of file in the CHANNELS of {what} (the file is truncated)"
                        ),
                    ));
                };
                match BvhChannel::from_name(t) {
                    Some(c) if channels.contains(&c) => {
                        return Err(ParseError::at_line(
                            l,
                            format!("channel {c} listed twice in the CHANNELS of {what}"),
                        ));
                    }
                    Some(c) => {
                        lx.next_token();
                        channels.push(c);
                    }
                    None if is_keyword(t) || t.parse::<f64>().is_ok() => {
                        return Err(ParseError::at_line(
                            line,
                            format!(
                                "CHANNELS {count} of {what} lists only {} channel names (next is {})",
                                channels.len(),
                                quote(t)
                            ),
                        ));
                    }
                    None => {
                        return Err(ParseError::at_line(
                            l,
                            format!(
                                "unknown channel {} in {what} (expected Xposition, Yposition, Zposition, Xrotation, Yrotation or Zrotation)",
                                quote(t)
                            ),
                        ));
                    }
                }
            }
            joints[index].channels = channels;
        } else if tok.eq_ignore_ascii_case("JOINT") {
            if end_site {
                return Err(ParseError::at_line(
                    line,
                    format!("JOINT inside the {}", describe(&joints, index)),
                ));
            }
            open.has_children = true;
            let j = begin_joint(lx, &mut joints, Some(index), "JOINT", line)?;
            stack.push(Open::new(j, line));
        } else if tok.eq_ignore_ascii_case("End") {
            match lx.next_token() {
                Some((t, _)) if t.eq_ignore_ascii_case("Site") => {}
                Some((t, l)) => {
                    return Err(ParseError::at_line(
                        l,
                        format!(
                            "expected 'End Site', found 'End {}'",
                            t.chars().take(40).collect::<String>()
                        ),
                    ));
                }
                None => {
                    return Err(ParseError::at_line(
                        lx.eof_line(),
                        "unexpected end of file after 'End' (the file is truncated)",
                    ));
                }
            }
            if end_site {
                return Err(ParseError::at_line(
                    line,
                    format!("End Site inside the {}", describe(&joints, index)),
                ));
            }
            open.has_children = true;
            match lx.next_token() {
                Some(("{", _)) => {}
                Some((t, l)) => {
                    return Err(ParseError::at_line(
                        l,
                        format!("expected '{{' after End Site, found {}", quote(t)),
                    ));
                }
                None => {
                    return Err(ParseError::at_line(
                        lx.eof_line(),
                        "unexpected end of file after End Site (the file is truncated)",
                    ));
                }
            }
            if joints.len() >= crate::error::MAX_JOINTS {
                return Err(crate::error::too_many_joints(
                    format!("line {line}"),
                    joints.len() + 1,
                ));
            }
            joints.push(BvhJoint {
                name: String::new(),
                parent: Some(index),
                offset: Vector3::zeros(),
                channels: Vec::new(),
                end_site: true,
            });
            stack.push(Open::new(joints.len() - 1, line));
        } else if tok == "}" {
            if !open.has_offset {
                return Err(ParseError::at_line(
                    line,
                    format!(
                        "{} (line {}) has no OFFSET",
                        describe(&joints, index),
                        open.line
                    ),
                ));
            }
            stack.pop();
        } else if tok.eq_ignore_ascii_case("MOTION") || tok.eq_ignore_ascii_case("ROOT") {
            return Err(ParseError::at_line(
                line,
                format!(
                    "{tok} inside {} opened on line {}: a '}}' is missing before it",
                    describe(&joints, index),
                    open.line
                ),
            ));
        } else {
            return Err(ParseError::at_line(
                line,
                format!("unexpected {} in {}", quote(tok), describe(&joints, index)),
            ));
        }
    }
}

/// Reads a header label such as `Frames:` or `Frame Time:` (split into tokens anyhow) and
/// returns its value token.
fn expect_label(
    lx: &mut Lexer<'_>,
    label: &str,
    shown: &str,
) -> Result<(String, usize), ParseError> {
    let compact: String = label.chars().filter(|c| !c.is_whitespace()).collect();
    let mut acc = String::new();
    loop {
        let Some((tok, line)) = lx.next_token() else {
            return Err(ParseError::at_line(
                lx.eof_line(),
                format!("missing '{shown}' in the MOTION section (the file is truncated)"),
            ));
        };
        acc.push_str(tok);
        let matches_so_far = |n: usize| {
            acc.get(..n)
                .zip(compact.get(..n))
                .is_some_and(|(a, b)| a.eq_ignore_ascii_case(b))
        };
        if acc.len() < compact.len() {
            if !matches_so_far(acc.len()) {
                return Err(ParseError::at_line(
                    line,
                    format!(
                        "expected '{shown}' in the MOTION section, found {}",
                        quote(&acc)
                    ),
                ));
            }
            continue;
        }
        if !matches_so_far(compact.len()) {
            return Err(ParseError::at_line(
                line,
                format!(
                    "expected '{shown}' in the MOTION section, found {}",
                    quote(&acc)
                ),
            ));
        }
        let rest = acc.get(compact.len()..).unwrap_or("");
        if !rest.is_empty() {
            return Ok((rest.to_string(), line));
        }
        return match lx.next_token() {
            Some((value, l)) => Ok((value.to_string(), l)),
            None => Err(ParseError::at_line(
                lx.eof_line(),
                format!("missing value after '{shown}' (the file is truncated)"),
            )),
        };
    }
}

/// The joint and channel of value `index` of a frame, for messages.
fn describe_value(joints: &[BvhJoint], index: usize) -> String {
    let mut start = 0;
    for j in joints {
        if index < start + j.channels.len() {
            return format!("{} {}", j.name, j.channels[index - start]);
        }
        start += j.channels.len();
    }
    String::new()
}

/// Reads `Frames:`, `Frame Time:` and the rows after them.
fn parse_motion(
    lx: &mut Lexer<'_>,
    joints: &[BvhJoint],
) -> Result<(f64, Vec<Vec<f64>>), ParseError> {
    let (frames_tok, frames_line) = expect_label(lx, "Frames:", "Frames:")?;
    let declared: usize = frames_tok.parse().map_err(|_| {
        ParseError::at_line(
            frames_line,
            format!(
                "'Frames:' expects a whole number, found {}",
                quote(&frames_tok)
            ),
        )
    })?;
    let (time_tok, time_line) = expect_label(lx, "Frame Time:", "Frame Time:")?;
    let frame_time: f64 = match time_tok.parse::<f64>() {
        Ok(t) if t.is_finite() && t > 0.0 => t,
        Ok(_) => {
            return Err(ParseError::at_line(
                time_line,
                format!(
                    "'Frame Time:' must be a positive number of seconds, found {}",
                    quote(&time_tok)
                ),
            ));
        }
        Err(_) => {
            return Err(ParseError::at_line(
                time_line,
                format!("'Frame Time:' expects a number, found {}", quote(&time_tok)),
            ));
        }
    };
    let tail = lx.rest_of_line().trim();
    if !tail.is_empty() {
        return Err(ParseError::at_line(
            lx.line,
            format!(
                "unexpected {} after the frame time (frames start on the next line)",
                quote(tail)
            ),
        ));
    }
    let count: usize = joints.iter().map(|j| j.channels.len()).sum();
    let mut frames: Vec<Vec<f64>> = Vec::new();
    let remaining = lx.text.get(lx.pos..).unwrap_or("");
    for (i, row) in remaining.split('\n').enumerate().skip(1) {
        let line = lx.line + i;
        let n = row.split_ascii_whitespace().count();
        if n == 0 {
            continue;
        }
        if n != count {
            return Err(ParseError::at_line(
                line,
                format!("frame {} has {n} values, expected {count}", frames.len()),
            ));
        }
        let mut values = Vec::with_capacity(count);
        for (k, tok) in row.split_ascii_whitespace().enumerate() {
            match tok.parse::<f64>() {
                Ok(v) if v.is_finite() && v.abs() <= MAX_COORDINATE => values.push(v),
                parsed => {
                    let what = match parsed {
                        Ok(v) if v.is_finite() => {
                            "is too large (out of range: at most 1e12 in magnitude)"
                        }
                        Ok(_) => "is not a finite number",
                        Err(_) => "is not a number",
                    };
                    return Err(ParseError::at_line(
                        line,
                        format!(
                            "frame {}, value {} ({}): {} {what}",
                            frames.len(),
                            k + 1,
                            describe_value(joints, k),
                            quote(tok)
                        ),
                    ));
                }
            }
        }
        frames.push(values);
    }
    if count == 0 {
        // No channels: rows are empty, so the header is all there is.
        const MAX_EMPTY_FRAMES: usize = 1 << 20;
        if declared > MAX_EMPTY_FRAMES {
            return Err(ParseError::at_line(
                frames_line,
                format!("'Frames: {declared}' is too many for a motion without channels"),
            ));
        }
        frames = vec![Vec::new(); declared];
    } else if frames.len() != declared {
        tracing::warn!(
            "BVH 'Frames: {declared}' (line {frames_line}) but the file holds {} data rows; reading the rows present",
            frames.len()
        );
    }
    Ok((frame_time, frames))
}

/// Names each End Site after its parent (`Parent_End`, or `Parent_End2`, ... when that is
/// taken), and warns about duplicate joint names.
fn name_end_sites(joints: &mut [BvhJoint]) {
    let mut taken: HashSet<String> = HashSet::new();
    let mut duplicate: Option<String> = None;
    for j in joints.iter().filter(|j| !j.end_site) {
        if !taken.insert(j.name.clone()) && duplicate.is_none() {
            duplicate = Some(j.name.clone());
        }
    }
    if let Some(name) = duplicate {
        tracing::warn!("BVH joint name '{name}' is used more than once (maybe others too)");
    }
    let mut next_suffix: HashMap<String, usize> = HashMap::new();
    for i in 0..joints.len() {
        if !joints[i].end_site {
            continue;
        }
        let parent_name = joints[i]
            .parent
            .and_then(|p| joints.get(p))
            .map(|p| p.name.clone())
            .unwrap_or_default();
        let base = format!("{parent_name}_End");
        let mut name = base.clone();
        let counter = next_suffix.entry(base.clone()).or_insert(1);
        while taken.contains(&name) {
            *counter += 1;
            name = format!("{base}{counter}");
        }
        taken.insert(name.clone());
        joints[i].name = name;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Deterministic pseudo-random numbers in [-1, 1).
    fn lcg(state: &mut u64) -> f64 {
        *state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((*state >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
    }

    #[test]
    fn euler3_recomposes_every_order() {
        let orders = [
            [0, 1, 2],
            [0, 2, 1],
            [1, 0, 2],
            [1, 2, 0],
            [2, 0, 1],
            [2, 1, 0],
        ];
        let mut s = 7u64;
        for order in orders {
            for n in 0..200 {
                let mut q = Quat::from_scaled_axis(
                    Vector3::new(lcg(&mut s), lcg(&mut s), lcg(&mut s)) * 3.0,
                );
                if n < 4 {
                    // Gimbal lock: the middle angle at +-90 degrees.
                    let b = if n % 2 == 0 { 1.0 } else { -1.0 } * std::f64::consts::FRAC_PI_2;
                    q = axis_rotation(order[0], lcg(&mut s) * 3.0)
                        * axis_rotation(order[1], b)
                        * axis_rotation(order[2], lcg(&mut s) * 3.0);
                }
                let [a, b, c] = euler3(&q, order);
                let back = axis_rotation(order[0], a)
                    * axis_rotation(order[1], b)
                    * axis_rotation(order[2], c);
                assert!(
                    back.angle_to(&q) < 1e-12,
                    "order {order:?}: {}",
                    back.angle_to(&q)
                );
            }
        }
    }

    #[test]
    fn euler2_and_single_axis_are_exact_when_representable() {
        let mut s = 3u64;
        for (p, q) in [(0, 1), (1, 0), (2, 0), (0, 2), (1, 2), (2, 1)] {
            for _ in 0..100 {
                let (x, y) = (lcg(&mut s) * 3.1, lcg(&mut s) * 3.1);
                let r = axis_rotation(p, x) * axis_rotation(q, y);
                let [a, b] = euler2(&r, p, q);
                let back = axis_rotation(p, a) * axis_rotation(q, b);
                assert!(back.angle_to(&r) < 1e-12);
                let single = single_axis_angle(&axis_rotation(p, x), p);
                assert!((wrap_angle(single) - x).abs() < 1e-12);
            }
        }
    }

    #[test]
    fn lexer_splits_braces_and_counts_lines() {
        let mut lx = Lexer {
            text: "ROOT a{\n  OFFSET 1\n}x",
            pos: 0,
            line: 1,
        };
        assert_eq!(lx.next_token(), Some(("ROOT", 1)));
        assert_eq!(lx.rest_of_line(), " a{");
        assert_eq!(lx.next_token(), Some(("OFFSET", 2)));
        assert_eq!(lx.next_token(), Some(("1", 2)));
        assert_eq!(lx.next_token(), Some(("}", 3)));
        assert_eq!(lx.next_token(), Some(("x", 3)));
        assert_eq!(lx.next_token(), None);
    }

    #[test]
    fn parses_a_minimal_file() {
        let text = "HIERARCHY\nROOT a\n{\nOFFSET 0 0 0\nCHANNELS 1 Yrotation\nEnd Site\n{\nOFFSET 0 1 0\n}\n}\nMOTION\nFrames: 1\nFrame Time: .5\n90\n";
        let doc = parse_bvh(text.as_bytes()).expect("valid");
        assert_eq!(doc.joints.len(), 2);
        assert_eq!(doc.joints[1].name, "a_End");
        assert_eq!(doc.frame_time, 0.5);
        assert_eq!(doc.frames, vec![vec![90.0]]);
    }

    #[test]
    fn end_site_names_stay_unique() {
        let text = "HIERARCHY\nROOT a\n{\nOFFSET 0 0 0\nCHANNELS 0\nEnd Site\n{\nOFFSET 0 1 0\n}\nEnd Site\n{\nOFFSET 0 2 0\n}\nJOINT a_End\n{\nOFFSET 1 0 0\nCHANNELS 0\n}\n}\nMOTION\nFrames: 0\nFrame Time: 1\n";
        let doc = parse_bvh(text.as_bytes()).expect("valid");
        let names: Vec<&str> = doc.joints.iter().map(|j| j.name.as_str()).collect();
        assert_eq!(names, ["a", "a_End2", "a_End3", "a_End"]);
    }
}
