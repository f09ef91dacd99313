//! Tracking one frame: the start pose predicted from the last frame's motion, then EM
//! (eq. 17) with `sigma` annealed from `sigma_0` to the noise level, each M-step pulling
//! the model points toward their targets (eq. 20).

use super::m_step::Pull;
use super::{FrameFit, TextureSource, TrackError, Tracker, check_cloud};
use crate::engine::fitting_loop::{
    EmModel, Expectation, Maximisation, Schedule, Stage, Widths, continued_trs, run_em,
};
use crate::engine::voxel_subsample;
use crate::engine::{WeightedPoints, candidate_radius, em_step, em_step_with};
use crate::kinematics::ForwardKinematics;
use crate::math::Point3;
use crate::skeleton::Pose;

/// A point standing for a voxel's points.
#[derive(Clone, Copy, Debug)]
struct Representative {
    /// The point's index (texture or data).
    index: usize,
    /// How many points it stands for.
    count: u32,
}

impl Representative {
    /// A point standing for itself alone.
    fn single(index: usize) -> Self {
        Self { index, count: 1 }
    }
}

/// [`voxel_subsample`]'s representatives of `points`, their indices mapped by `index`.
fn voxel_representatives(
    points: &[Point3],
    voxel: f64,
    index: impl Fn(usize) -> usize,
) -> Vec<Representative> {
    voxel_subsample(points, voxel)
        .into_iter()
        .map(|(k, count)| Representative {
            index: index(k),
            count,
        })
        .collect()
}

/// EM at the noise level stops when no joint moved more than this (fraction of height).
const CONVERGED_MOTION: f64 = 1e-3;

/// A datum is an inlier when its posterior of belonging to the model (eq. 17 summed over
/// the model points) is at least this: the model's kernel sum there is at least `c / 9`
/// (about one texture point within 1.3 sigma). Texture points are sparse next to sigma, so
/// one half would call most of the surface's data outliers.
const INLIER_POSTERIOR: f64 = 0.1;

/// Coarse-to-fine: above the noise level, points are merged into cubes this many `sigma`
/// wide (a representative weighted by its count), so a Gaussian of width `sigma` still
/// sees a few of them, and the work per level shrinks as `sigma` grows.
const VOXEL_SIGMAS: f64 = 1.0;

/// A texture point with at least this EM weight at the noise level counts as seen.
const SEEN_WEIGHT: f64 = 1e-3;

impl Tracker {
    /// Aligns the model to one frame's points, starting from the previous frame's pose.
    pub fn track(&mut self, data: &[Point3]) -> Result<FrameFit, TrackError> {
        check_cloud(data)?;
        let h = self.model.height;
        let before = self.pose.clone();
        if self.options.prediction > 0.0
            && let Some(previous) = &self.previous
        {
            self.pose = extrapolate(previous, &self.pose, self.options.prediction);
        }
        let start = self.pose.clone();
        let sigma0 = self.options.max_motion * h;
        let sigma_min = (self.options.noise * h).min(sigma0);
        let steps = self.options.anneal_steps.max(1);
        let kappa = (sigma_min / sigma0).powf(1.0 / steps as f64);
        let fk = ForwardKinematics::new(&self.model.skeleton, &self.pose);
        let all: Vec<usize> = (0..self.texture.len()).collect();
        if self.options.visible_only && self.seen.len() != self.texture.len() {
            // No view yet: the texture points with data near them from the start pose.
            self.update_seen(data, &fk, 3.0 * sigma_min);
        }
        let seen: Vec<usize> = if self.options.visible_only {
            all.iter().copied().filter(|&i| self.seen[i]).collect()
        } else {
            all.clone()
        };
        let schedule = Schedule {
            widths: Widths::Geometric {
                start: sigma0,
                ratio: kappa,
                steps,
            },
            rounds: self.options.em_iterations,
            final_rounds: self.options.final_em_iterations,
            tolerance: Some(CONVERGED_MOTION * h),
        };
        let mut frame = FrameEm {
            tracker: self,
            data,
            start,
            fk,
            all,
            seen,
            world: Vec::new(),
            model_reps: Vec::new(),
            coarse_points: None,
            model_weight: None,
            data_weight: None,
            found_at: None,
            finds: 0,
            timing: [0.0; 3],
            pulls: Vec::new(),
        };
        let Ok(report) = run_em(&mut frame, &schedule);
        let FrameEm {
            start,
            mut fk,
            finds,
            timing,
            ..
        } = frame;
        let iterations = report.iterations;
        tracing::trace!(
            "{iterations} EM iterations, {finds} neighbour searches: {:.2} ms searching, {:.2} ms E-steps, {:.2} ms M-steps",
            timing[0] * 1e3,
            timing[1] * 1e3,
            timing[2] * 1e3
        );
        // The final E-step ran over every texture point at full resolution: which of them
        // the data supports is the view for the next frame.
        self.seen.clear();
        self.seen
            .extend(self.em.lambda.iter().map(|&l| l > SEEN_WEIGHT));
        // The final E-step's posteriors say which data points are inliers.
        let inlier: Vec<bool> = self
            .em
            .inlier
            .iter()
            .map(|&a| a >= INLIER_POSTERIOR)
            .collect();
        let best = self.em.best.clone();
        if self.options.surface_fit_steps > 0 {
            self.surface_fit(data, &inlier, &best, sigma_min, &start);
            fk.update(&self.model.skeleton, &self.pose);
        }
        if self.options.texture == TextureSource::RefreshFromData {
            self.refresh_texture(data, &inlier, &best, &fk);
        }
        self.previous = Some(before);
        let inliers = inlier.iter().filter(|&&b| b).count();
        Ok(FrameFit {
            pose: self.pose.clone(),
            inliers,
            inlier,
            em_iterations: iterations,
        })
    }

