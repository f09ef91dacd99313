//! `rigfit render` and `rigfit pose --render` end to end: every real asset drawn to a PNG of
//! the right size with content, the pose picture, and bad input.

mod common;

use std::path::Path;

use common::*;
use rigfit_core::Point3;
use rigfit_formats::rig_file::{RigOptions, read_rig};
use rigfit_render::color::BACKGROUND;
use rigfit_render::{
    Color, Image, RenderOptions, Scene, chain_colors, render_cameras, side_by_side_cameras,
    stroke_colors,
};

fn s(p: &Path) -> &str {
    p.to_str().expect("utf-8 path")
}

/// The scene `rigfit render` draws for one file, rebuilt here to find where things project.
fn scene_of(path: &Path) -> (Scene, Vec<Point3>) {
    let mut scene = Scene::new();
    let points = if path.extension().is_some_and(|e| e == "ply") {
        let mesh = rigfit_formats::ply::read_ply(path).expect("mesh");
        scene.add_mesh(&mesh);
        mesh.vertices
    } else {
        let rig = read_rig(path, &RigOptions::default()).expect("rig").rig;
        scene.add_rig(&rig, &rig.pose);
        let joints = rig.skeleton.joint_positions(&rig.pose);
        rig.reported_joints().map(|j| joints[j]).collect()
    };
    (scene, points)
}

#[test]
fn renders_every_real_asset_where_its_geometry_projects() {
    let dir = tempfile::tempdir().expect("temp dir");
    let files = rigfit_testkit::assets::GLTF_RIGS
        .into_iter()
        .chain(["cmu/01_01.bvh", "bunny/bunny.ply"]);
    for file in files {
        let input = data(file);
        let out = dir.path().join("picture.png");
        let o = rigfit(&["render", s(&input), "-o", s(&out), "--tile", "200"]);
        assert!(o.status.success(), "{file}: {}", stderr(&o));
        assert!(
            stderr(&o).is_empty(),
            "{file}: nothing on stderr: {}",
            stderr(&o)
        );
        let (w, h, _) = png_size(&out);
        assert_eq!((w, h), (600, 200), "{file}");
        let image = Image::from_png(&std::fs::read(&out).expect("read")).expect("decodes");
        let drawn = (0..h)
            .flat_map(|y| (0..w).map(move |x| (x, y)))
            .filter(|&(x, y)| image.pixel(x, y) != Some(BACKGROUND))
            .count();
        assert!(drawn > 600, "{file}: {drawn} drawn pixels looks blank");
        let (scene, points) = scene_of(&input);
        let options = RenderOptions {
            tile: 200,
            ..Default::default()
        };
        for camera in render_cameras(&scene, &options) {
            for p in points.iter().step_by(7) {
                let (x, y, _) = camera.project(p);
                let near = (-2i64..=2).any(|dy| {
                    (-2i64..=2).any(|dx| {
                        let (px, py) = (x.round() as i64 + dx, y.round() as i64 + dy);
                        px >= 0
                            && py >= 0
                            && image
                                .pixel(px as u32, py as u32)
                                .is_some_and(|c| c != BACKGROUND)
                    })
                });
                assert!(
                    near,
                    "{file}: nothing drawn at {p:?} in the {:?} view",
                    camera.view
                );
            }
        }
    }
}

