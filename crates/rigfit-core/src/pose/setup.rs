//! Setting a solve up: the problem checked (strokes, points, joints, bone names), strokes
//! resampled into samples, the bone model built, and which joints may move. Everything in
//! [`Setup`] stays fixed while the solve runs.

use std::ops::Range;

use super::PoseProblem;
use super::beautify;
use super::bones::BoneModel;
use super::chains::{SAMPLES, arclength_samples};
use super::options::{
    MAX_POSE_JOINTS, MAX_STROKE_DISTANCE, MAX_STROKE_POINTS, MAX_STROKES, PoseError, PoseOptions,
};
use crate::interrupt::Interrupt;
use crate::kinematics::DofLayout;
use crate::math::{Point3, Vector3};
use crate::skeleton::{JointDof, Pose, Skeleton};

/// The strokes as the solver sees them: resampled points and the stroke each belongs to.
#[derive(Clone, Debug, Default)]
pub(super) struct StrokeSamples {
    pub points: Vec<Point3>,
    /// The stroke of each sample.
    pub stroke_of: Vec<usize>,
    /// The samples of each stroke, as a range of `points`.
    pub ranges: Vec<Range<usize>>,
    /// Per stroke: the bones it may match (`None` = any); strokes pinned to bones.
    pub allowed_bones: Vec<Option<Vec<bool>>>,
    /// Per stroke: its samples evenly spaced in arclength (as chains are compared) and its
    /// length, computed once.
    pub by_arclength: Vec<([Point3; SAMPLES], f64)>,
}

impl StrokeSamples {
    pub fn count(&self) -> usize {
        self.ranges.len()
    }

    /// The samples of stroke `s`, in drawing order.
    pub fn stroke(&self, s: usize) -> &[Point3] {
        &self.points[self.ranges[s].clone()]
    }

    /// Every `step`-th sample (a cheaper set for a rigid fit).
    pub fn thinned(&self, step: usize) -> Self {
        let points: Vec<Point3> = self.points.iter().step_by(step).copied().collect();
        let stroke_of: Vec<usize> = self.stroke_of.iter().step_by(step).copied().collect();
        Self {
            ranges: ranges_of(&stroke_of, self.count()),
            points,
            stroke_of,
            allowed_bones: self.allowed_bones.clone(),
            // The strokes' shapes, measured on every sample (a thinned stroke may keep none).
            by_arclength: self.by_arclength.clone(),
        }
    }

    /// Fills `by_arclength` from the samples.
    fn measure(&mut self) {
        self.by_arclength = (0..self.count())
            .map(|s| arclength_samples(self.stroke(s)))
            .collect();
    }
}

fn ranges_of(stroke_of: &[usize], strokes: usize) -> Vec<Range<usize>> {
    (0..strokes)
        .map(|s| stroke_of.partition_point(|&d| d < s)..stroke_of.partition_point(|&d| d <= s))
        .collect()
}

/// What a solve works on and never changes (shared by a solve's parallel workers).
pub(super) struct Setup<'a> {
    pub skeleton: &'a Skeleton,
    pub start: &'a Pose,
    pub options: &'a PoseOptions,
    /// When to give up: every Levenberg-Marquardt step and every outer loop polls it.
    pub interrupt: &'a Interrupt,
    pub height: f64,
    pub model: BoneModel,
    pub strokes: StrokeSamples,
    /// Joints allowed to move at all.
    pub movable: Vec<bool>,
    /// The joint placed by the rigid multi-start: the character's root when it may move
    /// freely.
    pub root: Option<usize>,
}

impl<'a> Setup<'a> {
    /// Checks the problem and prepares the solve.
    pub fn new(
        problem: &PoseProblem<'a>,
        options: &'a PoseOptions,
        interrupt: &'a Interrupt,
    ) -> Result<Self, PoseError> {
        let skeleton = problem.skeleton;
        check_sizes(problem)?;
        let height = if problem.height > 0.0 {
            problem.height
        } else {
            1.0
        };
        check_distance(problem, height)?;
        let model = BoneModel::new(
            skeleton,
            problem.start,
            options.spacing * height,
            1e-4 * height,
        );
        if model.bones.is_empty() {
            return Err(PoseError::NoBones);
        }
        let mut movable = movable_joints(skeleton, problem.movable)?;
        let strokes = sample_strokes(problem, options, &model, height)?;
        // Markers (every bone's tip moved by translation alone) have no shape to match: a
        // stroke cannot say which marker it draws unless it is pinned to it. Without any
        // pinned stroke the solve is refused; strokes that are not pinned are set aside
        // (strays) when some are.
        let mut strokes = strokes;
        if model.is_markers() {
            if strokes.allowed_bones.iter().all(Option::is_none) {
                let root = skeleton.joint(model.bones[0].joint).name.clone();
                return Err(PoseError::UnpinnedMarkers { root });
            }
            for allowed in &mut strokes.allowed_bones {
                allowed.get_or_insert_with(|| vec![false; model.bones.len()]);
            }
            // The markers carry all the motion: the joint they hang from stays.
            for bone in &model.bones {
                movable[bone.joint] = false;
            }
        }
        let root = skeleton
            .skin_root()
            .filter(|&r| movable[r] && skeleton.joint(r).dof == JointDof::Free);
        Ok(Self {
            skeleton,
            start: problem.start,
            options,
            interrupt,
            height,
            model,
            strokes,
            movable,
            root,
        })
    }

