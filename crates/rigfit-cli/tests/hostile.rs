//! Hostile inputs and outputs, run through the real binary: files the user did not choose
//! (glTF URIs out of the folder, FIFOs, devices, huge files), writes that would destroy
//! (outputs that are inputs, links, devices, folders), absurd numbers and counts, deep and
//! wide joint trees, and argument errors. Each refusal: exit status 2, exactly one line on
//! stderr, within 5 s and 500 MB, inputs unchanged and nothing written (no output, no
//! temporary file left).

mod common;

use std::collections::BTreeMap;
use std::hash::{DefaultHasher, Hash, Hasher};
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

use common::data;

const LIMIT: Duration = Duration::from_secs(5);
const MAX_RSS_KB: u64 = 500 * 1024;

fn s(p: &Path) -> &str {
    p.to_str().expect("utf-8 path")
}

/// What a run did: its output, wall time and peak memory (KiB, when measurable).
struct Run {
    output: Output,
    seconds: f64,
    rss_kb: Option<u64>,
}

/// Runs `rigfit` under `/usr/bin/time` (for the peak memory) with a hard time limit: a run
/// still going after twice the limit is killed and the test fails.
fn run(args: &[&str]) -> Run {
    let bin = env!("CARGO_BIN_EXE_rigfit");
    let rss_file = tempfile::NamedTempFile::new().expect("temp file");
    let timed = Path::new("/usr/bin/time").exists();
    let mut cmd = if timed {
        let mut c = Command::new("/usr/bin/time");
        c.args(["-f", "%M", "-o", s(rss_file.path()), bin]);
        c
    } else {
        Command::new(bin)
    };
    // Output to files (a pipe nobody reads while waiting would block a long output).
    let out_file = tempfile::NamedTempFile::new().expect("temp file");
    let err_file = tempfile::NamedTempFile::new().expect("temp file");
    let t0 = Instant::now();
    let mut child = cmd
        .args(args)
        .stdin(Stdio::null())
        .stdout(out_file.reopen().expect("reopen"))
        .stderr(err_file.reopen().expect("reopen"))
        .spawn()
        .expect("rigfit runs");
    loop {
        if child.try_wait().expect("wait").is_some() {
            break;
        }
        if t0.elapsed() > 2 * LIMIT {
            let _ = child.kill();
            let _ = child.wait();
            panic!("rigfit {args:?} still running after {:?}", 2 * LIMIT);
        }
        std::thread::sleep(Duration::from_millis(10));
    }
    let status = child.wait().expect("status");
    let output = Output {
        status,
        stdout: std::fs::read(out_file.path()).expect("stdout"),
        stderr: std::fs::read(err_file.path()).expect("stderr"),
    };
    let seconds = t0.elapsed().as_secs_f64();
    let rss_kb = std::fs::read_to_string(rss_file.path())
        .ok()
        .and_then(|t| t.lines().last().and_then(|l| l.trim().parse().ok()));
    Run {
        output,
        seconds,
        rss_kb,
    }
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Exit status 2 with exactly one line `rigfit: error: ...` holding `needle`, in time and
/// memory.
fn assert_refused(r: &Run, needle: &str) {
    let err = stderr(&r.output);
    assert_eq!(
        r.output.status.code(),
        Some(2),
        "exit status; stderr: {err}"
    );
    let lines: Vec<&str> = err.lines().collect();
    assert_eq!(lines.len(), 1, "exactly one line: {err}");
    assert!(lines[0].starts_with("rigfit: error: "), "{err}");
    assert!(
        lines[0].to_lowercase().contains(&needle.to_lowercase()),
        "'{needle}' in: {err}"
    );
    assert!(!err.contains("panicked"), "{err}");
    assert_within_limits(r);
}

fn assert_within_limits(r: &Run) {
    assert!(r.seconds < LIMIT.as_secs_f64(), "took {:.1} s", r.seconds);
    if let Some(kb) = r.rss_kb {
        assert!(kb < MAX_RSS_KB, "peak memory {kb} KiB");
    }
}

/// Every regular file under `dir` (recursively, not following links) with a hash of its
/// bytes; links, FIFOs and the like by kind only.
fn snapshot(dir: &Path) -> BTreeMap<PathBuf, u64> {
    let mut out = BTreeMap::new();
    let mut todo = vec![dir.to_path_buf()];
    while let Some(d) = todo.pop() {
        for entry in std::fs::read_dir(&d).expect("list") {
            let path = entry.expect("entry").path();
            let meta = std::fs::symlink_metadata(&path).expect("metadata");
            let mut h = DefaultHasher::new();
            if meta.is_dir() {
                todo.push(path.clone());
                "dir".hash(&mut h);
            } else if meta.is_file() && meta.len() > 64 << 20 {
                // A big sparse file: its length and time stand for its bytes.
                (meta.len(), meta.modified().ok()).hash(&mut h);
            } else if meta.is_file() {
                std::fs::read(&path).expect("read").hash(&mut h);
            } else if meta.file_type().is_symlink() {
                std::fs::read_link(&path).expect("link").hash(&mut h);
            } else {
                "special".hash(&mut h);
            }
            out.insert(path, h.finish());
        }
    }
    out
}

/// Runs `args` expecting a refusal naming `needle`, and checks `dir` is exactly as before.
fn refused_in(dir: &Path, args: &[&str], needle: &str) -> Run {
    let before = snapshot(dir);
    let r = run(args);
    assert_refused(&r, needle);
    let after = snapshot(dir);
    assert_eq!(before, after, "the folder is unchanged by {args:?}");
    r
}

fn mkfifo(path: &Path) {
    let ok = Command::new("mkfifo")
        .arg(path)
        .status()
        .expect("mkfifo runs");
    assert!(ok.success());
}

fn symlink(target: impl AsRef<Path>, link: &Path) {
    std::os::unix::fs::symlink(target, link).expect("symlink");
}

/// A small valid BVH: a root and two joints, a few frames.
fn small_bvh() -> String {
    let mut t = String::from(
        "HIERARCHY\nROOT Hips\n{\n OFFSET 0 0 0\n CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation\n JOINT Spine\n {\n  OFFSET 0 10 0\n  CHANNELS 3 Zrotation Xrotation Yrotation\n  JOINT Head\n  {\n   OFFSET 0 10 0\n   CHANNELS 3 Zrotation Xrotation Yrotation\n   End Site\n   {\n    OFFSET 0 5 0\n   }\n  }\n }\n}\nMOTION\nFrames: 3\nFrame Time: 0.0333\n",
    );
    for _ in 0..3 {
        t.push_str("0 0 0 0 0 0 0 0 0 0 0 0\n");
    }
    t
}

fn strokes_json() -> &'static str {
    r#"{"strokes": [{"points": [[0, 0, 0], [0, 10, 0], [0, 20, 0]]}]}"#
}

