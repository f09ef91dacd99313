//! `rigfit pose RIG STROKES`: pose a rigged character so its bones follow 3D strokes.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::anyhow;
use rigfit_core::joint_model::{apply_joint_model, with_clip_ranges};
use rigfit_core::pose::{PoseOptions, PoseProblem, PoseResult, solve_pose};
use rigfit_formats::files::{commit_all, stage};
use rigfit_formats::report::{pose_report, to_text};
use rigfit_formats::rig_file::{RigFile, RigOptions, StartFrame, read_rig};

/// Which solver to run.
#[derive(Debug, Clone, Copy, clap::ValueEnum, PartialEq, Eq)]
pub enum Method {
    /// rigfit: beautified strokes, rigid multi-start, one chain of bones per stroke.
    Rigfit,
    /// The method as published: softassign with annealing over all bones.
    Paper,
}

#[derive(Debug, clap::Args)]
pub struct PoseArgs {
    /// The rig: .glb / .gltf with a skin, or .bvh.
    pub rig: PathBuf,
    /// The strokes JSON (see interfaces.md).
    pub strokes: PathBuf,
    /// Output rig: .glb/.gltf (the input with the pose as node rotations and a `rigfit`
    /// animation key) or .bvh.
    #[arg(short, long)]
    pub output: Option<PathBuf>,
    /// Write a JSON report: joint positions and rotations, the bones of each stroke.
    #[arg(long)]
    pub report: Option<PathBuf>,
    /// Only these joints may move (comma-separated names).
    #[arg(long, value_delimiter = ',')]
    pub bones: Option<Vec<String>>,
    /// Key the pose at this frame of the output, keeping its other keys.
    #[arg(long)]
    pub frame: Option<usize>,
    /// The glTF skin to pose (by name); the first by default.
    #[arg(long)]
    pub skin: Option<String>,
    /// BVH: the frame the solver starts from (a number, or `rest` for all channels zero).
    #[arg(long)]
    pub start_frame: Option<String>,
    /// A joints file (JSON, see README): which joints are hinges (with their axis) or
    /// fixed, and the range each turns through. Without it every joint that turns is a ball,
    /// with the ranges the rig's clips show.
    #[arg(long, value_name = "FILE.json")]
    pub joints: Option<PathBuf>,
    /// The solver.
    #[arg(long, value_enum, default_value = "rigfit")]
    pub method: Method,
    /// Draw the start pose and the result side by side into this .png, each stroke in the
    /// colour of the bones it was matched to (strays grey).
    #[arg(long, value_name = "FILE.png")]
    pub render: Option<PathBuf>,
    #[command(flatten)]
    pub picture: super::render::PictureArgs,
}

/// Parses `--start-frame`.
pub fn start_frame(arg: Option<&str>) -> anyhow::Result<StartFrame> {
    match arg {
        None => Ok(StartFrame::First),
        Some("rest") => Ok(StartFrame::Rest),
        Some(n) => n
            .parse()
            .map(StartFrame::Frame)
            .map_err(|_| anyhow!("--start-frame: expected a frame number or 'rest', got '{n}'")),
    }
}

/// Solves the pose for a loaded rig; errors name the file they come from.
pub fn solve(
    rig_file: &RigFile,
    strokes_path: &Path,
    strokes: &[rigfit_core::Stroke],
    bones: Option<&[String]>,
    method: Method,
) -> anyhow::Result<(PoseResult, f64)> {
    let rig = &rig_file.rig;
    let problem = PoseProblem {
        skeleton: &rig.skeleton,
        start: &rig.pose,
        strokes,
        movable: bones,
        height: rig.height(),
    };
    let options = match method {
        Method::Rigfit => PoseOptions::default(),
        Method::Paper => PoseOptions::paper(),
    };
    let t0 = Instant::now();
    let result = solve_pose(&problem, &options).map_err(|e| match e {
        e if e.is_rig_problem() => anyhow!("{}: {e}", rig_file.path.display()),
        _ => anyhow!("{}: {e}", strokes_path.display()),
    })?;
    Ok((result, t0.elapsed().as_secs_f64()))
}

