//! `rigfit pose` and `rigfit demo` end to end: real rigs, output files, reports, options and
//! bad input.

mod common;

use std::path::Path;

use common::*;
use rigfit_core::Stroke;
use rigfit_formats::rig_file::{RigOptions, StartFrame, read_rig};
use rigfit_testkit::pose_suites::case_from_clip;
use serde_json::Value;

fn s(p: &Path) -> &str {
    p.to_str().expect("utf-8 path")
}

/// Strokes drawn through the joints of `rig_path` posed by its own animation at `time`
/// (BVH: frame index), written to `out`; returns the true joint positions by name.
fn draw_case(rig_path: &Path, frame_or_time: f64, out: &Path) -> Vec<(String, [f64; 3])> {
    let file = read_rig(
        rig_path,
        &RigOptions {
            start_frame: StartFrame::Rest,
            ..Default::default()
        },
    )
    .expect("rig");
    let rig = &file.rig;
    let t = rig.animations[0]
        .frame_time
        .map_or(frame_or_time, |dt| frame_or_time * dt);
    let (truth, case) = case_from_clip(rig, t, 5);
    rigfit_formats::strokes::write_strokes(out, &case.strokes).expect("write strokes");
    let positions = rig.skeleton.joint_positions(&truth);
    case.drawn_joints
        .iter()
        .map(|&j| {
            (
                rig.skeleton.joint(j).name.clone(),
                [positions[j].x, positions[j].y, positions[j].z],
            )
        })
        .collect()
}

/// A folder holding the built-in humanoid as `humanoid.glb` (written by `rigfit demo-rig`),
/// its path, and where each of its joints is in the stored pose.
fn demo_humanoid() -> (
    tempfile::TempDir,
    std::path::PathBuf,
    impl Fn(&str) -> rigfit_core::Point3,
) {
    let dir = tempfile::tempdir().expect("temp dir");
    let rig_path = dir.path().join("humanoid.glb");
    assert!(rigfit(&["demo-rig", "-o", s(&rig_path)]).status.success());
    let rig = rigfit_core::humanoid::humanoid();
    let positions = rig.skeleton.joint_positions(&rig.pose);
    let at = move |name: &str| positions[rig.skeleton.find(name).expect("joint")];
    (dir, rig_path, at)
}

fn report_position(report: &Value, name: &str) -> [f64; 3] {
    let joint = report["joints"]
        .as_array()
        .expect("joints")
        .iter()
        .find(|j| j["name"] == name)
        .unwrap_or_else(|| panic!("joint {name} in the report"));
    let p = joint["position"].as_array().expect("position");
    [0, 1, 2].map(|i| p[i].as_f64().expect("number"))
}

fn read_json(p: &Path) -> Value {
    serde_json::from_slice(&std::fs::read(p).expect("report")).expect("JSON")
}

#[test]
fn poses_a_gltf_character_and_writes_rig_and_report() {
    let dir = tempfile::tempdir().expect("temp dir");
    let rig = data("assimp/BCN_Epileptic.glb");
    let strokes = dir.path().join("strokes.json");
    let truth = draw_case(&rig, 1.5, &strokes);
    let (out, report) = (dir.path().join("posed.glb"), dir.path().join("report.json"));
    let o = rigfit(&[
        "pose",
        s(&rig),
        s(&strokes),
        "-o",
        s(&out),
        "--report",
        s(&report),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let r = read_json(&report);
    assert_eq!(
        r["joints"].as_array().expect("joints").len(),
        54,
        "every skin joint is reported"
    );
    assert_eq!(r["strokes"].as_array().expect("strokes").len(), 6);
    assert!(r["iterations"].as_u64().expect("iterations") > 0);
    let height = 1.81;
    let mean: f64 = truth
        .iter()
        .map(|(name, p)| {
            let q = report_position(&r, name);
            ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2) + (p[2] - q[2]).powi(2)).sqrt()
        })
        .sum::<f64>()
        / truth.len() as f64;
    assert!(mean < 0.02 * height, "mean joint error {mean}");
    // The output is the input file with the pose: same joints, a `rigfit` animation, and the
    // reported positions.
    let posed = read_rig(&out, &RigOptions::default()).expect("output reads back");
    assert_eq!(posed.rig.skeleton.len(), 55);
    assert!(posed.rig.animations.iter().any(|a| a.name == "rigfit"));
    assert!(
        posed.rig.animations.iter().any(|a| a.name == "Epileptisch"),
        "the original clip is kept"
    );
    let positions = posed.rig.skeleton.joint_positions(&posed.rig.pose);
    let j = posed.rig.skeleton.find("B_Hand_Left").expect("hand");
    let q = report_position(&r, "B_Hand_Left");
    assert!((positions[j] - rigfit_core::Point3::from(q)).norm() < 1e-5);
}

