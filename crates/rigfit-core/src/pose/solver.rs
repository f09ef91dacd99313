//! One solve from start to end: the rigid multi-start gives hypotheses; the chain step fits
//! each (assign chains, fit by arclength, set strays aside, re-assign until stable); local
//! moves improve the best; a restricted softassign polishes the winner. Without the chain
//! step, the paper's annealing over all bones. The hypotheses are fitted, and the best
//! improved, in parallel (rayon), each by a worker of its own ([`Solver::worker`]): the
//! results do not depend on the number of threads.

use super::annealing::{anneal, bones_by_weight, energy, schedule, settle};
use super::assignment::assign;
use super::candidates::{Candidates, STRAY_COST, candidates};
use super::chains::{Assignment, stroke_length, stroke_residuals};
use super::fitting::{FULL_FIT_STEPS, Fitter};
use super::local_moves::improve;
use super::mirror_image::bone_mirrors;
use super::multi_start::{placements, placements_and_turns};
use super::score::HYPOTHESIS_BEND_WEIGHT;
use super::setup::Setup;
use super::{PoseError, PoseResult};
use crate::kinematics::DofLayout;
use crate::skeleton::Pose;
use rayon::prelude::*;
use std::sync::Arc;

/// The whole character is placed on the strokes (rigid multi-start) only when they are at
/// least this long against its bones together (measured on the tuning half: 0.3 against 0,
/// 0.15 and 0.45).
const PLACED_BODY_SHARE: f64 = 0.3;

/// Levenberg-Marquardt steps within the joints' limits at the end of every full fit, and the
/// weight of the squared excess (radians) there (measured on the tuning half: 3 steps at
/// 1e-3 against 2 and 5 steps, and 3e-4, 3e-3, 1e-2, 0.1; fitting the limits from the start
/// blocks limbs that must swing far, see BENCHMARKS.md).
const LIMIT_TAIL_STEPS: usize = 3;
const LIMIT_TAIL_WEIGHT: f64 = 1e-3;

/// The longest chain of bones one stroke may cover.
const MAX_CHAIN_BONES: usize = 24;

/// The most trial assignments the local moves fit in one solve (the real rigs of the
/// accuracy suite use at most about 110; a thousand cluttered strokes would use tens of
/// thousands): shared evenly by the hypotheses improved, what they leave to the mirror
/// image.
const MAX_LOCAL_SEARCH_TRIALS: usize = 1_000;

/// Hypotheses (of the best-explained ones) that the local moves improve (measured on the
/// tuning half over every scenario: 3 against 2 gained 13 cases and lost 3, at about a
/// tenth more time; 4 gained no more; BENCHMARKS.md).
const IMPROVED_HYPOTHESES: usize = 3;

/// A fit from the character where it stands is convincing (the rigid placements and turns
/// are not searched) when every stroke it covers lies within this RMS distance of its chain
/// (heights; strokes are drawn with about 1% noise), ...
const CONVINCING_RESIDUAL: f64 = 0.02;
/// ... at most this many strokes are set aside, ...
const CONVINCING_SET_ASIDE: usize = 1;
/// ... and its preference costs at most that of this mean bend of the joints that move
/// (radians). Measured on the tuning half with the bend weight at 5e-4: 0.25 lost no case
/// against searching every start, 0.4 lost two every-chain cases, and without a bound
/// limbs-only lost 28 of 432 (bodies turned about with their limbs traded).
const CONVINCING_MEAN_BEND: f64 = 0.25;

/// Rounds of the chain step (re-assignments and strays set aside).
const CHAIN_STEP_ROUNDS: usize = 8;

/// A fitted hypothesis: its score, pose, assignment and the layout of joints that move.
#[derive(Clone)]
pub(super) struct ChainFit {
    pub score: f64,
    pub pose: Pose,
    pub assignment: Vec<Assignment>,
    pub layout: DofLayout,
    /// Whether its strokes were matched to chains by shape (or by distance).
    pub by_shape: bool,
}

