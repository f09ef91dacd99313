//! Posing a skeleton from 3D strokes (Cannavò et al. 2020, section 3.2): match stroke
//! points to points along the bones by softassign under deterministic annealing, solve the
//! joint rotations that align the bones to their matches, and alternate until the match
//! converges. Beyond the paper: stroke beautification, a rigid multi-start alignment for a
//! far start pose, and a chain step that gives each stroke one connected chain of bones,
//! so undrawn limbs keep their start pose and stray strokes are set aside.

pub mod beautify;
pub mod bones;
pub mod cases;
mod chains;

use crate::engine::{
    MatchMatrix, NormalSink, SkeletonNormalEquations, SoftassignParams, SubtreeMoments, softassign,
};
use crate::interrupt::Interrupt;
use crate::kinematics::{DofLayout, ForwardKinematics};
use crate::math::{Matrix4, Point3, Quat, Trs, Vector3};
use crate::skeleton::{JointDof, Pose, Skeleton};
use crate::strokes::Stroke;

pub use bones::BoneModel;

/// Weight of the mean squared joint rotation (radians) against the mean squared stroke
/// residual (heights) when choosing among heading hypotheses.
const HYPOTHESIS_BEND_WEIGHT: f64 = 2e-3;

/// Levenberg-Marquardt steps used to judge a trial assignment in the local search.
const QUICK_FIT_STEPS: usize = 8;

/// A chain is tried for a stroke in the local search when its fit at the current pose is
/// within this factor of the stroke's own chain's.
const EJECTION_COST_RATIO: f64 = 3.0;

/// Stroke points further than this many character heights from the rig are rejected.
const MAX_STROKE_DISTANCE: f64 = 100.0;

/// Weight of a joint-limit violation (radians) in the fit.
const LIMIT_WEIGHT: f64 = 100.0;

/// The longest chain of bones one stroke may cover.
const MAX_CHAIN_BONES: usize = 12;

/// The most trial assignments the local search fits in one solve (the real rigs of the
/// accuracy suite use at most about 110; a thousand cluttered strokes would use tens of
/// thousands).
const MAX_LOCAL_SEARCH_TRIALS: usize = 1_000;

/// The most strokes set aside as strays that the local search tries in place of an
/// assigned stroke, per pass.
const MAX_STRAY_EXCHANGES: usize = 8;

/// The most strokes one solve takes (more than any rig has chains to match).
pub const MAX_STROKES: usize = 1_000;

/// The most stroke points one solve takes, all strokes together, before resampling.
pub const MAX_STROKE_POINTS: usize = 1_000_000;

/// The most joints a rig may have for posing (ten times the largest production rigs).
pub const MAX_POSE_JOINTS: usize = 10_000;

/// How the solver runs. [`PoseOptions::paper`] is the method as published;
/// [`PoseOptions::default`] adds rigfit's improvements. Lengths are fractions of the
/// character's height.
#[derive(Clone, Debug, PartialEq)]
pub struct PoseOptions {
    /// Resample strokes evenly and smooth them before matching.
    pub beautify: bool,
    /// Before articulated fitting, align the whole character rigidly from several headings
    /// and keep the best.
    pub rigid_init: bool,
    /// Give each stroke one connected chain of bones (in order) and restrict its matches to
    /// it; undrawn bones keep their start pose; strokes no chain explains are set aside.
    pub chain_assignment: bool,
    /// Run the paper's softassign annealing over all bones before the chain step (measured:
    /// the chain step does better from the rigid alignment alone).
    pub anneal_before_chains: bool,
    /// Spacing of the model points along the bones.
    pub spacing: f64,
    /// Spacing of stroke samples after resampling.
    pub stroke_spacing: f64,
    /// Annealing: the match scale `sigma = 1/sqrt(beta)` goes from `sigma_start` to
    /// `sigma_end`.
    pub sigma_start: f64,
    pub sigma_end: f64,
    /// Steps of the annealing schedule.
    pub anneal_steps: usize,
    /// Paper: beta grows by a fixed amount per step; otherwise geometrically.
    pub additive_beta: bool,
    /// `zeta` of eq. (1) as a distance: matches further than this lose to the outlier class.
    pub outlier_distance: f64,
    /// Weight of `Phi(p)`: keeps joint rotations near the start pose.
    pub prior_weight: f64,
    /// Gauss-Newton steps per match update.
    pub gauss_newton_steps: usize,
    /// Extra iterations at the final temperature until the match converges.
    pub max_final_iterations: usize,
    /// A stroke whose RMS distance to its best chain exceeds this is a stray.
    pub stray_distance: f64,
}

impl Default for PoseOptions {
    fn default() -> Self {
        Self {
            beautify: true,
            rigid_init: true,
            chain_assignment: true,
            anneal_before_chains: false,
            spacing: 0.025,
            stroke_spacing: 0.025,
            sigma_start: 0.2,
            sigma_end: 0.012,
            anneal_steps: 14,
            additive_beta: false,
            outlier_distance: 0.06,
            prior_weight: 0.002,
            gauss_newton_steps: 1,
            max_final_iterations: 12,
            stray_distance: 0.06,
        }
    }
}

impl PoseOptions {
    /// The method as published: softassign with outlier row and column, beta raised by a
    /// fixed step, all bones, raw strokes (only resampled to the model's spacing).
    pub fn paper() -> Self {
        Self {
            beautify: false,
            rigid_init: false,
            chain_assignment: false,
            additive_beta: true,
            ..Self::default()
        }
    }
}

