//! `rigfit surface MESH FRAME... -o OUTDIR`: track a reference mesh through a sequence of
//! point clouds or meshes (Cagniart et al. 2010), writing the moved reference per frame.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, anyhow};
use rigfit_core::TriMesh;
use rigfit_core::surface::{Observations, SurfaceError, SurfaceOptions, SurfaceTracker};
use rigfit_formats::files::{commit_all, stage};
use rigfit_formats::mesh_file::{read_mesh, read_surface};
use rigfit_formats::ply::ply_bytes;
use serde_json::json;

#[derive(Debug, clap::Args)]
pub struct SurfaceArgs {
    /// The reference surface: .ply, .obj, or a .glb/.gltf (its skinned meshes in the stored
    /// pose).
    pub mesh: PathBuf,
    /// The frames, in order: point clouds or meshes (.ply, .obj), with or without normals.
    #[arg(required = true)]
    pub frames: Vec<PathBuf>,
    /// Output folder: frame_00000.ply, ... (the reference's vertices, moved, and its faces).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Write a JSON report: per frame the file, inlier count, rms residual, EM
    /// iterations, final sigma and seconds.
    #[arg(long)]
    pub report: Option<PathBuf>,
    /// Largest patch radius, as a fraction of the reference's bounding-box diagonal.
    #[arg(long, default_value_t = SurfaceOptions::default().patches.radius)]
    pub patch_radius: f64,
    /// Expected fraction of outlier points in a frame.
    #[arg(long, default_value_t = SurfaceOptions::default().data.outlier_ratio)]
    pub outliers: f64,
    /// Weight of the rigidity between neighbouring patches.
    #[arg(long, default_value_t = SurfaceOptions::default().rigidity)]
    pub rigidity: f64,
    /// EM iterations per frame at most.
    #[arg(long, default_value_t = SurfaceOptions::default().max_iterations)]
    pub iterations: usize,
    /// Merge each frame's points by cubes of this many point spacings (and by normal
    /// direction) before fitting: fewer points to search, at a small bias on coarse meshes
    /// (0: every point, the default).
    #[arg(long, default_value_t = SurfaceOptions::default().merge_cell)]
    pub merge: f64,
    /// A frame's first EM iterations (two; four with --fast-motion) use one point in this
    /// many (they take up the motion at wide kernels; the rest use every point). 1 uses
    /// every point throughout.
    #[arg(long, default_value_t = SurfaceOptions::default().coarse_stride)]
    pub coarse: usize,
    /// On an object of rigid pieces (tracked with its pieces' tree), fit about this many of
    /// a frame's points per reference vertex in every iteration (a scan much denser than the
    /// mesh costs what the mesh needs); 0 fits every point. A skin fits every point.
    #[arg(long, default_value_t = SurfaceOptions::default().points_per_vertex)]
    pub points_per_vertex: f64,
    /// For fast articulated motion (limbs moving a tenth of the object or more between
    /// frames): a wider first kernel after fast frames, each part of a many-part object
    /// held nearly rigid in four thinned first iterations, the kernel held while the mesh
    /// still travels. More accurate on such motion, at about twice the time on its frames.
    #[arg(long)]
    pub fast_motion: bool,
    /// Do not start each frame of a many-part reference from its pieces' kinematic tree
    /// (tracked by the articulated tracker; on by default for a reference of pieces that
    /// touch): each patch starts from its own motion continued, as for one skin, and the
    /// pieces are handed out as the surface fit left them (with the tree, each is laid
    /// rigidly where the fit put it).
    #[arg(long)]
    pub no_piece_tree: bool,
    /// Draw a contact sheet of evenly spaced frames (the moved reference shaded flat over the
    /// frame's points) with inliers and time per frame, as a .png.
    #[arg(long)]
    pub render: Option<PathBuf>,
    /// Ground truth for the picture's error plot: the true vertex positions per frame, in
    /// the reference's order (.ply or .obj; `surface_sequence` writes `truth_NNNN.ply`),
    /// one file per frame, comma-separated.
    #[arg(long, requires = "render", value_delimiter = ',')]
    pub truth: Option<Vec<PathBuf>>,
    #[command(flatten)]
    pub picture: super::render::PictureArgs,
    /// No progress bar (a take run by `rigfit batch`); not an option of the command line.
    #[arg(skip)]
    pub quiet: bool,
}

fn named(path: &Path, e: SurfaceError) -> anyhow::Error {
    anyhow!("{}: {e}", path.display())
}

/// The name of output frame `i`.
fn frame_name(i: usize) -> String {
    format!("frame_{i:05}.ply")
}

