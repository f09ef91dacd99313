//! Keyframed animations of joint transforms, sampled at any time.

use crate::math::{Quat, Vector3};
use crate::skeleton::Pose;

/// Which part of a joint's local transform a channel drives.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ChannelTarget {
    Translation,
    Rotation,
    Scale,
}

/// How values between keys are found (glTF's three modes).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Interpolation {
    Step,
    /// Linear for vectors, spherical linear for rotations.
    Linear,
    /// Cubic Hermite; each key holds in-tangent, value, out-tangent.
    CubicSpline,
}

/// The keys of one joint property.
#[derive(Clone, Debug, PartialEq)]
pub struct AnimationChannel {
    pub joint: usize,
    pub target: ChannelTarget,
    pub interpolation: Interpolation,
    /// Increasing key times in seconds.
    pub times: Vec<f64>,
    /// One value per key (`[x, y, z, _]` or quaternion `[x, y, z, w]`); three per key
    /// (in-tangent, value, out-tangent) for cubic splines.
    pub values: Vec<[f64; 4]>,
}

impl AnimationChannel {
    fn key_value(&self, key: usize) -> [f64; 4] {
        match self.interpolation {
            Interpolation::CubicSpline => self.values[3 * key + 1],
            _ => self.values[key],
        }
    }

    /// The channel's value at time `t` (clamped to the key range).
    pub fn sample(&self, t: f64) -> [f64; 4] {
        let n = self.times.len();
        if n == 0 {
            return [0.0, 0.0, 0.0, 1.0];
        }
        if n == 1 || t <= self.times[0] {
            return self.key_value(0);
        }
        if t >= self.times[n - 1] {
            return self.key_value(n - 1);
        }
        let i = self.times.partition_point(|&k| k <= t) - 1;
        let (t0, t1) = (self.times[i], self.times[i + 1]);
        let dt = t1 - t0;
        let s = if dt > 0.0 { (t - t0) / dt } else { 0.0 };
        let is_rotation = self.target == ChannelTarget::Rotation;
        match self.interpolation {
            Interpolation::Step => self.key_value(i),
            Interpolation::Linear => {
                let (a, b) = (self.values[i], self.values[i + 1]);
                if is_rotation {
                    slerp(a, b, s)
                } else {
                    std::array::from_fn(|k| a[k] + (b[k] - a[k]) * s)
                }
            }
            Interpolation::CubicSpline => {
                // glTF 2.0 appendix C: p(s) = h00 v0 + h10 dt b0 + h01 v1 + h11 dt a1.
                let v0 = self.values[3 * i + 1];
                let b0 = self.values[3 * i + 2];
                let a1 = self.values[3 * (i + 1)];
                let v1 = self.values[3 * (i + 1) + 1];
                let (s2, s3) = (s * s, s * s * s);
                let h00 = 2.0 * s3 - 3.0 * s2 + 1.0;
                let h10 = s3 - 2.0 * s2 + s;
                let h01 = -2.0 * s3 + 3.0 * s2;
                let h11 = s3 - s2;
                let mut out: [f64; 4] = std::array::from_fn(|k| {
                    h00 * v0[k] + h10 * dt * b0[k] + h01 * v1[k] + h11 * dt * a1[k]
                });
                if is_rotation {
                    let len = out.iter().map(|x| x * x).sum::<f64>().sqrt();
                    if len > 0.0 {
                        out.iter_mut().for_each(|x| *x /= len);
                    }
                }
                out
            }
        }
    }
}

fn slerp(a: [f64; 4], b: [f64; 4], s: f64) -> [f64; 4] {
    let qa = quat_from_xyzw(a);
    let qb = quat_from_xyzw(b);
    let q = qa.try_slerp(&qb, s, 1e-12).unwrap_or_else(|| {
        // Opposite quaternions: nlerp is as good as anything.
        Quat::new_normalize(qa.into_inner().lerp(&qb.into_inner(), s))
    });
    quat_to_xyzw(&q)
}

/// A unit quaternion from `[x, y, z, w]` (normalised).
pub fn quat_from_xyzw(v: [f64; 4]) -> Quat {
    Quat::new_normalize(nalgebra::Quaternion::new(v[3], v[0], v[1], v[2]))
}

/// `[x, y, z, w]` of a unit quaternion.
pub fn quat_to_xyzw(q: &Quat) -> [f64; 4] {
    [q.i, q.j, q.k, q.w]
}

/// A named set of channels.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Animation {
    pub name: String,
    pub channels: Vec<AnimationChannel>,
    /// The sampling period for frame-based sources (BVH), in seconds.
    pub frame_time: Option<f64>,
}

impl Animation {
    /// The time of the first key.
    pub fn start(&self) -> f64 {
        self.channels
            .iter()
            .filter_map(|c| c.times.first().copied())
            .fold(f64::INFINITY, f64::min)
            .min(self.end())
    }

    /// The time of the last key.
    pub fn end(&self) -> f64 {
        self.channels
            .iter()
            .filter_map(|c| c.times.last().copied())
            .fold(0.0, f64::max)
    }

