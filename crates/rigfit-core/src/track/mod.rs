//! Articulated tracking in 3D point clouds (Dewaele et al. 2006): an articulated surface
//! model ([`parts`]: ellipsoids fused into one surface; [`texture`]: model points carried by
//! blends of adjacent parts' motions, eq. 3), aligned to each frame's points by EM with a
//! uniform outlier class ([`crate::engine::em`], eq. 17) and Gauss-Newton / Levenberg-
//! Marquardt on eq. (20), with `sigma` annealed geometrically; then a surface-fitting pass
//! (eq. 21-22). [`Tracker`] runs it frame after frame from the previous pose.
//!
//! [`TrackOptions::paper`] is the method as published; [`TrackOptions::default`] adds what
//! the accuracy table in BENCHMARKS.md measures: constant-velocity prediction, coarse-to-
//! fine correspondences at large `sigma`, and texture points kept on the model's own
//! surface instead of refreshed from the (noisy) data every frame.

pub mod cases;
pub mod parts;
pub mod texture;

use rand::SeedableRng;

use crate::engine::em::{
    Candidates, DEWAELE_OUTLIER_CONSTANT, EmStep, candidate_radius, em_step, em_step_with,
};
use crate::engine::point_grid::{PointGrid, voxel_subsample};
use crate::engine::{NormalSink, SkeletonNormalEquations, SubtreeMoments};
use crate::kinematics::{DofLayout, ForwardKinematics};
use crate::math::{Point3, Quat, Vector3, transform_point};
use crate::rig::Rig;
use crate::skeleton::{JointDof, Pose, Skeleton};
use parts::{PartModel, PlacedParts};
use texture::{TexturePoint, sample_triangles};

/// Where the texture points come from after each frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TextureSource {
    /// The paper: the data points fitted at the previous frame (inliers near the surface).
    RefreshFromData,
    /// The model's own surface samples, attached once (no drift from noisy data).
    ModelSurface,
}

/// Settings of the tracker. Lengths are fractions of the character's height.
#[derive(Clone, Debug)]
pub struct TrackOptions {
    /// `sigma_0`: the largest motion of a point expected between frames.
    pub max_motion: f64,
    /// `sigma` floor: the noise of the data.
    pub noise: f64,
    /// Annealing steps from `sigma_0` to the floor (geometric).
    pub anneal_steps: usize,
    /// EM iterations at each `sigma` above the floor, and at the floor.
    pub em_iterations: usize,
    pub final_em_iterations: usize,
    /// Gauss-Newton steps per M-step.
    pub gauss_newton_steps: usize,
    /// The outlier term `c` of eq. (17).
    pub outlier_constant: f64,
    /// The exponent `a` of eq. (3).
    pub bending_exponent: f64,
    /// Surface-fitting (eq. 21) Gauss-Newton steps after EM; 0 skips the pass.
    pub surface_fit_steps: usize,
    pub texture: TextureSource,
    /// Start each frame from the previous pose moved on by this fraction of the last
    /// frame's motion (0: from the previous pose, 1: constant velocity).
    pub prediction: f64,
    /// At large `sigma`, match voxel-grid representatives (weighted by their counts)
    /// instead of every point.
    pub coarse_to_fine: bool,
    /// Weight of the prior keeping joint rotations near the frame's start pose.
    pub prior_weight: f64,
    /// How many texture points the model has (0: from the surface's area).
    pub model_points: usize,
    /// Above the noise level, match only the texture points the data supported at the end
    /// of the previous frame (the side of the body the cameras see).
    pub visible_only: bool,
    /// Factor on each M-step's parameter step (1: plain EM).
    pub over_relaxation: f64,
    /// Pull texture points along their normals only (point-to-plane) in the M-step, when
    /// the model's normals come from a mesh (the fused ellipsoids' gradient is too crude).
    pub point_to_plane: bool,
}

impl TrackOptions {
    /// The method as published: texture points refreshed from the data, no prediction,
    /// every point matched at every `sigma`.
    pub fn paper() -> Self {
        Self {
            max_motion: 0.08,
            anneal_steps: 5,
            em_iterations: 2,
            final_em_iterations: 8,
            texture: TextureSource::RefreshFromData,
            prediction: 0.0,
            coarse_to_fine: false,
            visible_only: false,
            point_to_plane: false,
            over_relaxation: 1.0,
            ..Self::default()
        }
    }
}

