//! Ground-truth scan sequences from skinned characters: the mesh is skinned at every frame of
//! one of the rig's animations (the true vertex positions), and each frame's scan is drawn
//! afresh from that surface (points and normals, no vertex shared with the reference), with
//! Gaussian noise, outliers (a floor slab and random clutter) and, for some frames, a hole
//! where a limb is not seen. Used by tests, benches and the peer comparison.

use rand::{Rng, SeedableRng};
use rand_distr::{Distribution, Normal};

use rigfit_core::geometry::{Aabb, TriMesh};
use rigfit_core::math::{Point3, Vector3};
use rigfit_core::rig::Rig;
use rigfit_core::skeleton::Pose;
use rigfit_core::surface::{Observations, SurfaceOptions, SurfaceTracker};

/// The test meshes of core (its own unit tests use them): a torus, bent, scanned.
pub use rigfit_core::surface::test_meshes::{bend, mean_distance, sample_surface, scan, torus};

/// How to draw a sequence. Lengths are fractions of the reference's bounding-box diagonal.
#[derive(Clone, Debug)]
pub struct SequenceOptions {
    pub frames: usize,
    /// Points per frame, outliers included.
    pub points: usize,
    /// Gaussian noise per coordinate.
    pub noise: f64,
    /// Fraction of each frame's points that are outliers: half a floor slab under the
    /// character, half clutter in the space around it.
    pub outlier_ratio: f64,
    /// Frames in which a limb region is missing from the scan.
    pub hole_frames: std::ops::Range<usize>,
    /// Fraction of the vertices in the missing region (the limb whose share is closest).
    pub hole_size: f64,
    /// Seconds between frames; `None` takes the clip's own key spacing (its frame rate),
    /// `frames` of them from the middle of the clip.
    pub frame_time: Option<f64>,
    /// The vertical axis (0: x, 1: y, 2: z): the floor slab lies under the object along it.
    pub up_axis: usize,
}

impl Default for SequenceOptions {
    fn default() -> Self {
        Self {
            frames: 30,
            points: 10_000,
            noise: 0.01,
            outlier_ratio: 0.15,
            hole_frames: 10..13,
            hole_size: 0.04,
            frame_time: None,
            up_axis: 1,
        }
    }
}

/// A generated sequence.
#[derive(Clone, Debug)]
pub struct SurfaceSequence {
    /// The reference: the character's meshes skinned at the first frame, with normals.
    pub reference: TriMesh,
    /// One scan per frame (points with normals, no faces).
    pub frames: Vec<TriMesh>,
    /// The true position of every reference vertex at every frame.
    pub truth: Vec<Vec<Point3>>,
    /// The vertices of the region left out of the scans in `hole_frames`.
    pub hole_vertices: Vec<usize>,
    /// The reference's bounding-box diagonal.
    pub diagonal: f64,
}

/// The animation of `rig` whose name contains `name` (case-insensitive), else the first.
pub fn find_animation(rig: &Rig, name: &str) -> usize {
    let name = name.to_ascii_lowercase();
    rig.animations
        .iter()
        .position(|a| a.name.to_ascii_lowercase().contains(&name))
        .unwrap_or(0)
}

/// The vertices of a limb: those whose dominant joint lies under the joint whose subtree
/// holds the share of the vertices closest to `share` (a hand, a lower leg).
fn limb_vertices(rig: &Rig, share: f64) -> Vec<usize> {
    let dominant: Vec<usize> = rig.meshes.iter().flat_map(|m| m.dominant_joint()).collect();
    let total = dominant.len().max(1) as f64;
    let skeleton = &rig.skeleton;
    let best = (0..skeleton.len())
        .map(|j| {
            let count = dominant
                .iter()
                .filter(|&&d| d < skeleton.len() && skeleton.is_ancestor_or_self(j, d))
                .count();
            (j, (count as f64 / total - share).abs(), count)
        })
        .filter(|&(_, _, c)| c > 0)
        .min_by(|a, b| a.1.total_cmp(&b.1));
    match best {
        Some((j, _, _)) => (0..dominant.len())
            .filter(|&v| {
                dominant[v] < skeleton.len() && skeleton.is_ancestor_or_self(j, dominant[v])
            })
            .collect(),
        None => Vec::new(),
    }
}

/// Draws a sequence of `rig`'s animation `animation` (the rig's stored pose if it has none).
pub fn make_sequence(
    rig: &Rig,
    animation: usize,
    options: &SequenceOptions,
    rng: &mut impl Rng,
) -> SurfaceSequence {
    let frames = options.frames.max(1);
    let poses: Vec<Pose> = match rig.animations.get(animation) {
        Some(anim) => {
            let (mut start, end) = (anim.start(), anim.end());
            let step = match options.frame_time {
                Some(dt) => dt,
                None => {
                    let dt = anim.duration() / (anim.frame_count().max(2) - 1) as f64;
                    let span = dt * (frames - 1) as f64;
                    start += ((end - start - span) / 2.0).max(0.0);
                    dt
                }
            };
            (0..frames)
                .map(|f| anim.sample(&rig.pose, (start + step * f as f64).min(end)))
                .collect()
        }
        None => vec![rig.pose.clone(); frames],
    };
    sequence_of_poses(rig, &poses, options, rng)
}

