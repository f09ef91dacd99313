//! `rigfit batch` end to end: a job file mixing pose, track and surface takes on the real
//! assets, two of them broken on purpose; outputs compared with each take run alone; bad
//! job files.
#![allow(clippy::duplicate_mod)]

mod common;
use rigfit_testkit::track_suites;

use std::path::{Path, PathBuf};

use common::{assert_bad_input, malformed_dir, rigfit, stderr, stdout};
use rigfit_cli::commands::batch::read_jobs;
use serde_json::{Value, json};

fn s(p: &Path) -> &str {
    p.to_str().expect("utf-8 path")
}

/// The inputs of the takes: the demo humanoid and its strokes, a short hand sequence.
struct Inputs {
    humanoid: PathBuf,
    strokes: PathBuf,
    hand_start: PathBuf,
    hand_frames: Vec<PathBuf>,
}

fn inputs(dir: &Path) -> Inputs {
    let demo = dir.join("demo");
    let o = rigfit(&["demo", "-o", s(&demo)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let seq = dir.join("hand");
    std::fs::create_dir_all(&seq).expect("folder");
    let (hand_start, hand_frames, _) = track_suites::write_sequence(&seq, "hand", 3);
    Inputs {
        humanoid: demo.join("humanoid.glb"),
        strokes: demo.join("strokes.json"),
        hand_start,
        hand_frames,
    }
}

/// Six good takes (writing under `out`) and two broken ones.
fn takes(inputs: &Inputs, out: &str) -> Vec<Value> {
    let frames: Vec<&str> = inputs.hand_frames.iter().map(|f| s(f)).collect();
    let pattern = inputs.hand_frames[0]
        .with_file_name("frame_*.ply")
        .display()
        .to_string();
    let bad_frame = malformed_dir().join("ply_truncated_binary.ply");
    vec![
        json!({"name": "pose-glb", "command": "pose", "rig": s(&inputs.humanoid),
               "strokes": s(&inputs.strokes), "output": format!("{out}/pose.glb"),
               "report": format!("{out}/pose.json")}),
        json!({"name": "pose-paper-bvh", "command": "pose", "rig": s(&inputs.humanoid),
               "strokes": s(&inputs.strokes), "output": format!("{out}/paper.bvh"), "method": "paper"}),
        json!({"name": "broken-strokes", "command": "pose", "rig": s(&inputs.humanoid),
               "strokes": "no-such-strokes.json", "output": format!("{out}/broken.glb")}),
        json!({"name": "track-hand", "command": "track", "rig": s(&inputs.hand_start),
               "frames": frames, "output": format!("{out}/hand.bvh"), "report": format!("{out}/hand.json")}),
        json!({"name": "track-hand-pattern", "command": "track", "rig": s(&inputs.hand_start),
               "frames": pattern, "output": format!("{out}/hand-pattern.glb"), "noise": 0.02}),
        json!({"name": "broken-frame", "command": "track", "rig": s(&inputs.hand_start),
               "frames": [s(&bad_frame)], "output": format!("{out}/broken.bvh")}),
        json!({"name": "surface-hand", "command": "surface", "mesh": s(&common::data("webxr_hand/left.glb")),
               "frames": frames, "output": format!("{out}/surface"), "report": format!("{out}/surface.json"),
               "iterations": 10}),
        json!({"name": "surface-hand-coarse", "command": "surface", "mesh": s(&common::data("webxr_hand/left.glb")),
               "frames": frames, "output": format!("{out}/surface-coarse"), "coarse": 2, "merge": 1.5}),
    ]
}

/// A report without its timings (they differ run to run), its numbers to 12 significant
/// digits: the surface tracker's rms and sigma are sums taken in parallel, whose last bits
/// depend on how the threads split the work (its meshes do not).
fn untimed(mut value: Value) -> Value {
    if let Some(x) = value.as_f64().filter(|_| value.is_f64()) {
        return json!(format!("{x:.11e}"));
    }
    match &mut value {
        Value::Object(map) => {
            map.remove("seconds");
            for v in map.values_mut() {
                *v = untimed(v.take());
            }
        }
        Value::Array(items) => {
            for v in items.iter_mut() {
                *v = untimed(v.take());
            }
        }
        _ => {}
    }
    value
}

/// Every file under `dir`, relative, sorted.
fn files(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for entry in std::fs::read_dir(&d).expect("list") {
            let path = entry.expect("entry").path();
            if path.is_dir() {
                stack.push(path);
            } else {
                out.push(path.strip_prefix(dir).expect("inside").to_path_buf());
            }
        }
    }
    out.sort();
    out
}

#[test]
fn a_batch_runs_every_take_reports_the_broken_ones_and_matches_each_take_run_alone() {
    let dir = tempfile::tempdir().expect("temp dir");
    let inputs = inputs(dir.path());
    let batch_out = dir.path().join("batch");
    let alone_out = dir.path().join("alone");
    std::fs::create_dir_all(&batch_out).expect("folder");
    std::fs::create_dir_all(&alone_out).expect("folder");
    let jobs = dir.path().join("jobs.json");
    std::fs::write(
        &jobs,
        json!({ "takes": takes(&inputs, "batch") }).to_string(),
    )
    .expect("jobs");
    let report = dir.path().join("batch-report.json");
    let o = rigfit(&["batch", s(&jobs), "--report", s(&report), "--workers", "2"]);
    // Exit status 1: some takes failed; one line for each on stderr, naming the problem
    // (beside the solvers' warnings, as each command alone prints them).
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    let err = stderr(&o);
    let lines: Vec<&str> = err.lines().filter(|l| l.contains("failed:")).collect();
    assert_eq!(lines.len(), 2, "{err}");
    assert!(
        err.contains("take 'broken-strokes' (pose) failed: ")
            && err.contains("no-such-strokes.json")
    );
    assert!(
        err.contains("take 'broken-frame' (track) failed: ")
            && err.contains("ply_truncated_binary.ply")
    );
    assert!(!err.contains("panicked"), "{err}");
    assert!(stdout(&o).contains("8 takes from"), "{}", stdout(&o));
    assert!(stdout(&o).contains("6 done, 2 failed"), "{}", stdout(&o));

    let value: Value =
        serde_json::from_slice(&std::fs::read(&report).expect("report")).expect("json");
    assert_eq!(value["done"], 6);
    assert_eq!(value["failed"], 2);
    let entries = value["takes"].as_array().expect("takes");
    assert_eq!(entries.len(), 8);
    for entry in entries {
        let failed = entry["name"].as_str().expect("name").starts_with("broken");
        assert_eq!(
            entry["status"],
            if failed { "failed" } else { "done" },
            "{entry}"
        );
        assert_eq!(entry["error"].is_string(), failed, "{entry}");
    }

    // Each take alone, through the command line, writing under alone/.
    let alone = dir.path().join("alone.json");
    std::fs::write(
        &alone,
        json!({ "takes": takes(&inputs, "alone") }).to_string(),
    )
    .expect("jobs");
    for take in read_jobs(&alone).expect("job file").takes {
        let argv = take.command_line().expect("command line");
        let args: Vec<&str> = argv[1..]
            .iter()
            .map(|a| a.to_str().expect("utf-8"))
            .collect();
        let o = rigfit(&args);
        assert_eq!(
            o.status.success(),
            !take.name.starts_with("broken"),
            "{}: {}",
            take.name,
            stderr(&o)
        );
    }
    // The same files, byte for byte (reports up to their timings); nothing of the broken
    // takes, nothing temporary.
    let written = files(&batch_out);
    assert_eq!(written, files(&alone_out));
    assert_eq!(written.len(), 3 + 3 + 4 + 3, "{written:?}");
    for file in &written {
        let (a, b) = (
            std::fs::read(batch_out.join(file)).expect("read"),
            std::fs::read(alone_out.join(file)).expect("read"),
        );
        if file.extension().is_some_and(|e| e == "json") {
            let a: Value = serde_json::from_slice(&a).expect("json");
            let b: Value = serde_json::from_slice(&b).expect("json");
            assert_eq!(untimed(a), untimed(b), "{}", file.display());
        } else {
            assert!(a == b, "{} differs", file.display());
        }
    }
}

#[test]
fn relative_paths_are_taken_from_the_job_file_folder_and_output_folders_made() {
    let dir = tempfile::tempdir().expect("temp dir");
    let inputs = inputs(dir.path());
    let jobs = dir.path().join("jobs.json");
    std::fs::write(
        &jobs,
        json!({ "takes": [ {"command": "pose", "rig": "demo/humanoid.glb", "strokes": "demo/strokes.json",
                            "output": "new/folder/posed.bvh", "bones": ["LeftArm", "LeftForeArm"]} ] })
        .to_string(),
    )
    .expect("jobs");
    let o = rigfit(&["batch", s(&jobs)]);
    assert!(o.status.success(), "{}", stderr(&o));
    // The output's folder is made for it.
    assert!(dir.path().join("new/folder/posed.bvh").is_file());
    assert!(stdout(&o).contains("1 takes from") && stdout(&o).contains("1 done, 0 failed"));
    let _ = inputs;
}

#[test]
fn a_bad_job_file_is_one_line_and_exit_status_2_with_nothing_written() {
    let dir = tempfile::tempdir().expect("temp dir");
    let jobs = dir.path().join("jobs.json");
    let report = dir.path().join("report.json");
    let cases = [
        "not json",
        r#"{"takes": []}"#,
        r#"{"takes": [{"command": "paint"}]}"#,
        r#"{"takes": [{"command": "pose", "name": "x"}, {"command": "track", "name": "x"}]}"#,
        r#"{"takes": [{"command": "pose", "output": "a.glb"}, {"command": "pose", "output": "./a.glb"}]}"#,
        r#"{"takes": [{"command": "pose", "output": "report.json"}]}"#,
    ];
    for text in cases {
        std::fs::write(&jobs, text).expect("jobs");
        let o = rigfit(&["batch", s(&jobs), "--report", s(&report)]);
        let named = if text.contains("report.json") {
            &report
        } else {
            &jobs
        };
        assert_bad_input(&o, named);
        assert!(!report.exists(), "{text}: no report");
    }
    let o = rigfit(&["batch", s(&dir.path().join("missing.json"))]);
    assert_bad_input(&o, Path::new("missing.json"));
    let o = rigfit(&["batch", s(&jobs), "--workers", "0"]);
    assert_eq!(o.status.code(), Some(2));
}
