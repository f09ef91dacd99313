//! BVH <-> rigfit-core: a document's skeleton, poses, animation and rig, and a skeleton's
//! poses stored as BVH channel values.

use rigfit_core::animation::quat_to_xyzw;
use rigfit_core::{
    Animation, AnimationChannel, ChannelTarget, Interpolation, Joint, JointDof, JointKind, Pose,
    Quat, Rig, Skeleton, SkeletonError, Trs, Vector3,
};

use super::euler::{euler2, euler3, single_axis_angle, wrap_angle};
use super::{BvhChannel, BvhDocument, BvhJoint};

impl BvhDocument {
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
    /// non-finite offset; [`parse_bvh`](super::parse_bvh) never returns such a document (see
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
        let mut rig = Rig {
            skeleton: self.skeleton(),
            pose,
            meshes: Vec::new(),
            animations,
        };
        rig.free_translating_joints();
        rig.tie_goals();
        rig.note_clip_places();
        rig
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
    /// skeleton's joint `i` (the file is written depth first). Tips found from a skin
    /// ([`JointKind::SkinTip`], appended after the file's joints) are not written.
    pub fn from_skeleton(skeleton: &Skeleton, poses: &[Pose], frame_time: f64) -> BvhDocument {
        let in_file = skeleton
            .joints()
            .iter()
            .position(|j| j.kind == JointKind::SkinTip)
            .unwrap_or(skeleton.len());
        if in_file < skeleton.len() && in_file > 0 {
            let joints = skeleton.joints()[..in_file].to_vec();
            if let Ok(trimmed) = Skeleton::new(joints) {
                let poses: Vec<Pose> = poses
                    .iter()
                    .map(|p| Pose {
                        local: p.local.iter().take(in_file).copied().collect(),
                    })
                    .collect();
                return Self::from_skeleton(&trimmed, &poses, frame_time);
            }
        }
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
                let end_site = joint.kind.is_tip() && skeleton.children(i).is_empty();
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