/// A folder with `rig.bvh` and `strokes.json`.
fn rig_dir() -> (tempfile::TempDir, PathBuf, PathBuf) {
    let dir = tempfile::tempdir().expect("temp dir");
    let rig = dir.path().join("rig.bvh");
    std::fs::write(&rig, small_bvh()).expect("write");
    let strokes = dir.path().join("strokes.json");
    std::fs::write(&strokes, strokes_json()).expect("write");
    (dir, rig, strokes)
}

/// A minimal skinned glTF whose buffer 0 is `uri` of `byte_length` bytes (and, when given,
/// an image URI).
fn gltf_with_uri(uri: &str, byte_length: usize, image: Option<&str>) -> String {
    let mut json = serde_json::json!({
        "asset": { "version": "2.0" },
        "nodes": [ { "name": "root", "children": [1] }, { "name": "tip", "translation": [0, 1, 0] } ],
        "skins": [ { "joints": [0, 1] } ],
        "buffers": [ { "uri": uri, "byteLength": byte_length } ]
    });
    if let Some(image) = image {
        json["images"] = serde_json::json!([{ "uri": image }]);
    }
    json.to_string()
}

// ---------------------------------------------------------------- files not chosen

#[test]
fn gltf_buffer_uris_leave_no_folder_and_read_no_special_file() {
    let top = tempfile::tempdir().expect("temp dir");
    let dir = top.path().join("model");
    std::fs::create_dir(&dir).expect("mkdir");
    std::fs::write(top.path().join("outside.bin"), vec![7u8; 64]).expect("write");
    std::fs::write(dir.join("buf.bin"), vec![1u8; 64]).expect("write");
    std::fs::write(dir.join("short.bin"), vec![1u8; 10]).expect("write");
    std::fs::create_dir(dir.join("sub")).expect("mkdir");
    symlink("../outside.bin", &dir.join("link.bin"));
    symlink("/etc/hostname", &dir.join("abs_link.bin"));
    symlink("/dev/zero", &dir.join("zero.bin"));
    mkfifo(&dir.join("fifo.bin"));
    let strokes = dir.join("strokes.json");
    std::fs::write(&strokes, strokes_json()).expect("write");
    let cases: &[(&str, usize, &str)] = &[
        ("/etc/hostname", 8, "absolute"),
        ("/etc/passwd", 8, "absolute"),
        ("/dev/zero", 1 << 30, "absolute"),
        ("../outside.bin", 64, "leaves the glTF's folder"),
        (
            "../../../../../../etc/passwd",
            8,
            "leaves the glTF's folder",
        ),
        ("sub/../../outside.bin", 64, "leaves the glTF's folder"),
        ("%2e%2e/outside.bin", 64, "leaves the glTF's folder"),
        ("%2E%2E%2Foutside.bin", 64, "leaves the glTF's folder"),
        ("%2fetc%2fhostname", 8, "absolute"),
        ("file:///etc/hostname", 8, "not a relative file path"),
        ("link.bin", 64, "outside the glTF's folder"),
        ("abs_link.bin", 8, "outside the glTF's folder"),
        ("zero.bin", 1 << 20, "outside the glTF's folder"),
        ("fifo.bin", 64, "FIFO"),
        ("sub", 64, "directory"),
        ("short.bin", 64, "holds only 10 bytes"),
        ("buf.bin", 1 << 40, "byteLength"),
        ("missing.bin", 64, "cannot read"),
    ];
    for (k, &(uri, len, needle)) in cases.iter().enumerate() {
        let rig = dir.join(format!("case{k}.gltf"));
        std::fs::write(&rig, gltf_with_uri(uri, len, None)).expect("write");
        let out = dir.join(format!("out{k}.glb"));
        let r = refused_in(top.path(), &["info", s(&rig)], needle);
        assert!(stderr(&r.output).contains(&format!("case{k}.gltf")));
        refused_in(
            top.path(),
            &["pose", s(&rig), s(&strokes), "-o", s(&out)],
            needle,
        );
        assert!(!out.exists());
    }
    // A buffer file longer than its byteLength: only byteLength bytes are read.
    let rig = dir.join("good.gltf");
    std::fs::write(&rig, gltf_with_uri("buf.bin", 16, None)).expect("write");
    let r = run(&["info", s(&rig)]);
    assert_eq!(r.output.status.code(), Some(0), "{}", stderr(&r.output));
}