/// The frame files in `dir` (`frame_` digits `.ply`) with their numbers: an earlier run's.
fn frame_files(dir: &Path) -> anyhow::Result<Vec<(usize, PathBuf)>> {
    let entries = match std::fs::read_dir(dir) {
        Ok(e) => e,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(Vec::new()),
        Err(e) => return Err(anyhow!("{}: cannot list the folder: {e}", dir.display())),
    };
    let mut out = Vec::new();
    for entry in entries {
        let entry = entry.with_context(|| format!("{}: cannot list the folder", dir.display()))?;
        let name = entry.file_name();
        let Some(name) = name.to_str() else { continue };
        let Some(digits) = name
            .strip_prefix("frame_")
            .and_then(|n| n.strip_suffix(".ply"))
        else {
            continue;
        };
        if digits.len() < 5 || !digits.bytes().all(|b| b.is_ascii_digit()) {
            continue;
        }
        if let Ok(i) = digits.parse::<usize>() {
            if frame_name(i) == name {
                out.push((i, entry.path()));
            }
        }
    }
    Ok(out)
}

/// The tracker's options from the flags, checked against the core's bounds
/// ([`SurfaceOptions::check`]); an error names the flag.
fn options(args: &SurfaceArgs) -> anyhow::Result<SurfaceOptions> {
    let mut options = if args.fast_motion {
        SurfaceOptions::fast_motion()
    } else {
        SurfaceOptions::default()
    };
    options.patches.radius = args.patch_radius;
    options.data.outlier_ratio = args.outliers;
    options.rigidity = args.rigidity;
    options.max_iterations = args.iterations;
    options.merge_cell = args.merge;
    options.coarse_stride = args.coarse;
    options.points_per_vertex = args.points_per_vertex;
    if args.no_piece_tree {
        options.piece_tree = None;
    }
    options
        .check()
        .map_err(|e| anyhow!("--{}: {}", e.option.flag(), e.problem))?;
    Ok(options)
}

/// Tracks the reference through the frames and writes the outputs; returns the summary.
pub fn run(args: &SurfaceArgs) -> anyhow::Result<String> {
    if let Some(picture) = &args.render {
        super::render::check_png_path(picture)?;
    }
    // The bounds are the core's (shared with the Python package), checked before any file.
    let options = options(args)?;
    // OUTDIR: a folder (made when missing). Its frame_NNNNN.ply files are replaced; those
    // of an earlier run numbered past this run's frames are removed once this run's are all
    // in place. An input among them (or among the new names) is refused.
    let outdir = &args.output;
    let outdir_exists = match std::fs::metadata(outdir) {
        Ok(m) if m.is_dir() => true,
        Ok(_) => {
            return Err(anyhow!(
                "{}: the output must be a folder (it is a file)",
                outdir.display()
            ));
        }
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => false,
        Err(e) => return Err(anyhow!("{}: {e}", outdir.display())),
    };
    let stale = frame_files(outdir)?;
    let frame_outputs: Vec<PathBuf> = (0..args.frames.len())
        .map(|i| outdir.join(frame_name(i)))
        .collect();
    let mut inputs: Vec<&Path> = vec![&args.mesh];
    inputs.extend(args.frames.iter().map(PathBuf::as_path));
    inputs.extend(args.truth.iter().flatten().map(PathBuf::as_path));
    // A report or picture inside an OUTDIR not made yet is checked when it is written.
    let mut outputs: Vec<&Path> = [&args.report, &args.render]
        .into_iter()
        .flatten()
        .map(PathBuf::as_path)
        .filter(|p| outdir_exists || p.parent() != Some(outdir.as_path()))
        .collect();
    if outdir_exists {
        outputs.extend(frame_outputs.iter().map(PathBuf::as_path));
        // Earlier frames past this run's count are removed: they too must not be inputs.
        outputs.extend(
            stale
                .iter()
                .filter(|(i, _)| *i >= args.frames.len())
                .map(|(_, p)| p.as_path()),
        );
    }
    super::check_files(&inputs, &outputs)?;
    let reference = read_surface(&args.mesh)?;
    let mut tracker =
        SurfaceTracker::new(&reference, &options).map_err(|e| named(&args.mesh, e))?;
    // A progress bar on stderr (indicatif hides it when stderr is not a terminal).
    let progress = if args.quiet {
        indicatif::ProgressBar::hidden()
    } else {
        indicatif::ProgressBar::new(args.frames.len() as u64)
    };
    progress.set_style(
        indicatif::ProgressStyle::with_template("tracking {bar:30} {pos}/{len} frames {msg}")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    // Every frame is solved before anything is written: a bad frame leaves no output.
    let mut results = Vec::with_capacity(args.frames.len());
    let mut total_seconds = 0.0;
    let shown = rigfit_render::pick_frames(args.frames.len(), 8);
    let mut shown_points = Vec::new();
    for (i, path) in args.frames.iter().enumerate() {
        let frame = read_mesh(path)?;
        if args.render.is_some() && shown.contains(&i) {
            shown_points.push((i, frame.vertices.clone()));
        }
        let observations = Observations::from_mesh(&frame).map_err(|e| named(path, e))?;
        let t0 = Instant::now();
        let fit = tracker.track(&observations).map_err(|e| named(path, e))?;
        let seconds = t0.elapsed().as_secs_f64();
        total_seconds += seconds;
        progress.set_message(format!(
            "({:.0} ms/frame)",
            total_seconds / (i + 1) as f64 * 1000.0
        ));
        progress.inc(1);
        results.push((path, fit, seconds));
    }
    progress.finish_and_clear();
    let made_outdir = !outdir_exists;
    if made_outdir {
        std::fs::create_dir_all(outdir)
            .with_context(|| format!("{}: cannot create the folder", outdir.display()))?;
    }
    let written = write_outputs(args, &reference, &results, &shown_points, &frame_outputs);
    if let Err(e) = written {
        if made_outdir {
            // Empty: every output went to a temporary file, removed on failure.
            let _ = std::fs::remove_dir(outdir);
        }
        return Err(e);
    }
    for (i, path) in &stale {
        let regular = std::fs::symlink_metadata(path).is_ok_and(|m| m.is_file());
        if *i >= results.len() && regular {
            std::fs::remove_file(path).with_context(|| {
                format!(
                    "{}: cannot remove this frame of an earlier run",
                    path.display()
                )
            })?;
        }
    }
    Ok(format!(
        "tracked {} ({} vertices, {} patches) through {} frames in {:.1} ms per frame; wrote {}\n",
        args.mesh.display(),
        reference.vertices.len(),
        tracker.model.patch_count(),
        results.len(),
        total_seconds / results.len().max(1) as f64 * 1000.0,
        outdir.display()
    ))
}

/// One tracked frame: its file, the fit and the seconds it took.
type Tracked<'a> = (&'a PathBuf, rigfit_core::surface::FrameFit, f64);