    /// The length in seconds from the first key to the last.
    pub fn duration(&self) -> f64 {
        self.end() - self.start()
    }

    /// The number of distinct key times (frames).
    pub fn frame_count(&self) -> usize {
        let mut times: Vec<f64> = self
            .channels
            .iter()
            .flat_map(|c| c.times.iter().copied())
            .collect();
        times.sort_by(f64::total_cmp);
        times.dedup_by(|a, b| (*a - *b).abs() < 1e-9);
        times.len()
    }

    /// An animation through `keys` (time in seconds, pose), sorted by time: every joint's
    /// translation, rotation and scale keyed at each time, interpolated linearly (rotations
    /// spherically).
    pub fn through_poses(name: impl Into<String>, keys: &[(f64, Pose)]) -> Self {
        let joints = keys.iter().map(|(_, p)| p.local.len()).min().unwrap_or(0);
        let times: Vec<f64> = keys.iter().map(|(t, _)| *t).collect();
        let mut channels = Vec::with_capacity(3 * joints);
        for joint in 0..joints {
            for target in [
                ChannelTarget::Translation,
                ChannelTarget::Rotation,
                ChannelTarget::Scale,
            ] {
                let values = keys
                    .iter()
                    .map(|(_, p)| {
                        let trs = &p.local[joint];
                        match target {
                            ChannelTarget::Translation => {
                                let v = trs.translation;
                                [v.x, v.y, v.z, 0.0]
                            }
                            ChannelTarget::Rotation => quat_to_xyzw(&trs.rotation),
                            ChannelTarget::Scale => {
                                let v = trs.scale;
                                [v.x, v.y, v.z, 0.0]
                            }
                        }
                    })
                    .collect();
                channels.push(AnimationChannel {
                    joint,
                    target,
                    interpolation: Interpolation::Linear,
                    times: times.clone(),
                    values,
                });
            }
        }
        Self {
            name: name.into(),
            channels,
            frame_time: None,
        }
    }

    /// `base` with every animated property replaced by its value at time `t`.
    pub fn sample(&self, base: &Pose, t: f64) -> Pose {
        let mut pose = base.clone();
        for c in &self.channels {
            let Some(local) = pose.local.get_mut(c.joint) else {
                continue;
            };
            let v = c.sample(t);
            match c.target {
                ChannelTarget::Translation => local.translation = Vector3::new(v[0], v[1], v[2]),
                ChannelTarget::Scale => local.scale = Vector3::new(v[0], v[1], v[2]),
                ChannelTarget::Rotation => local.rotation = quat_from_xyzw(v),
            }
        }
        pose
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn channel(interpolation: Interpolation, values: Vec<[f64; 4]>) -> AnimationChannel {
        AnimationChannel {
            joint: 0,
            target: ChannelTarget::Translation,
            interpolation,
            times: vec![0.0, 1.0],
            values,
        }
    }

    #[test]
    fn linear_step_and_cubic() {
        let lin = channel(Interpolation::Linear, vec![[0.0; 4], [2.0, 4.0, 6.0, 0.0]]);
        assert_eq!(lin.sample(0.5)[..3], [1.0, 2.0, 3.0]);
        let step = channel(Interpolation::Step, vec![[0.0; 4], [2.0, 4.0, 6.0, 0.0]]);
        assert_eq!(step.sample(0.99)[0], 0.0);
        // Zero tangents: a smoothstep between the values, equal to linear at the midpoint.
        let cubic = channel(
            Interpolation::CubicSpline,
            vec![
                [0.0; 4],
                [0.0; 4],
                [0.0; 4],
                [0.0; 4],
                [2.0, 4.0, 6.0, 0.0],
                [0.0; 4],
            ],
        );
        assert!((cubic.sample(0.5)[0] - 1.0).abs() < 1e-12);
        assert!(cubic.sample(0.25)[0] < 0.5);
    }

    #[test]
    fn slerp_halfway() {
        let a = quat_to_xyzw(&Quat::identity());
        let b = quat_to_xyzw(&Quat::from_euler_angles(0.0, 1.0, 0.0));
        let mid = quat_from_xyzw(slerp(a, b, 0.5));
        assert!((mid.angle() - 0.5).abs() < 1e-12);
    }

    #[test]
    fn through_poses_hits_every_key_and_interpolates_between() {
        use crate::math::Trs;
        let pose = |x: f64, angle: f64| Pose {
            local: vec![Trs::new(
                Vector3::new(x, 0.0, 0.0),
                Quat::from_euler_angles(0.0, angle, 0.0),
            )],
        };
        let keys = [(0.0, pose(0.0, 0.0)), (1.0, pose(2.0, 1.0))];
        let anim = Animation::through_poses("rigfit", &keys);
        assert_eq!(anim.channels.len(), 3);
        let base = pose(9.0, 0.0);
        let end = anim.sample(&base, 1.0);
        assert!((end.local[0].translation.x - 2.0).abs() < 1e-12);
        let mid = anim.sample(&base, 0.5);
        assert!((mid.local[0].translation.x - 1.0).abs() < 1e-12);
        assert!((mid.local[0].rotation.angle() - 0.5).abs() < 1e-12);
    }
}