#[test]
fn gltf_image_uris_are_held_to_the_same_rules() {
    let dir = tempfile::tempdir().expect("temp dir");
    std::fs::write(dir.path().join("buf.bin"), vec![1u8; 16]).expect("write");
    for (k, image) in [
        "/etc/passwd",
        "../x.png",
        "%2e%2e/x.png",
        "file:///etc/passwd",
    ]
    .iter()
    .enumerate()
    {
        let rig = dir.path().join(format!("img{k}.gltf"));
        std::fs::write(&rig, gltf_with_uri("buf.bin", 16, Some(image))).expect("write");
        refused_in(dir.path(), &["info", s(&rig)], "images[0]");
    }
    let rig = dir.path().join("fine.gltf");
    std::fs::write(&rig, gltf_with_uri("buf.bin", 16, Some("tex/skin.png"))).expect("write");
    let r = run(&["info", s(&rig)]);
    assert_eq!(r.output.status.code(), Some(0), "{}", stderr(&r.output));
}

#[test]
fn inputs_must_be_regular_files_of_bounded_size() {
    let (dir, rig, strokes) = rig_dir();
    let d = dir.path();
    mkfifo(&d.join("fifo.bvh"));
    mkfifo(&d.join("fifo.json"));
    mkfifo(&d.join("fifo.ply"));
    symlink("/dev/zero", &d.join("zero.ply"));
    symlink("/dev/zero", &d.join("zero.bvh"));
    std::fs::create_dir(d.join("folder.obj")).expect("mkdir");
    // Sparse: 2 GiB on paper, nothing on disk.
    let huge = d.join("huge.ply");
    std::fs::File::create(&huge)
        .and_then(|f| f.set_len(2 << 30))
        .expect("sparse file");
    let out = d.join("out.bvh");
    refused_in(d, &["info", s(&d.join("fifo.bvh"))], "FIFO");
    refused_in(d, &["info", s(&d.join("zero.ply"))], "device");
    refused_in(d, &["info", s(&d.join("folder.obj"))], "directory");
    refused_in(d, &["info", s(&huge)], "bytes");
    refused_in(d, &["pose", s(&d.join("zero.bvh")), s(&strokes)], "device");
    refused_in(
        d,
        &["pose", s(&rig), s(&d.join("fifo.json")), "-o", s(&out)],
        "FIFO",
    );
    refused_in(
        d,
        &["track", s(&rig), s(&d.join("fifo.ply")), "-o", s(&out)],
        "FIFO",
    );
    refused_in(
        d,
        &[
            "track",
            s(&rig),
            s(&huge),
            s(&d.join("zero.ply")),
            "-o",
            s(&out),
        ],
        "bytes",
    );
    refused_in(
        d,
        &[
            "surface",
            s(&cloud_of(d)),
            s(&d.join("fifo.ply")),
            "-o",
            s(&d.join("frames")),
        ],
        "FIFO",
    );
    refused_in(
        d,
        &["render", s(&d.join("zero.ply")), "-o", s(&d.join("x.png"))],
        "device",
    );
}