/// Poses the rig and writes the outputs; returns the summary to print (lines ending in `\n`).
pub fn run(args: &PoseArgs) -> anyhow::Result<String> {
    super::check_rig_options(&args.rig, args.skin.as_deref(), args.start_frame.as_deref())?;
    let options = RigOptions {
        skin: args.skin.clone(),
        start_frame: start_frame(args.start_frame.as_deref())?,
    };
    if let Some(picture) = &args.render {
        super::render::check_png_path(picture)?;
    }
    let outputs: Vec<&Path> = [&args.output, &args.report, &args.render]
        .into_iter()
        .flatten()
        .map(PathBuf::as_path)
        .collect();
    let mut inputs: Vec<&Path> = vec![&args.rig, &args.strokes];
    inputs.extend(args.joints.as_deref());
    super::check_files(&inputs, &outputs)?;
    let mut rig_file = read_rig(&args.rig, &options)?;
    // Leaf bones need a length to be drawn along and fitted; the ranges the rig's clips show
    // choose among poses that explain the strokes alike.
    rig_file.rig.tip_skinned_leaves();
    let rig = &mut rig_file.rig;
    rig.skeleton = with_clip_ranges(&rig.skeleton, &rig.animations);
    if let Some(path) = &args.joints {
        let model = rigfit_formats::joints_file::read_joints_file(path, &rig_file.rig.skeleton)?;
        apply_joint_model(&mut rig_file.rig.skeleton, &model);
    }
    let rig_inputs = super::rig_inputs(&rig_file);
    inputs.extend(rig_inputs.iter().map(PathBuf::as_path));
    // The inputs were checked before reading (a glTF's buffers as they were read): only the
    // outputs are checked again, against the buffer files too.
    rigfit_formats::files::check_outputs(&inputs, &outputs)?;
    if let Some(out) = &args.output {
        rig_file.check_output_format(out)?;
    }
    if let (Some(out), Some(n)) = (&args.output, args.frame) {
        rig_file.check_frame(out, n)?;
    }
    if rig_file.rig.meshes.is_empty()
        && matches!(
            rig_file.source,
            rigfit_formats::rig_file::RigSource::Gltf(_)
        )
    {
        tracing::warn!(
            "{}: the skin has no mesh; posing the skeleton alone",
            args.rig.display()
        );
    }
    let strokes = rigfit_formats::strokes::read_strokes(&args.strokes)?;
    let (result, seconds) = solve(
        &rig_file,
        &args.strokes,
        &strokes,
        args.bones.as_deref(),
        args.method,
    )?;
    // Every output is made and written to its temporary file before any is renamed into
    // place: a failure leaves none of them.
    let mut staged = Vec::new();
    if let Some(out) = &args.output {
        staged.push(stage(
            out,
            &rig_file.pose_bytes(out, &result.pose, args.frame)?,
        )?);
    }
    if let Some(report) = &args.report {
        let value = pose_report(
            &rig_file.rig,
            &result.pose,
            &result.stroke_bones,
            result.iterations,
            result.energy,
            seconds,
        );
        staged.push(stage(report, to_text(&value).as_bytes())?);
    }
    if let Some(picture) = &args.render {
        let image = side_by_side(&rig_file.rig, &strokes, &result, &args.picture);
        staged.push(stage(picture, &super::render::png_bytes(picture, &image)?)?);
    }
    commit_all(staged)?;
    let matched = result.stroke_bones.iter().filter(|b| !b.is_empty()).count();
    let mut summary = format!(
        "posed {} from {} strokes ({} matched to bones, {} set aside) in {:.1} ms\n",
        args.rig.display(),
        strokes.len(),
        matched,
        strokes.len() - matched,
        seconds * 1000.0
    );
    for (i, bones) in result.stroke_bones.iter().enumerate() {
        let names: Vec<&str> = bones
            .iter()
            .map(|&j| rig_file.rig.skeleton.joint(j).name.as_str())
            .collect();
        let names = if names.is_empty() {
            "(stray)".to_string()
        } else {
            names.join(" > ")
        };
        summary.push_str(&format!("  stroke {i}: {names}\n"));
    }
    Ok(summary)
}

/// The start pose and the result side by side, the strokes over both, each stroke in the
/// colour of the bones it was matched to.
pub fn side_by_side(
    rig: &rigfit_core::Rig,
    strokes: &[rigfit_core::Stroke],
    result: &PoseResult,
    picture: &super::render::PictureArgs,
) -> rigfit_render::Image {
    let joint_colors = rigfit_render::chain_colors(&rig.skeleton);
    let stroke_colors = rigfit_render::stroke_colors(&result.stroke_bones, &joint_colors);
    let mut start = rigfit_render::Scene::new();
    start
        .add_rig(rig, &rig.pose)
        .add_strokes(strokes, &stroke_colors);
    let mut posed = rigfit_render::Scene::new();
    posed
        .add_rig(rig, &result.pose)
        .add_strokes(strokes, &stroke_colors);
    let options = picture.options(&posed);
    rigfit_render::render_side_by_side(&[("start", &start), ("result", &posed)], &options)
}
