//! The sweep's scenarios (which chains are drawn, how, and toward which poses) and the
//! deterministic generation of a scenario's case on a corpus rig.

use crate::targets::{FarPoseOptions, clip_pose, far_pose, mirror_pose};
use rand::SeedableRng;
use rand::rngs::StdRng;
use rigfit_core::pose::sketch::{
    Case, CaseOptions, Coverage, JointErrors, desktop_view, draw_case,
};
use rigfit_core::{Pose, Quat, Skeleton};

use crate::corpus::CorpusRig;
use crate::symmetry::{joint_model_excess, relabelled_error, twin_local_rotations};

/// How far from horizontal the view of a flattened case may tilt (radians).
const DESKTOP_ELEVATION: f64 = 0.35;

/// A way of drawing cases. Noise is a fraction of the height.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Scenario {
    /// Every chain at least 2% of the height (fingers, face, tails, helper bones), 1% noise,
    /// one stray stroke, one limb dropped; clip, far and mirrored targets in turn.
    EveryChain,
    /// The limbs (chains at least 10% of the height that carry skin weight), 1% noise;
    /// clip, far and mirrored targets in turn.
    LimbsOnly,
    /// Two or three limbs, 1% noise; clip, far and mirrored targets in turn, taken by the
    /// drawn limbs alone (the rest of the body keeps the start pose).
    FewLimbs,
    /// Every chain, 1% noise, each stroke flattened in depth as seen from a random
    /// horizontal-ish view (a desktop user drawing); clip, far and mirrored targets in turn.
    Flattened,
    /// The limbs, 2% noise, far random targets only.
    Far,
}

/// Where a case's true pose came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TargetKind {
    /// A random time of one of the rig's clips.
    Clip,
    /// A random pose far from the start ([`far_pose`]).
    Far,
    /// A random mirror-symmetric pose ([`mirror_pose`]).
    Mirror,
}

impl TargetKind {
    pub fn name(self) -> &'static str {
        match self {
            TargetKind::Clip => "clip",
            TargetKind::Far => "far",
            TargetKind::Mirror => "mirror",
        }
    }
}

impl Scenario {
    pub const ALL: [Scenario; 5] = [
        Scenario::EveryChain,
        Scenario::LimbsOnly,
        Scenario::FewLimbs,
        Scenario::Flattened,
        Scenario::Far,
    ];

    /// The scenario's name on the command line and in tables.
    pub fn name(self) -> &'static str {
        match self {
            Scenario::EveryChain => "every-chain",
            Scenario::LimbsOnly => "limbs-only",
            Scenario::FewLimbs => "few-limbs",
            Scenario::Flattened => "flattened",
            Scenario::Far => "far",
        }
    }

    /// The scenario named `name`.
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|s| s.name() == name)
    }

    /// The share of successful cases required on the held-out half. The issue sets
    /// every-chain (95%) and limbs-only (98%); the others are this harness's proposal.
    pub fn required_success(self) -> f64 {
        match self {
            Scenario::EveryChain => 0.95,
            Scenario::LimbsOnly => 0.98,
            Scenario::FewLimbs => 0.95,
            Scenario::Flattened => 0.90,
            Scenario::Far => 0.90,
        }
    }

    /// How the scenario draws its strokes (the view of a flattened case is set per case).
    pub fn case_options(self) -> CaseOptions {
        let every_chain = CaseOptions {
            coverage: Coverage::EveryChain,
            ..CaseOptions::default()
        };
        match self {
            Scenario::EveryChain => CaseOptions {
                drop_limbs: 1,
                stray_strokes: 1,
                ..every_chain
            },
            Scenario::LimbsOnly => CaseOptions::default(),
            Scenario::FewLimbs => CaseOptions {
                coverage: Coverage::FewLimbs,
                ..CaseOptions::default()
            },
            Scenario::Flattened => every_chain,
            Scenario::Far => CaseOptions {
                noise: 0.02,
                ..CaseOptions::default()
            },
        }
    }

    /// The kinds of target the scenario's cases take in turn (case `i` the `i % len`th).
    pub fn targets(self) -> &'static [TargetKind] {
        match self {
            Scenario::Far => &[TargetKind::Far],
            _ => &[TargetKind::Clip, TargetKind::Far, TargetKind::Mirror],
        }
    }
}

