//! `rigfit track RIG FRAME...`: track an articulated body or hand through a sequence of
//! point clouds (EM alignment of Dewaele et al. 2006 on the rig's articulated surface).

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{anyhow, bail};
use rigfit_core::joint_model::{apply_joint_model, with_clip_model};
use rigfit_core::track::{
    ArticulatedModel, FrameFit, FrameStart, StartMode, Take, TakeOptions, TrackOptions, Tracker,
};
use rigfit_core::{Point3, Pose};
use rigfit_formats::files::{commit_all, stage};
use rigfit_formats::mesh_file::read_mesh;
use rigfit_formats::report::{to_text, track_frame_json};
use rigfit_formats::rig_file::{RigOptions, read_rig};
use serde_json::json;

/// Which tracker to run.
#[derive(Debug, Clone, Copy, clap::ValueEnum, PartialEq, Eq)]
pub enum TrackMethod {
    /// rigfit: the published EM with prediction, view-aware coarse-to-fine matching,
    /// point-to-plane pulls and over-relaxed steps.
    Rigfit,
    /// The EM as published: texture points refreshed from the data every frame.
    Paper,
}

/// Where the first frame starts.
#[derive(Debug, Clone, Copy, clap::ValueEnum, PartialEq, Eq)]
pub enum InitMode {
    /// The rig's stored pose when it explains the first frame; else the search's pose when
    /// that explains it clearly better.
    Auto,
    /// The rig's stored pose, however far it is from the first frame.
    Stored,
    /// The search: the body found wherever it stands and however it is turned.
    Search,
}

impl InitMode {
    fn start_mode(self) -> StartMode {
        match self {
            InitMode::Auto => StartMode::Auto,
            InitMode::Stored => StartMode::Stored,
            InitMode::Search => StartMode::Search,
        }
    }
}

#[derive(Debug, clap::Args)]
pub struct TrackArgs {
    /// The rig: .glb / .gltf with a skin (its mesh gives the surface), or .bvh (ellipsoids
    /// sized from bone lengths).
    pub rig: PathBuf,
    /// Point clouds or meshes, one per time step, in order (.ply, .obj).
    #[arg(required = true)]
    pub frames: Vec<PathBuf>,
    /// Output: .glb/.gltf (the input rig with the track as its `rigfit` animation) or .bvh
    /// (one frame per time step).
    #[arg(short, long)]
    pub output: Option<PathBuf>,
    /// Write a JSON report: per frame, the joint positions, inliers and seconds.
    #[arg(long)]
    pub report: Option<PathBuf>,
    /// The glTF skin to track (by name); the first by default.
    #[arg(long)]
    pub skin: Option<String>,
    /// BVH: the frame the tracker starts from (a number, or `rest`).
    #[arg(long)]
    pub start_frame: Option<String>,
    /// The tracker.
    #[arg(long, value_enum, default_value = "rigfit")]
    pub method: TrackMethod,
    /// Noise of the data, as a fraction of the character's height (the floor of sigma).
    #[arg(long, default_value_t = 0.01)]
    pub noise: f64,
    /// The largest motion of a point between frames, as a fraction of the height.
    #[arg(long)]
    pub max_motion: Option<f64>,
    /// Where the first frame starts: `auto` keeps the stored pose when it explains the first
    /// frame and otherwise searches for the body (position, heading, then limbs).
    #[arg(long, value_enum, default_value = "auto")]
    pub init: InitMode,
    /// A joints file (JSON, see README): which joints are hinges (with their axis) or
    /// fixed, and their limits, overriding what the rig's clips show (by default a joint
    /// the clips turn about one axis only is a hinge, and every joint the clips turn keeps
    /// softly to the range they show).
    #[arg(long, value_name = "FILE.json")]
    pub joints: Option<PathBuf>,
    /// Never search again on a frame whose fit collapsed (by default such a frame, with
    /// inliers far below the frames before it, is searched for and the report marks it).
    #[arg(long)]
    pub no_recovery: bool,
    /// Frames per second of the output animation.
    #[arg(long, default_value_t = 30.0)]
    pub fps: f64,
    /// Draw a contact sheet of evenly spaced frames (skeleton and cloud, rejected points
    /// in another colour) with inliers and time per frame, as a .png.
    #[arg(long)]
    pub render: Option<PathBuf>,
    /// Ground truth for the picture's error plot: a track report (`frames[k].joints` with
    /// `name` and `position`), frame k against tracked frame k.
    #[arg(long, requires = "render")]
    pub truth: Option<PathBuf>,
    #[command(flatten)]
    pub picture: super::render::PictureArgs,
    /// No progress bar and no summary on a partial failure (a take run by `rigfit batch`);
    /// not an option of the command line.
    #[arg(skip)]
    pub quiet: bool,
}