    /// Marks the texture points with data within a few `sigma` in the pose of `fk`.
    fn update_seen(&mut self, data: &[Point3], fk: &ForwardKinematics, sigma: f64) {
        let world: Vec<Point3> = self.texture.iter().map(|t| t.world(fk)).collect();
        em_step(
            WeightedPoints::unit(data),
            WeightedPoints::unit(&world),
            sigma,
            self.options.outlier_constant,
            &mut self.grid,
            &mut self.em,
        );
        self.seen.clear();
        self.seen
            .extend(self.em.lambda.iter().map(|&l| l > SEEN_WEIGHT));
    }
}

/// One frame's EM as a model of the engine's fitting loop: each level's representatives,
/// the E-step of eq. (17) over them, the M-step pulling texture points to eq. (20)'s targets.
struct FrameEm<'t, 'd> {
    tracker: &'t mut Tracker,
    data: &'d [Point3],
    /// The pose the frame started from (the fit's prior).
    start: Pose,
    fk: ForwardKinematics,
    /// Every texture point, and those the data supported at the end of the last frame.
    all: Vec<usize>,
    seen: Vec<usize>,
    /// The representatives' world positions at the current pose.
    world: Vec<Point3>,
    model_reps: Vec<Representative>,
    /// Coarse levels: the data's representatives, and both sides' counts.
    coarse_points: Option<Vec<Point3>>,
    model_weight: Option<Vec<f64>>,
    data_weight: Option<Vec<f64>>,
    /// Where the representatives were when their neighbours were last found.
    found_at: Option<Vec<Point3>>,
    finds: usize,
    /// Seconds searching, in E-steps and in M-steps.
    timing: [f64; 3],
    /// The M-step's pulls, kept between steps.
    pulls: Vec<Pull>,
}

impl EmModel for FrameEm<'_, '_> {
    type Error = std::convert::Infallible;

    fn begin_level(&mut self, stage: &Stage) -> Result<(), Self::Error> {
        let tracker = &*self.tracker;
        let sigma = stage.sigma;
        let last = stage.last_level;
        let active = if last || self.seen.len() < self.all.len() / 10 {
            &self.all
        } else {
            &self.seen
        };
        let voxel = VOXEL_SIGMAS * sigma;
        let coarse = tracker.options.coarse_to_fine && !last && voxel > 1.5 * tracker.spacing;
        // Representatives at this level: of texture points and of data points.
        let (model_reps, data_reps): (Vec<Representative>, Vec<Representative>) = if coarse {
            self.world.clear();
            self.world
                .extend(active.iter().map(|&i| tracker.texture[i].world(&self.fk)));
            let reps = voxel_representatives(&self.world, voxel, |k| active[k]);
            (reps, voxel_representatives(self.data, voxel, |j| j))
        } else {
            (
                active.iter().map(|&i| Representative::single(i)).collect(),
                Vec::new(),
            )
        };
        self.model_weight = coarse.then(|| model_reps.iter().map(|r| r.count as f64).collect());
        self.coarse_points = coarse.then(|| data_reps.iter().map(|r| self.data[r.index]).collect());
        self.data_weight = coarse.then(|| data_reps.iter().map(|r| r.count as f64).collect());
        self.model_reps = model_reps;
        // Neighbours found once per level, with a margin for the motion within it.
        self.found_at = None;
        Ok(())
    }

