//! The corpus sweep: every chosen rig's cases of every chosen scenario, solved, with what
//! each gave.

use std::time::Instant;

use rayon::prelude::*;
use rigfit_core::pose::{PoseError, PoseOptions, PoseProblem, PoseResult, solve_pose};
use rigfit_core::{Point3, Pose, Skeleton, Stroke};

use crate::corpus::{Corpus, CorpusError, CorpusRig, Half, RigKind};
use crate::scenario::{GeneratedCase, Scenario, TargetKind, generate_case};

/// A case succeeds when its mean drawn-joint error is at most this fraction of the height...
pub const SUCCESS_MEAN_ERROR: f64 = 0.03;
/// ...and no drawn joint is further than this fraction of the height from the truth.
pub const SUCCESS_MAX_ERROR: f64 = 0.10;

/// A failed case whose result fits the strokes within this fraction of the height of how
/// well the true pose fits them is an ambiguous drawing, not a search failure.
pub const AMBIGUITY_TOLERANCE: f64 = 0.005;

/// What to sweep.
#[derive(Clone, Debug)]
pub struct SweepOptions {
    /// Only rigs of this half (all when `None`).
    pub half: Option<Half>,
    /// Only these rig ids (all when empty).
    pub rigs: Vec<String>,
    pub scenarios: Vec<Scenario>,
    /// Cases per rig and scenario, indices `0..cases`.
    pub cases: usize,
    /// Only this case index (to reproduce one case of a table).
    pub only_case: Option<usize>,
    pub pose: PoseOptions,
    /// Solver threads (rayon's default, one per core, when `None`).
    pub threads: Option<usize>,
    /// Give the solver the rig's joint model (hinges and limits from its joints file or
    /// clips), as `rigfit pose --joints` does; cases are drawn with it either way.
    pub joint_model: bool,
    /// What each solve is offered as an extra start ([`PoseOptions::extra_starts`]).
    pub offer: Offer,
}

/// An extra start offered to each solve of a sweep: a diagnostic that splits the failures
/// into those the search missed (the truth, offered, wins) and those the score chose wrong.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Offer {
    /// Nothing: the solver as a user runs it.
    #[default]
    Nothing,
    /// The true pose.
    Truth,
    /// The start pose with the character's root placed as in the truth.
    TruthRoot,
}

impl Offer {
    pub fn from_name(name: &str) -> Option<Self> {
        match name {
            "nothing" => Some(Self::Nothing),
            "truth" => Some(Self::Truth),
            "truth-root" => Some(Self::TruthRoot),
            _ => None,
        }
    }

    /// The pose offered for `generated` on `rig`, if any.
    fn start(self, rig: &CorpusRig, generated: &GeneratedCase) -> Option<Pose> {
        match self {
            Self::Nothing => None,
            Self::Truth => Some(generated.truth.clone()),
            Self::TruthRoot => {
                let root = rig.solver_skeleton().skin_root()?;
                let mut start = rig.start.clone();
                start.local[root] = generated.truth.local[root];
                Some(start)
            }
        }
    }
}

impl Default for SweepOptions {
    fn default() -> Self {
        Self {
            half: None,
            rigs: Vec::new(),
            scenarios: Scenario::ALL.to_vec(),
            cases: 4,
            only_case: None,
            pose: PoseOptions::default(),
            threads: None,
            joint_model: false,
            offer: Offer::Nothing,
        }
    }
}

