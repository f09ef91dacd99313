//! `rigfit track` end to end: frames written as PLY files from a ground-truth sequence,
//! tracked through the command line, results read back; and bad input.
#![allow(clippy::duplicate_mod)]

mod common;
use rigfit_testkit::track_suites;

use std::path::{Path, PathBuf};

use common::{assert_bad_input, rigfit, stderr};

fn args<'a>(head: &[&'a str], files: &'a [PathBuf], tail: &[&'a str]) -> Vec<&'a str> {
    let mut v: Vec<&str> = head.to_vec();
    v.extend(files.iter().map(|f| f.to_str().expect("utf-8 path")));
    v.extend_from_slice(tail);
    v
}

#[test]
fn tracks_a_hand_through_ply_frames_and_writes_glb_bvh_report_and_picture() {
    let dir = tempfile::tempdir().expect("temp dir");
    let (start, files, suite) = track_suites::write_sequence(dir.path(), "hand", 10);
    let out = dir.path().join("track.glb");
    let report = dir.path().join("track.json");
    let picture = dir.path().join("track.png");
    // Ground truth for the picture's error plot, as a track report.
    let truth = dir.path().join("truth.json");
    let frames_json: Vec<serde_json::Value> = suite
        .frames
        .iter()
        .map(|f| rigfit_formats::report::track_frame_json(&suite.rig, &f.truth, "", 0, 0.0))
        .collect();
    std::fs::write(
        &truth,
        serde_json::json!({ "frames": frames_json }).to_string(),
    )
    .expect("truth");
    let o = rigfit(&args(
        &["track", start.to_str().expect("utf-8")],
        &files,
        &[
            "-o",
            out.to_str().expect("utf-8"),
            "--report",
            report.to_str().expect("utf-8"),
            "--render",
            picture.to_str().expect("utf-8"),
            "--truth",
            truth.to_str().expect("utf-8"),
        ],
    ));
    assert!(o.status.success(), "{}", stderr(&o));
    // The report: one entry per frame, joints near the truth.
    let value: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&report).expect("report")).expect("json");
    let frames = value["frames"].as_array().expect("frames");
    assert_eq!(frames.len(), 10);
    let h = suite.model.height;
    for (k, frame) in frames.iter().enumerate() {
        assert!(
            frame["file"]
                .as_str()
                .expect("file")
                .ends_with(&format!("frame_{k:04}.ply"))
        );
        assert!(frame["inliers"].as_u64().is_some() && frame["seconds"].as_f64().is_some());
        let truth = suite.rig.skeleton.joint_positions(&suite.frames[k].truth);
        let joints = frame["joints"].as_array().expect("joints");
        assert_eq!(joints.len(), suite.rig.reported_joints().count());
        let mut error = 0.0;
        for j in joints {
            let index = suite
                .rig
                .skeleton
                .find(j["name"].as_str().expect("name"))
                .expect("a joint of the rig");
            let p = j["position"].as_array().expect("position");
            let p = rigfit_core::Point3::new(
                p[0].as_f64().expect("x"),
                p[1].as_f64().expect("y"),
                p[2].as_f64().expect("z"),
            );
            error += (p - truth[index]).norm();
        }
        error /= joints.len() as f64 * h;
        assert!(error < 0.04, "frame {k}: mean joint error {error}");
    }
    // The .glb holds the track as its `rigfit` animation.
    let doc = rigfit_formats::gltf::read_gltf(&out, None).expect("output reads");
    assert_eq!(doc.rigfit_keys().len(), 10);
    let png = std::fs::read(&picture).expect("picture");
    assert_eq!(&png[1..4], b"PNG");

    // .bvh output: one frame per time step.
    let bvh = dir.path().join("track.bvh");
    let o = rigfit(&args(
        &["track", start.to_str().expect("utf-8")],
        &files[..4],
        &["-o", bvh.to_str().expect("utf-8"), "--method", "paper"],
    ));
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(!stderr(&o).contains("error"), "{}", stderr(&o));
    let doc = rigfit_formats::bvh::read_bvh(&bvh).expect("bvh reads");
    assert_eq!(doc.frames.len(), 4);
}

#[test]
fn tracks_a_bare_bvh_skeleton() {
    let dir = tempfile::tempdir().expect("temp dir");
    let (start, files, _) = track_suites::write_sequence(dir.path(), "01_01", 5);
    let out = dir.path().join("track.bvh");
    let o = rigfit(&args(
        &["track", start.to_str().expect("utf-8")],
        &files,
        &["-o", out.to_str().expect("utf-8")],
    ));
    assert!(o.status.success(), "{}", stderr(&o));
    let doc = rigfit_formats::bvh::read_bvh(&out).expect("bvh reads");
    assert_eq!(doc.frames.len(), 5);
}