impl Default for TrackOptions {
    fn default() -> Self {
        Self {
            max_motion: 0.04,
            noise: 0.01,
            anneal_steps: 4,
            em_iterations: 1,
            final_em_iterations: 6,
            gauss_newton_steps: 1,
            outlier_constant: DEWAELE_OUTLIER_CONSTANT,
            bending_exponent: 2.0,
            surface_fit_steps: 0,
            texture: TextureSource::ModelSurface,
            prediction: 0.5,
            coarse_to_fine: true,
            prior_weight: 0.02,
            model_points: 0,
            visible_only: true,
            point_to_plane: true,
            over_relaxation: 1.8,
        }
    }
}

/// Why a frame cannot be tracked.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum TrackError {
    #[error("the point cloud is empty")]
    EmptyCloud,
    #[error("point {index}: coordinate is not a finite number")]
    NonFinite { index: usize },
    #[error(
        "point {index}: a coordinate is beyond +-{:e}, out of range (a unit or export mistake)",
        crate::math::MAX_COORDINATE
    )]
    OutOfRange { index: usize },
    #[error("the rig has no volume to track: no mesh and no bones of any length")]
    NoParts,
    #[error("the rig has no joints that can move")]
    NothingMoves,
}

/// The articulated surface model of a rig.
#[derive(Clone, Debug)]
pub struct ArticulatedModel {
    pub skeleton: Skeleton,
    pub parts: PartModel,
    pub height: f64,
    /// The pose tracking starts from (the rig's stored pose).
    pub start: Pose,
    /// The pose the parts were fitted and the texture sampled in (the bind pose of a
    /// skinned character, else the stored pose).
    pub built: Pose,
    /// Points on the model's surface in the start pose (world), with their normals when
    /// known (else the fused surface's gradient is used).
    pub surface_samples: Vec<Point3>,
    pub surface_normals: Option<Vec<Vector3>>,
}

impl ArticulatedModel {
    /// The model of `rig` in its stored pose: ellipsoids fitted to the skinned mesh and
    /// `samples` texture points sampled on it, or, for a bare skeleton, ellipsoids sized from
    /// bone lengths and sampled on their fused surface. `samples == 0` picks the count from
    /// the surface's area (see [`texture_count`]).
    pub fn from_rig(rig: &Rig, samples: usize) -> Result<Self, TrackError> {
        let height = rig.height().max(1e-9);
        let has_mesh = rig
            .meshes
            .iter()
            .any(|m| !m.positions.is_empty() && !m.triangles.is_empty());
        let mut rng = rand::rngs::StdRng::seed_from_u64(0x7ac4);
        // A skinned character is modelled in its bind pose (limbs apart, as it was
        // modelled); a bare skeleton in its stored pose.
        let built = if has_mesh {
            bind_pose(rig)
        } else {
            rig.pose.clone()
        };
        let parts = if has_mesh {
            PartModel::fit_to_skin(&rig.skeleton, &built, &rig.meshes, height)
        } else {
            PartModel::from_bone_lengths(&rig.skeleton, &built, height)
        };
        if parts.parts.is_empty() {
            return Err(TrackError::NoParts);
        }
        let fk = ForwardKinematics::new(&rig.skeleton, &built);
        let (surface_samples, surface_normals) = if has_mesh {
            let world = rig.skeleton.world_matrices(&built);
            let mut vertices = Vec::new();
            let mut triangles = Vec::new();
            for mesh in &rig.meshes {
                let base = vertices.len() as u32;
                vertices.extend(mesh.skin(&world).0);
                triangles.extend(mesh.triangles.iter().map(|t| t.map(|i| i + base)));
            }
            let samples = texture_count(samples, &vertices, &triangles, height);
            let samples = sample_triangles(&vertices, &triangles, samples, &mut rng);
            let normals = samples
                .iter()
                .map(|&(_, t)| {
                    let [a, b, c] = triangles[t].map(|i| vertices[i as usize]);
                    (b - a).cross(&(c - a)).normalize()
                })
                .collect();
            (samples.into_iter().map(|(p, _)| p).collect(), Some(normals))
        } else {
            let mesh = parts.triangulate(&fk, 12, 16);
            let mut placed = PlacedParts::default();
            parts.place(&fk, &mut placed);
            let samples = texture_count(samples, &mesh.vertices, &mesh.triangles, height);
            let points = sample_triangles(&mesh.vertices, &mesh.triangles, samples * 2, &mut rng)
                .into_iter()
                .filter_map(|(p, _)| parts.project(&placed, &p, None))
                .filter(|p| {
                    parts
                        .surface_distance(&placed, p, None)
                        .is_some_and(|s| s.distance.abs() < 1e-3 * height)
                })
                .take(samples)
                .collect();
            (points, None)
        };
        Ok(Self {
            skeleton: rig.skeleton.clone(),
            parts,
            height,
            start: rig.pose.clone(),
            built,
            surface_samples,
            surface_normals,
        })
    }
}