/// A three-point cloud in `dir`.
fn cloud_of(dir: &Path) -> PathBuf {
    let cloud = dir.join("cloud.ply");
    std::fs::write(
        &cloud,
        "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nend_header\n0 0 0\n0 1 0\n1 0 0\n",
    )
    .expect("write");
    cloud
}

// ---------------------------------------------------------------- writes that destroy

#[test]
fn outputs_that_are_inputs_or_not_regular_files_are_refused() {
    let (dir, rig, strokes) = rig_dir();
    let d = dir.path();
    std::fs::hard_link(&rig, d.join("hard.bvh")).expect("hard link");
    symlink(&rig, &d.join("soft.bvh"));
    symlink("/dev/null", &d.join("null.bvh"));
    symlink(d, &d.join("dirlink.bvh"));
    std::fs::create_dir(d.join("folder.bvh")).expect("mkdir");
    std::fs::write(d.join("old.json"), "{}").expect("write");
    let dotted = format!("{}/./rig.bvh", s(d));
    let cases: Vec<(Vec<String>, &str)> = vec![
        (vec!["-o".into(), s(&rig).into()], "is the input"),
        (vec!["-o".into(), dotted.clone()], "is the input"),
        (
            vec!["-o".into(), s(&d.join("hard.bvh")).into()],
            "is the input",
        ),
        (
            vec!["-o".into(), s(&d.join("soft.bvh")).into()],
            "symbolic link",
        ),
        (
            vec!["-o".into(), s(&d.join("null.bvh")).into()],
            "symbolic link",
        ),
        (vec!["-o".into(), "/dev/null".into()], "device"),
        (
            vec!["-o".into(), s(&d.join("dirlink.bvh")).into()],
            "symbolic link",
        ),
        (
            vec!["-o".into(), s(&d.join("folder.bvh")).into()],
            "directory",
        ),
        (vec!["--report".into(), s(&strokes).into()], "is the input"),
        (vec!["--report".into(), s(&rig).into()], "is the input"),
        (
            vec![
                "-o".into(),
                s(&d.join("a.bvh")).into(),
                "--report".into(),
                s(&d.join("a.bvh")).into(),
            ],
            "two outputs",
        ),
        (
            // The report's folder does not exist: -o is not written either.
            vec![
                "-o".into(),
                s(&d.join("a.bvh")).into(),
                "--report".into(),
                s(&d.join("nowhere/r.json")).into(),
            ],
            "nowhere",
        ),
        (
            vec![
                "-o".into(),
                s(&d.join("a.bvh")).into(),
                "--render".into(),
                s(&rig.with_extension("png")).into(),
                "--report".into(),
                s(&d.join("folder.bvh")).into(),
            ],
            "directory",
        ),
    ];
    for (extra, needle) in cases {
        let mut args = vec!["pose", s(&rig), s(&strokes)];
        args.extend(extra.iter().map(String::as_str));
        refused_in(d, &args, needle);
        assert!(!d.join("a.bvh").exists());
    }
    // track and render refuse the same way.
    refused_in(
        d,
        &[
            "track",
            s(&rig),
            s(&d.join("old.json")),
            "--report",
            s(&d.join("old.json")),
        ],
        "is the input",
    );
    let png = d.join("pic.png");
    std::fs::write(&png, b"not a png").expect("write");
    refused_in(d, &["render", s(&png), "-o", s(&png)], "is the input");
}

#[test]
fn surface_outdir_rules() {
    let dir = tempfile::tempdir().expect("temp dir");
    let d = dir.path();
    let mesh = data("bunny/bunny.ply");
    let outdir = d.join("out");
    std::fs::create_dir(&outdir).expect("mkdir");
    // A frame that lives in OUTDIR under an output name, or an earlier frame past the
    // new count (which would be removed).
    std::fs::copy(&mesh, outdir.join("frame_00000.ply")).expect("copy");
    std::fs::copy(&mesh, outdir.join("frame_00007.ply")).expect("copy");
    refused_in(
        d,
        &[
            "surface",
            s(&mesh),
            s(&outdir.join("frame_00000.ply")),
            "-o",
            s(&outdir),
        ],
        "is the input",
    );
    refused_in(
        d,
        &[
            "surface",
            s(&mesh),
            s(&outdir.join("frame_00007.ply")),
            "-o",
            s(&outdir),
        ],
        "is the input",
    );
    // OUTDIR is a file; the reference as OUTDIR.
    refused_in(
        d,
        &["surface", s(&mesh), s(&mesh), "-o", s(&mesh)],
        "folder",
    );
    // A link where a frame goes.
    std::fs::remove_file(outdir.join("frame_00000.ply")).expect("rm");
    symlink("/dev/null", &outdir.join("frame_00000.ply"));
    refused_in(
        d,
        &["surface", s(&mesh), s(&mesh), "-o", s(&outdir)],
        "symbolic link",
    );
    // --report is a frame.
    refused_in(
        d,
        &[
            "surface",
            s(&mesh),
            s(&mesh),
            "-o",
            s(&d.join("new")),
            "--report",
            s(&mesh),
        ],
        "is the input",
    );
    assert!(!d.join("new").exists(), "no OUTDIR made");
}