/// What one case gave. Errors are fractions of the height. The drawn joints are every
/// joint of a drawn chain, the joint it attaches at included (a stroke runs through it).
#[derive(Clone, Debug)]
pub struct Outcome {
    pub rig: String,
    pub half: Half,
    pub kind: RigKind,
    pub scenario: Scenario,
    pub case: usize,
    pub target: TargetKind,
    pub strokes: usize,
    pub drawn_joints: usize,
    /// Mean distance of the drawn joints from the truth (infinite when the solve failed).
    pub mean_error: f64,
    /// The largest distance of a drawn joint from the truth.
    pub max_error: f64,
    /// The drawn joint furthest from the truth.
    pub worst_joint: String,
    /// How far dropped limbs moved from the start pose relative to where they attach.
    pub undrawn_motion: f64,
    pub seconds: f64,
    /// The solver's error when it refused the case.
    pub failure: Option<String>,
    /// How far the result's drawn chains are from the strokes ([`stroke_misfit`]), and
    /// how far the truth's are: a result that fits as well as the truth and still fails
    /// found another pose the strokes draw as well (a mirror image turned around).
    pub misfit: f64,
    pub truth_misfit: f64,
    /// How far the result's own chains (those it matched the strokes to) are from the
    /// strokes ([`own_chains_misfit`]).
    pub own_misfit: f64,
    /// Whether the answer expected is a twin of the truth under one of the rig's
    /// symmetries ([`crate::scenario::expected_labelling`]).
    pub twinned: bool,
    /// Whether the case succeeds judged against the truth itself, whatever its twins.
    pub strict_success: bool,
}

impl Outcome {
    /// Mean drawn-joint error at most 3% of the height and no drawn joint over 10%.
    pub fn success(&self) -> bool {
        self.failure.is_none() && within_bounds(self.mean_error, self.max_error)
    }

    /// How far past the bounds the case is (at most 1 for a success): the larger of its
    /// errors over their bounds.
    pub fn badness(&self) -> f64 {
        if self.failure.is_some() {
            return f64::INFINITY;
        }
        (self.mean_error / SUCCESS_MEAN_ERROR).max(self.max_error / SUCCESS_MAX_ERROR)
    }

    /// A failure whose result fits the strokes as well as the truth does, with the drawn
    /// chains or with the chains it matched them to: the strokes do not tell the two poses
    /// apart.
    pub fn ambiguous(&self) -> bool {
        self.failure.is_none()
            && !self.success()
            && self.misfit.min(self.own_misfit) <= self.truth_misfit + AMBIGUITY_TOLERANCE
    }
}

/// Whether a mean and a largest drawn-joint error (fractions of the height) are within a
/// case's bounds.
fn within_bounds(mean: f64, max: f64) -> bool {
    mean <= SUCCESS_MEAN_ERROR && max <= SUCCESS_MAX_ERROR
}

/// How far a pose's drawn chains are from the strokes drawn on them, in heights: the mean
/// distance of the drawn strokes' points from the nearest bone of a drawn chain, plus the
/// mean distance of the drawn joints from the nearest drawn stroke point. Labels play no
/// part within the drawn chains: a pose whose drawn limbs trade places scores as the true
/// one does.
pub fn stroke_misfit(
    skeleton: &rigfit_core::Skeleton,
    pose: &rigfit_core::Pose,
    case: &rigfit_core::pose::sketch::Case,
    height: f64,
) -> f64 {
    chains_misfit(
        skeleton,
        pose,
        case,
        &case.stroke_chains,
        &case.drawn_joints,
        height,
    )
}

/// [`stroke_misfit`] with the chains a solver matched the strokes to (`stroke_bones`, as
/// `PoseResult` gives them: each stroke's bones named by the joints that turn them) in
/// place of the drawn ones: how well the answer's own limbs explain the drawn strokes. A
/// run of strokes moved one finger along a row into the finger left undrawn, or a limb's
/// stroke given to the dropped limb, is judged by the limbs that took them. Each chain's
/// last bone ends at its joint's only child (left out when the joint has several).
pub fn own_chains_misfit(
    skeleton: &rigfit_core::Skeleton,
    pose: &rigfit_core::Pose,
    case: &rigfit_core::pose::sketch::Case,
    stroke_bones: &[Vec<usize>],
    height: f64,
) -> f64 {
    let chains: Vec<Vec<usize>> = stroke_bones
        .iter()
        .map(|bones| {
            let mut chain = bones.clone();
            // In the order along the stroke: root first or tip first.
            let tip_first = chain.len() >= 2 && skeleton.joint(chain[0]).parent == Some(chain[1]);
            if tip_first {
                chain.reverse();
            }
            if let Some(&last) = chain.last()
                && let [only] = skeleton.children(last)[..]
            {
                chain.push(only);
            }
            chain
        })
        .collect();
    let mut joints: Vec<usize> = chains.iter().flatten().copied().collect();
    joints.sort_unstable();
    joints.dedup();
    chains_misfit(skeleton, pose, case, &chains, &joints, height)
}

