//! The many-part objects of the surface corpus (`data/surface_corpus.json`): robots, hands
//! and creatures converted from their packages' MJCF descriptions with their meshes
//! (`scripts/corpus/mjcf2parts.py`), every link its own piece of mesh, rigidly skinned to
//! its joint. Each is posed through its joints by a fast synthetic motion
//! ([`synthetic_motion_through`], within the joints' ranges) into a ground-truth scan
//! sequence ([`sequence_of_poses`]: noise, a floor and clutter, a part unseen for several
//! frames), tracked by [`SurfaceTracker`] and scored vertex by vertex against the truth, as
//! fractions of the reference's bounding-box diagonal.

use std::path::PathBuf;
use std::time::Instant;

use rand::SeedableRng;
use rand::rngs::StdRng;

use rigfit_core::geometry::TriMesh;
use rigfit_core::surface::patches::{VertexGraph, connected_components};
use rigfit_core::surface::{Observations, SurfaceOptions, SurfaceTracker};

use crate::corpus::{Corpus, CorpusError, RigEntry};
use crate::surface_cases::{SequenceOptions, SurfaceSequence, mean_and_p95, sequence_of_poses};
use crate::track_corpus::synthetic_motion_through;

/// The environment variable naming the surface corpus's manifest, when it is not the
/// workspace's `data/surface_corpus.json`.
pub const SURFACE_MANIFEST_ENV: &str = "RIGFIT_SURFACE_MANIFEST";

/// The surface corpus: its manifest (`RIGFIT_SURFACE_MANIFEST`, by default
/// `data/surface_corpus.json`) and the rig corpus's folder (`RIGFIT_CORPUS`).
pub fn load() -> Result<Corpus, CorpusError> {
    let (rig_manifest, folder) = Corpus::locations();
    let manifest = std::env::var_os(SURFACE_MANIFEST_ENV)
        .map(PathBuf::from)
        .unwrap_or_else(|| rig_manifest.with_file_name("surface_corpus.json"));
    let corpus = Corpus::read(&manifest, &folder)?;
    corpus.check_files()?;
    Ok(corpus)
}

/// How a many-part sequence is drawn.
#[derive(Clone, Debug)]
pub struct PartsOptions {
    pub frames: usize,
    /// Random far poses the motion passes through over the frames (the more, the faster).
    pub far_poses: usize,
    /// The scans: points, noise, outliers, the unseen part and when.
    pub scan: SequenceOptions,
}

impl Default for PartsOptions {
    /// 30 frames through 6 far poses (joints turn up to their limits, limbs up to 90
    /// degrees, in 5 frames), 8,000 points a frame with 0.5% noise and 15% outliers, a part
    /// of about 4% of the vertices unseen in frames 10 to 19.
    fn default() -> Self {
        Self {
            frames: 30,
            far_poses: 6,
            scan: SequenceOptions {
                frames: 30,
                points: 8_000,
                noise: 0.005,
                outlier_ratio: 0.15,
                hole_frames: 10..20,
                hole_size: 0.04,
                frame_time: None,
                up_axis: 1,
            },
        }
    }
}

/// A drawn sequence of one corpus object.
#[derive(Clone, Debug)]
pub struct PartsCase {
    pub entry: RigEntry,
    pub seed: u64,
    /// Connected pieces of the reference mesh.
    pub pieces: usize,
    pub sequence: SurfaceSequence,
}

/// Draws the sequence of `entry` for `seed`.
pub fn parts_case(
    corpus: &Corpus,
    entry: &RigEntry,
    seed: u64,
    options: &PartsOptions,
) -> Result<PartsCase, CorpusError> {
    let read = corpus.read_rig(entry)?;
    let mut rng = StdRng::seed_from_u64(0x22_0000 + seed);
    let poses = synthetic_motion_through(&read, options.frames, options.far_poses, &mut rng);
    let up_axis = read.up.iamax();
    let scan = SequenceOptions {
        frames: options.frames,
        up_axis,
        ..options.scan.clone()
    };
    let sequence = sequence_of_poses(&read.rig, &poses, &scan, &mut rng);
    if sequence.reference.triangles.is_empty() {
        return Err(CorpusError::Rig {
            id: entry.id.clone(),
            problem: "no skinned mesh to track".into(),
        });
    }
    let pieces = piece_count(&sequence.reference);
    Ok(PartsCase {
        entry: entry.clone(),
        seed,
        pieces,
        sequence,
    })
}