/// A solve in progress.
pub(super) struct Solver<'a> {
    pub setup: Arc<Setup<'a>>,
    pub fitter: Fitter,
    /// Every chain of bones a stroke may cover.
    pub chains: Arc<Vec<Vec<usize>>>,
    /// Trial assignments the local moves may still fit (bounds their cost on many strokes).
    pub trials_left: usize,
    /// Strokes are matched to chains by shape (or by distance at the current pose).
    pub by_shape: bool,
    /// Each bone's mirror image, when the skeleton names its left and right joints.
    pub bone_mirrors: Option<Vec<Option<usize>>>,
    /// The candidates of every stroke among all chains (by shape, those costing at most a
    /// stray) last ranked by [`Solver::ranked_now`], with the pose and the matching they
    /// were ranked at: a chain step whose stray sends the pose back to its start, and the
    /// local moves at a pose no move changed, do not rank again.
    pub ranked_at: std::cell::RefCell<Option<(Pose, bool, Candidates)>>,
    /// The score of the last trial the local moves judged, after its judging fit.
    pub last_judged: f64,
}

impl<'a> Solver<'a> {
    pub fn new(setup: Setup<'a>) -> Self {
        let fitter = Fitter::new(setup.start.clone(), setup.options.prior_weight);
        let chains = if setup.options.chain_assignment {
            setup.model.chains(MAX_CHAIN_BONES)
        } else {
            Vec::new()
        };
        let bone_mirrors = bone_mirrors(setup.skeleton, &setup.model);
        Self {
            bone_mirrors,
            setup: Arc::new(setup),
            fitter,
            chains: Arc::new(chains),
            trials_left: MAX_LOCAL_SEARCH_TRIALS,
            by_shape: false,
            ranked_at: Default::default(),
            last_judged: f64::INFINITY,
        }
    }

