//! The pictures of docs/img/render_*.png, one of each kind `rigfit-render` draws: a rig,
//! a mesh, a tracked-looking point cloud with outliers, strokes, `pose --render` (start and
//! result side by side) and a `track --render`-style contact sheet with per-frame plots
//! (01_01.bvh posed frame by frame from strokes, each frame starting from the last).
//!
//! `cargo run --release -p rigfit-testkit --example render_gallery [OUT_DIR]` (default docs/img)

use std::path::{Path, PathBuf};
use std::time::Instant;

use rand::{Rng, SeedableRng};
use rigfit_core::pose::sketch::{CaseOptions, make_case, mean_joint_error};
use rigfit_core::pose::{PoseOptions, PoseProblem, solve_pose};
use rigfit_core::{Point3, Vector3};
use rigfit_formats::rig_file::{RigOptions, StartFrame, read_rig};
use rigfit_render::{
    FrameStats, Image, RenderOptions, Scene, View, chain_colors, pick_frames, render,
    render_side_by_side, stroke_colors, tracking_sheet,
};
use rigfit_testkit::pose_suites::case_from_clip;

fn write(image: &Image, dir: &Path, name: &str) {
    let path = dir.join(name);
    let bytes = image.png().expect("PNG encoding");
    rigfit_formats::error::write_atomic(&path, &bytes).expect("writing the picture");
    println!(
        "wrote {} ({} x {})",
        path.display(),
        image.width(),
        image.height()
    );
}