/// Makes every output and writes each to its temporary file, then renames them all into
/// place (a failure before the renames leaves nothing).
fn write_outputs(
    args: &SurfaceArgs,
    reference: &TriMesh,
    results: &[Tracked<'_>],
    shown_points: &[(usize, Vec<rigfit_core::Point3>)],
    frame_outputs: &[PathBuf],
) -> anyhow::Result<()> {
    let mut staged = Vec::with_capacity(results.len() + 2);
    let mut frames_json = Vec::with_capacity(results.len());
    for (i, (path, fit, seconds)) in results.iter().enumerate() {
        let mesh = TriMesh {
            normals: None,
            triangles: reference.triangles.clone(),
            vertices: fit.positions.clone(),
        };
        staged.push(stage(&frame_outputs[i], &ply_bytes(&mesh, true))?);
        frames_json.push(json!({
            "file": path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default(),
            "inliers": fit.inliers,
            "rms": fit.rms,
            "iterations": fit.iterations,
            "sigma": fit.sigma,
            "seconds": seconds,
        }));
    }
    if let Some(picture) = &args.render {
        let frames: Vec<(String, rigfit_render::Scene)> = shown_points
            .iter()
            .map(|(i, points)| {
                let mut scene = rigfit_render::Scene::new();
                scene
                    .add_mesh(&TriMesh {
                        normals: None,
                        triangles: reference.triangles.clone(),
                        vertices: results[*i].1.positions.clone(),
                    })
                    .add_points(points, None);
                (format!("frame {i}"), scene)
            })
            .collect();
        // Per frame, the mean vertex distance to the truth, % of the reference's diagonal.
        let diagonal = reference.bounds().map_or(1.0, |b| b.diagonal()).max(1e-12);
        let error = match &args.truth {
            Some(files) => Some(
                files
                    .iter()
                    .zip(results)
                    .map(|(file, r)| {
                        let truth = read_mesh(file)?;
                        if truth.vertices.len() != r.1.positions.len() {
                            return Err(anyhow!(
                                "{}: {} vertices, the reference has {}",
                                file.display(),
                                truth.vertices.len(),
                                r.1.positions.len()
                            ));
                        }
                        let sum: f64 = truth
                            .vertices
                            .iter()
                            .zip(&r.1.positions)
                            .map(|(a, b)| (a - b).norm())
                            .sum();
                        Ok(100.0 * sum / truth.vertices.len().max(1) as f64 / diagonal)
                    })
                    .collect::<anyhow::Result<Vec<f64>>>()?,
            ),
            None => None,
        };
        let stats = rigfit_render::FrameStats {
            error,
            error_label: "mean vertex error (% of diagonal)".into(),
            inliers: results.iter().map(|r| r.1.inliers as f64).collect(),
            seconds: results.iter().map(|r| r.2).collect(),
        };
        if let Some((_, first)) = frames.first() {
            let options = args.picture.options(first);
            let image = rigfit_render::tracking_sheet(&frames, &stats, &options);
            staged.push(stage(picture, &super::render::png_bytes(picture, &image)?)?);
        }
    }
    if let Some(report) = &args.report {
        let value = json!({ "frames": frames_json });
        let text = serde_json::to_string_pretty(&value).context("the report")? + "\n";
        staged.push(stage(report, text.as_bytes())?);
    }
    commit_all(staged)?;
    Ok(())
}
