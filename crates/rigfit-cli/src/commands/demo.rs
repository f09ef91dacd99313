//! `rigfit demo`: the main job on the built-in humanoid, with nothing downloaded. The
//! humanoid is posed by its own wave animation, strokes are drawn through its limbs (with a
//! little hand jitter), and rigfit poses the rest-pose humanoid from those strokes alone.
//! Beside the files, `demo.png` shows the start pose and the result side by side (the picture
//! of `rigfit pose --render`).

use std::path::PathBuf;
use std::time::Instant;

use rand::SeedableRng;
use rigfit_core::pose::sketch::{CaseOptions, make_case, mean_joint_error};
use rigfit_core::pose::{PoseOptions, PoseProblem, solve_pose};
use rigfit_formats::files::{commit_all, stage};
use rigfit_formats::report::{pose_report, to_text};

#[derive(Debug, clap::Args)]
pub struct DemoArgs {
    /// Where to write humanoid.glb (rest pose), strokes.json, posed.glb, report.json and
    /// demo.png (the start pose and the result side by side, from the front).
    #[arg(short, long, default_value = "rigfit-demo")]
    output: PathBuf,
}

pub fn run(args: &DemoArgs) -> anyhow::Result<()> {
    std::fs::create_dir_all(&args.output).map_err(|e| {
        anyhow::anyhow!(
            "{}: cannot create the directory: {e}",
            args.output.display()
        )
    })?;
    let rig = rigfit_core::humanoid::humanoid();
    let height = rig.height();
    let truth = rig.animations[0].sample(&rig.pose, 1.0);
    let mut rng = rand::rngs::StdRng::seed_from_u64(7);
    let case = make_case(
        &rig.skeleton,
        &truth,
        height,
        &CaseOptions {
            noise: 0.005,
            ..Default::default()
        },
        &mut rng,
    );
    let problem = PoseProblem {
        skeleton: &rig.skeleton,
        start: &rig.pose,
        strokes: &case.strokes,
        movable: None,
        height,
    };
    let t0 = Instant::now();
    let result = solve_pose(&problem, &PoseOptions::default())?;
    let seconds = t0.elapsed().as_secs_f64();
    let error = mean_joint_error(
        &rig.skeleton,
        &result.pose,
        &truth,
        &case.drawn_joints,
        height,
    );

    let rest_path = args.output.join("humanoid.glb");
    let mut posed = rig.clone();
    posed.pose = result.pose.clone();
    let report = pose_report(
        &rig,
        &result.pose,
        &result.stroke_bones,
        result.iterations,
        result.energy,
        seconds,
    );
    let picture_path = args.output.join("demo.png");
    let picture = super::pose::side_by_side(&rig, &case.strokes, &result, &demo_picture());
    // All five written to temporaries first, then renamed together.
    let staged = vec![
        stage(&rest_path, &rigfit_formats::gltf::rig_to_glb(&rig))?,
        stage(
            &args.output.join("strokes.json"),
            rigfit_formats::strokes::strokes_json(&case.strokes).as_bytes(),
        )?,
        stage(
            &args.output.join("posed.glb"),
            &rigfit_formats::gltf::rig_to_glb(&posed),
        )?,
        stage(
            &args.output.join("report.json"),
            to_text(&report).as_bytes(),
        )?,
        stage(
            &picture_path,
            &super::render::png_bytes(&picture_path, &picture)?,
        )?,
    ];
    commit_all(staged)?;

    println!(
        "rigfit demo: posing the built-in humanoid ({} joints, height {height:.2}) from {} strokes",
        rig.skeleton.len(),
        case.strokes.len()
    );
    for (i, bones) in result.stroke_bones.iter().enumerate() {
        let names: Vec<&str> = bones
            .iter()
            .map(|&j| rig.skeleton.joint(j).name.as_str())
            .collect();
        println!("  stroke {i}: {}", names.join(" > "));
    }
    println!(
        "solved in {:.1} ms ({} iterations); mean joint error {:.2}% of the height",
        seconds * 1000.0,
        result.iterations,
        error * 100.0
    );
    println!(
        "wrote {}/{{humanoid.glb, strokes.json, posed.glb, report.json, demo.png}}",
        args.output.display()
    );
    println!(
        "picture: {} (start | result, {} x {})",
        picture_path.display(),
        picture.width(),
        picture.height()
    );
    println!(
        "try: rigfit pose {} {} -o posed.glb --report report.json",
        rest_path.display(),
        args.output.join("strokes.json").display()
    );
    Ok(())
}

/// How `demo.png` is drawn: one front view per panel (the wave reads best from the front),
/// 400-pixel tiles, so the two panels make a picture wider than tall.
fn demo_picture() -> super::render::PictureArgs {
    super::render::PictureArgs {
        tile: 400,
        views: vec![super::render::ViewArg::Front],
    }
}