/// The misfit of [`stroke_misfit`] between the points of the strokes the case draws on a
/// chain (strays left out) and the bones of `chains` (one joint path per stroke, or empty)
/// and `joints`.
fn chains_misfit(
    skeleton: &rigfit_core::Skeleton,
    pose: &rigfit_core::Pose,
    case: &rigfit_core::pose::sketch::Case,
    chains: &[Vec<usize>],
    joints: &[usize],
    height: f64,
) -> f64 {
    let positions = skeleton.joint_positions(pose);
    let segments: Vec<(rigfit_core::Point3, rigfit_core::Point3)> = chains
        .iter()
        .flat_map(|chain| chain.windows(2).map(|w| (positions[w[0]], positions[w[1]])))
        .collect();
    let points: Vec<&rigfit_core::Point3> = case
        .strokes
        .iter()
        .zip(&case.stroke_chains)
        .filter(|(_, chain)| !chain.is_empty())
        .flat_map(|(stroke, _)| &stroke.points)
        .collect();
    if segments.is_empty() || points.is_empty() {
        return 0.0;
    }
    let to_segment = |p: &rigfit_core::Point3,
                      (a, b): &(rigfit_core::Point3, rigfit_core::Point3)| {
        let ab = b - a;
        let t = ((p - a).dot(&ab) / ab.norm_squared().max(1e-300)).clamp(0.0, 1.0);
        (p - (a + ab * t)).norm()
    };
    let stroke_side = points
        .iter()
        .map(|p| {
            segments
                .iter()
                .map(|s| to_segment(p, s))
                .fold(f64::INFINITY, f64::min)
        })
        .sum::<f64>()
        / points.len() as f64;
    let joint_side = joints
        .iter()
        .map(|&j| {
            points
                .iter()
                .map(|p| (*p - positions[j]).norm())
                .fold(f64::INFINITY, f64::min)
        })
        .sum::<f64>()
        / joints.len().max(1) as f64;
    (stroke_side + joint_side) / height.max(1e-300)
}

/// A marker rig's strokes, each pinned to the markers it was drawn through: every joint of
/// its chain but the one the chain hangs from (the solver refuses unpinned strokes on
/// markers: nothing says which marker a stroke draws). Strays stay unpinned.
pub fn pinned_to_markers(
    skeleton: &rigfit_core::Skeleton,
    case: &rigfit_core::pose::sketch::Case,
) -> Vec<rigfit_core::Stroke> {
    pinned_to_joints(skeleton, case, |chain, j| {
        skeleton.joint(j).parent.is_some_and(|p| chain.contains(&p))
    })
}

/// Every drawn stroke pinned to the bones of the chain it was drawn along, each named by
/// the joint that turns it (every joint of the chain with a child on it): the solver then
/// scores the true assignment (`pose_case --pin truth`). Strays stay unpinned.
pub fn pinned_to_drawn_chains(
    skeleton: &rigfit_core::Skeleton,
    case: &rigfit_core::pose::sketch::Case,
) -> Vec<rigfit_core::Stroke> {
    pinned_to_joints(skeleton, case, |chain, j| {
        skeleton.children(j).iter().any(|c| chain.contains(c))
    })
}