#[test]
fn overlays_several_inputs_and_takes_views() {
    let dir = tempfile::tempdir().expect("temp dir");
    let strokes = dir.path().join("strokes.json");
    std::fs::write(
        &strokes,
        r#"{"strokes": [{"points": [[0, 0, 0], [0.5, 1.0, 0.2], [0.6, 1.6, 0.1]]}]}"#,
    )
    .expect("strokes");
    let out = dir.path().join("both.png");
    let rig = data("assimp/BCN_Epileptic.glb");
    let o = rigfit(&[
        "render",
        s(&rig),
        s(&strokes),
        "-o",
        s(&out),
        "--views",
        "front,side",
        "--tile",
        "256",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(png_size(&out).0, 512);
    assert!(stdout(&o).contains("from 2 file(s)"), "{}", stdout(&o));
    // `auto`: the two views that show the most.
    let hand = data("webxr_hand/left.glb");
    let o = rigfit(&[
        "render",
        s(&hand),
        "-o",
        s(&out),
        "--views",
        "auto",
        "--tile",
        "128",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!((png_size(&out).0, png_size(&out).1), (256, 128));
}

#[test]
fn pose_render_draws_start_and_result_side_by_side_strokes_in_their_bones_colours() {
    let dir = tempfile::tempdir().expect("temp dir");
    let demo = dir.path().join("demo");
    let o = rigfit(&["demo", "-o", s(&demo)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let (rig_path, strokes_path) = (demo.join("humanoid.glb"), demo.join("strokes.json"));
    let (picture, posed, report) = (
        dir.path().join("pose.png"),
        dir.path().join("posed.glb"),
        dir.path().join("report.json"),
    );
    let o = rigfit(&[
        "pose",
        s(&rig_path),
        s(&strokes_path),
        "-o",
        s(&posed),
        "--report",
        s(&report),
        "--render",
        s(&picture),
        "--tile",
        "300",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    // Two panels (start, result) of three views each, one below the other.
    let (w, h, _) = png_size(&picture);
    assert_eq!((w, h), (600, 900));
    let image = Image::from_png(&std::fs::read(&picture).expect("read")).expect("decodes");

    // Rebuild both scenes to know where each stroke lands and which colour it must have.
    let start = read_rig(&rig_path, &RigOptions::default())
        .expect("rig")
        .rig;
    let result = read_rig(&posed, &RigOptions::default()).expect("posed").rig;
    let strokes = rigfit_formats::strokes::read_strokes(&strokes_path).expect("strokes");
    let report: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&report).expect("report")).expect("JSON");
    let stroke_bones: Vec<Vec<usize>> = report["strokes"]
        .as_array()
        .expect("strokes")
        .iter()
        .map(|st| {
            st["bones"]
                .as_array()
                .expect("bones")
                .iter()
                .map(|b| {
                    start
                        .skeleton
                        .find(b.as_str().expect("name"))
                        .expect("known bone")
                })
                .collect()
        })
        .collect();
    let colors = stroke_colors(&stroke_bones, &chain_colors(&start.skeleton));
    assert!(
        colors.iter().any(|&c| c != colors[0]),
        "strokes get different colours"
    );
    let (mut before, mut after) = (Scene::new(), Scene::new());
    before
        .add_rig(&start, &start.pose)
        .add_strokes(&strokes, &colors);
    after
        .add_rig(&result, &result.pose)
        .add_strokes(&strokes, &colors);
    let options = RenderOptions {
        tile: 300,
        ..Default::default()
    };
    let cameras = side_by_side_cameras(&[("start", &before), ("result", &after)], &options);
    let close = |a: Color, b: Color| {
        (a.r as i32 - b.r as i32).abs()
            + (a.g as i32 - b.g as i32).abs()
            + (a.b as i32 - b.b as i32).abs()
            < 12
    };
    for panel in &cameras {
        let camera = panel[0]; // front
        for (stroke, &color) in strokes.iter().zip(&colors) {
            let p = stroke.points[stroke.points.len() / 2];
            let (x, y, _) = camera.project(&p);
            let found = (-1i64..=1).any(|dy| {
                (-1i64..=1).any(|dx| {
                    image
                        .pixel(
                            (x.round() as i64 + dx) as u32,
                            (y.round() as i64 + dy) as u32,
                        )
                        .is_some_and(|c| close(c, color))
                })
            });
            assert!(found, "stroke at {p:?} is drawn in {color:?}");
        }
    }
}

#[test]
fn bad_input_gets_exit_2_and_one_line() {
    let dir = tempfile::tempdir().expect("temp dir");
    let out = dir.path().join("x.png");
    // A file that does not parse.
    let broken = dir.path().join("broken.ply");
    std::fs::write(
        &broken,
        "ply\nformat ascii 1.0\nelement vertex 3\nend_header\n1 2\n",
    )
    .expect("write");
    assert_bad_input(&rigfit(&["render", s(&broken), "-o", s(&out)]), &broken);
    // The damaged real scan (its Debian package lost bytes).
    let pond = data("assimp/pond.0.ply");
    assert_bad_input(&rigfit(&["render", s(&pond), "-o", s(&out)]), &pond);
    // An unknown file type.
    let text = dir.path().join("notes.txt");
    std::fs::write(&text, "hello").expect("write");
    assert_bad_input(&rigfit(&["render", s(&text), "-o", s(&out)]), &text);
    assert!(!out.exists(), "no picture after a failure");
    // An output that cannot be written: a missing folder, a folder, not a .png.
    let bunny = data("bunny/bunny.ply");
    for bad in [
        Path::new("/nonexistent/dir/x.png").to_path_buf(),
        dir.path().join("x.jpg"),
    ] {
        assert_bad_input(&rigfit(&["render", s(&bunny), "-o", s(&bad)]), &bad);
    }
    let folder = dir.path().join("folder.png");
    std::fs::create_dir(&folder).expect("mkdir");
    assert_bad_input(&rigfit(&["render", s(&bunny), "-o", s(&folder)]), &folder);
    // pose --render checks the picture's path before solving.
    let rig = data("assimp/BCN_Epileptic.glb");
    let strokes = dir.path().join("strokes.json");
    std::fs::write(
        &strokes,
        r#"{"strokes": [{"points": [[0, 0, 0], [0, 1, 0]]}]}"#,
    )
    .expect("write");
    let bad = Path::new("/nonexistent/dir/pose.png");
    let o = rigfit(&["pose", s(&rig), s(&strokes), "--render", s(bad)]);
    assert_bad_input(&o, bad);
    assert!(stdout(&o).is_empty(), "nothing solved: {}", stdout(&o));
}