/// Why strokes cannot be used.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PoseError {
    #[error("no strokes")]
    NoStrokes,
    #[error("strokes: {count} strokes, more than the {MAX_STROKES} one solve takes")]
    TooManyStrokes { count: usize },
    #[error("strokes: {count} points in all, more than the {MAX_STROKE_POINTS} one solve takes")]
    TooManyPoints { count: usize },
    #[error("the rig has {count} joints, more than the {MAX_POSE_JOINTS} posing takes")]
    TooManyJoints { count: usize },
    #[error("strokes[{stroke}]: a stroke needs at least 2 points")]
    StrokeTooShort { stroke: usize },
    #[error("strokes[{stroke}].points[{point}]: coordinate is not a finite number")]
    NonFinite { stroke: usize, point: usize },
    #[error(
        "strokes[{stroke}].points[{point}]: the point is more than {MAX_STROKE_DISTANCE} character heights away from the rig"
    )]
    FarAway { stroke: usize, point: usize },
    #[error("strokes[{stroke}].bones: unknown bone '{name}'")]
    UnknownStrokeBone { stroke: usize, name: String },
    #[error("unknown bone '{name}' in the list of bones that may move")]
    UnknownBone { name: String },
    #[error("the rig has no bones to align (no joint with a child at a distance)")]
    NoBones,
    #[error("none of the chosen bones can move")]
    NothingMoves,
    #[error("the solve was stopped before it finished (deadline passed or cancelled)")]
    Interrupted,
}

impl PoseError {
    /// True when the rig (or the list of bones that may move) is at fault, not the strokes:
    /// callers name the rig's file in the message.
    pub fn is_rig_problem(&self) -> bool {
        matches!(
            self,
            Self::UnknownBone { .. }
                | Self::NoBones
                | Self::NothingMoves
                | Self::TooManyJoints { .. }
        )
    }
}

/// What the solver found.
#[derive(Clone, Debug)]
pub struct PoseResult {
    pub pose: Pose,
    /// For each input stroke, the joints (bones, named by the joint that turns them) it was
    /// matched to, in order along the stroke; empty for a stroke set aside as a stray.
    pub stroke_bones: Vec<Vec<usize>>,
    /// Match-and-align iterations run.
    pub iterations: usize,
    /// The final energy of eq. (1) (squared distances in the rig's units).
    pub energy: f64,
}

/// The posing problem: a skeleton, the pose to start from, strokes, and which joints may
/// move.
#[derive(Clone, Debug)]
pub struct PoseProblem<'a> {
    pub skeleton: &'a Skeleton,
    pub start: &'a Pose,
    pub strokes: &'a [Stroke],
    /// Names of the joints that may move (`--bones`); all when `None`.
    pub movable: Option<&'a [String]>,
    /// The character's height (lengths in the options are fractions of it).
    pub height: f64,
}

/// The state of one solve.
struct Solver<'a> {
    skeleton: &'a Skeleton,
    start: &'a Pose,
    options: &'a PoseOptions,
    /// When to give up: every Levenberg-Marquardt step and every outer loop polls it.
    interrupt: &'a Interrupt,
    /// Trial assignments the local search may still fit (bounds its cost on many strokes).
    trials_left: usize,
    height: f64,
    model: BoneModel,
    /// Stroke samples and the stroke each belongs to.
    data: Vec<Point3>,
    data_stroke: Vec<usize>,
    /// The samples of each stroke, as a range of `data`.
    stroke_ranges: Vec<std::ops::Range<usize>>,
    /// Per stroke: the bones it may match (`None` = any).
    stroke_allowed: Vec<Option<Vec<bool>>>,
    /// Joints allowed to move at all.
    movable: Vec<bool>,
    pose: Pose,
    iterations: usize,
    /// The weight of `Phi(p)` in force (lowered for the final polish).
    prior_weight: f64,
    /// The Levenberg-Marquardt damping, adapted from step to step.
    lambda: f64,
    /// Buffers reused by the Levenberg-Marquardt steps: the targets of `align`, the model
    /// points' subtree moments, the normal equations of the last layout, the forward
    /// kinematics of the last pose reached (with that pose), and a trial pose with its
    /// forward kinematics.
    targets: Vec<Option<(Point3, f64)>>,
    moments: SubtreeMoments,
    normal: Option<SkeletonNormalEquations>,
    fk: Option<(Pose, ForwardKinematics)>,
    trial: Option<(Pose, ForwardKinematics)>,
}

/// Poses `problem.skeleton` so its bones lie along the strokes.
pub fn solve_pose(problem: &PoseProblem, options: &PoseOptions) -> Result<PoseResult, PoseError> {
    solve_pose_interruptible(problem, options, &Interrupt::never())
}