/// What tracking one frame found.
#[derive(Clone, Debug)]
pub struct FrameFit {
    pub pose: Pose,
    /// Data points taken as inliers (see [`FrameFit::inlier`]).
    pub inliers: usize,
    /// Per data point, whether it was taken as an inlier: its posterior of belonging to the
    /// model, at the noise level, is at least 0.1.
    pub inlier: Vec<bool>,
    /// EM iterations run.
    pub em_iterations: usize,
}

/// A point standing for a voxel's points: (index, count).
type Representative = (usize, u32);

/// A point pulled toward a target with a weight.
#[derive(Clone, Copy, Debug)]
struct Pull {
    point: TexturePoint,
    target: Point3,
    weight: f64,
}

/// Tracks one model through a sequence of point clouds.
#[derive(Debug)]
pub struct Tracker {
    model: ArticulatedModel,
    options: TrackOptions,
    layout: DofLayout,
    pose: Pose,
    previous: Option<Pose>,
    texture: Vec<TexturePoint>,
    /// Typical spacing between texture points.
    spacing: f64,
    grid: PointGrid,
    candidates: Candidates,
    em: EmStep,
    moments: SubtreeMoments,
    normal: Option<SkeletonNormalEquations>,
    placed: PlacedParts,
    lambda: f64,
    /// Per texture point, whether data supported it at the end of the last frame.
    seen: Vec<bool>,
}