    pub fn run(mut self) -> Result<PoseResult, PoseError> {
        let opts = self.setup.options;
        let setup = &self.setup;
        // Markers are placed by their strokes alone. Strokes covering little of the body (a
        // hand's fingers) say nothing of where the whole body is: it stays where it stands.
        let placed_root = match (opts.rigid_init, setup.root) {
            (true, Some(root))
                if !setup.model.is_markers() && self.drawn_share() >= PLACED_BODY_SHARE =>
            {
                Some(root)
            }
            _ => None,
        };
        let joints = setup.skeleton.len();
        let mut starts: Vec<Pose> = std::iter::once(setup.start.clone())
            .chain(
                opts.extra_starts
                    .iter()
                    .filter(|p| p.local.len() == joints)
                    .cloned(),
            )
            .collect();
        let all = setup.layout(&setup.movable);
        let sigmas = schedule(
            setup.height,
            opts.sigma_start,
            opts.sigma_end,
            opts.anneal_steps,
            opts.additive_beta,
        );
        let last = *sigmas.last().unwrap_or(&opts.sigma_end);
        if !opts.chain_assignment {
            if let Some(root) = placed_root {
                starts = placements(setup, root);
            }
            self.fitter.pose = starts.into_iter().next().expect("at least one start");
            anneal(&self.setup, &mut self.fitter, &all, &sigmas, None);
            let matches = settle(&self.setup, &mut self.fitter, &all, last, None);
            return Ok(self.result(bones_by_weight(&self.setup, &matches), &matches));
        }
        // Every hypothesis goes through the whole chain step; the ones whose strokes are
        // best explained are improved by local moves, and the best wins.
        // Each start is fitted with strokes matched by distance and, with shape matching,
        // by shape too: distance knows best where a limb near its stroke is, shape finds a
        // limb drawn far from where it is.
        let modes: &[bool] = if opts.shape_matching {
            &[true, false]
        } else {
            &[false]
        };
        let mut fits: Vec<ChainFit> = Vec::new();
        self.fit_hypotheses(&starts, modes, &all, &sigmas, &mut fits);
        // The character where it stands first: when it explains the strokes convincingly,
        // the body is where it stood and the rigid placements and turns are not searched.
        if let Some(root) = placed_root
            && (opts.search_every_start || !fits.iter().any(|f| self.convincing(f)))
        {
            // The character placed on the strokes, and turned where it stands (its limbs
            // far from their strokes: matched by shape alone).
            let (mut placements, turned) = placements_and_turns(&self.setup, root);
            // In the order placements, the start, turns: ties go to the earlier.
            let fitted_at_start = std::mem::take(&mut fits);
            self.fit_hypotheses(&placements, modes, &all, &sigmas, &mut fits);
            fits.extend(fitted_at_start);
            self.fit_hypotheses(&turned, &[opts.shape_matching], &all, &sigmas, &mut fits);
            placements.append(&mut starts);
            starts = placements;
        }
        fits.sort_by(|a, b| a.score.total_cmp(&b.score));
        // Hypotheses that converged to the same assignment are one.
        fits.dedup_by(|a, b| a.assignment == b.assignment);
        let cutoff = fits.first().map_or(0.0, |f| 2.0 * f.score);
        // The best-explained hypotheses are improved in parallel, each by its own fitter
        // (from the first step's damping) with an even share of the trials left.
        let kept: Vec<ChainFit> = fits
            .into_iter()
            .filter(|f| f.score <= cutoff)
            .take(IMPROVED_HYPOTHESES)
            .collect();
        let share = self.trials_left / kept.len().max(1);
        let workers: Vec<(ChainFit, Solver)> = kept
            .into_iter()
            .map(|fit| {
                let mut worker = self.worker(fit.pose.clone(), fit.by_shape);
                worker.trials_left = share;
                (fit, worker)
            })
            .collect();
        let improved: Vec<(ChainFit, Solver)> = workers
            .into_par_iter()
            .map(|(fit, mut worker)| (improve(&mut worker, fit), worker))
            .collect();
        let mut best: Option<ChainFit> = None;
        for (fit, worker) in improved {
            self.trials_left -= share - worker.trials_left;
            self.fitter.iterations += worker.fitter.iterations;
            if best.as_ref().is_none_or(|b| fit.score < b.score) {
                best = Some(fit);
            }
        }
        // Only when interrupted before the first hypothesis was fitted.
        let best = best.ok_or(PoseError::Interrupted)?;
        let best = self.try_mirror_image(best, &starts);
        self.fitter.pose = best.pose;
        let allowed_bones: Vec<Option<Vec<bool>>> = best
            .assignment
            .iter()
            .map(|c| {
                // A bone whose tip translates has its weight at its ends: nearest-point
                // matching would pull its tip into the stroke; its arclength fit stands.
                let bones = &self.setup.model.bones;
                let mut a = vec![false; bones.len()];
                c.iter()
                    .flat_map(|c| &c.0)
                    .for_each(|&b| a[b] = !bones[b].tip_translates);
                Some(a)
            })
            .collect();
        // With every stroke's chain known, the start-pose prior has done its job (keeping
        // twists and choosing among mirror images); the polish lets short bones follow
        // their strokes.
        self.fitter.prior_weight = opts.prior_weight * 0.05;
        // Joints that translate keep where the arclength fit put them (the polish matches
        // only bones that turn, and the prior alone would pull them back).
        let mut polished: Vec<bool> = (0..self.setup.skeleton.len())
            .map(|j| best.layout.offset(j).is_some())
            .collect();
        for bone in self.setup.model.bones.iter().filter(|b| b.tip_translates) {
            polished[bone.child] = false;
        }
        let polish_layout = self.setup.layout(&polished);
        let matches = settle(
            &self.setup,
            &mut self.fitter,
            &polish_layout,
            last,
            Some(&allowed_bones),
        );
        let stroke_bones = best
            .assignment
            .iter()
            .map(|c| match c {
                Some((chain, reversed)) => {
                    let mut joints: Vec<usize> = chain
                        .iter()
                        .map(|&b| self.setup.model.bones[b].joint)
                        .collect();
                    if *reversed {
                        joints.reverse();
                    }
                    joints
                }
                None => Vec::new(),
            })
            .collect();
        Ok(self.result(stroke_bones, &matches))
    }