#[test]
fn surface_removes_an_earlier_runs_extra_frames_only_after_success() {
    let dir = tempfile::tempdir().expect("temp dir");
    let d = dir.path();
    let mesh = data("bunny/bunny.ply");
    let outdir = d.join("out");
    let ok = |frames: usize| {
        let mut args = vec!["surface", s(&mesh)];
        args.extend(std::iter::repeat_n(s(&mesh), frames));
        args.extend(["-o", s(&outdir), "--iterations", "2"]);
        let r = run(&args);
        assert_eq!(r.output.status.code(), Some(0), "{}", stderr(&r.output));
    };
    ok(3);
    // A report inside an OUTDIR the run makes.
    let fresh = d.join("fresh");
    let r = run(&[
        "surface",
        s(&mesh),
        s(&mesh),
        "-o",
        s(&fresh),
        "--iterations",
        "2",
        "--report",
        s(&fresh.join("report.json")),
    ]);
    assert_eq!(r.output.status.code(), Some(0), "{}", stderr(&r.output));
    assert!(fresh.join("report.json").is_file() && fresh.join("frame_00000.ply").is_file());
    std::fs::write(outdir.join("notes.txt"), "mine").expect("write");
    std::fs::write(outdir.join("frame_1.ply"), "not an output name").expect("write");
    // A failing run (a bad frame) leaves the earlier frames as they were.
    let bad = d.join("bad.ply");
    std::fs::write(&bad, "ply\nformat ascii 1.0\nend_header\n").expect("write");
    refused_in(
        d,
        &["surface", s(&mesh), s(&mesh), s(&bad), "-o", s(&outdir)],
        "bad.ply",
    );
    ok(1);
    let mut names: Vec<String> = std::fs::read_dir(&outdir)
        .expect("list")
        .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert_eq!(names, ["frame_00000.ply", "frame_1.ply", "notes.txt"]);
}

#[test]
fn an_output_of_an_unknown_type_is_refused_before_solving() {
    let (dir, rig, strokes) = rig_dir();
    let d = dir.path();
    refused_in(
        d,
        &["pose", s(&rig), s(&strokes), "-o", s(&d.join("out.txt"))],
        "unsupported",
    );
    refused_in(
        d,
        &["pose", s(&rig), s(&strokes), "-o", s(&d.join("out.gltf"))],
        "unsupported",
    );
}

#[test]
fn temporaries_are_exclusive_and_random() {
    // A link planted at the old predictable temporary name goes untouched.
    let dir = tempfile::tempdir().expect("temp dir");
    let d = dir.path();
    let victim = d.join("victim.txt");
    std::fs::write(&victim, "keep me").expect("write");
    let out = d.join("out.json");
    let planted = d.join(format!(".out.json.rigfit-tmp-{}", std::process::id()));
    symlink(&victim, &planted);
    rigfit_formats::error::write_atomic(&out, b"{}\n").expect("write");
    assert_eq!(std::fs::read_to_string(&victim).expect("read"), "keep me");
    assert_eq!(std::fs::read(&out).expect("read"), b"{}\n");
    let names: Vec<String> = std::fs::read_dir(d)
        .expect("list")
        .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
        .collect();
    assert_eq!(names.len(), 3, "no temporary left: {names:?}");
}

// ---------------------------------------------------------------- numbers and counts