#[test]
fn poses_a_bvh_skeleton_from_its_rest_pose() {
    let dir = tempfile::tempdir().expect("temp dir");
    let rig = data("cmu/01_01.bvh");
    let strokes = dir.path().join("strokes.json");
    let truth = draw_case(&rig, 900.0, &strokes);
    let (out, report) = (dir.path().join("posed.bvh"), dir.path().join("report.json"));
    let o = rigfit(&[
        "pose",
        s(&rig),
        s(&strokes),
        "-o",
        s(&out),
        "--report",
        s(&report),
        "--start-frame",
        "rest",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let r = read_json(&report);
    let ends = r["joints"]
        .as_array()
        .expect("joints")
        .iter()
        .filter(|j| j["end_site"] == true)
        .count();
    assert!(ends > 0, "BVH End Sites are reported as such");
    let height = 25.65;
    for (name, p) in &truth {
        let q = report_position(&r, name);
        let d = ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2) + (p[2] - q[2]).powi(2)).sqrt();
        assert!(d < 0.05 * height, "{name} off by {d}");
    }
    let back = rigfit_formats::bvh::read_bvh(&out).expect("output BVH");
    assert_eq!(back.frames.len(), 1);
    // --frame keeps the file's motion and replaces one frame.
    let keyed = dir.path().join("keyed.bvh");
    let o = rigfit(&[
        "pose",
        s(&rig),
        s(&strokes),
        "-o",
        s(&keyed),
        "--frame",
        "3",
        "--start-frame",
        "rest",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(
        rigfit_formats::bvh::read_bvh(&keyed)
            .expect("keyed")
            .frames
            .len(),
        2752
    );
}

#[test]
fn frame_keys_accumulate_in_the_rigfit_animation() {
    let dir = tempfile::tempdir().expect("temp dir");
    let rig = dir.path().join("humanoid.glb");
    assert!(rigfit(&["demo-rig", "-o", s(&rig)]).status.success());
    let strokes = dir.path().join("strokes.json");
    draw_case(&rig, 1.0, &strokes);
    let first = dir.path().join("k1.glb");
    let second = dir.path().join("k2.glb");
    assert!(
        rigfit(&[
            "pose",
            s(&rig),
            s(&strokes),
            "-o",
            s(&first),
            "--frame",
            "0"
        ])
        .status
        .success()
    );
    let o = rigfit(&[
        "pose",
        s(&first),
        s(&strokes),
        "-o",
        s(&second),
        "--frame",
        "12",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let doc = rigfit_formats::gltf::read_gltf(&second, None).expect("keyed file");
    let times: Vec<f64> = doc.rigfit_keys().iter().map(|k| k.0).collect();
    assert_eq!(times.len(), 2, "{times:?}");
    assert!((times[1] - 0.5).abs() < 1e-6);
}

#[test]
fn only_the_chosen_bones_move_and_pinned_strokes_keep_their_bones() {
    let (dir, rig_path, at) = demo_humanoid();
    // One stroke: the left arm raised, pinned to the arm bones.
    let shoulder = at("LeftArm");
    let stroke = Stroke {
        points: (0..=20)
            .map(|i| shoulder + rigfit_core::Vector3::new(0.03, 0.7, 0.0) * (i as f64 / 20.0))
            .collect(),
        bones: Some(vec!["LeftArm".into(), "LeftForeArm".into()]),
    };
    let strokes = dir.path().join("strokes.json");
    rigfit_formats::strokes::write_strokes(&strokes, &[stroke]).expect("write");
    let report = dir.path().join("report.json");
    let o = rigfit(&[
        "pose",
        s(&rig_path),
        s(&strokes),
        "--report",
        s(&report),
        "--bones",
        "LeftArm,LeftForeArm",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let r = read_json(&report);
    let bones: Vec<&str> = r["strokes"][0]["bones"]
        .as_array()
        .expect("bones")
        .iter()
        .map(|b| b.as_str().expect("name"))
        .collect();
    assert_eq!(bones, ["LeftArm", "LeftForeArm"]);
    // Joints not listed keep their place; the hand went up.
    for name in ["Hips", "Head", "RightHand", "LeftShoulder", "LeftArm"] {
        let q = report_position(&r, name);
        assert!(
            (at(name) - rigfit_core::Point3::from(q)).norm() < 1e-9,
            "{name} moved"
        );
    }
    assert!(report_position(&r, "LeftHand")[1] > at("LeftArm").y + 0.3);
}

#[test]
fn a_joints_file_makes_joints_hinges_or_fixed() {
    let (dir, rig_path, at) = demo_humanoid();
    // The left arm drawn raised and bent at the elbow, pinned to the arm bones.
    let (shoulder, elbow) = (at("LeftArm"), at("LeftForeArm"));
    let upper = (elbow - shoulder).norm();
    let bend = shoulder + rigfit_core::Vector3::new(0.0, upper, 0.0);
    let points = (0..=20)
        .map(|i| shoulder + (bend - shoulder) * (i as f64 / 20.0))
        .chain(
            (1..=20).map(|i| bend + rigfit_core::Vector3::new(0.0, 0.0, 0.2) * (i as f64 / 20.0)),
        )
        .collect();
    let stroke = Stroke {
        points,
        bones: Some(vec!["LeftArm".into(), "LeftForeArm".into()]),
    };
    let strokes = dir.path().join("strokes.json");
    rigfit_formats::strokes::write_strokes(&strokes, &[stroke]).expect("write");
    let joints = dir.path().join("joints.json");
    std::fs::write(
        &joints,
        r#"{"joints": {"LeftForeArm": {"dof": "fixed"}, "Spine": {"dof": "fixed"}}}"#,
    )
    .expect("write");
    let report = dir.path().join("report.json");
    let run = |extra: &[&str]| {
        let mut args = vec!["pose", s(&rig_path), s(&strokes), "--report", s(&report)];
        args.extend_from_slice(extra);
        let o = rigfit(&args);
        assert!(o.status.success(), "{}", stderr(&o));
        read_json(&report)
    };
    // Without the file the elbow bends; with it the forearm keeps its rest turn, so the hand
    // stays on the line of the upper arm.
    let elbow_bend = |r: &Value| {
        let [a, b, c] = ["LeftArm", "LeftForeArm", "LeftHand"]
            .map(|n| rigfit_core::Point3::from(report_position(r, n)));
        (b - a).angle(&(c - b))
    };
    let rest_bend =
        (at("LeftForeArm") - at("LeftArm")).angle(&(at("LeftHand") - at("LeftForeArm")));
    assert!(elbow_bend(&run(&[])) > rest_bend + 0.5);
    assert!((elbow_bend(&run(&["--joints", s(&joints)])) - rest_bend).abs() < 1e-6);
    // A bad joints file is one line naming the file and the place.
    let bad = dir.path().join("bad_joints.json");
    std::fs::write(&bad, r#"{"joints": {"Tail": {"dof": "ball"}}}"#).expect("write");
    let o = rigfit(&["pose", s(&rig_path), s(&strokes), "--joints", s(&bad)]);
    assert_bad_input(&o, &bad);
    assert!(stderr(&o).contains("joints.Tail: the rig has no joint of that name"));
}

#[test]
fn bad_strokes_and_options_exit_2_with_one_line() {
    let dir = tempfile::tempdir().expect("temp dir");
    let rig = data("assimp/BCN_Epileptic.glb");
    let write = |name: &str, text: &str| {
        let p = dir.path().join(name);
        std::fs::write(&p, text).expect("write");
        p
    };
    let good = write(
        "good.json",
        r#"{"strokes": [{"points": [[0, 1, 0], [0, 1.5, 0]]}]}"#,
    );
    for (file, text) in [
        (
            "nan.json",
            r#"{"strokes": [{"points": [[0, 1, 0], [1e999, 1.5, 0]]}]}"#,
        ),
        (
            "one_point.json",
            r#"{"strokes": [{"points": [[0, 1, 0]]}]}"#,
        ),
        ("empty.json", r#"{"strokes": []}"#),
        (
            "far_away.json",
            r#"{"strokes": [{"points": [[1e300, 1, 0], [-1e300, 1, 0]]}]}"#,
        ),
        (
            "unknown_bone.json",
            r#"{"strokes": [{"points": [[0, 1, 0], [0, 1.5, 0]], "bones": ["NoSuchBone"]}]}"#,
        ),
    ] {
        let p = write(file, text);
        let o = rigfit(&["pose", s(&rig), s(&p)]);
        assert_bad_input(&o, &p);
    }
    let o = rigfit(&["pose", s(&rig), s(&good), "--bones", "NoSuchBone"]);
    assert_bad_input(&o, &rig);
    assert!(stderr(&o).contains("NoSuchBone"));
    let no_skin = malformed_dir().join("gltf_no_skin.gltf");
    let o = rigfit(&["pose", s(&no_skin), s(&good)]);
    assert_bad_input(&o, &no_skin);
    assert!(stderr(&o).contains("no skin"));
    let out = dir.path().join("missing-dir/out.glb");
    let o = rigfit(&["pose", s(&rig), s(&good), "-o", s(&out)]);
    assert_bad_input(&o, &out);
    assert!(!out.exists());
}

#[test]
fn demo_runs_with_nothing_downloaded() {
    let dir = tempfile::tempdir().expect("temp dir");
    let o = rigfit(&["demo", "-o", s(dir.path())]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = stdout(&o);
    assert!(text.contains("mean joint error"), "{text}");
    let outputs = [
        "humanoid.glb",
        "strokes.json",
        "posed.glb",
        "report.json",
        "demo.png",
    ];
    for f in outputs {
        assert!(dir.path().join(f).is_file(), "{f}");
    }
    let wrote = text
        .lines()
        .find(|l| l.starts_with("wrote "))
        .expect("a wrote line");
    assert!(outputs.iter().all(|f| wrote.contains(f)), "{wrote}");
    // The picture: start and result side by side, so wider than tall; it decodes.
    let picture = dir.path().join("demo.png");
    assert!(
        text.contains(&format!("picture: {} (start | result", picture.display())),
        "{text}"
    );
    let (width, height, _) = png_size(&picture);
    assert!(width > height, "{width} x {height}");
    let image = rigfit_render::Image::from_png(&std::fs::read(&picture).expect("read"))
        .expect("the picture decodes");
    assert_eq!((image.width(), image.height()), (width, height));
    // Each half (the start, the result) has something drawn in it.
    for half in [0..width / 2, width / 2..width] {
        let drawn = half
            .flat_map(|x| (0..height).map(move |y| (x, y)))
            .filter(|&(x, y)| image.pixel(x, y) != Some(rigfit_render::color::BACKGROUND))
            .count();
        assert!(drawn > 1000, "{drawn} pixels drawn in a half");
    }
    // Nothing is left beside the outputs (the temporaries were all renamed).
    let mut names: Vec<String> = std::fs::read_dir(dir.path())
        .expect("list")
        .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    let mut expected: Vec<String> = outputs.iter().map(|f| f.to_string()).collect();
    expected.sort();
    assert_eq!(names, expected);
}