    /// Fits every start in every matching mode through the chain step into `fits`, in that
    /// order. Each hypothesis is fitted from its start alone (its own fitter, with the first
    /// step's damping), so they run in parallel with the same results as one after another.
    fn fit_hypotheses(
        &mut self,
        starts: &[Pose],
        modes: &[bool],
        all: &DofLayout,
        sigmas: &[f64],
        fits: &mut Vec<ChainFit>,
    ) {
        let workers: Vec<Solver> = starts
            .iter()
            .flat_map(|start| modes.iter().map(move |&by_shape| (start, by_shape)))
            .map(|(start, by_shape)| self.worker(start.clone(), by_shape))
            .collect();
        let fitted: Vec<Option<(ChainFit, Fitter)>> = workers
            .into_par_iter()
            .map(|mut worker| {
                if worker.setup.interrupt.is_set() {
                    return None;
                }
                if worker.setup.options.anneal_before_chains {
                    anneal(&worker.setup, &mut worker.fitter, all, sigmas, None);
                }
                let fit = worker.chain_step(None);
                Some((fit, worker.fitter))
            })
            .collect();
        for (fit, fitter) in fitted.into_iter().flatten() {
            // The solve goes on from the last hypothesis's fitter state (its damping), as
            // it would after fitting them one after another.
            self.fitter.continue_after(&fitter);
            self.by_shape = fit.by_shape;
            fits.push(fit);
        }
    }