/// Draws a sequence of `rig` through `poses` (the first is the reference's), each frame's
/// scan drawn as [`make_sequence`] describes; `options.frames` and `frame_time` are not
/// used.
pub fn sequence_of_poses(
    rig: &Rig,
    poses: &[Pose],
    options: &SequenceOptions,
    rng: &mut impl Rng,
) -> SurfaceSequence {
    let frames = poses.len();
    let reference = rig.skinned_surface(&poses[0]);
    let bounds = Aabb::from_points(&reference.vertices).unwrap_or(Aabb {
        min: Point3::origin(),
        max: Point3::new(1.0, 1.0, 1.0),
    });
    let diagonal = bounds.diagonal().max(1e-12);
    let hole_vertices = limb_vertices(rig, options.hole_size);
    let mut in_hole = vec![false; reference.vertices.len()];
    for &v in &hole_vertices {
        in_hole[v] = true;
    }
    let visible_triangles: Vec<[u32; 3]> = reference
        .triangles
        .iter()
        .copied()
        .filter(|t| !t.iter().any(|&i| in_hole[i as usize]))
        .collect();
    let noise = Normal::new(0.0, (options.noise * diagonal).max(1e-300)).expect("valid deviation");
    let outliers =
        ((options.points as f64) * options.outlier_ratio.clamp(0.0, 1.0)).round() as usize;
    let surface_points = options.points.saturating_sub(outliers);
    // The floor's axes: up, then the two across it in order (x and z under y).
    let up = options.up_axis.min(2);
    let (a, b) = ((up + 1) % 3, (up + 2) % 3);
    let (a, b) = (a.min(b), a.max(b));
    let floor_level = bounds.min[up] - 0.01 * diagonal;
    let mut truth = Vec::with_capacity(frames);
    let mut scans = Vec::with_capacity(frames);
    for (f, pose) in poses.iter().enumerate() {
        let surface = rig.skinned_surface(pose);
        let triangles = if options.hole_frames.contains(&f) {
            &visible_triangles
        } else {
            &surface.triangles
        };
        let (mut points, mut normals) =
            sample_surface(&surface.vertices, triangles, surface_points, rng);
        for p in &mut points {
            *p += Vector3::new(noise.sample(rng), noise.sample(rng), noise.sample(rng));
        }
        let frame_bounds = Aabb::from_points(&surface.vertices).unwrap_or(bounds);
        let margin = 0.15 * diagonal;
        for o in 0..outliers {
            if o % 2 == 0 {
                // The floor: a thin slab under the character's first pose, wider than it.
                let e = bounds.extent();
                let mut p = Point3::origin();
                p[a] = rng.random_range(bounds.min[a] - 0.3 * e[a]..bounds.max[a] + 0.3 * e[a]);
                p[up] = floor_level - rng.random_range(0.0..0.005 * diagonal);
                p[b] = rng.random_range(bounds.min[b] - 0.3 * e[b]..bounds.max[b] + 0.3 * e[b]);
                points.push(p);
                normals.push(Vector3::ith(up, 1.0));
            } else {
                points.push(Point3::from(Vector3::from_fn(|i, _| {
                    rng.random_range(frame_bounds.min[i] - margin..frame_bounds.max[i] + margin)
                })));
                let n = Vector3::new(noise.sample(rng), noise.sample(rng), noise.sample(rng));
                normals.push(n.try_normalize(1e-300).unwrap_or_else(Vector3::x));
            }
        }
        truth.push(surface.vertices);
        scans.push(TriMesh {
            vertices: points,
            normals: Some(normals),
            triangles: Vec::new(),
        });
    }
    SurfaceSequence {
        reference,
        frames: scans,
        truth,
        hole_vertices,
        diagonal,
    }
}

/// Per-vertex distances between `fitted` and `truth` over every frame, as fractions of
/// `diagonal`.
pub fn vertex_errors(fitted: &[Vec<Point3>], truth: &[Vec<Point3>], diagonal: f64) -> Vec<f64> {
    fitted
        .iter()
        .zip(truth)
        .flat_map(|(a, b)| a.iter().zip(b).map(|(p, q)| (p - q).norm() / diagonal))
        .collect()
}

/// Mean and 95th percentile of errors.
pub fn mean_and_p95(errors: &[f64]) -> (f64, f64) {
    if errors.is_empty() {
        return (0.0, 0.0);
    }
    let mean = errors.iter().sum::<f64>() / errors.len() as f64;
    let mut sorted = errors.to_vec();
    sorted.sort_by(f64::total_cmp);
    let p95 = sorted[((sorted.len() - 1) as f64 * 0.95).round() as usize];
    (mean, p95)
}

/// The speed case of the surface bench: a 5,000-vertex torus (100 x 50) and `frames` scans
/// of it bent 0.15 more each frame ([`bend`]), 10,000 points each with 1% noise and 15%
/// clutter ([`scan`]), drawn with `seed`.
pub fn bending_torus_scans(frames: usize, seed: u64) -> (TriMesh, Vec<TriMesh>) {
    let reference = torus(100, 50);
    let diagonal = reference.bounds().map_or(1.0, |b| b.diagonal());
    let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
    let scans = (0..frames)
        .map(|f| {
            let moved = bend(&reference, 0.15 * f as f64);
            scan(
                &moved,
                &reference.triangles,
                10_000,
                0.01 * diagonal,
                0.15,
                &mut rng,
            )
        })
        .collect();
    (reference, scans)
}

/// The surface bench's case ([`bending_torus_scans`], 3 frames, seed 3): the reference, the
/// frames as observations, and a tracker (default options) that has tracked the first two,
/// so that frame 2 is the one measured (the bench, the `surface_frame` example).
pub fn warmed_torus_tracker() -> (TriMesh, Vec<Observations>, SurfaceTracker) {
    let (reference, scans) = bending_torus_scans(3, 3);
    let frames: Vec<Observations> = scans
        .iter()
        .map(|cloud| Observations::from_mesh(cloud).expect("frame"))
        .collect();
    let mut tracker = SurfaceTracker::new(&reference, &SurfaceOptions::default()).expect("tracker");
    tracker.track(&frames[0]).expect("frame 0");
    tracker.track(&frames[1]).expect("frame 1");
    (reference, frames, tracker)
}