#[test]
fn absurd_frames_and_options_are_bounded() {
    let (dir, rig, strokes) = rig_dir();
    let d = dir.path();
    let out = d.join("out.bvh");
    for frame in ["100000000", "1000001", "18446744073709551615"] {
        refused_in(
            d,
            &[
                "pose",
                s(&rig),
                s(&strokes),
                "-o",
                s(&out),
                "--frame",
                frame,
            ],
            "frame",
        );
    }
    refused_in(d, &["pose", s(&rig), s(&strokes), "--frame", "-1"], "-1");
    let cloud = d.join("cloud.ply");
    std::fs::write(
        &cloud,
        "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nend_header\n0 0 0\n0 1 0\n1 0 0\n",
    )
    .expect("write");
    for fps in ["1e-300", "0", "nan", "1e300"] {
        refused_in(
            d,
            &[
                "track",
                s(&rig),
                s(&cloud),
                "-o",
                s(&out),
                &format!("--fps={fps}"),
            ],
            "--fps",
        );
    }
    for (flag, v) in [
        ("--noise", "1e-300"),
        ("--noise", "1e300"),
        ("--max-motion", "1e300"),
    ] {
        refused_in(
            d,
            &[
                "track",
                s(&rig),
                s(&cloud),
                "-o",
                s(&out),
                &format!("{flag}={v}"),
            ],
            flag,
        );
    }
    for (flag, v) in [
        ("--iterations", "100000000"),
        ("--iterations", "0"),
        ("--coarse", "100000000"),
        ("--patch-radius", "1e-300"),
        ("--patch-radius", "1e300"),
    ] {
        refused_in(
            d,
            &[
                "surface",
                s(&cloud),
                s(&cloud),
                "-o",
                s(&d.join("f")),
                flag,
                v,
            ],
            flag,
        );
    }
}