/// A generated case with the pose it was drawn from.
#[derive(Clone, Debug)]
pub struct GeneratedCase {
    /// The kind of target used: a clip falls back to a far pose when the rig has no clip
    /// that lasts, a mirrored pose when it has no left-right pairs.
    pub target: TargetKind,
    pub truth: Pose,
    pub case: Case,
    pub options: CaseOptions,
    /// The answer expected, as a relabelling of the truth's joints (joint `i` of the truth
    /// is expected at joint `labelling[i]` of the answer): the identity, or the truth's twin
    /// under one of the rig's symmetries when the twin lies nearer the start
    /// ([`expected_labelling`]).
    pub labelling: Vec<usize>,
}

impl GeneratedCase {
    /// How far `solved`'s drawn joints lie from the expected answer's on `rig`, as
    /// fractions of its height (the worst joint is `solved`'s).
    pub fn errors(&self, rig: &CorpusRig, solved: &Pose) -> JointErrors {
        self.errors_under(rig, solved, &self.labelling)
    }

    /// [`GeneratedCase::errors`] against the truth itself, whatever its twins.
    pub fn strict_errors(&self, rig: &CorpusRig, solved: &Pose) -> JointErrors {
        let identity: Vec<usize> = (0..self.labelling.len()).collect();
        self.errors_under(rig, solved, &identity)
    }

    /// Whether the expected answer is a twin of the truth rather than the truth.
    pub fn twinned(&self) -> bool {
        self.labelling.iter().enumerate().any(|(i, &j)| i != j)
    }

    fn errors_under(&self, rig: &CorpusRig, solved: &Pose, labelling: &[usize]) -> JointErrors {
        let skeleton = &rig.rig.skeleton;
        let (solved, truth) = (
            skeleton.joint_positions(solved),
            skeleton.joint_positions(&self.truth),
        );
        let joints = &self.case.drawn_joints;
        let mut errors = JointErrors {
            mean: 0.0,
            max: 0.0,
            worst: None,
        };
        for &i in joints {
            let d = (solved[labelling[i]] - truth[i]).norm() / rig.height;
            errors.mean += d / joints.len() as f64;
            if errors.worst.is_none() || d > errors.max {
                errors.max = d;
                errors.worst = Some(labelling[i]);
            }
        }
        errors
    }
}

/// The answer a case expects, as a relabelling of the truth's joints (see
/// [`GeneratedCase::labelling`]). A rig that a turn maps onto itself with its joints
/// relabelled (a box character turned half round, its left and right limbs swapped) draws
/// the same strokes in a pose and in that pose's twin, and the solver is given the same
/// start. When the twin also keeps within the solver's joint model as well as the truth
/// does (a rig's clips may let its right arm swing further than its left), nothing the
/// solver is given tells the two apart. Of such twins and the truth, the posing tool
/// should give the one that keeps the body where it stood (what an animator drawing on the
/// rig expects): the case expects whichever has its drawn joints nearest their places in
/// the start pose (the truth on a tie). Which one is decided before the solve, never by
/// the answer.
pub fn expected_labelling(rig: &CorpusRig, truth: &Pose, drawn: &[usize]) -> Vec<usize> {
    let skeleton = &rig.rig.skeleton;
    let solver = rig.solver_skeleton();
    // Only the drawn joints' rotations are the strokes' to say (the solver keeps the rest
    // at the start); a twin draws with the images of the truth's.
    let excess = |p: &[usize]| {
        let local = twin_local_rotations(skeleton, &rig.start, truth, p);
        joint_model_excess(solver, &local, drawn.iter().map(|&i| p[i]))
    };
    let (start, truth_at) = (
        skeleton.joint_positions(&rig.start),
        skeleton.joint_positions(truth),
    );
    let identity: Vec<usize> = (0..skeleton.len()).collect();
    let truth_local: Vec<Quat> = truth.local.iter().map(|t| t.rotation).collect();
    let truth_excess = joint_model_excess(solver, &truth_local, drawn.iter().copied());
    rig.symmetries
        .iter()
        .filter(|p| p.as_slice() == identity.as_slice() || excess(p) <= truth_excess + TWIN_EXCESS)
        .map(|p| (relabelled_error(&start, &truth_at, drawn, p, rig.height), p))
        .min_by(|a, b| a.0.total_cmp(&b.0))
        .map_or(identity.clone(), |(_, p)| p.clone())
}