/// [`solve_pose`] that gives up with [`PoseError::Interrupted`] soon after `interrupt` is set
/// (a deadline, or a client that went away).
pub fn solve_pose_interruptible(
    problem: &PoseProblem,
    options: &PoseOptions,
    interrupt: &Interrupt,
) -> Result<PoseResult, PoseError> {
    let skeleton = problem.skeleton;
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
    if skeleton.len() > MAX_POSE_JOINTS {
        return Err(PoseError::TooManyJoints {
            count: skeleton.len(),
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
    let height = if problem.height > 0.0 {
        problem.height
    } else {
        1.0
    };
    // Strokes must be drawn near the character: a point thousands of heights away is a unit
    // or coordinate mistake (and would overflow the squared distances).
    let joints = skeleton.joint_positions(problem.start);
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
    let spacing = options.spacing * height;
    let model = BoneModel::new(skeleton, problem.start, spacing, 1e-4 * height);
    if model.bones.is_empty() {
        return Err(PoseError::NoBones);
    }
    let mut movable: Vec<bool> = skeleton
        .joints()
        .iter()
        .map(|j| j.dof != JointDof::Fixed)
        .collect();
    if let Some(names) = problem.movable {
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
    let mut stroke_allowed = Vec::with_capacity(problem.strokes.len());
    let mut data = Vec::new();
    let mut data_stroke = Vec::new();
    for (s, stroke) in problem.strokes.iter().enumerate() {
        let samples = if options.beautify {
            beautify::beautify(&stroke.points, options.stroke_spacing * height)
        } else {
            beautify::resample(&stroke.points, options.stroke_spacing * height)
        };
        data_stroke.extend(std::iter::repeat_n(s, samples.len()));
        data.extend(samples);
        stroke_allowed.push(match &stroke.bones {
            None => None,
            Some(names) => {
                let mut allowed = vec![false; model.bones.len()];
                for name in names {
                    let j = skeleton
                        .find(name)
                        .ok_or_else(|| PoseError::UnknownStrokeBone {
                            stroke: s,
                            name: name.clone(),
                        })?;
                    for (b, bone) in model.bones.iter().enumerate() {
                        if bone.joint == j {
                            allowed[b] = true;
                        }
                    }
                }
                Some(allowed)
            }
        });
    }
    let mut solver = Solver {
        skeleton,
        start: problem.start,
        options,
        interrupt,
        trials_left: MAX_LOCAL_SEARCH_TRIALS,
        height,
        model,
        stroke_ranges: (0..problem.strokes.len())
            .map(|s| {
                let start = data_stroke.partition_point(|&d| d < s);
                start..data_stroke.partition_point(|&d| d <= s)
            })
            .collect(),
        data,
        data_stroke,
        stroke_allowed,
        movable,
        pose: problem.start.clone(),
        iterations: 0,
        prior_weight: options.prior_weight,
        lambda: 1e-3,
        targets: Vec::new(),
        moments: SubtreeMoments::new(),
        normal: None,
        fk: None,
        trial: None,
    };
    let result = solver.run();
    if interrupt.is_set() {
        return Err(PoseError::Interrupted);
    }
    result
}

impl Solver<'_> {
    fn run(&mut self) -> Result<PoseResult, PoseError> {
        let opts = self.options;
        let root = self
            .skeleton
            .skin_root()
            .filter(|&r| self.movable[r] && self.skeleton.joint(r).dof == JointDof::Free);
        let starts = match (opts.rigid_init, root) {
            (true, Some(root)) => self.rigid_candidates(root),
            _ => vec![self.start.clone()],
        };
        let all = self.layout(&self.movable.clone());
        let sigmas = self.schedule(
            opts.sigma_start,
            opts.sigma_end,
            opts.anneal_steps,
            opts.additive_beta,
        );
        let last = *sigmas.last().unwrap_or(&opts.sigma_end);
        let matches;
        let mut stroke_bones: Vec<Vec<usize>>;
        if opts.chain_assignment {
            // Every heading hypothesis goes through the whole chain fit; the one whose strokes
            // are best explained wins (a mirrored body fits its strokes visibly worse).
            let chains = self.model.chains(MAX_CHAIN_BONES);
            let mut fits: Vec<(f64, Pose, Vec<chains::Assignment>, DofLayout)> = Vec::new();
            for start in starts {
                if self.interrupt.is_set() {
                    break;
                }
                self.pose = start;
                if opts.anneal_before_chains {
                    self.anneal(&all, &sigmas, None);
                }
                let (assignment, layout, score) = self.fit_chains(&chains, root);
                fits.push((score, self.pose.clone(), assignment, layout));
            }
            // Local search on the promising hypotheses only.
            fits.sort_by(|a, b| a.0.total_cmp(&b.0));
            // Headings that converged to the same assignment are one hypothesis.
            fits.dedup_by(|a, b| a.2 == b.2);
            let cutoff = fits.first().map_or(0.0, |f| 2.0 * f.0);
            let mut best: Option<(f64, Pose, Vec<chains::Assignment>, DofLayout)> = None;
            for (score, pose, assignment, layout) in
                fits.into_iter().filter(|f| f.0 <= cutoff).take(2)
            {
                self.pose = pose;
                let (assignment, layout, score) =
                    self.improve_chains(&chains, root, assignment, layout, score);
                if best.as_ref().is_none_or(|b| score < b.0) {
                    best = Some((score, self.pose.clone(), assignment, layout));
                }
            }
            let Some((_, pose, assignment, layout)) = best else {
                // Only when interrupted before the first hypothesis was fitted.
                return Err(PoseError::Interrupted);
            };
            self.pose = pose;
            let allowed_bones: Vec<Option<Vec<bool>>> = assignment
                .iter()
                .map(|c| {
                    let mut a = vec![false; self.model.bones.len()];
                    for &b in c.iter().flat_map(|c| &c.0) {
                        a[b] = true;
                    }
                    Some(a)
                })
                .collect();
            // With every stroke's chain known, the start-pose prior has done its job (keeping
            // twists and choosing among mirror images); the polish lets short bones follow
            // their strokes.
            self.prior_weight = opts.prior_weight * 0.05;
            matches = self.settle(&layout, last, Some(&allowed_bones));
            stroke_bones = assignment
                .iter()
                .map(|c| match c {
                    Some((chain, reversed)) => {
                        let mut joints: Vec<usize> =
                            chain.iter().map(|&b| self.model.bones[b].joint).collect();
                        if *reversed {
                            joints.reverse();
                        }
                        joints
                    }
                    None => Vec::new(),
                })
                .collect();
        } else {
            self.pose = starts.into_iter().next().expect("at least one start");
            self.anneal(&all, &sigmas, None);
            matches = self.settle(&all, last, None);
            stroke_bones = self.bones_by_weight(&matches);
        }
        for b in &mut stroke_bones {
            b.dedup();
        }
        let energy = self.energy(&matches);
        Ok(PoseResult {
            pose: self.pose.clone(),
            stroke_bones,
            iterations: self.iterations,
            energy,
        })
    }

    /// The chain step from the current pose: assign chains, fit by arclength, set strays
    /// aside, re-assign until stable. Returns the assignment, the layout of joints that may
    /// move, and a score (mean squared stroke residual, strays counted at the stray
    /// distance).
    fn fit_chains(
        &mut self,
        chains: &[Vec<usize>],
        root: Option<usize>,
    ) -> (Vec<chains::Assignment>, DofLayout, f64) {
        let strokes = self.stroke_allowed.len();
        let stray = self.options.stray_distance;
        let initial = self.pose.clone();
        let mut excluded = vec![false; strokes];
        let mut assignment = chains::assign(self, chains, &excluded);
        let mut layout = self.layout(&self.movable.clone());
        for _round in 0..8 {
            if self.interrupt.is_set() {
                break;
            }
            layout = self.keep_unexplained_at_start(&assignment, root);
            self.fit_arclength(&layout, &assignment);
            let again = chains::assign(self, chains, &excluded);
            if again != assignment {
                assignment = again;
                continue;
            }
            // The assignment is stable. A stroke that stays far from its chain is a stray:
            // set it aside and start over without it.
            let residuals = chains::stroke_residuals(self, &assignment);
            let worst = (0..strokes)
                .filter(|&s| assignment[s].is_some())
                .max_by(|&a, &b| residuals[a].total_cmp(&residuals[b]));
            match worst.filter(|&s| residuals[s] > stray) {
                Some(s) => {
                    excluded[s] = true;
                    self.pose = initial.clone();
                    assignment = chains::assign(self, chains, &excluded);
                }
                None => break,
            }
        }
        let score = self.chain_score(&assignment, &layout, root);
        (assignment, layout, score)
    }

    /// Local search from a chain fit: swap the chains of two strokes of similar length (left
    /// and right limbs), or move a stroke to another chain, whenever that explains the
    /// strokes better.
    fn improve_chains(
        &mut self,
        chains: &[Vec<usize>],
        root: Option<usize>,
        mut assignment: Vec<chains::Assignment>,
        mut layout: DofLayout,
        mut score: f64,
    ) -> (Vec<chains::Assignment>, DofLayout, f64) {
        let strokes = assignment.len();
        // Local search: swap the chains of two strokes of similar length (left and right
        // limbs) when that explains the strokes better.
        let bone_lengths: Vec<f64> = self.model.bones.iter().map(|b| b.length).collect();
        let length = |c: &[usize]| c.iter().map(|&b| bone_lengths[b]).sum::<f64>();
        for _pass in 0..2 {
            if self.interrupt.is_set() {
                break;
            }
            let mut improved = false;
            for s in 0..strokes {
                for t in s + 1..strokes {
                    let (Some((cs, _)), Some((ct, _))) = (&assignment[s], &assignment[t]) else {
                        continue;
                    };
                    // Mirror-image limbs: chains of as many bones and about the same length.
                    let (ls, lt) = (length(cs), length(ct));
                    if cs.len() != ct.len() || (ls - lt).abs() > 0.15 * ls.max(lt) {
                        continue;
                    }
                    let mut trial = assignment.clone();
                    trial[s] = Some((ct.clone(), chains::better_direction(self, s, ct)));
                    trial[t] = Some((cs.clone(), chains::better_direction(self, t, cs)));
                    if let Some((trial_layout, trial_score)) =
                        self.try_assignment(&trial, root, score)
                    {
                        assignment = trial;
                        layout = trial_layout;
                        score = trial_score;
                        improved = true;
                    }
                }
            }
            // A stroke set aside as a stray may be the real one: give it the chain of an
            // assigned stroke and set that one aside instead.
            // The candidates at the current pose, computed again only after the pose moved.
            let mut ranked_now: Option<chains::Candidates> = None;
            let mut set_aside: Vec<usize> =
                (0..strokes).filter(|&e| assignment[e].is_none()).collect();
            if set_aside.len() > MAX_STRAY_EXCHANGES {
                // Many strays (clutter): only those that fit some chain best are tried.
                let ranked = chains::candidates(self, chains, &vec![false; strokes]);
                let best = |e: usize| ranked[e].first().map_or(f64::INFINITY, |c| c.0);
                set_aside.sort_by(|&a, &b| best(a).total_cmp(&best(b)));
                set_aside.truncate(MAX_STRAY_EXCHANGES);
                set_aside.sort_unstable();
                ranked_now = Some(ranked);
            }
            for e in set_aside {
                if assignment[e].is_some() {
                    continue;
                }
                let ranked = ranked_now
                    .get_or_insert_with(|| chains::candidates(self, chains, &vec![false; strokes]))
                    .clone();
                for s in 0..strokes {
                    if assignment[s].is_none() {
                        continue;
                    }
                    // Stroke `e` takes its best chain among the bones `s` leaves free.
                    let mut fixed = assignment.clone();
                    fixed[s] = None;
                    let mut excluded: Vec<bool> =
                        (0..strokes).map(|t| t != e && fixed[t].is_none()).collect();
                    excluded[s] = true;
                    let trial = chains::greedy(self, chains, &ranked, &fixed, &excluded);
                    if trial[e].is_none() {
                        continue;
                    }
                    if let Some((trial_layout, trial_score)) =
                        self.try_assignment(&trial, root, score)
                    {
                        assignment = trial;
                        layout = trial_layout;
                        score = trial_score;
                        improved = true;
                        ranked_now = None;
                        break;
                    }
                }
            }
            // Give a stroke one of its best candidate chains at the current pose, and let the
            // strokes whose chains that takes pick again.
            let ranked = chains::candidates(self, chains, &vec![false; strokes]);
            for s in 0..strokes {
                let Some((current, _)) = assignment[s].clone() else {
                    continue;
                };
                // Only chains that lie about as close to the stroke as its own does.
                let own = ranked[s]
                    .iter()
                    .find(|(_, c, _)| chains[*c] == current)
                    .map_or(f64::INFINITY, |e| e.0);
                let picks: Vec<(usize, bool)> = ranked[s]
                    .iter()
                    .filter(|(cost, c, _)| {
                        chains[*c] != current && *cost < EJECTION_COST_RATIO * own
                    })
                    .map(|&(_, c, r)| (c, r))
                    .take(2)
                    .collect();
                for (c, reversed) in picks {
                    let chain = &chains[c];
                    let mut fixed = assignment.clone();
                    fixed[s] = Some((chain.clone(), reversed));
                    for (t, f) in fixed.iter_mut().enumerate() {
                        if t != s
                            && f.as_ref()
                                .is_some_and(|(ct, _)| ct.iter().any(|b| chain.contains(b)))
                        {
                            *f = None;
                        }
                    }
                    let excluded: Vec<bool> =
                        (0..strokes).map(|t| assignment[t].is_none()).collect();
                    let trial = chains::greedy(self, chains, &ranked, &fixed, &excluded);
                    if trial == assignment {
                        continue;
                    }
                    if let Some((trial_layout, trial_score)) =
                        self.try_assignment(&trial, root, score)
                    {
                        assignment = trial;
                        layout = trial_layout;
                        score = trial_score;
                        improved = true;
                        break;
                    }
                }
            }
            // Move a stroke to a free chain of similar length (the other side's limb when one
            // limb is undrawn).
            for s in 0..strokes {
                let Some((current, _)) = assignment[s].clone() else {
                    continue;
                };
                let mut used = vec![false; bone_lengths.len()];
                for (t, a) in assignment.iter().enumerate() {
                    if t != s {
                        for &b in a.iter().flat_map(|a| &a.0) {
                            used[b] = true;
                        }
                    }
                }
                // Candidates: a free chain of about the same length elsewhere, or the current
                // chain grown or shrunk (a stroke that fits its chain only in part).
                let lc = length(&current);
                let stroke_length = chains::stroke_length(self, s);
                let mut options: Vec<&Vec<usize>> = chains
                    .iter()
                    .filter(|c| **c != current && c.iter().all(|&b| !used[b]))
                    .filter(|c| self.stroke_may_cover(s, c))
                    .filter(|c| {
                        c.iter().any(|b| current.contains(b)) || (length(c) - lc).abs() < 0.15 * lc
                    })
                    .collect();
                options.sort_by(|a, b| {
                    (length(a) - stroke_length)
                        .abs()
                        .total_cmp(&(length(b) - stroke_length).abs())
                });
                for c in options.into_iter().take(3) {
                    let mut trial = assignment.clone();
                    trial[s] = Some((c.clone(), chains::better_direction(self, s, c)));
                    if let Some((trial_layout, trial_score)) =
                        self.try_assignment(&trial, root, score)
                    {
                        assignment = trial;
                        layout = trial_layout;
                        score = trial_score;
                        improved = true;
                        break;
                    }
                }
            }
            if !improved {
                break;
            }
        }
        (assignment, layout, score)
    }

    /// Judges a trial assignment from the current pose by a quick fit; when it explains the
    /// strokes better than `score`, fits it fully and returns its layout and score, otherwise
    /// restores the pose.
    fn try_assignment(
        &mut self,
        trial: &[chains::Assignment],
        root: Option<usize>,
        score: f64,
    ) -> Option<(DofLayout, f64)> {
        if self.trials_left == 0 {
            return None;
        }
        self.trials_left -= 1;
        let saved = self.pose.clone();
        let layout = self.keep_unexplained_at_start(trial, root);
        self.fit_arclength_steps(&layout, trial, QUICK_FIT_STEPS);
        if self.chain_score(trial, &layout, root) < score {
            self.fit_arclength(&layout, trial);
            let fitted = self.chain_score(trial, &layout, root);
            return Some((layout, fitted));
        }
        self.pose = saved;
        None
    }

    /// Whether stroke `s` may cover `chain` (a stroke pinned to bones covers only those).
    fn stroke_may_cover(&self, s: usize, chain: &[usize]) -> bool {
        self.stroke_allowed[s]
            .as_ref()
            .is_none_or(|allowed| chain.iter().all(|&b| allowed[b]))
    }

    /// How well a chain fit explains the strokes: the mean squared stroke residual (strays
    /// counted at the stray distance) plus a small preference for bending less.
    fn chain_score(
        &self,
        assignment: &[chains::Assignment],
        layout: &DofLayout,
        root: Option<usize>,
    ) -> f64 {
        let stray = self.options.stray_distance;
        let strokes = assignment.len();
        let residuals = chains::stroke_residuals(self, assignment);
        let data = (0..strokes)
            .map(|s| {
                if assignment[s].is_some() {
                    residuals[s].powi(2)
                } else {
                    stray * stray
                }
            })
            .sum::<f64>()
            / strokes.max(1) as f64;
        // Strokes alone cannot always tell a body from its mirror image turned around (ball
        // joints bend either way), so among fits that explain the strokes equally, the one
        // that bends the joints least away from the start pose wins.
        let moved: Vec<f64> = (0..self.skeleton.len())
            .filter(|&j| Some(j) != root && layout.offset(j).is_some())
            .map(|j| {
                (self.start.local[j].rotation.inverse() * self.pose.local[j].rotation)
                    .angle()
                    .powi(2)
            })
            .collect();
        let bend = moved.iter().sum::<f64>() / moved.len().max(1) as f64;
        data + HYPOTHESIS_BEND_WEIGHT * bend
    }

    /// Puts joints with no assigned bone at or below them back to their start rotation and
    /// holds them there; returns the layout of the joints that may still move.
    fn keep_unexplained_at_start(
        &mut self,
        assignment: &[chains::Assignment],
        root: Option<usize>,
    ) -> DofLayout {
        let mut explained = vec![false; self.skeleton.len()];
        for (chain, _) in assignment.iter().flatten() {
            for &b in chain {
                explained[self.model.bones[b].joint] = true;
            }
        }
        for j in (0..self.skeleton.len()).rev() {
            if explained[j] {
                if let Some(p) = self.skeleton.joint(j).parent {
                    explained[p] = true;
                }
            }
        }
        let mut movable = self.movable.clone();
        for j in 0..self.skeleton.len() {
            if !explained[j] && Some(j) != root {
                self.pose.local[j].rotation = self.start.local[j].rotation;
                movable[j] = false;
            }
        }
        self.layout(&movable)
    }

    /// Levenberg-Marquardt to convergence with every chain point pulled to the stroke point
    /// at the same fraction of arclength.
    fn fit_arclength(&mut self, layout: &DofLayout, assignment: &[chains::Assignment]) {
        self.fit_arclength_steps(layout, assignment, 20);
    }

    /// At most `steps` Levenberg-Marquardt steps of the arclength fit.
    fn fit_arclength_steps(
        &mut self,
        layout: &DofLayout,
        assignment: &[chains::Assignment],
        steps: usize,
    ) {
        let targets = chains::arclength_targets(self, assignment);
        for _ in 0..steps {
            self.iterations += 1;
            if self.align_to(layout, &targets) < 1e-3 {
                break;
            }
        }
    }

    /// The DOF layout over movable joints that can influence some model point.
    fn layout(&self, movable: &[bool]) -> DofLayout {
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

    /// Match scales from `from` to `to` over `steps` (geometric in beta, or additive).
    fn schedule(&self, from: f64, to: f64, steps: usize, additive: bool) -> Vec<f64> {
        let steps = steps.max(2);
        let (b0, b1) = (1.0 / (from * from), 1.0 / (to * to));
        (0..steps)
            .map(|s| {
                let t = s as f64 / (steps - 1) as f64;
                let beta = if additive {
                    b0 + (b1 - b0) * t
                } else {
                    b0 * (b1 / b0).powf(t)
                };
                self.height / beta.sqrt()
            })
            .collect()
    }

    fn softassign_at(
        &self,
        world: &[Point3],
        sigma: f64,
        allowed: Option<&[Option<Vec<bool>>]>,
    ) -> MatchMatrix {
        let zeta = (self.options.outlier_distance * self.height).powi(2);
        let params = SoftassignParams {
            beta: 1.0 / (sigma * sigma),
            zeta,
            sinkhorn_iterations: 30,
            sinkhorn_tolerance: 1e-3,
        };
        let pinned = &self.stroke_allowed;
        let model = &self.model;
        let data_stroke = &self.data_stroke;
        softassign(world, &self.data, &params, |k, i| {
            let s = data_stroke[i];
            let b = model.points[k].bone;
            let ok_pin = pinned[s].as_ref().is_none_or(|a| a[b]);
            let ok_chain = allowed.is_none_or(|a| a[s].as_ref().is_none_or(|a| a[b]));
            ok_pin && ok_chain
        })
    }

    /// One annealing pass: for each scale, match then align.
    fn anneal(
        &mut self,
        layout: &DofLayout,
        sigmas: &[f64],
        allowed: Option<&[Option<Vec<bool>>]>,
    ) -> MatchMatrix {
        let mut matches = MatchMatrix::default();
        for &sigma in sigmas {
            if self.interrupt.is_set() {
                break;
            }
            let fk = ForwardKinematics::new(self.skeleton, &self.pose);
            let world = self.model.world_points(&fk);
            matches = self.softassign_at(&world, sigma, allowed);
            for _ in 0..self.options.gauss_newton_steps {
                self.align(layout, &matches);
            }
            self.iterations += 1;
        }
        matches
    }

    /// Iterates at the final scale until the match stops changing.
    fn settle(
        &mut self,
        layout: &DofLayout,
        sigma: f64,
        allowed: Option<&[Option<Vec<bool>>]>,
    ) -> MatchMatrix {
        let mut matches = self.match_now(sigma, allowed);
        for _ in 0..self.options.max_final_iterations {
            if self.interrupt.is_set() {
                break;
            }
            self.align(layout, &matches);
            self.iterations += 1;
            let next = self.match_now(sigma, allowed);
            let change = next.change_from(&matches);
            matches = next;
            if change < 1e-3 {
                break;
            }
        }
        matches
    }

    /// Softassign at the current pose.
    fn match_now(&self, sigma: f64, allowed: Option<&[Option<Vec<bool>>]>) -> MatchMatrix {
        let fk = ForwardKinematics::new(self.skeleton, &self.pose);
        let world = self.model.world_points(&fk);
        self.softassign_at(&world, sigma, allowed)
    }

    /// One Levenberg-Marquardt step on eq. (1) with `omega` fixed: each model point pulled
    /// to the weighted mean of its matches (Dewaele eq. 20 form), plus `Phi(p)`.
    fn align(&mut self, layout: &DofLayout, matches: &MatchMatrix) {
        let mut targets = std::mem::take(&mut self.targets);
        targets.clear();
        targets.extend((0..matches.rows()).map(|k| matches.target(k, &self.data)));
        self.align_to(layout, &targets);
        self.targets = targets;
    }

    /// The weighted cost of `pose` (whose forward kinematics is `fk`): model point `k`
    /// pulled to `targets[k]`, plus `Phi(p)` and joint-limit penalties. With `ne`, also
    /// accumulates the normal equations (the points' through their subtree moments).
    fn objective(
        &self,
        layout: &DofLayout,
        targets: &[Option<(Point3, f64)>],
        pose: &Pose,
        fk: &ForwardKinematics,
        mut ne: Option<(&mut SubtreeMoments, &mut SkeletonNormalEquations)>,
    ) -> f64 {
        let mut cost = 0.0;
        if let Some((moments, _)) = ne.as_mut() {
            moments.reset(self.skeleton.len());
        }
        let inv_height = 1.0 / self.height;
        for (k, mp) in self.model.points.iter().enumerate() {
            let Some((target, w)) = targets[k] else {
                continue;
            };
            let p = fk.point(mp.joint, &mp.local);
            let r = (p - target) * inv_height;
            match ne.as_mut() {
                Some((moments, _)) => moments.add_point(fk, mp.joint, &p, &r, w),
                None => cost += w * r.norm_squared(),
            }
        }
        if let Some((moments, ne)) = ne.as_mut() {
            ne.assemble_points(moments, fk, inv_height);
        }
        // Phi(p): rotation vectors away from the start pose, per joint and axis.
        let prior = self.prior_weight;
        let mut scalar = |ne: &mut Option<(&mut SubtreeMoments, &mut SkeletonNormalEquations)>,
                          r: f64,
                          w: f64,
                          col: usize| match ne {
            Some((_, ne)) => ne.add_scalar(r, w, col, 1.0),
            None => cost += w * r * r,
        };
        for j in 0..self.skeleton.len() {
            let Some(o) = layout.offset(j) else { continue };
            let delta =
                (self.start.local[j].rotation.inverse() * pose.local[j].rotation).scaled_axis();
            match layout.dof(j) {
                JointDof::Ball => (0..3).for_each(|a| scalar(&mut ne, delta[a], prior, o + a)),
                JointDof::Hinge { axis } => scalar(&mut ne, delta.dot(&axis.normalize()), prior, o),
                _ => {}
            }
            if let (Some(lim), JointDof::Ball) = (&self.skeleton.joint(j).limits, layout.dof(j)) {
                let rest = (self.skeleton.joint(j).rest.rotation.inverse()
                    * pose.local[j].rotation)
                    .scaled_axis();
                for a in 0..3 {
                    let excess = (rest[a] - lim.max[a]).max(0.0) + (rest[a] - lim.min[a]).min(0.0);
                    if excess != 0.0 {
                        scalar(&mut ne, excess, LIMIT_WEIGHT, o + a);
                    }
                }
            }
        }
        match ne {
            Some((_, ne)) => ne.cost(),
            None => cost,
        }
    }

    /// One Levenberg-Marquardt step pulling model point `k` to `targets[k]` (weighted),
    /// plus `Phi(p)`. Returns the relative decrease of the cost.
    fn align_to(&mut self, layout: &DofLayout, targets: &[Option<(Point3, f64)>]) -> f64 {
        if layout.is_empty() || self.interrupt.is_set() {
            return 0.0;
        }
        let skeleton = self.skeleton;
        let parent = |j: usize| skeleton.joint(j).parent;
        let mut ne = match self.normal.take() {
            Some(ne) if ne.is_for(layout) => ne,
            Some(mut ne) => {
                ne.set_layout(layout, parent);
                ne
            }
            None => SkeletonNormalEquations::new(layout, parent),
        };
        ne.clear();
        let (mut fk_pose, mut fk) = match self.fk.take() {
            Some((mut p, mut fk)) => {
                if p != self.pose {
                    fk.update(skeleton, &self.pose);
                    p.clone_from(&self.pose);
                }
                (p, fk)
            }
            None => (
                self.pose.clone(),
                ForwardKinematics::new(skeleton, &self.pose),
            ),
        };
        let (mut trial, mut trial_fk) = self
            .trial
            .take()
            .unwrap_or_else(|| (self.pose.clone(), fk.clone()));
        let mut moments = std::mem::take(&mut self.moments);
        let cost = self.objective(
            layout,
            targets,
            &self.pose,
            &fk,
            Some((&mut moments, &mut ne)),
        );
        self.moments = moments;
        let mut decrease = 0.0;
        for _ in 0..8 {
            let Some(step) = ne.solve(self.lambda) else {
                self.lambda *= 10.0;
                continue;
            };
            trial.clone_from(&self.pose);
            layout.apply(&mut trial, step);
            trial_fk.update(skeleton, &trial);
            let trial_cost = self.objective(layout, targets, &trial, &trial_fk, None);
            if trial_cost <= cost {
                fk_pose.clone_from(&trial);
                std::mem::swap(&mut fk, &mut trial_fk);
                std::mem::swap(&mut self.pose, &mut trial);
                self.lambda = (self.lambda / 3.0).max(1e-7);
                decrease = (cost - trial_cost) / cost.max(1e-300);
                break;
            }
            self.lambda *= 10.0;
        }
        self.normal = Some(ne);
        self.fk = Some((fk_pose, fk));
        self.trial = Some((trial, trial_fk));
        decrease
    }

    /// Eq. (1) at the current pose: `sum omega |y - v|^2 - zeta sum omega`.
    fn energy(&self, matches: &MatchMatrix) -> f64 {
        let fk = ForwardKinematics::new(self.skeleton, &self.pose);
        let world = self.model.world_points(&fk);
        let zeta = (self.options.outlier_distance * self.height).powi(2);
        let mut e = 0.0;
        for k in 0..matches.rows() {
            for &(i, w) in matches.row(k) {
                e += w * ((self.data[i as usize] - world[k]).norm_squared() - zeta);
            }
        }
        e
    }

    /// For each stroke, the bones that took a good share of its points, in stroke order.
    fn bones_by_weight(&self, matches: &MatchMatrix) -> Vec<Vec<usize>> {
        let strokes = self.stroke_allowed.len();
        // For each data point, its best bone.
        let mut best = vec![(0.0, usize::MAX); self.data.len()];
        for k in 0..matches.rows() {
            let b = self.model.points[k].bone;
            for &(i, w) in matches.row(k) {
                if w > best[i as usize].0 {
                    best[i as usize] = (w, b);
                }
            }
        }
        let mut out = vec![Vec::new(); strokes];
        for (i, &(w, b)) in best.iter().enumerate() {
            if w > 0.2 && b != usize::MAX {
                let joint = self.model.bones[b].joint;
                let list = &mut out[self.data_stroke[i]];
                if list.last() != Some(&joint) && !list.contains(&joint) {
                    list.push(joint);
                }
            }
        }
        out
    }

    /// Rigid alignments of the whole character from four headings about the vertical axis,
    /// best explained first.
    fn rigid_candidates(&mut self, root: usize) -> Vec<Pose> {
        let mut only_root = vec![false; self.skeleton.len()];
        only_root[root] = true;
        let layout = DofLayout::with_active(self.skeleton, &only_root);
        let data_centre = centroid(&self.data);
        let mut found: Vec<(f64, Pose)> = Vec::new();
        let sigmas = self.schedule(0.3, 0.05, 6, false);
        // A rigid fit needs few points: every third stroke sample, every other model point.
        let full_data = std::mem::take(&mut self.data);
        let full_strokes = std::mem::take(&mut self.data_stroke);
        let full_points = std::mem::take(&mut self.model.points);
        self.data = full_data.iter().step_by(3).copied().collect();
        self.data_stroke = full_strokes.iter().step_by(3).copied().collect();
        self.model.points = full_points.iter().step_by(2).copied().collect();
        for heading in 0..4 {
            let angle = heading as f64 * std::f64::consts::FRAC_PI_2;
            self.pose = self.start.clone();
            let fk = ForwardKinematics::new(self.skeleton, &self.pose);
            let model_centre = centroid(&self.model.world_points(&fk));
            // Turn about the vertical through the model's centre, then move onto the strokes.
            let turn = Trs::new(
                Vector3::zeros(),
                Quat::from_axis_angle(&Vector3::y_axis(), angle),
            )
            .to_matrix();
            let world_root = Matrix4::new_translation(&(data_centre - model_centre))
                * Matrix4::new_translation(&model_centre)
                * turn
                * Matrix4::new_translation(&-model_centre)
                * fk.world(root);
            let parent = self
                .skeleton
                .joint(root)
                .parent
                .map(|p| *fk.world(p))
                .unwrap_or_else(Matrix4::identity);
            let local = parent.try_inverse().unwrap_or_else(Matrix4::identity) * world_root;
            let trs = Trs::from_matrix(&local);
            self.pose.local[root].translation = trs.translation;
            self.pose.local[root].rotation = trs.rotation;
            self.anneal(&layout, &sigmas, None);
            found.push((self.truncated_chamfer(), self.pose.clone()));
        }
        self.data = full_data;
        self.data_stroke = full_strokes;
        self.model.points = full_points;
        found.sort_by(|a, b| a.0.total_cmp(&b.0));
        found.into_iter().map(|f| f.1).collect()
    }

    /// Mean over stroke samples of the squared distance to the nearest model point, capped
    /// at the outlier distance: how well the strokes are explained.
    fn truncated_chamfer(&self) -> f64 {
        let fk = ForwardKinematics::new(self.skeleton, &self.pose);
        let world = self.model.world_points(&fk);
        let cap = (self.options.outlier_distance * self.height * 3.0).powi(2);
        self.data
            .iter()
            .map(|y| {
                world
                    .iter()
                    .map(|v| (y - v).norm_squared())
                    .fold(cap, f64::min)
            })
            .sum::<f64>()
            / self.data.len().max(1) as f64
    }
}

fn centroid(points: &[Point3]) -> Vector3 {
    let sum: Vector3 = points.iter().map(|p| p.coords).sum();
    sum / points.len().max(1) as f64
}