/// `case`'s strokes, each drawn one pinned to the joints `j` of its chain for which
/// `keep(chain, j)` holds.
fn pinned_to_joints(
    skeleton: &rigfit_core::Skeleton,
    case: &rigfit_core::pose::sketch::Case,
    keep: impl Fn(&[usize], usize) -> bool,
) -> Vec<rigfit_core::Stroke> {
    case.strokes
        .iter()
        .zip(&case.stroke_chains)
        .map(|(stroke, chain)| {
            let mut pinned = stroke.clone();
            if !chain.is_empty() {
                let names = chain
                    .iter()
                    .filter(|&&j| keep(chain, j))
                    .map(|&j| skeleton.joint(j).name.clone())
                    .collect();
                pinned.bones = Some(names);
            }
            pinned
        })
        .collect()
}

/// A generated case solved from the rig's start pose: the strokes given to the solver
/// (pinned to their markers on a marker rig), its answer and the seconds it took.
#[derive(Debug)]
pub struct Solved {
    pub strokes: Vec<Stroke>,
    pub result: Result<PoseResult, PoseError>,
    pub seconds: f64,
}

/// Solves `generated` on `rig` with `options`.
pub fn solve_generated(
    rig: &CorpusRig,
    generated: &GeneratedCase,
    options: &PoseOptions,
) -> Solved {
    let skeleton = rig.solver_skeleton();
    let strokes = if rig.entry.kind == RigKind::Marker {
        pinned_to_markers(skeleton, &generated.case)
    } else {
        generated.case.strokes.clone()
    };
    let problem = PoseProblem {
        skeleton,
        start: &rig.start,
        strokes: &strokes,
        movable: None,
        height: rig.height,
    };
    let began = Instant::now();
    let result = solve_pose(&problem, options);
    let seconds = began.elapsed().as_secs_f64();
    Solved {
        strokes,
        result,
        seconds,
    }
}

/// Generates case `index` of `scenario` on `rig` and solves it with `options`, offered
/// `offer` as an extra start.
pub fn solve_case(
    rig: &CorpusRig,
    scenario: Scenario,
    index: usize,
    options: &PoseOptions,
    offer: Offer,
) -> Outcome {
    let generated = generate_case(rig, scenario, index);
    let skeleton = &rig.rig.skeleton;
    let offered;
    let options = match offer.start(rig, &generated) {
        Some(start) => {
            offered = PoseOptions {
                extra_starts: vec![start],
                ..options.clone()
            };
            &offered
        }
        None => options,
    };
    let Solved {
        result, seconds, ..
    } = solve_generated(rig, &generated, options);
    let mut outcome = Outcome {
        rig: rig.entry.id.clone(),
        half: rig.entry.half,
        kind: rig.entry.kind,
        scenario,
        case: index,
        target: generated.target,
        strokes: generated.case.strokes.len(),
        drawn_joints: generated.case.drawn_joints.len(),
        mean_error: f64::INFINITY,
        max_error: f64::INFINITY,
        worst_joint: String::new(),
        undrawn_motion: 0.0,
        seconds,
        failure: None,
        misfit: f64::INFINITY,
        truth_misfit: stroke_misfit(skeleton, &generated.truth, &generated.case, rig.height),
        own_misfit: f64::INFINITY,
        twinned: generated.twinned(),
        strict_success: false,
    };
    match result {
        Ok(result) => {
            let errors = generated.errors(rig, &result.pose);
            outcome.misfit = stroke_misfit(skeleton, &result.pose, &generated.case, rig.height);
            outcome.own_misfit = own_chains_misfit(
                skeleton,
                &result.pose,
                &generated.case,
                &result.stroke_bones,
                rig.height,
            );
            outcome.mean_error = errors.mean;
            outcome.max_error = errors.max;
            let strict = generated.strict_errors(rig, &result.pose);
            outcome.strict_success = within_bounds(strict.mean, strict.max);
            outcome.worst_joint = errors
                .worst
                .map(|j| skeleton.joint(j).name.clone())
                .unwrap_or_default();
            outcome.undrawn_motion = generated
                .case
                .dropped_chains
                .iter()
                .map(|chain| {
                    // Expecting a twin, the answer's undrawn limb is the image of the truth's.
                    let chain: Vec<usize> = chain.iter().map(|&j| generated.labelling[j]).collect();
                    limb_motion(skeleton, &rig.start, &result.pose, &chain, rig.height)
                })
                .fold(0.0, f64::max);
        }
        Err(e) => outcome.failure = Some(e.to_string()),
    }
    outcome
}