#[test]
fn extreme_numbers_say_what_is_wrong() {
    let dir = tempfile::tempdir().expect("temp dir");
    let d = dir.path();
    let files: Vec<(&str, String, &str)> = vec![
        ("big.obj", "v 1e308 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\n".into(), "too large"),
        ("inf.obj", "v 1e309 0 0\nv 0 1 0\nv 0 0 1\n".into(), "not a finite"),
        (
            "big.ply",
            "ply\nformat ascii 1.0\nelement vertex 1\nproperty double x\nproperty double y\nproperty double z\nend_header\n1e308 0 0\n".into(),
            "too large",
        ),
        ("big.json", r#"{"strokes": [{"points": [[1e308, 0, 0], [0, 1, 0]]}]}"#.into(), "too large"),
        ("offset.bvh", small_bvh().replace("OFFSET 0 10 0", "OFFSET 1e308 10 0"), "too large"),
        ("motion.bvh", small_bvh().replacen("0 0 0 0 0 0 0 0 0 0 0 0", "1e300 0 0 0 0 0 0 0 0 0 0 0", 1), "too large"),
    ];
    for (name, text, needle) in files {
        let path = d.join(name);
        std::fs::write(&path, text).expect("write");
        let r = refused_in(d, &["info", s(&path)], needle);
        assert!(stderr(&r.output).contains(name));
    }
    // glTF: a cycle is called a cycle; a huge translation is out of range.
    let cycle = serde_json::json!({
        "asset": { "version": "2.0" },
        "nodes": [ { "name": "a", "children": [1] }, { "name": "b", "children": [2] }, { "name": "c", "children": [1] } ],
        "skins": [ { "joints": [0, 1, 2] } ]
    });
    let path = d.join("cycle.gltf");
    std::fs::write(&path, cycle.to_string()).expect("write");
    refused_in(d, &["info", s(&path)], "parent");
    let ring = serde_json::json!({
        "asset": { "version": "2.0" },
        "nodes": [ { "name": "a", "children": [1] }, { "name": "b", "children": [0] } ],
        "skins": [ { "joints": [0, 1] } ]
    });
    let path = d.join("ring.gltf");
    std::fs::write(&path, ring.to_string()).expect("write");
    refused_in(d, &["info", s(&path)], "joint cycle");
    let own = serde_json::json!({
        "asset": { "version": "2.0" },
        "nodes": [ { "name": "a", "children": [0] } ],
        "skins": [ { "joints": [0] } ]
    });
    let path = d.join("own.gltf");
    std::fs::write(&path, own.to_string()).expect("write");
    refused_in(d, &["info", s(&path)], "joint cycle");
    let far = serde_json::json!({
        "asset": { "version": "2.0" },
        "nodes": [ { "name": "a", "translation": [1e200, 0, 0] } ],
        "skins": [ { "joints": [0] } ]
    });
    let path = d.join("far.gltf");
    std::fs::write(&path, far.to_string()).expect("write");
    refused_in(d, &["info", s(&path)], "too large");
    // A rotation whose norm overflows is normalised, not zeroed.
    let huge_q = serde_json::json!({
        "asset": { "version": "2.0" },
        "nodes": [ { "name": "a", "rotation": [1e300, 1e300, 0, 0], "children": [1] }, { "name": "b", "translation": [0, 0, 1] } ],
        "skins": [ { "joints": [0, 1] } ]
    });
    let path = d.join("q.gltf");
    std::fs::write(&path, huge_q.to_string()).expect("write");
    let doc = rigfit_formats::gltf::read_gltf(&path, None).expect("reads");
    let q = doc.rig.expect("rig").pose.local[0].rotation;
    let half = std::f64::consts::FRAC_1_SQRT_2;
    assert!(
        (q.i - half).abs() < 1e-12 && (q.j - half).abs() < 1e-12,
        "{q:?}"
    );
}

#[test]
fn rig_options_that_do_not_apply_are_refused() {
    let (dir, rig, strokes) = rig_dir();
    let d = dir.path();
    let glb = data("assimp/simple_skin.gltf");
    refused_in(
        d,
        &["pose", s(&glb), s(&strokes), "--start-frame", "2"],
        "--start-frame applies to BVH",
    );
    refused_in(
        d,
        &["pose", s(&rig), s(&strokes), "--skin", "Armature"],
        "--skin applies to glTF",
    );
}

#[test]
fn warnings_name_their_file() {
    let dir = tempfile::tempdir().expect("temp dir");
    let path = dir.path().join("rows.bvh");
    std::fs::write(&path, small_bvh().replace("Frames: 3", "Frames: 5")).expect("write");
    let r = run(&["info", s(&path)]);
    let err = stderr(&r.output);
    assert_eq!(r.output.status.code(), Some(0), "{err}");
    assert!(err.contains("WARN") && err.contains("rows.bvh"), "{err}");
    assert!(!err.contains('\x1b'), "no colour codes in a file: {err:?}");
}

// ---------------------------------------------------------------- deep and wide trees

/// A BVH chain `depth` joints deep (each one channel), one frame.
fn deep_bvh(depth: usize) -> String {
    let mut t = String::with_capacity(depth * 60);
    t.push_str("HIERARCHY\nROOT j0\n{\nOFFSET 0 0 0\nCHANNELS 3 Xposition Yposition Zposition\n");
    for i in 1..depth {
        t.push_str(&format!(
            "JOINT j{i}\n{{\nOFFSET 0 1 0\nCHANNELS 1 Zrotation\n"
        ));
    }
    for _ in 0..depth {
        t.push_str("}\n");
    }
    t.push_str("MOTION\nFrames: 1\nFrame Time: 0.04\n0 0 0");
    for _ in 1..depth {
        t.push_str(" 0");
    }
    t.push('\n');
    t
}

/// A BVH whose root has `width` children.
fn wide_bvh(width: usize) -> String {
    let mut t = String::with_capacity(width * 60);
    t.push_str("HIERARCHY\nROOT r\n{\nOFFSET 0 0 0\nCHANNELS 3 Xposition Yposition Zposition\n");
    for i in 0..width {
        t.push_str(&format!(
            "JOINT c{i}\n{{\nOFFSET {i} 1 0\nCHANNELS 1 Zrotation\n}}\n"
        ));
    }
    t.push_str("}\nMOTION\nFrames: 1\nFrame Time: 0.04\n0 0 0");
    for _ in 0..width {
        t.push_str(" 0");
    }
    t.push('\n');
    t
}

/// A glTF chain or fan of `n` skin joints (no buffers).
fn many_joint_gltf(n: usize, chain: bool) -> String {
    let mut t = String::with_capacity(n * 48);
    t.push_str(r#"{"asset":{"version":"2.0"},"nodes":["#);
    for i in 0..n {
        if i > 0 {
            t.push(',');
        }
        if chain && i + 1 < n {
            t.push_str(&format!(
                r#"{{"name":"j{i}","translation":[0,1,0],"children":[{}]}}"#,
                i + 1
            ));
        } else if !chain && i == 0 {
            t.push_str(r#"{"name":"j0","children":["#);
            for c in 1..n {
                if c > 1 {
                    t.push(',');
                }
                t.push_str(&c.to_string());
            }
            t.push_str("]}");
        } else {
            t.push_str(&format!(r#"{{"name":"j{i}","translation":[{i},1,0]}}"#));
        }
    }
    t.push_str(r#"],"skins":[{"joints":["#);
    for i in 0..n {
        if i > 0 {
            t.push(',');
        }
        t.push_str(&i.to_string());
    }
    t.push_str("]}]}");
    t
}

fn info_in_time(path: &Path, joints: usize) -> Run {
    let r = run(&["info", s(path)]);
    assert_eq!(r.output.status.code(), Some(0), "{}", stderr(&r.output));
    assert_within_limits(&r);
    let text = String::from_utf8_lossy(&r.output.stdout);
    assert!(
        text.contains(&format!("joints: {joints}")),
        "{}",
        &text[..text.len().min(400)]
    );
    // Linear output: indentation stops growing.
    assert!(
        text.len() < 200 * joints + 10_000,
        "{} bytes of output",
        text.len()
    );
    r
}

#[test]
fn deep_and_wide_joint_trees_take_near_linear_time() {
    let dir = tempfile::tempdir().expect("temp dir");
    let d = dir.path();
    let deep = d.join("deep.bvh");
    std::fs::write(&deep, deep_bvh(50_000)).expect("write");
    let r = info_in_time(&deep, 50_000);
    eprintln!(
        "info, 50,000-deep BVH chain: {:.2} s, {:?} KiB",
        r.seconds, r.rss_kb
    );
    let wide = d.join("wide.bvh");
    std::fs::write(&wide, wide_bvh(100_000)).expect("write");
    let r = info_in_time(&wide, 100_001);
    eprintln!(
        "info, 100,000-wide BVH: {:.2} s, {:?} KiB",
        r.seconds, r.rss_kb
    );
    let chain = d.join("chain.gltf");
    std::fs::write(&chain, many_joint_gltf(50_000, true)).expect("write");
    let r = info_in_time(&chain, 50_000);
    eprintln!(
        "info, 50,000-deep glTF chain: {:.2} s, {:?} KiB",
        r.seconds, r.rss_kb
    );
    let fan = d.join("fan.gltf");
    std::fs::write(&fan, many_joint_gltf(200_000, false)).expect("write");
    let r = info_in_time(&fan, 200_000);
    eprintln!(
        "info, glTF with 200,000 skin joints: {:.2} s, {:?} KiB",
        r.seconds, r.rss_kb
    );
}

#[test]
fn posing_huge_trees_is_bounded() {
    let dir = tempfile::tempdir().expect("temp dir");
    let d = dir.path();
    let strokes = d.join("strokes.json");
    std::fs::write(&strokes, strokes_json()).expect("write");
    // Past the solver's joint bound: refused in one line naming the rig.
    let wide = d.join("wide.bvh");
    std::fs::write(&wide, wide_bvh(100_000)).expect("write");
    let out = d.join("posed.bvh");
    let r = refused_in(
        d,
        &["pose", s(&wide), s(&strokes), "-o", s(&out)],
        "wide.bvh: the rig has 100001 joints",
    );
    eprintln!("pose, 100,000-wide BVH: refused in {:.2} s", r.seconds);
    // Within it: posed in bounded time.
    let deep = d.join("deep.bvh");
    std::fs::write(&deep, deep_bvh(5_000)).expect("write");
    let r = run(&["pose", s(&deep), s(&strokes), "-o", s(&out)]);
    assert_eq!(r.output.status.code(), Some(0), "{}", stderr(&r.output));
    assert_within_limits(&r);
    eprintln!("pose, 5,000-deep BVH chain: {:.2} s", r.seconds);
}

#[test]
fn a_million_joints_is_refused_quickly() {
    let dir = tempfile::tempdir().expect("temp dir");
    let d = dir.path();
    let fan = d.join("fan.gltf");
    std::fs::write(&fan, many_joint_gltf(1_000_000, false)).expect("write");
    let r = refused_in(d, &["info", s(&fan)], "too many");
    eprintln!(
        "info, glTF with 1,000,000 skin joints: refused in {:.2} s, {:?} KiB",
        r.seconds, r.rss_kb
    );
    let wide = d.join("wide.bvh");
    std::fs::write(&wide, wide_bvh(1_000_000)).expect("write");
    let r = refused_in(d, &["info", s(&wide)], "too many");
    eprintln!(
        "info, 1,000,000-wide BVH: refused in {:.2} s, {:?} KiB",
        r.seconds, r.rss_kb
    );
}

// ---------------------------------------------------------------- argument errors

#[test]
fn argument_errors_are_one_line_and_help_still_works() {
    let dir = tempfile::tempdir().expect("temp dir");
    let d = dir.path();
    let cases: &[&[&str]] = &[
        &[],
        &["nosuchcommand"],
        &["pose"],
        &["pose", "a.glb"],
        &["pose", "a.glb", "s.json", "--no-such-flag"],
        &["pose", "a.glb", "s.json", "--frame", "x"],
        &["pose", "a.glb", "s.json", "--method", "magic"],
        &["surface", "m.ply", "f.ply"],
        &["render", "a.ply", "-o", "x.png", "--tile", "1000000"],
        &["info"],
        &["info", "a", "b"],
    ];
    for args in cases {
        let r = refused_in(d, args, "");
        assert!(
            stderr(&r.output).contains("rigfit --help"),
            "{}",
            stderr(&r.output)
        );
    }
    // The missing arguments are named on the one line.
    let r = refused_in(d, &["pose"], "<RIG> <STROKES>");
    assert!(stderr(&r.output).contains("not provided"));
    for help in [
        &["--help"][..],
        &["pose", "--help"],
        &["-h"],
        &["--version"],
        &["-V"],
    ] {
        let r = run(help);
        assert_eq!(r.output.status.code(), Some(0), "{help:?}");
        assert!(!r.output.stdout.is_empty());
    }
}