fn main() {
    let dir = PathBuf::from(std::env::args().nth(1).unwrap_or_else(|| "docs/img".into()));
    std::fs::create_dir_all(&dir).expect("output folder");
    let options = RenderOptions {
        tile: 320,
        ..Default::default()
    };
    let asset = rigfit_testkit::assets::asset;

    // A rig: skinned mesh shaded flat, skeleton on top.
    let bcn = read_rig(&asset("assimp/BCN_Epileptic.glb"), &RigOptions::default()).expect("rig");
    let mut scene = Scene::new();
    scene.add_rig(&bcn.rig, &bcn.rig.pose);
    write(&render(&scene, &options), &dir, "render_rig.png");

    // A mesh.
    let bunny = rigfit_formats::ply::read_ply(&asset("bunny/bunny.ply")).expect("bunny");
    let mut scene = Scene::new();
    scene.add_mesh(&bunny);
    write(&render(&scene, &options), &dir, "render_mesh.png");

    // A cloud as a tracker sees it: 10,000 points on the humanoid's surface, 10% outliers.
    let humanoid = rigfit_core::humanoid::humanoid();
    let pose = humanoid.animations[0].sample(&humanoid.pose, 0.8);
    let world = humanoid.skeleton.world_matrices(&pose);
    let mut triangles = Vec::new();
    for mesh in &humanoid.meshes {
        let (v, _) = mesh.skin(&world);
        triangles.extend(mesh.triangles.iter().map(|t| t.map(|i| v[i as usize])));
    }
    let mut rng = rand::rngs::StdRng::seed_from_u64(8);
    let (mut cloud, mut inliers) = (Vec::new(), Vec::new());
    for i in 0..10_000 {
        let [a, b, c] = triangles[rng.random_range(0..triangles.len())];
        let (mut u, mut v): (f64, f64) = (rng.random(), rng.random());
        if u + v > 1.0 {
            (u, v) = (1.0 - u, 1.0 - v);
        }
        let mut p: Point3 = a + (b - a) * u + (c - a) * v;
        if i % 10 == 0 {
            p += Vector3::new(
                rng.random::<f64>() - 0.5,
                rng.random::<f64>() - 0.5,
                rng.random::<f64>() - 0.5,
            ) * 0.6;
        }
        cloud.push(p);
        inliers.push(i % 10 != 0);
    }
    let mut scene = Scene::new();
    scene
        .add_points(&cloud, Some(&inliers))
        .add_skeleton(&humanoid.skeleton, &pose);
    write(&render(&scene, &options), &dir, "render_cloud.png");

    // Strokes, and pose --render: BCN_Epileptic posed like its clip at 1.5 s from strokes
    // with one stray.
    let rig = &bcn.rig;
    let truth = rig.animations[0].sample(&rig.pose, 1.5);
    let mut rng = rand::rngs::StdRng::seed_from_u64(5);
    let case = make_case(
        &rig.skeleton,
        &truth,
        rig.height(),
        &CaseOptions {
            stray_strokes: 1,
            ..Default::default()
        },
        &mut rng,
    );
    let mut scene = Scene::new();
    scene.add_strokes(&case.strokes, &[]);
    write(&render(&scene, &options), &dir, "render_strokes.png");
    let problem = PoseProblem {
        skeleton: &rig.skeleton,
        start: &rig.pose,
        strokes: &case.strokes,
        movable: None,
        height: rig.height(),
    };
    let result = solve_pose(&problem, &PoseOptions::default()).expect("solves");
    let colors = stroke_colors(&result.stroke_bones, &chain_colors(&rig.skeleton));
    let (mut start, mut posed) = (Scene::new(), Scene::new());
    start
        .add_rig(rig, &rig.pose)
        .add_strokes(&case.strokes, &colors);
    posed
        .add_rig(rig, &result.pose)
        .add_strokes(&case.strokes, &colors);
    write(
        &render_side_by_side(&[("start", &start), ("result", &posed)], &options),
        &dir,
        "render_pose.png",
    );

    // A contact sheet with per-frame plots: 48 frames of 01_01.bvh, each posed from strokes
    // drawn through the true joints, starting from the previous frame's result.
    let bvh = read_rig(
        &asset("cmu/01_01.bvh"),
        &RigOptions {
            start_frame: StartFrame::Rest,
            ..Default::default()
        },
    )
    .expect("bvh");
    let rig = &bvh.rig;
    let animation = &rig.animations[0];
    let frame_time = animation.frame_time.expect("timed frames");
    let solved_frames = pick_frames(animation.frame_count(), 48);
    let shown = pick_frames(solved_frames.len(), 8);
    let mut previous = rig.pose.clone();
    let mut stats = FrameStats {
        error: Some(Vec::new()),
        error_label: "mean joint error (% of height)".into(),
        ..Default::default()
    };
    let mut sheet = Vec::new();
    for (k, &frame) in solved_frames.iter().enumerate() {
        let (truth, case) = case_from_clip(rig, frame as f64 * frame_time, frame as u64);
        let problem = PoseProblem {
            skeleton: &rig.skeleton,
            start: &previous,
            strokes: &case.strokes,
            movable: None,
            height: rig.height(),
        };
        let t0 = Instant::now();
        let result = solve_pose(&problem, &PoseOptions::default()).expect("solves");
        stats.seconds.push(t0.elapsed().as_secs_f64());
        let matched: usize = case
            .strokes
            .iter()
            .zip(&result.stroke_bones)
            .filter(|(_, bones)| !bones.is_empty())
            .map(|(s, _)| s.points.len())
            .sum();
        stats.inliers.push(matched as f64);
        if let Some(error) = stats.error.as_mut() {
            error.push(
                100.0
                    * mean_joint_error(
                        &rig.skeleton,
                        &result.pose,
                        &truth,
                        &case.drawn_joints,
                        rig.height(),
                    ),
            );
        }
        if shown.contains(&k) {
            let colors = stroke_colors(&result.stroke_bones, &chain_colors(&rig.skeleton));
            let mut scene = Scene::new();
            scene
                .add_skeleton(&rig.skeleton, &result.pose)
                .add_strokes(&case.strokes, &colors);
            sheet.push((format!("frame {frame}"), scene));
        }
        previous = result.pose;
    }
    let sheet_options = RenderOptions {
        tile: 240,
        views: vec![View::Front, View::Top],
    };
    write(
        &tracking_sheet(&sheet, &stats, &sheet_options),
        &dir,
        "render_contact_sheet.png",
    );
}