/// A twin keeps within the joint model as well as the truth when its summed squared excess
/// is at most this much more (radians squared: about a degree in all).
const TWIN_EXCESS: f64 = 3e-4;

/// The seed of case `index` of `scenario` on rig `rig_id` (FNV-1a of the three, stable
/// across runs, platforms and Rust versions).
pub fn case_seed(rig_id: &str, scenario: Scenario, index: usize) -> u64 {
    let mut hash: u64 = 0xcbf2_9ce4_8422_2325;
    let bytes = rig_id
        .bytes()
        .chain([0])
        .chain(scenario.name().bytes())
        .chain([0])
        .chain((index as u64).to_le_bytes());
    for b in bytes {
        hash ^= u64::from(b);
        hash = hash.wrapping_mul(0x0100_0000_01b3);
    }
    hash
}

/// Case `index` of `scenario` on `rig`: the same for the same three every time.
pub fn generate_case(rig: &CorpusRig, scenario: Scenario, index: usize) -> GeneratedCase {
    let mut rng = StdRng::seed_from_u64(case_seed(&rig.entry.id, scenario, index));
    let skeleton = &rig.rig.skeleton;
    let animations = &rig.rig.animations;
    let far = FarPoseOptions {
        up: rig.up,
        ..FarPoseOptions::default()
    };
    let targets = scenario.targets();
    let planned = targets[index % targets.len()];
    let chosen = match planned {
        TargetKind::Clip => {
            clip_pose(animations, &rig.start, &mut rng).map(|p| (TargetKind::Clip, p))
        }
        TargetKind::Mirror => {
            mirror_pose(skeleton, &rig.start, animations, rig.height, &far, &mut rng)
                .map(|p| (TargetKind::Mirror, p))
        }
        TargetKind::Far => None,
    };
    let (target, truth) = chosen.unwrap_or_else(|| {
        let pose = far_pose(skeleton, &rig.start, animations, rig.height, &far, &mut rng);
        (TargetKind::Far, pose)
    });
    let mut options = scenario.case_options();
    if scenario == Scenario::Flattened {
        options.flatten = Some(desktop_view(&rig.up, DESKTOP_ELEVATION, &mut rng));
    }
    let mut draw_rng = rng.clone();
    let mut case = draw_case(
        skeleton,
        &rig.deforming,
        &truth,
        rig.height,
        &options,
        &mut rng,
    );
    let mut truth = truth;
    if scenario == Scenario::FewLimbs {
        // An animator re-posing two or three limbs: those limbs take the target, the rest
        // of the body keeps the start pose (as the solver keeps undrawn limbs), so the
        // strokes say all there is to recover. Drawn again with the same random numbers:
        // the same chains, now through the limbs on the standing body.
        truth = only_drawn_limbs_moved(skeleton, &rig.start, &truth, &case.stroke_chains);
        case = draw_case(
            skeleton,
            &rig.deforming,
            &truth,
            rig.height,
            &options,
            &mut draw_rng,
        );
    }
    let labelling = expected_labelling(rig, &truth, &case.drawn_joints);
    GeneratedCase {
        target,
        truth,
        case,
        options,
        labelling,
    }
}

/// `start` with the joints that turn the drawn chains' bones, and everything below them,
/// taken from `target`: each chain's first joint (where it attaches) and the joints above
/// it keep their start transform.
fn only_drawn_limbs_moved(
    skeleton: &Skeleton,
    start: &Pose,
    target: &Pose,
    chains: &[Vec<usize>],
) -> Pose {
    let mut moved = vec![false; skeleton.len()];
    for chain in chains {
        // A stroke may run either way along its chain: its end nearest the root attaches.
        let Some(attach) = chain
            .iter()
            .copied()
            .find(|&j| chain.iter().all(|&k| skeleton.is_ancestor_or_self(j, k)))
        else {
            continue;
        };
        for &j in chain.iter().filter(|&&j| j != attach) {
            moved[j] = true;
        }
    }
    let mut pose = start.clone();
    for j in 0..skeleton.len() {
        let below_moved = skeleton.joint(j).parent.is_some_and(|p| moved[p]);
        if moved[j] || below_moved {
            moved[j] = true;
            pose.local[j] = target.local[j];
        }
    }
    pose
}