/// Reads a track report as ground truth: per frame, joint name to position.
fn read_truth(path: &Path) -> anyhow::Result<Vec<std::collections::HashMap<String, Point3>>> {
    let bytes = rigfit_formats::error::read_bytes(path)?;
    let value: serde_json::Value =
        serde_json::from_slice(&bytes).map_err(|e| anyhow!("{}: not JSON: {e}", path.display()))?;
    let frames = value["frames"]
        .as_array()
        .ok_or_else(|| anyhow!("{}: frames: expected an array", path.display()))?;
    frames
        .iter()
        .enumerate()
        .map(|(k, frame)| {
            let joints = frame["joints"].as_array().ok_or_else(|| {
                anyhow!("{}: frames[{k}].joints: expected an array", path.display())
            })?;
            joints
                .iter()
                .enumerate()
                .map(|(j, joint)| {
                    let bad = || {
                        anyhow!(
                            "{}: frames[{k}].joints[{j}]: expected a name and a position [x, y, z]",
                            path.display()
                        )
                    };
                    let name = joint["name"].as_str().ok_or_else(bad)?.to_string();
                    let p = joint["position"].as_array().ok_or_else(bad)?;
                    let c: Vec<f64> = p.iter().filter_map(serde_json::Value::as_f64).collect();
                    if c.len() != 3 || !c.iter().all(|x| x.is_finite()) {
                        return Err(bad());
                    }
                    Ok((name, Point3::new(c[0], c[1], c[2])))
                })
                .collect()
        })
        .collect()
}

/// Reads one frame's points (vertices of a .ply / .obj cloud or mesh).
pub fn read_points(path: &Path) -> anyhow::Result<Vec<Point3>> {
    let mesh = read_mesh(path)?;
    if mesh.vertices.is_empty() {
        bail!("{}: the point cloud is empty", path.display());
    }
    Ok(mesh.vertices)
}

/// One tracked frame.
struct Tracked {
    file: String,
    fit: FrameFit,
    start: FrameStart,
    seconds: f64,
}

/// The line saying where the first frame started, and the report's `start` object.
fn first_frame_choice(start: &FrameStart, mode: InitMode) -> (String, serde_json::Value) {
    let mode_name = format!("{mode:?}").to_lowercase();
    match *start {
        FrameStart::Searched { score, stored } => {
            let why = match stored {
                Some(s) => format!(
                    "the stored pose explained {:.0}% of the points, the search {:.0}%",
                    100.0 * s,
                    100.0 * score
                ),
                None => format!(
                    "--init search; it explains {:.0}% of the points",
                    100.0 * score
                ),
            };
            (
                format!("first frame: started from the search ({why})\n"),
                json!({ "mode": mode_name, "chose": "search", "score": score, "stored_score": stored }),
            )
        }
        FrameStart::Stored { score, searched } => {
            let why = match searched {
                Some(s) => format!(
                    "it explained {:.0}% of the points, the search {:.0}%",
                    100.0 * score,
                    100.0 * s
                ),
                None => format!("it explains {:.0}% of the points", 100.0 * score),
            };
            (
                format!("first frame: started from the rig's stored pose ({why})\n"),
                json!({ "mode": mode_name, "chose": "stored", "score": score, "search_score": searched }),
            )
        }
        _ => (String::new(), json!({ "mode": mode_name })),
    }
}

/// The report's fields for a frame that collapsed (nothing for other frames).
fn collapse_json(start: &FrameStart) -> Option<serde_json::Value> {
    match *start {
        FrameStart::Collapsed {
            inliers,
            expected,
            tracked_score,
            search_score,
            recovered,
        } => Some(json!({
            "inliers": inliers,
            "expected_inliers": expected,
            "tracked_score": tracked_score,
            "search_score": search_score,
            "recovered": recovered,
        })),
        _ => None,
    }
}