/// The connected piece of each vertex of a mesh, vertices closer than `weld_tolerance`
/// joined where they lie on open edges (0: as the file has them; see
/// [`VertexGraph::new`]).
pub fn piece_labels(mesh: &TriMesh, weld_tolerance: f64) -> Vec<u32> {
    let graph = VertexGraph::new(&mesh.vertices, &mesh.triangles, weld_tolerance);
    connected_components(&graph)
}

/// Connected pieces of a mesh (coincident vertices not welded: as the file has them).
fn piece_count(mesh: &TriMesh) -> usize {
    let labels = piece_labels(mesh, 0.0);
    let mut used: Vec<u32> = mesh
        .triangles
        .iter()
        .map(|t| labels[t[0] as usize])
        .collect();
    used.sort_unstable();
    used.dedup();
    used.len()
}

/// How the tracker did on a sequence; errors are fractions of the diagonal.
#[derive(Clone, Debug)]
pub struct PartsScore {
    /// Mean and 95th percentile over every vertex of every frame.
    pub mean: f64,
    pub p95: f64,
    /// Each frame's mean.
    pub frame_means: Vec<f64>,
    /// Each frame's farthest vertex: its error, and which vertex it is.
    pub frame_worst: Vec<f64>,
    pub frame_worst_vertex: Vec<usize>,
    /// Each frame's farthest vertex of those the scan could show: the unseen part's
    /// vertices are left out while it is unseen.
    pub frame_worst_seen: Vec<f64>,
    /// The bar's four figures over what the scans show (the unseen part's vertices left
    /// out while it is unseen, judged again from the frame it comes back).
    pub seen: BarFigures,
    /// The mean over the unseen part's vertices in the first frame it is seen again.
    pub returned: Option<f64>,
    /// The farthest of the unseen part's vertices in that frame.
    pub returned_worst: Option<f64>,
    /// Seconds per frame.
    pub seconds: Vec<f64>,
    /// Every vertex's error in the frame with the farthest vertex the scans show, that
    /// frame, and the fit's vertices in it.
    pub worst_vertex_frame_errors: Vec<f64>,
    pub worst_vertex_frame: usize,
    pub worst_vertex_frame_fit: Vec<rigfit_core::math::Point3>,
}

/// The four figures the bar judges, fractions of the diagonal.
#[derive(Clone, Copy, Debug, Default)]
pub struct BarFigures {
    /// Mean and 95th percentile over every vertex of every frame judged.
    pub mean: f64,
    pub p95: f64,
    /// The worst frame's mean, and the farthest vertex in any frame.
    pub worst_frame: f64,
    pub worst_vertex: f64,
}

impl BarFigures {
    /// The bar: mean at most 1.5%, p95 at most 4%, no frame's mean over 3%, no
    /// vertex over 10% in any frame.
    pub fn passes(&self) -> bool {
        self.mean <= 0.015
            && self.p95 <= 0.04
            && self.worst_frame <= 0.03
            && self.worst_vertex <= 0.10
    }
}

impl PartsScore {
    pub fn worst_frame(&self) -> f64 {
        self.frame_means.iter().copied().fold(0.0, f64::max)
    }

    pub fn worst_vertex(&self) -> f64 {
        self.frame_worst.iter().copied().fold(0.0, f64::max)
    }

    /// The bar over every vertex of every frame ([`BarFigures::passes`]).
    pub fn passes(&self) -> bool {
        BarFigures {
            mean: self.mean,
            p95: self.p95,
            worst_frame: self.worst_frame(),
            worst_vertex: self.worst_vertex(),
        }
        .passes()
    }

    pub fn median_seconds(&self) -> f64 {
        let mut s = self.seconds.clone();
        s.sort_by(f64::total_cmp);
        s.get(s.len() / 2).copied().unwrap_or(0.0)
    }
}