/// Texture points blended with weights in this range get their exact Jacobian (eq. 3);
/// outside it, the dominant joint's (an error of at most 5% in the other's columns).
const EXACT_BLEND_MIN: f64 = 0.05;
const EXACT_BLEND_MAX: f64 = 0.95;

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

    /// The texture points' world positions in the current pose.
    pub fn texture_positions(&self) -> Vec<Point3> {
        let fk = ForwardKinematics::new(&self.model.skeleton, &self.pose);
        self.texture.iter().map(|t| t.world(&fk)).collect()
    }

    /// Aligns the model to one frame's points, starting from the previous frame's pose.
    pub fn track(&mut self, data: &[Point3]) -> Result<FrameFit, TrackError> {
        if data.is_empty() {
            return Err(TrackError::EmptyCloud);
        }
        if let Some(index) = data.iter().position(|p| !p.iter().all(|c| c.is_finite())) {
            return Err(TrackError::NonFinite { index });
        }
        if let Some(index) = crate::math::first_out_of_range(data) {
            return Err(TrackError::OutOfRange { index });
        }
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
        let mut iterations = 0;
        let mut fk = ForwardKinematics::new(&self.model.skeleton, &self.pose);
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
        let mut world: Vec<Point3> = Vec::new();
        let (mut finds, mut timing) = (0, [0.0; 3]);
        for level in 0..=steps {
            let sigma = sigma0 * kappa.powi(level as i32);
            let last = level == steps;
            let active = if last || seen.len() < all.len() / 10 {
                &all
            } else {
                &seen
            };
            let voxel = VOXEL_SIGMAS * sigma;
            let coarse = self.options.coarse_to_fine && !last && voxel > 1.5 * self.spacing;
            // Representatives at this level: (texture index, count) and (data index, count).
            let (model_reps, data_reps): (Vec<Representative>, Vec<Representative>) = if coarse {
                world.clear();
                world.extend(active.iter().map(|&i| self.texture[i].world(&fk)));
                let reps = voxel_subsample(&world, voxel)
                    .into_iter()
                    .map(|(k, c)| (active[k], c))
                    .collect();
                (reps, voxel_subsample(data, voxel))
            } else {
                (active.iter().map(|&i| (i, 1)).collect(), Vec::new())
            };
            let model_weight: Option<Vec<f64>> =
                coarse.then(|| model_reps.iter().map(|r| r.1 as f64).collect());
            let points: Vec<Point3> = data_reps.iter().map(|&(j, _)| data[j]).collect();
            let data_weight: Option<Vec<f64>> =
                coarse.then(|| data_reps.iter().map(|r| r.1 as f64).collect());
            let rounds = if last {
                self.options.final_em_iterations
            } else {
                self.options.em_iterations
            };
            let level_data = if coarse { &points[..] } else { data };
            // Neighbours found once per level, with a margin for the motion within it.
            let margin = 0.5 * sigma;
            let mut found_at: Option<Vec<Point3>> = None;
            for _ in 0..rounds {
                iterations += 1;
                world.clear();
                world.extend(model_reps.iter().map(|&(i, _)| self.texture[i].world(&fk)));
                let stale = found_at.as_ref().is_none_or(|at| {
                    at.iter()
                        .zip(&world)
                        .any(|(a, b)| (a - b).norm_squared() > margin * margin)
                });
                let t0 = std::time::Instant::now();
                if stale {
                    self.candidates.find(
                        level_data,
                        &world,
                        candidate_radius(sigma, margin),
                        &mut self.grid,
                    );
                    found_at = Some(world.clone());
                    finds += 1;
                    tracing::trace!(
                        "level {level} sigma {:.4}: {} data, {} model, {} candidates",
                        sigma / h,
                        level_data.len(),
                        world.len(),
                        self.candidates.len()
                    );
                }
                let t1 = std::time::Instant::now();
                em_step_with(
                    level_data,
                    data_weight.as_deref(),
                    &world,
                    model_weight.as_deref(),
                    sigma,
                    self.options.outlier_constant,
                    &self.candidates,
                    &mut self.em,
                );
                // Eq. (20): each model point pulled to G_i with weight lambda_i.
                let pulls: Vec<Pull> = model_reps
                    .iter()
                    .enumerate()
                    .filter(|(k, _)| self.em.lambda[*k] > 1e-9)
                    .map(|(k, &(i, _))| {
                        let point = self.texture[i];
                        let mut target = self.em.target[k];
                        if self.options.point_to_plane && self.model.surface_normals.is_some() {
                            // Only the normal part of the pull: the point-to-plane
                            // gradient, free of the tangential bias of blurred centroids.
                            let x = world[k];
                            let n = point.world_normal(&fk);
                            target = x + n * n.dot(&(target - x));
                        }
                        Pull {
                            point,
                            target,
                            weight: self.em.lambda[k],
                        }
                    })
                    .collect();
                let t2 = std::time::Instant::now();
                let before = fk.clone();
                self.fit(
                    &pulls,
                    &start,
                    self.options.gauss_newton_steps,
                    last,
                    self.options.over_relaxation,
                );
                fk.update(&self.model.skeleton, &self.pose);
                let t3 = std::time::Instant::now();
                timing[0] += (t1 - t0).as_secs_f64();
                timing[1] += (t2 - t1).as_secs_f64();
                timing[2] += (t3 - t2).as_secs_f64();
                // At the noise level, EM runs until the joints stop moving.
                let moved = (0..fk.len())
                    .map(|j| (fk.origin(j) - before.origin(j)).norm())
                    .fold(0.0, f64::max);
                if last && moved < CONVERGED_MOTION * h {
                    break;
                }
            }
        }
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
            data,
            None,
            &world,
            None,
            sigma,
            self.options.outlier_constant,
            &mut self.grid,
            &mut self.em,
        );
        self.seen.clear();
        self.seen
            .extend(self.em.lambda.iter().map(|&l| l > SEEN_WEIGHT));
    }

    /// Eq. (21)-(22): pulls the fused surface onto the inlier data points, each weighted by
    /// `exp(-d^2 / (2 sigma^2))`. The surface's closest point to a datum, carried by the
    /// dominant part's joint, moves toward the datum (its residual is along the surface
    /// normal, so the gradient is that of `d^2`).
    fn surface_fit(
        &mut self,
        data: &[Point3],
        inlier: &[bool],
        best: &[u32],
        sigma: f64,
        start: &Pose,
    ) {
        for _ in 0..self.options.surface_fit_steps {
            let parts = &self.model.parts;
            let fk = ForwardKinematics::new(&self.model.skeleton, &self.pose);
            parts.place(&fk, &mut self.placed);
            let mut pulls = Vec::new();
            for (j, y) in data.iter().enumerate() {
                if !inlier[j] {
                    continue;
                }
                let hint = (best[j] != u32::MAX).then(|| self.texture[best[j] as usize].part);
                let Some(s) = parts.surface_distance(&self.placed, y, hint) else {
                    continue;
                };
                let g2 = s.gradient.norm_squared();
                if g2 < 1e-18 {
                    continue;
                }
                let beta = (-(s.distance * s.distance) / (2.0 * sigma * sigma)).exp();
                let foot = y - s.gradient * (s.distance / g2);
                let joint = parts.parts[s.dominant].joint;
                let Some(inv) = fk.world(joint).try_inverse() else {
                    continue;
                };
                let normal = crate::math::linear_part(&inv) * s.gradient;
                pulls.push(Pull {
                    point: TexturePoint::rigid(
                        joint,
                        transform_point(&inv, &foot),
                        normal,
                        s.dominant,
                    ),
                    target: *y,
                    weight: beta,
                });
            }
            self.fit(&pulls, start, 1, true, 1.0);
        }
    }

    /// The paper's texture update: the inlier data points near the fitted surface become
    /// the texture points of the next frame (kept when too few qualify).
    fn refresh_texture(
        &mut self,
        data: &[Point3],
        inlier: &[bool],
        best: &[u32],
        fk: &ForwardKinematics,
    ) {
        let h = self.model.height;
        let parts = &self.model.parts;
        parts.place(fk, &mut self.placed);
        let mut fresh = Vec::new();
        for (j, y) in data.iter().enumerate() {
            if !inlier[j] || best[j] == u32::MAX {
                continue;
            }
            let hint = Some(self.texture[best[j] as usize].part);
            let near = parts
                .surface_distance(&self.placed, y, hint)
                .is_some_and(|s| s.distance.abs() < 0.05 * h);
            if !near {
                continue;
            }
            if let Some(t) = TexturePoint::attach(
                parts,
                &self.placed,
                fk,
                y,
                None,
                self.options.bending_exponent,
                hint,
            ) {
                fresh.push(t);
            }
        }
        // As many texture points as the model started with, at most.
        let keep = self.model.surface_samples.len().max(1);
        if fresh.len() * 4 >= self.texture.len().min(keep) {
            if fresh.len() > keep {
                let stride = fresh.len() as f64 / keep as f64;
                fresh = (0..keep)
                    .map(|k| fresh[(k as f64 * stride) as usize])
                    .collect();
            }
            self.texture = fresh;
            self.seen.clear();
        }
    }

    /// Levenberg-Marquardt steps on `sum w |x(theta) - target|^2` (eq. 20 or 21) plus the
    /// rotation prior toward `start`.
    /// With `exact_blend`, blended points get their exact Jacobian; otherwise their
    /// dominant joint's (cheaper, slightly biased: for the annealing levels above the
    /// noise level).
    /// `relax` scales each step (over-relaxed EM: with the M-step's cost quadratic, any
    /// factor below 2 still lowers it, and EM's slow directions converge faster).
    fn fit(&mut self, pulls: &[Pull], start: &Pose, steps: usize, exact_blend: bool, relax: f64) {
        let mut relaxed: Vec<f64> = Vec::new();
        if pulls.is_empty() {
            return;
        }
        let skeleton = &self.model.skeleton;
        let parent = |j: usize| skeleton.joint(j).parent;
        let mut ne = match self.normal.take() {
            Some(ne) => ne,
            None => SkeletonNormalEquations::new(&self.layout, parent),
        };
        let inv_h = 1.0 / self.model.height;
        let prior = self.options.prior_weight;
        let layout = &self.layout;
        let objective = |pose: &Pose,
                         fk: &ForwardKinematics,
                         ne: Option<(&mut SubtreeMoments, &mut SkeletonNormalEquations)>|
         -> f64 {
            let mut cost = 0.0;
            match ne {
                Some((moments, ne)) => {
                    ne.clear();
                    moments.reset(skeleton.len());
                    let mut blended = Vec::new();
                    for pull in pulls {
                        let x = pull.point.world(fk);
                        let r = (x - pull.target) * inv_h;
                        let w = pull.point.weight;
                        if !exact_blend || !(EXACT_BLEND_MIN..=EXACT_BLEND_MAX).contains(&w) {
                            // Nearly rigid: the dominant joint's Jacobian.
                            let j = pull.point.joints[usize::from(w < 0.5)];
                            moments.add_point(fk, j, &x, &r, pull.weight);
                        } else {
                            blended.push((pull, r));
                        }
                    }
                    // Blended points (eq. 3) need the tree or dense form for their
                    // Jacobian, the weighted sum of both parts' (exact, not summarised by
                    // moments).
                    ne.set_allow_articulated(blended.is_empty());
                    ne.assemble_points(moments, fk, inv_h);
                    let mut cols: Vec<(usize, Vector3)> = Vec::new();
                    for (pull, r) in blended {
                        cols.clear();
                        pull.point.jacobian(fk, layout, inv_h, &mut cols);
                        ne.add_point_columns(&r, pull.weight, &cols);
                    }
                    rotation_prior(layout, start, pose, prior, &mut |r, w, col| {
                        ne.add_scalar(r, w, col, 1.0)
                    });
                    ne.cost()
                }
                None => {
                    for pull in pulls {
                        let r = (pull.point.world(fk) - pull.target) * inv_h;
                        cost += pull.weight * r.norm_squared();
                    }
                    rotation_prior(layout, start, pose, prior, &mut |r, w, _| cost += w * r * r);
                    cost
                }
            }
        };
        let mut fk = ForwardKinematics::new(skeleton, &self.pose);
        let mut trial_fk = fk.clone();
        let mut trial = self.pose.clone();
        for _ in 0..steps {
            let cost = objective(&self.pose, &fk, Some((&mut self.moments, &mut ne)));
            let mut improved = false;
            for _ in 0..6 {
                let Some(step) = ne.solve(self.lambda) else {
                    self.lambda *= 10.0;
                    continue;
                };
                trial.clone_from(&self.pose);
                if relax == 1.0 {
                    layout.apply(&mut trial, step);
                } else {
                    relaxed.clear();
                    relaxed.extend(step.iter().map(|d| d * relax));
                    layout.apply(&mut trial, &relaxed);
                }
                trial_fk.update(skeleton, &trial);
                let trial_cost = objective(&trial, &trial_fk, None);
                if trial_cost <= cost {
                    std::mem::swap(&mut self.pose, &mut trial);
                    std::mem::swap(&mut fk, &mut trial_fk);
                    self.lambda = (self.lambda / 3.0).max(1e-7);
                    improved = true;
                    break;
                }
                self.lambda *= 10.0;
            }
            if !improved {
                break;
            }
        }
        self.normal = Some(ne);
    }
}