/// Tracks the frames and writes the outputs; returns the summary to print. Frames tracked
/// before a failing frame are written, their summary printed unless `quiet`, and the
/// failure returned.
pub fn run(args: &TrackArgs) -> anyhow::Result<String> {
    if let Some(picture) = &args.render {
        super::render::check_png_path(picture)?;
    }
    // Fractions of the height; past these bounds the kernels and grids lose all meaning.
    if !(1e-6..=1.0).contains(&args.noise) {
        bail!(
            "--noise: expected a fraction of the height from 0.000001 to 1, got {}",
            args.noise
        );
    }
    if let Some(problem) = rigfit_formats::rig_file::fps_problem(args.fps) {
        bail!("--fps: {problem}");
    }
    super::check_rig_options(&args.rig, args.skin.as_deref(), args.start_frame.as_deref())?;
    let outputs: Vec<&Path> = [&args.output, &args.report, &args.render]
        .into_iter()
        .flatten()
        .map(PathBuf::as_path)
        .collect();
    let mut inputs: Vec<&Path> = vec![&args.rig];
    inputs.extend(args.frames.iter().map(PathBuf::as_path));
    inputs.extend(args.truth.as_deref());
    inputs.extend(args.joints.as_deref());
    super::check_files(&inputs, &outputs)?;
    let rig_options = RigOptions {
        skin: args.skin.clone(),
        start_frame: super::pose::start_frame(args.start_frame.as_deref())?,
    };
    let truth = args.truth.as_deref().map(read_truth).transpose()?;
    let rig_file = read_rig(&args.rig, &rig_options)?;
    let rig_inputs = super::rig_inputs(&rig_file);
    inputs.extend(rig_inputs.iter().map(PathBuf::as_path));
    // The inputs were checked before reading (a glTF's buffers as they were read): only the
    // outputs are checked again, against the buffer files too.
    rigfit_formats::files::check_outputs(&inputs, &outputs)?;
    if let Some(out) = &args.output {
        rig_file.check_output_format(out)?;
    }
    let rig = &rig_file.rig;
    let mut options = match args.method {
        TrackMethod::Rigfit => TrackOptions::default(),
        TrackMethod::Paper => TrackOptions::paper(),
    };
    options.noise = args.noise;
    if let Some(m) = args.max_motion {
        if !(m > 0.0 && m <= 10.0) {
            bail!(
                "--max-motion: expected a fraction of the height above 0 and at most 10, got {m}"
            );
        }
        options.max_motion = m.max(args.noise);
    }
    // The joint model the tracker fits: the clips' hinges and ranges, then the joints file.
    let mut modelled = rig.clone();
    modelled.skeleton = with_clip_model(&rig.skeleton, &rig.animations);
    if let Some(path) = &args.joints {
        let model = rigfit_formats::joints_file::read_joints_file(path, &rig.skeleton)?;
        apply_joint_model(&mut modelled.skeleton, &model);
    }
    let model = ArticulatedModel::from_rig(&modelled, options.model_points)
        .map_err(|e| anyhow!("{}: {e}", args.rig.display()))?;
    let take_options = TakeOptions {
        start: args.init.start_mode(),
        recover: !args.no_recovery,
        ..TakeOptions::default()
    };
    let mut take = Take::new(model, options, take_options)
        .map_err(|e| anyhow!("{}: {e}", args.rig.display()))?;

    let shown = rigfit_render::pick_frames(args.frames.len(), 8);
    let mut shown_clouds: Vec<(usize, Vec<Point3>)> = Vec::new();
    let progress = if args.quiet {
        indicatif::ProgressBar::hidden()
    } else {
        indicatif::ProgressBar::new(args.frames.len() as u64)
    };
    progress.set_style(
        indicatif::ProgressStyle::with_template("tracking {bar:40} {pos}/{len} frames {msg}")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    let mut tracked: Vec<Tracked> = Vec::new();
    let mut failure: Option<anyhow::Error> = None;
    for (k, path) in args.frames.iter().enumerate() {
        let points = match read_points(path) {
            Ok(p) => p,
            Err(e) => {
                failure = Some(e);
                break;
            }
        };
        let t0 = Instant::now();
        let frame = match take.track(&points) {
            Ok(frame) => frame,
            Err(e) => {
                failure = Some(anyhow!("{}: {e}", path.display()));
                break;
            }
        };
        let seconds = t0.elapsed().as_secs_f64();
        let fit = frame.fit;
        progress.set_message(format!("{} inliers", fit.inliers));
        progress.inc(1);
        if args.render.is_some() && shown.contains(&k) {
            shown_clouds.push((k, points));
        }
        tracked.push(Tracked {
            file: path.display().to_string(),
            fit,
            start: frame.start,
            seconds,
        });
    }
    progress.finish_and_clear();

    // Frames tracked before a failure are written all the same; every output is made and
    // written to its temporary file before any is renamed into place.
    let mut summary = String::new();
    if !tracked.is_empty() {
        let poses: Vec<Pose> = tracked.iter().map(|t| t.fit.pose.clone()).collect();
        let (start_line, start_json) = first_frame_choice(&tracked[0].start, args.init);
        let mut staged = Vec::new();
        if let Some(out) = &args.output {
            staged.push(stage(out, &rig_file.poses_bytes(out, &poses, args.fps)?)?);
        }
        if let Some(report) = &args.report {
            let frames: Vec<serde_json::Value> = tracked
                .iter()
                .map(|t| {
                    let mut frame =
                        track_frame_json(rig, &t.fit.pose, &t.file, t.fit.inliers, t.seconds);
                    if let Some(collapse) = collapse_json(&t.start) {
                        frame["collapse"] = collapse;
                    }
                    frame
                })
                .collect();
            staged.push(stage(
                report,
                to_text(&json!({ "start": start_json, "frames": frames })).as_bytes(),
            )?);
        }
        if let Some(picture) = &args.render {
            let image = sheet(
                take.tracker(),
                &tracked,
                &shown_clouds,
                &args.picture,
                rig,
                truth.as_deref(),
            );
            staged.push(stage(picture, &super::render::png_bytes(picture, &image)?)?);
        }
        commit_all(staged)?;
        let total: f64 = tracked.iter().map(|t| t.seconds).sum();
        summary = start_line;
        let collapsed: Vec<(usize, bool)> = tracked
            .iter()
            .enumerate()
            .filter_map(|(k, t)| match t.start {
                FrameStart::Collapsed { recovered, .. } => Some((k, recovered)),
                _ => None,
            })
            .collect();
        if !collapsed.is_empty() {
            let list = |recovered: bool| {
                collapsed
                    .iter()
                    .filter(|c| c.1 == recovered)
                    .map(|c| c.0.to_string())
                    .collect::<Vec<_>>()
                    .join(", ")
            };
            let (found, kept) = (list(true), list(false));
            if !found.is_empty() {
                summary +=
                    &format!("frames whose fit collapsed, found again by the search: {found}\n");
            }
            if !kept.is_empty() {
                summary += &format!(
                    "frames whose fit collapsed, the search found nothing better: {kept}\n"
                );
            }
        }
        summary += &format!(
            "tracked {} of {} frames with {} in {:.1} ms per frame (mean {:.0} inliers)\n",
            tracked.len(),
            args.frames.len(),
            args.rig.display(),
            1000.0 * total / tracked.len() as f64,
            tracked.iter().map(|t| t.fit.inliers as f64).sum::<f64>() / tracked.len() as f64
        );
    }
    if failure.is_some() && !args.quiet {
        print!("{summary}");
    }
    match failure {
        Some(e) if tracked.is_empty() => Err(e),
        Some(e) => Err(e.context(format!(
            "stopped after {} tracked frame(s), which were written",
            tracked.len()
        ))),
        None => Ok(summary),
    }
}

/// The contact sheet of `--render`.
fn sheet(
    tracker: &Tracker,
    tracked: &[Tracked],
    clouds: &[(usize, Vec<Point3>)],
    picture: &super::render::PictureArgs,
    rig: &rigfit_core::Rig,
    truth: Option<&[std::collections::HashMap<String, Point3>]>,
) -> rigfit_render::Image {
    // Per frame, the mean distance over the joints the truth names, % of the height.
    let height = rig.height().max(1e-12);
    let error = truth.map(|truth| {
        tracked
            .iter()
            .zip(truth)
            .map(|(t, frame)| {
                let positions = rig.skeleton.joint_positions(&t.fit.pose);
                let (sum, n) = rig
                    .reported_joints()
                    .filter_map(|j| {
                        let name = &rig.skeleton.joint(j).name;
                        frame.get(name).map(|p| (positions[j] - p).norm())
                    })
                    .fold((0.0, 0usize), |(s, n), d| (s + d, n + 1));
                if n == 0 {
                    f64::NAN
                } else {
                    100.0 * sum / n as f64 / height
                }
            })
            .collect()
    });
    let skeleton = &tracker.model().skeleton;
    let frames: Vec<(String, rigfit_render::Scene)> = clouds
        .iter()
        .map(|(k, points)| {
            let mut scene = rigfit_render::Scene::new();
            scene
                .add_skeleton(skeleton, &tracked[*k].fit.pose)
                .add_points(points, Some(&tracked[*k].fit.inlier));
            (format!("frame {k}"), scene)
        })
        .collect();
    let stats = rigfit_render::FrameStats {
        error,
        error_label: "mean joint error (% of height)".into(),
        inliers: tracked.iter().map(|t| t.fit.inliers as f64).collect(),
        seconds: tracked.iter().map(|t| t.seconds).collect(),
    };
    let mut first = rigfit_render::Scene::new();
    first.add_rig(rig, &rig.pose);
    let options = picture.options(frames.first().map_or(&first, |f| &f.1));
    rigfit_render::tracking_sheet(&frames, &stats, &options)
}