#[test]
fn bad_frames_stop_with_one_line_and_keep_what_was_tracked() {
    let dir = tempfile::tempdir().expect("temp dir");
    let (start, mut files, _) = track_suites::write_sequence(dir.path(), "hand", 3);
    let start_s = start.to_str().expect("utf-8").to_string();

    // An empty cloud.
    let empty = dir.path().join("empty.ply");
    std::fs::write(&empty, "ply\nformat ascii 1.0\nelement vertex 0\nproperty float x\nproperty float y\nproperty float z\nend_header\n").expect("write");
    let o = rigfit(&["track", &start_s, empty.to_str().expect("utf-8")]);
    assert_bad_input(&o, &empty);

    // NaN coordinates.
    let nan = dir.path().join("nan.ply");
    std::fs::write(&nan, "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\nproperty float z\nend_header\n0 0 0\nnan 1 2\n").expect("write");
    let o = rigfit(&["track", &start_s, nan.to_str().expect("utf-8")]);
    assert_bad_input(&o, &nan);

    // A frame that fails to parse mid-sequence: the frames before it are written.
    let broken = dir.path().join("frame_broken.ply");
    std::fs::write(
        &broken,
        "ply\nformat ascii 1.0\nelement vertex 5\nproperty float x\nend_header\n1\n2\n",
    )
    .expect("write");
    files.insert(2, broken.clone());
    let out = dir.path().join("partial.glb");
    let report = dir.path().join("partial.json");
    let o = rigfit(&args(
        &["track", &start_s],
        &files,
        &[
            "-o",
            out.to_str().expect("utf-8"),
            "--report",
            report.to_str().expect("utf-8"),
        ],
    ));
    assert_bad_input(&o, &broken);
    assert!(stderr(&o).contains("2 tracked frame(s)"), "{}", stderr(&o));
    let doc = rigfit_formats::gltf::read_gltf(&out, None).expect("partial output reads");
    assert_eq!(doc.rigfit_keys().len(), 2);
    let value: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&report).expect("report")).expect("json");
    assert_eq!(value["frames"].as_array().expect("frames").len(), 2);

    // Unsupported frame type, missing rig, bad picture path.
    let txt = dir.path().join("frame.txt");
    std::fs::write(&txt, "1 2 3").expect("write");
    let o = rigfit(&["track", &start_s, txt.to_str().expect("utf-8")]);
    assert_bad_input(&o, &txt);
    // A truth file that is not a track report.
    let o = rigfit(&[
        "track",
        &start_s,
        files[0].to_str().expect("utf-8"),
        "--render",
        dir.path().join("x.png").to_str().expect("utf-8"),
        "--truth",
        txt.to_str().expect("utf-8"),
    ]);
    assert_bad_input(&o, &txt);
    let missing = dir.path().join("missing.glb");
    let o = rigfit(&[
        "track",
        missing.to_str().expect("utf-8"),
        files[0].to_str().expect("utf-8"),
    ]);
    assert_bad_input(&o, &missing);
    let o = rigfit(&[
        "track",
        &start_s,
        files[0].to_str().expect("utf-8"),
        "--render",
        "/nonexistent/dir/x.png",
    ]);
    assert_bad_input(&o, Path::new("x.png"));
}