    /// A solver of the same setup and chains (shared, not copied) fitting from `start` on
    /// its own (for work run in parallel): a fresh fitter, no trials, nothing ranked yet.
    fn worker(&self, start: Pose, by_shape: bool) -> Solver<'a> {
        Solver {
            setup: Arc::clone(&self.setup),
            fitter: Fitter::new(start, self.fitter.prior_weight),
            chains: Arc::clone(&self.chains),
            trials_left: 0,
            by_shape,
            bone_mirrors: self.bone_mirrors.clone(),
            ranked_at: Default::default(),
            last_judged: f64::INFINITY,
        }
    }

    /// Whether `fit`, from the character where it stands, explains the strokes so well
    /// that no other start need be searched: every stroke it covers within noise of its
    /// chain, at most one set aside, and the joints bent little on average (a body turned
    /// about with its limbs traded explains strokes as closely, bending them far).
    fn convincing(&self, fit: &ChainFit) -> bool {
        let residuals = stroke_residuals(&self.setup, &fit.pose, &fit.assignment);
        let aside = fit.assignment.iter().filter(|a| a.is_none()).count();
        let (_, preference) = self.score_parts(&fit.pose, &fit.assignment, &fit.layout);
        aside <= CONVINCING_SET_ASIDE
            && preference <= HYPOTHESIS_BEND_WEIGHT * CONVINCING_MEAN_BEND
            && fit
                .assignment
                .iter()
                .zip(&residuals)
                .all(|(a, &r)| a.is_none() || r <= CONVINCING_RESIDUAL)
    }

    fn result(
        &self,
        mut stroke_bones: Vec<Vec<usize>>,
        matches: &crate::engine::MatchMatrix,
    ) -> PoseResult {
        for b in &mut stroke_bones {
            b.dedup();
        }
        PoseResult {
            pose: self.fitter.pose.clone(),
            stroke_bones,
            iterations: self.fitter.iterations,
            energy: energy(&self.setup, &self.fitter, matches),
        }
    }

    /// The strokes' total length over the bones': how much of the body is drawn.
    fn drawn_share(&self) -> f64 {
        let setup = &self.setup;
        let drawn: f64 = (0..setup.strokes.count())
            .map(|s| stroke_length(setup, s))
            .sum();
        let body: f64 = setup.model.bones.iter().map(|b| b.length).sum();
        drawn / body.max(f64::MIN_POSITIVE)
    }

    /// The chain step from the fitter's pose: assign chains (or start from `seed`), fit by
    /// arclength, set strays aside (judged after the fit: a stroke its chain cannot
    /// follow), re-assign until stable.
    pub fn chain_step(&mut self, seed: Option<Vec<Assignment>>) -> ChainFit {
        let strokes = self.setup.strokes.count();
        let stray = self.setup.options.stray_distance;
        let initial = self.fitter.pose.clone();
        let (mut excluded, mut assignment) = match seed {
            Some(seed) => (seed.iter().map(Option::is_none).collect(), seed),
            None => {
                let excluded = vec![false; strokes];
                let assignment = self.assign_at_start(&excluded);
                (excluded, assignment)
            }
        };
        let mut layout = self.setup.layout(&self.setup.movable);
        let mut refitted = false;
        for _round in 0..CHAIN_STEP_ROUNDS {
            if self.setup.interrupt.is_set() {
                break;
            }
            layout = self
                .fitter
                .keep_unexplained_at_start(&self.setup, &assignment);
            self.fitter
                .fit_arclength(&self.setup, &layout, &assignment, FULL_FIT_STEPS);
            let again = self.assign_now(&excluded, Some(&assignment));
            if again != assignment {
                assignment = again;
                continue;
            }
            // The assignment is stable. A stroke that stays far from its fitted chain is a
            // stray: set it aside and start over without it.
            let residuals = stroke_residuals(&self.setup, &self.fitter.pose, &assignment);
            let worst = (0..strokes)
                .filter(|&s| assignment[s].is_some())
                .max_by(|&a, &b| residuals[a].total_cmp(&residuals[b]));
            match worst.filter(|&s| residuals[s] > stray) {
                // Matched by shape, a limb far from its stroke may need more than one fit to
                // get there: it gets one more before it is judged.
                Some(_) if self.by_shape && !refitted => refitted = true,
                Some(s) => {
                    refitted = false;
                    excluded[s] = true;
                    self.fitter.pose = initial.clone();
                    assignment = self.assign_at_start(&excluded);
                }
                None => break,
            }
        }
        self.limit_tail(&layout, &assignment);
        let score = self.score(&assignment, &layout);
        ChainFit {
            score,
            pose: self.fitter.pose.clone(),
            assignment,
            layout,
            by_shape: self.by_shape,
        }
    }

    /// The end of every full fit: a few steps within the joints' limits, so that a
    /// hypothesis is judged by a pose the rig can take wherever its strokes leave room.
    pub fn limit_tail(&mut self, layout: &DofLayout, assignment: &[Assignment]) {
        self.fitter.fit_within_limits(
            &self.setup,
            layout,
            assignment,
            LIMIT_TAIL_STEPS,
            LIMIT_TAIL_WEIGHT,
        );
    }

    /// The assignment of every stroke not `excluded` from the candidates at the current
    /// pose (`settled`: the one just fitted, kept when greedy agrees).
    fn assign_now(&self, excluded: &[bool], settled: Option<&[Assignment]>) -> Vec<Assignment> {
        let ranked = candidates(
            &self.setup,
            &self.fitter.pose,
            &self.chains,
            excluded,
            self.by_shape,
            STRAY_COST,
        );
        self.assign_ranked(&ranked, excluded, settled)
    }

    /// [`Solver::assign_now`] at a chain step's start pose, from every stroke's candidates
    /// there (an excluded stroke's are passed over): a stroke set aside sends the pose back,
    /// where [`Solver::ranked_now`] has them already.
    fn assign_at_start(&self, excluded: &[bool]) -> Vec<Assignment> {
        self.assign_ranked(&self.ranked_now(), excluded, None)
    }

    /// The assignment of every stroke not `excluded` from the candidates `ranked`.
    fn assign_ranked(
        &self,
        ranked: &Candidates,
        excluded: &[bool],
        settled: Option<&[Assignment]>,
    ) -> Vec<Assignment> {
        assign(
            &self.setup,
            &self.chains,
            ranked,
            &vec![None; excluded.len()],
            excluded,
            settled,
        )
    }
}
