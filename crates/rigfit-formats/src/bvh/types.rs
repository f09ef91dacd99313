//! The BVH document: its joints, their channels, and where each channel's value sits in a
//! frame.

use std::fmt;

use rigfit_core::{Quat, Trs, Vector3};

use super::euler::axis_rotation;

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
}