/// The manifest's rigs that `options` chooses, in manifest order. Fails naming an id that
/// is not listed.
pub fn chosen_rigs<'a>(
    corpus: &'a Corpus,
    options: &SweepOptions,
) -> Result<Vec<&'a crate::corpus::RigEntry>, CorpusError> {
    if let Some(unknown) = options.rigs.iter().find(|id| corpus.entry(id).is_none()) {
        return Err(CorpusError::Rig {
            id: unknown.clone(),
            problem: format!("not listed in {}", corpus.manifest.display()),
        });
    }
    Ok(corpus
        .rigs
        .iter()
        .filter(|r| options.half.is_none_or(|h| r.half == h))
        .filter(|r| options.rigs.is_empty() || options.rigs.contains(&r.id))
        .collect())
}

/// Sweeps the chosen rigs (read one at a time) and scenarios; cases run in parallel.
/// `progress` is called after each rig with its outcomes.
pub fn sweep(
    corpus: &Corpus,
    options: &SweepOptions,
    mut progress: impl FnMut(&CorpusRig, &[Outcome]),
) -> Result<Vec<Outcome>, CorpusError> {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(options.threads.unwrap_or(0))
        .build()
        .map_err(|e| CorpusError::Rig {
            id: "(all)".into(),
            problem: format!("no thread pool: {e}"),
        })?;
    let indices: Vec<usize> = match options.only_case {
        Some(i) => vec![i],
        None => (0..options.cases).collect(),
    };
    let mut outcomes = Vec::new();
    for entry in chosen_rigs(corpus, options)? {
        let mut rig = corpus.read_rig(entry)?;
        rig.solve_with_joint_model = options.joint_model;
        let jobs: Vec<(Scenario, usize)> = options
            .scenarios
            .iter()
            .flat_map(|&s| indices.iter().map(move |&i| (s, i)))
            .collect();
        let rig_outcomes: Vec<Outcome> = pool.install(|| {
            jobs.par_iter()
                .map(|&(scenario, index)| {
                    solve_case(&rig, scenario, index, &options.pose, options.offer)
                })
                .collect()
        });
        progress(&rig, &rig_outcomes);
        outcomes.extend(rig_outcomes);
    }
    Ok(outcomes)
}

/// How far an undrawn chain moved relative to where it attaches: the largest change, between
/// `start` and `solved`, of its joints' positions in the frame of its first joint, as a
/// fraction of `height`. Zero when the limb kept its start pose.
pub fn limb_motion(
    skeleton: &Skeleton,
    start: &Pose,
    solved: &Pose,
    chain: &[usize],
    height: f64,
) -> f64 {
    let ws = skeleton.world_matrices(start);
    let wr = skeleton.world_matrices(solved);
    let anchor = chain[0];
    let (Some(is), Some(ir)) = (ws[anchor].try_inverse(), wr[anchor].try_inverse()) else {
        return f64::INFINITY;
    };
    // Distances measured in the start frame's units.
    let scale = ws[anchor].fixed_view::<3, 3>(0, 0).column(0).norm();
    chain[1..]
        .iter()
        .map(|&j| {
            let p = |w: &rigfit_core::math::Matrix4| Point3::new(w[(0, 3)], w[(1, 3)], w[(2, 3)]);
            let a = rigfit_core::math::transform_point(&is, &p(&ws[j]));
            let b = rigfit_core::math::transform_point(&ir, &p(&wr[j]));
            (a - b).norm() * scale
        })
        .fold(0.0, f64::max)
        / height
}