    fn e_step(&mut self, stage: &Stage) -> Result<Expectation, Self::Error> {
        let sigma = stage.sigma;
        let tracker = &mut *self.tracker;
        self.world.clear();
        self.world.extend(
            self.model_reps
                .iter()
                .map(|r| tracker.texture[r.index].world(&self.fk)),
        );
        let level_data = self.coarse_points.as_deref().unwrap_or(self.data);
        let data = WeightedPoints {
            points: level_data,
            weights: self.data_weight.as_deref(),
        };
        let model = WeightedPoints {
            points: &self.world,
            weights: self.model_weight.as_deref(),
        };
        let c = tracker.options.outlier_constant;
        let t0 = std::time::Instant::now();
        // A level of one E-step (above the noise level, one EM iteration) reads each point's
        // neighbours from the grid as it goes; a level of several finds them once, with a
        // margin for the motion, and searches again only when a model point moved farther.
        let reused = stage.last_level || tracker.options.em_iterations > 1;
        if !reused {
            em_step(data, model, sigma, c, &mut tracker.grid, &mut tracker.em);
            self.timing[1] += t0.elapsed().as_secs_f64();
            return Ok(Expectation::Ready);
        }
        let margin = 0.5 * sigma;
        let stale = self.found_at.as_ref().is_none_or(|at| {
            at.iter()
                .zip(&self.world)
                .any(|(a, b)| (a - b).norm_squared() > margin * margin)
        });
        if stale {
            tracker.candidates.find(
                level_data,
                &self.world,
                candidate_radius(sigma, margin),
                &mut tracker.grid,
            );
            self.found_at = Some(self.world.clone());
            self.finds += 1;
            tracing::trace!(
                "level {} sigma {:.4}: {} data, {} model, {} candidates",
                stage.level,
                sigma / tracker.model.height,
                level_data.len(),
                self.world.len(),
                tracker.candidates.len()
            );
        }
        let t1 = std::time::Instant::now();
        em_step_with(data, model, sigma, c, &tracker.candidates, &mut tracker.em);
        self.timing[0] += (t1 - t0).as_secs_f64();
        self.timing[1] += t1.elapsed().as_secs_f64();
        Ok(Expectation::Ready)
    }

    fn m_step(&mut self, stage: &Stage) -> Result<Maximisation, Self::Error> {
        let t1 = std::time::Instant::now();
        let tracker = &mut *self.tracker;
        let (world, fk) = (&self.world, &self.fk);
        // Eq. (20): each model point pulled to G_i with weight lambda_i.
        let mut pulls = std::mem::take(&mut self.pulls);
        pulls.clear();
        pulls.extend(
            self.model_reps
                .iter()
                .enumerate()
                .filter(|(k, _)| tracker.em.lambda[*k] > 1e-9)
                .map(|(k, r)| {
                    let point = tracker.texture[r.index];
                    let mut target = tracker.em.target[k];
                    if tracker.options.point_to_plane && tracker.model.surface_normals.is_some() {
                        // The normal part of the pull (the point-to-plane gradient, free of the
                        // tangential bias of blurred centroids) and a share of the rest, which
                        // keeps a limb from sliding along or turning about itself.
                        let x = world[k];
                        let n = point.world_normal(fk);
                        let pull = target - x;
                        let normal = n * n.dot(&pull);
                        target = x + normal + (pull - normal) * tracker.options.tangential;
                    }
                    Pull {
                        point,
                        target,
                        weight: tracker.em.lambda[k],
                    }
                }),
        );
        let t2 = std::time::Instant::now();
        let before = self.fk.clone();
        tracker.fit(
            &pulls,
            &self.start,
            tracker.options.gauss_newton_steps,
            stage.last_level,
            tracker.options.over_relaxation,
        );
        self.pulls = pulls;
        self.fk.update(&tracker.model.skeleton, &tracker.pose);
        self.timing[1] += (t2 - t1).as_secs_f64();
        self.timing[2] += t2.elapsed().as_secs_f64();
        // At the noise level, EM runs until the joints stop moving.
        let moved = (0..self.fk.len())
            .map(|j| (self.fk.origin(j) - before.origin(j)).norm())
            .fold(0.0, f64::max);
        Ok(Maximisation::moved(moved))
    }
}

/// Prediction: `current` moved on by `gain` times the motion from `previous`.
fn extrapolate(previous: &Pose, current: &Pose, gain: f64) -> Pose {
    let mut next = current.clone();
    for ((n, p), c) in next
        .local
        .iter_mut()
        .zip(&previous.local)
        .zip(&current.local)
    {
        (n.translation, n.rotation) = continued_trs(p, c, gain);
    }
    next
}