    /// The DOF layout over the joints of `movable` that can influence some model point.
    pub fn layout(&self, movable: &[bool]) -> DofLayout {
        let mut influences = vec![false; self.skeleton.len()];
        for p in &self.model.points {
            let mut cur = Some(p.joint);
            while let Some(j) = cur {
                if influences[j] {
                    break;
                }
                influences[j] = true;
                cur = self.skeleton.joint(j).parent;
            }
        }
        let active: Vec<bool> = movable
            .iter()
            .zip(&influences)
            .map(|(m, i)| *m && *i)
            .collect();
        DofLayout::with_active(self.skeleton, &active)
    }

    /// Whether stroke `s` may cover `chain` (a stroke pinned to bones covers only those).
    pub fn stroke_may_cover(&self, s: usize, chain: &[usize]) -> bool {
        self.strokes.allowed_bones[s]
            .as_ref()
            .is_none_or(|allowed| chain.iter().all(|&b| allowed[b]))
    }

    /// The same setup with every `data_step`-th stroke sample and every `model_step`-th
    /// model point: enough for a rigid fit, at a fraction of the cost.
    pub fn thinned(&self, data_step: usize, model_step: usize) -> Self {
        let mut model = self.model.clone();
        model.points = model.points.iter().step_by(model_step).copied().collect();
        Self {
            skeleton: self.skeleton,
            start: self.start,
            options: self.options,
            interrupt: self.interrupt,
            height: self.height,
            model,
            strokes: self.strokes.thinned(data_step),
            movable: self.movable.clone(),
            root: self.root,
        }
    }
}

fn check_sizes(problem: &PoseProblem) -> Result<(), PoseError> {
    if problem.strokes.is_empty() {
        return Err(PoseError::NoStrokes);
    }
    if problem.strokes.len() > MAX_STROKES {
        return Err(PoseError::TooManyStrokes {
            count: problem.strokes.len(),
        });
    }
    let points: usize = problem.strokes.iter().map(|s| s.points.len()).sum();
    if points > MAX_STROKE_POINTS {
        return Err(PoseError::TooManyPoints { count: points });
    }
    if problem.skeleton.len() > MAX_POSE_JOINTS {
        return Err(PoseError::TooManyJoints {
            count: problem.skeleton.len(),
        });
    }
    for (s, stroke) in problem.strokes.iter().enumerate() {
        if stroke.points.len() < 2 {
            return Err(PoseError::StrokeTooShort { stroke: s });
        }
        if let Some(point) = stroke
            .points
            .iter()
            .position(|p| !p.iter().all(|v| v.is_finite()))
        {
            return Err(PoseError::NonFinite { stroke: s, point });
        }
    }
    Ok(())
}

/// Strokes must be drawn near the character: a point thousands of heights away is a unit or
/// coordinate mistake (and would overflow the squared distances).
fn check_distance(problem: &PoseProblem, height: f64) -> Result<(), PoseError> {
    let joints = problem.skeleton.joint_positions(problem.start);
    let centre = joints.iter().map(|p| p.coords).sum::<Vector3>() / joints.len().max(1) as f64;
    for (s, stroke) in problem.strokes.iter().enumerate() {
        if let Some(point) = stroke
            .points
            .iter()
            .position(|p| (p.coords - centre).norm() > MAX_STROKE_DISTANCE * height)
        {
            return Err(PoseError::FarAway { stroke: s, point });
        }
    }
    Ok(())
}

/// Joints that may move: not fixed, and among the chosen ones when a list is given.
fn movable_joints(skeleton: &Skeleton, names: Option<&[String]>) -> Result<Vec<bool>, PoseError> {
    let mut movable: Vec<bool> = skeleton
        .joints()
        .iter()
        .map(|j| j.dof != JointDof::Fixed)
        .collect();
    if let Some(names) = names {
        let mut chosen = vec![false; skeleton.len()];
        for name in names {
            let j = skeleton
                .find(name)
                .ok_or_else(|| PoseError::UnknownBone { name: name.clone() })?;
            chosen[j] = true;
        }
        for (m, c) in movable.iter_mut().zip(chosen) {
            *m &= c;
        }
        if !movable.iter().any(|&m| m) {
            return Err(PoseError::NothingMoves);
        }
    }
    Ok(movable)
}

/// Every stroke resampled (and beautified), with the bones it is pinned to.
fn sample_strokes(
    problem: &PoseProblem,
    options: &PoseOptions,
    model: &BoneModel,
    height: f64,
) -> Result<StrokeSamples, PoseError> {
    let mut samples = StrokeSamples::default();
    for (s, stroke) in problem.strokes.iter().enumerate() {
        let points = if options.beautify {
            beautify::beautify(&stroke.points, options.stroke_spacing * height)
        } else {
            beautify::resample(&stroke.points, options.stroke_spacing * height)
        };
        samples
            .stroke_of
            .extend(std::iter::repeat_n(s, points.len()));
        samples.points.extend(points);
        samples.allowed_bones.push(match &stroke.bones {
            None => None,
            Some(names) => {
                let mut allowed = vec![false; model.bones.len()];
                for name in names {
                    let j = problem.skeleton.find(name).ok_or_else(|| {
                        PoseError::UnknownStrokeBone {
                            stroke: s,
                            name: name.clone(),
                        }
                    })?;
                    // A bone is named by the joint that turns it, or by its tip when the tip
                    // translates (a marker is named by itself).
                    for (b, bone) in model.bones.iter().enumerate() {
                        if bone.joint == j || (bone.tip_translates && bone.child == j) {
                            allowed[b] = true;
                        }
                    }
                }
                Some(allowed)
            }
        });
    }
    samples.ranges = ranges_of(&samples.stroke_of, problem.strokes.len());
    samples.measure();
    Ok(samples)
}