/// The rig as its file stores it (BCN_Epileptic in its bind pose) and a take where the
/// person stands 1.6 m away, turned 150 degrees: `--init auto` finds the body, prints the
/// choice and reports it; `--init stored` keeps the stored pose.
#[test]
fn a_take_away_from_the_stored_pose_starts_from_the_search() {
    use rigfit_core::math::{Point3, Quat, Vector3};
    let dir = tempfile::tempdir().expect("temp dir");
    let options = rigfit_testkit::track_cases::SequenceOptions::default();
    let mut suite = track_suites::suite("BCN_Epileptic", track_suites::FRAMES, &options);
    suite.frames.truncate(6);
    let turn = Quat::from_axis_angle(&Vector3::y_axis(), 150f64.to_radians());
    let shift = Vector3::new(1.3, 0.0, -0.9);
    let moved = |p: &Point3| Point3::from(turn * p.coords + shift);
    let files: Vec<PathBuf> = suite
        .frames
        .iter()
        .enumerate()
        .map(|(k, f)| {
            let path = dir.path().join(format!("frame_{k:04}.ply"));
            let cloud = rigfit_core::TriMesh {
                vertices: f.points.iter().map(moved).collect(),
                ..rigfit_core::TriMesh::default()
            };
            rigfit_formats::ply::write_ply(&path, &cloud).expect("frame written");
            path
        })
        .collect();
    let rig = rigfit_testkit::assets::asset("assimp/BCN_Epileptic.glb");
    let report = dir.path().join("track.json");
    let o = rigfit(&args(
        &["track", rig.to_str().expect("utf-8")],
        &files,
        &["--report", report.to_str().expect("utf-8")],
    ));
    assert!(o.status.success(), "{}", stderr(&o));
    let printed = String::from_utf8_lossy(&o.stdout);
    assert!(
        printed.contains("first frame: started from the search"),
        "{printed}"
    );
    let value: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&report).expect("report")).expect("json");
    assert_eq!(value["start"]["mode"], "auto");
    assert_eq!(value["start"]["chose"], "search");
    // The last frame's joints are where the moved truth puts them.
    let last = &value["frames"][5]["joints"];
    let truth = suite.rig.skeleton.joint_positions(&suite.frames[5].truth);
    let (mut sum, mut n) = (0.0, 0);
    for joint in last.as_array().expect("joints") {
        let j = suite
            .rig
            .skeleton
            .find(joint["name"].as_str().expect("name"))
            .expect("joint of the rig");
        let p: Vec<f64> = joint["position"]
            .as_array()
            .expect("position")
            .iter()
            .map(|c| c.as_f64().expect("number"))
            .collect();
        sum += (Point3::new(p[0], p[1], p[2]) - moved(&truth[j])).norm();
        n += 1;
    }
    let error = sum / n as f64 / suite.model.height;
    assert!(error < 0.03, "mean joint error {:.2}%", 100.0 * error);

    let o = rigfit(&args(
        &["track", rig.to_str().expect("utf-8")],
        &files[..1],
        &[
            "--init",
            "stored",
            "--report",
            report.to_str().expect("utf-8"),
        ],
    ));
    assert!(o.status.success(), "{}", stderr(&o));
    let value: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&report).expect("report")).expect("json");
    assert_eq!(value["start"]["chose"], "stored");
}

/// `--joints` fixes the elbow: its bend stays the start pose's in every frame; a joints file
/// naming no joint of the rig is one line and exit status 2.
#[test]
fn a_joints_file_fixes_a_joint_and_a_bad_one_is_refused() {
    let dir = tempfile::tempdir().expect("temp dir");
    let (start, files, suite) = track_suites::write_sequence(dir.path(), "BCN_Epileptic", 3);
    let joints = dir.path().join("joints.json");
    std::fs::write(
        &joints,
        r#"{"joints": {"B_ForeArm_Left": {"dof": "fixed"}}}"#,
    )
    .expect("write");
    let report = dir.path().join("track.json");
    let s = |p: &Path| p.to_str().expect("utf-8").to_string();
    let (start_s, joints_s, report_s) = (s(&start), s(&joints), s(&report));
    let o = rigfit(&args(
        &["track", &start_s],
        &files,
        &["--joints", &joints_s, "--report", &report_s],
    ));
    assert!(o.status.success(), "{}", stderr(&o));
    let value: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&report).expect("report")).expect("json");
    let bend = |positions: &dyn Fn(&str) -> rigfit_core::Point3| {
        let [a, b, c] = ["B_UpperArm_Left", "B_ForeArm_Left", "B_Hand_Left"].map(positions);
        (b - a).angle(&(c - b))
    };
    let truth = suite.rig.skeleton.joint_positions(&suite.frames[0].truth);
    let start_bend = bend(&|n| truth[suite.rig.skeleton.find(n).expect("joint")]);
    for frame in value["frames"].as_array().expect("frames") {
        let at = |n: &str| {
            let joint = frame["joints"]
                .as_array()
                .expect("joints")
                .iter()
                .find(|j| j["name"] == n)
                .expect("joint reported");
            let p: Vec<f64> = joint["position"]
                .as_array()
                .expect("position")
                .iter()
                .map(|c| c.as_f64().expect("number"))
                .collect();
            rigfit_core::Point3::new(p[0], p[1], p[2])
        };
        assert!((bend(&at) - start_bend).abs() < 1e-6);
    }
    let bad = dir.path().join("bad_joints.json");
    std::fs::write(&bad, r#"{"joints": {"Tail": {"dof": "ball"}}}"#).expect("write");
    let bad_s = s(&bad);
    let o = rigfit(&args(&["track", &start_s], &files, &["--joints", &bad_s]));
    assert_bad_input(&o, &bad);
    assert!(stderr(&o).contains("joints.Tail: the rig has no joint of that name"));
}