/// Tracks `case` frame by frame from its reference and scores it.
pub fn track_parts(
    case: &PartsCase,
    options: &SurfaceOptions,
    hole_frames: std::ops::Range<usize>,
) -> Result<PartsScore, String> {
    let sequence = &case.sequence;
    let mut tracker = SurfaceTracker::new(&sequence.reference, options)
        .map_err(|e| format!("{}: no tracker: {e}", case.entry.id))?;
    let diagonal = sequence.diagonal;
    let mut all = Vec::new();
    let mut frame_means = Vec::new();
    let mut frame_worst = Vec::new();
    let mut frame_worst_vertex = Vec::new();
    let mut frame_worst_seen = Vec::new();
    let (mut all_seen, mut frame_means_seen) = (Vec::new(), Vec::new());
    let mut hidden = vec![false; sequence.reference.vertices.len()];
    for &v in &sequence.hole_vertices {
        hidden[v] = true;
    }
    let mut seconds = Vec::new();
    let (mut returned, mut returned_worst) = (None, None);
    let mut worst_vertex_frame_errors: Vec<f64> = Vec::new();
    let (mut worst_vertex_frame, mut worst_vertex_frame_fit) = (0, Vec::new());
    for (f, (frame, truth)) in sequence.frames.iter().zip(&sequence.truth).enumerate() {
        let data = Observations::from_mesh(frame).map_err(|e| format!("frame {f}: {e}"))?;
        let t0 = Instant::now();
        let fit = tracker
            .track(&data)
            .map_err(|e| format!("{} frame {f}: {e}", case.entry.id))?;
        seconds.push(t0.elapsed().as_secs_f64());
        let errors: Vec<f64> = fit
            .positions
            .iter()
            .zip(truth)
            .map(|(p, q)| (p - q).norm() / diagonal)
            .collect();
        let frame_mean = errors.iter().sum::<f64>() / errors.len().max(1) as f64;
        frame_means.push(frame_mean);
        let (worst_at, worst) = errors
            .iter()
            .copied()
            .enumerate()
            .fold((0, 0.0), |a, (i, e)| if e > a.1 { (i, e) } else { a });
        frame_worst.push(worst);
        frame_worst_vertex.push(worst_at);
        let unseen = hole_frames.contains(&f);
        let shown: Vec<f64> = errors
            .iter()
            .zip(&hidden)
            .filter(|(_, h)| !(unseen && **h))
            .map(|(&e, _)| e)
            .collect();
        let worst_shown = shown.iter().copied().fold(0.0, f64::max);
        if frame_worst_seen.iter().all(|&w| w < worst_shown) {
            worst_vertex_frame_errors = errors.clone();
            worst_vertex_frame = f;
            worst_vertex_frame_fit = fit.positions.clone();
        }
        frame_worst_seen.push(worst_shown);
        frame_means_seen.push(shown.iter().sum::<f64>() / shown.len().max(1) as f64);
        all_seen.extend(shown);
        if f == hole_frames.end && !sequence.hole_vertices.is_empty() {
            let part: Vec<f64> = sequence.hole_vertices.iter().map(|&v| errors[v]).collect();
            returned = Some(part.iter().sum::<f64>() / part.len() as f64);
            returned_worst = Some(part.iter().copied().fold(0.0, f64::max));
        }
        all.extend(errors);
    }
    let (mean, p95) = mean_and_p95(&all);
    let (seen_mean, seen_p95) = mean_and_p95(&all_seen);
    let seen = BarFigures {
        mean: seen_mean,
        p95: seen_p95,
        worst_frame: frame_means_seen.iter().copied().fold(0.0, f64::max),
        worst_vertex: frame_worst_seen.iter().copied().fold(0.0, f64::max),
    };
    Ok(PartsScore {
        mean,
        p95,
        frame_means,
        frame_worst,
        frame_worst_vertex,
        frame_worst_seen,
        seen,
        returned,
        returned_worst,
        seconds,
        worst_vertex_frame_errors,
        worst_vertex_frame,
        worst_vertex_frame_fit,
    })
}
