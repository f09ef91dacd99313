//! Setting up a [`Tracker`]: texture points attached to the model's parts, and its
//! accessors.

use super::parts::PlacedParts;
use super::texture::TexturePoint;
use super::{ArticulatedModel, TrackError, TrackOptions, Tracker, explained_share};
use crate::engine::{Candidates, EmStep, PointGrid, SubtreeMoments};
use crate::kinematics::{DofLayout, ForwardKinematics};
use crate::math::{Matrix3, Point3, linear_part, nearest_rotation, rotation_quat};
use crate::skeleton::Pose;

/// What a frame starts from ([`Tracker::frame_start`]).
#[derive(Clone, Debug)]
pub(crate) struct TrackerStart {
    pose: Pose,
    previous: Option<Pose>,
    seen: Vec<bool>,
    lambda: f64,
}

impl Tracker {
    /// A tracker starting from the model's start pose.
    pub fn new(model: ArticulatedModel, options: TrackOptions) -> Result<Self, TrackError> {
        let layout = DofLayout::new(&model.skeleton);
        if layout.is_empty() {
            return Err(TrackError::NothingMoves);
        }
        let pose = model.start.clone();
        let fk = ForwardKinematics::new(&model.skeleton, &model.built);
        let mut placed = PlacedParts::default();
        model.parts.place(&fk, &mut placed);
        let texture: Vec<TexturePoint> = model
            .surface_samples
            .iter()
            .enumerate()
            .filter_map(|(k, p)| {
                let normal = model.surface_normals.as_ref().map(|n| n[k]);
                TexturePoint::attach(
                    &model.parts,
                    &placed,
                    &fk,
                    p,
                    normal,
                    options.bending_exponent,
                    None,
                )
            })
            .collect();
        if texture.is_empty() {
            return Err(TrackError::NoParts);
        }
        let spacing = typical_spacing(&model.surface_samples, model.height);
        tracing::debug!(
            "texture spacing {:.4} of the height",
            spacing / model.height
        );
        Ok(Self {
            model,
            options,
            layout,
            pose,
            previous: None,
            texture,
            spacing,
            grid: PointGrid::default(),
            candidates: Candidates::default(),
            em: EmStep::default(),
            moments: SubtreeMoments::new(),
            normal: None,
            placed,
            lambda: 1e-4,
            seen: Vec::new(),
        })
    }

    /// Sets the pose the next frame starts from, and the one before it (whose motion to it
    /// the next frame continues; `None` forgets the motion).
    pub fn resume_from(&mut self, previous: Option<&Pose>, pose: &Pose) {
        self.pose.clone_from(pose);
        self.previous = previous.cloned();
    }

    /// What the next frame starts from: the pose, the motion it continues, the texture
    /// points seen and the damping ([`Tracker::restart_from`] tracks a frame again from it).
    pub(crate) fn frame_start(&self) -> TrackerStart {
        TrackerStart {
            pose: self.pose.clone(),
            previous: self.previous.clone(),
            seen: self.seen.clone(),
            lambda: self.lambda,
        }
    }

    /// Puts the tracker back where `start` ([`Tracker::frame_start`]) found it.
    pub(crate) fn restart_from(&mut self, start: &TrackerStart) {
        self.pose.clone_from(&start.pose);
        self.previous.clone_from(&start.previous);
        self.seen.clone_from(&start.seen);
        self.lambda = start.lambda;
    }

    /// Sets the pose the next frame starts from (forgetting the motion so far).
    pub fn set_pose(&mut self, pose: &Pose) {
        self.pose.clone_from(pose);
        self.previous = None;
        self.seen.clear();
    }

    /// The current pose.
    pub fn pose(&self) -> &Pose {
        &self.pose
    }

    /// The model.
    pub fn model(&self) -> &ArticulatedModel {
        &self.model
    }

    /// The share of `data` the current pose explains: the data's summed inlier posteriors
    /// of one E-step (eq. 17, with the outlier class) at `sigma` over every texture point,
    /// per data point.
    pub fn explained_share(&mut self, data: &[Point3], sigma: f64) -> f64 {
        let world = self.texture_positions();
        explained_share(
            data,
            &world,
            sigma,
            self.options.outlier_constant,
            &mut self.grid,
            &mut self.em,
        )
    }

    /// Each texture point's dominant joint.
    pub(crate) fn texture_joints(&self) -> impl Iterator<Item = usize> + '_ {
        self.texture.iter().map(|t| t.joints[0])
    }

    /// Turns `joint` and everything it carries by `turn` (world axes) about the joint's
    /// place, keeping the motion the next frame continues; the texture points it carries
    /// count as seen (the turn put them on data).
    pub(crate) fn turn_joint(&mut self, joint: usize, turn: &Matrix3) {
        let skeleton = &self.model.skeleton;
        let parent = match skeleton.joint(joint).parent {
            Some(p) => nearest_rotation(&linear_part(&skeleton.world_matrices(&self.pose)[p])),
            None => Matrix3::identity(),
        };
        let local = &mut self.pose.local[joint].rotation;
        *local = rotation_quat(&(parent.transpose() * turn * parent)) * *local;
        if self.seen.len() == self.texture.len() {
            for (seen, t) in self.seen.iter_mut().zip(&self.texture) {
                if skeleton.is_ancestor_or_self(joint, t.joints[0]) {
                    *seen = true;
                }
            }
        }
    }

    /// The texture points' world positions in the current pose.
    pub fn texture_positions(&self) -> Vec<Point3> {
        let fk = ForwardKinematics::new(&self.model.skeleton, &self.pose);
        self.texture.iter().map(|t| t.world(&fk)).collect()
    }
}

/// The median distance from a point to its nearest neighbour (a sample of them).
fn typical_spacing(points: &[Point3], height: f64) -> f64 {
    if points.len() < 2 {
        return height;
    }
    let grid = PointGrid::new(points, 0.05 * height);
    let mut d: Vec<f64> = points
        .iter()
        .step_by((points.len() / 200).max(1))
        .filter_map(|p| {
            let mut best = f64::INFINITY;
            grid.for_each_within(p, 0.05 * height, |_, d2| {
                if d2 > 0.0 && d2 < best {
                    best = d2;
                }
            });
            best.is_finite().then(|| best.sqrt())
        })
        .collect();
    if d.is_empty() {
        return 0.05 * height;
    }
    d.sort_by(f64::total_cmp);
    d[d.len() / 2]
}