/// `Phi`: each rotating joint's rotation vector away from `start`, per axis.
fn rotation_prior(
    layout: &DofLayout,
    start: &Pose,
    pose: &Pose,
    weight: f64,
    add: &mut dyn FnMut(f64, f64, usize),
) {
    if weight <= 0.0 {
        return;
    }
    for j in 0..layout.joint_count() {
        let Some(o) = layout.offset(j) else { continue };
        let delta = (start.local[j].rotation.inverse() * pose.local[j].rotation).scaled_axis();
        match layout.dof(j) {
            JointDof::Ball => (0..3).for_each(|a| add(delta[a], weight, o + a)),
            JointDof::Hinge { axis } => add(delta.dot(&axis.normalize()), weight, o),
            _ => {}
        }
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
        n.translation = c.translation + (c.translation - p.translation) * gain;
        let step = (p.rotation.inverse() * c.rotation).scaled_axis() * gain;
        n.rotation = Quat::new_normalize((c.rotation * Quat::from_scaled_axis(step)).into_inner());
    }
    next
}

/// The pose in which a skinned rig's meshes were bound: every skin joint's world transform
/// is the inverse of its inverse bind matrix (of the first mesh that uses it); other joints
/// keep their stored local transforms.
pub fn bind_pose(rig: &Rig) -> Pose {
    let skeleton = &rig.skeleton;
    let stored = &rig.pose;
    let mut world: Vec<crate::math::Matrix4> = Vec::with_capacity(skeleton.len());
    for (j, joint) in skeleton.joints().iter().enumerate() {
        let from_bind = rig
            .meshes
            .iter()
            .filter(|m| m.joints.iter().any(|js| js.contains(&(j as u32))))
            .find_map(|m| m.inverse_bind.get(j).and_then(|ib| ib.try_inverse()));
        let local = stored.local[j].to_matrix();
        let w = match (from_bind, joint.parent) {
            (Some(w), _) => w,
            (None, Some(p)) => world[p] * local,
            (None, None) => local,
        };
        world.push(w);
    }
    let pose = skeleton.pose_from_world(&world);
    let finite = pose.local.iter().all(|t| {
        t.translation.iter().all(|c| c.is_finite())
            && t.scale.iter().all(|c| c.is_finite() && *c != 0.0)
    });
    if finite { pose } else { stored.clone() }
}

/// Texture points for a surface: `requested`, or with 0 one per `(2% of the height)^2`
/// of area (a nearest-neighbour spacing near the 1% noise level, so the EM kernel sums
/// stay comparable across characters), between 500 and 5,000.
pub fn texture_count(
    requested: usize,
    vertices: &[Point3],
    triangles: &[[u32; 3]],
    height: f64,
) -> usize {
    if requested > 0 {
        return requested;
    }
    let area: f64 = triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| vertices[i as usize]);
            0.5 * (b - a).cross(&(c - a)).norm()
        })
        .filter(|a| a.is_finite())
        .sum();
    ((area / (0.02 * height).powi(2)).round() as usize).clamp(500, 5000)
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::humanoid::humanoid;
    use crate::math::Vector3;
    use rand::Rng;

    /// With every texture point pulled to where it is in a known pose, the M-step finds it.
    #[test]
    fn m_step_recovers_a_pose_from_exact_targets() {
        let rig = humanoid();
        let model = ArticulatedModel::from_rig(&rig, 1500).expect("model");
        let rigid = std::env::var("RIGID").is_ok();
        let options = TrackOptions {
            bending_exponent: if rigid { 1e6 } else { 2.0 },
            ..TrackOptions::default()
        };
        let mut tracker = Tracker::new(model, options).expect("tracker");
        let mut rng = rand::rngs::StdRng::seed_from_u64(5);
        let mut truth = rig.pose.clone();
        for j in 1..truth.local.len() {
            let w = Vector3::new(rng.random(), rng.random(), rng.random()) * 0.3;
            truth.local[j].rotation *= Quat::from_scaled_axis(w);
        }
        truth.local[0].translation += Vector3::new(0.05, -0.02, 0.03);
        let fk = ForwardKinematics::new(&rig.skeleton, &truth);
        let pulls: Vec<Pull> = tracker
            .texture
            .iter()
            .map(|t| Pull {
                point: *t,
                target: t.world(&fk),
                weight: 1.0,
            })
            .collect();
        let start = rig.pose.clone();
        tracker.options.prior_weight = 0.0;
        tracker.fit(&pulls, &start, 30, true, 1.0);
        let a = rig.skeleton.joint_positions(&tracker.pose);
        let b = rig.skeleton.joint_positions(&truth);
        let err = a
            .iter()
            .zip(&b)
            .map(|(p, q)| (p - q).norm())
            .fold(0.0, f64::max);
        assert!(err < 1e-3 * rig.height(), "largest joint error {err}");
    }
}
