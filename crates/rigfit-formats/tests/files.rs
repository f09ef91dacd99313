//! `rigfit_formats::files`: what may be read and written, in-process (the command-line side
//! is `rigfit-cli/tests/hostile.rs`).

use std::path::Path;
use std::time::{Duration, Instant};

use rigfit_formats::files::{
    MAX_INPUT_BYTES, check_outputs, commit_all, read_input, read_relative_uri, stage,
};

fn names(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .expect("list")
        .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

#[test]
fn special_files_are_refused_without_blocking() {
    let dir = tempfile::tempdir().expect("temp dir");
    let fifo = dir.path().join("pipe.ply");
    assert!(
        std::process::Command::new("mkfifo")
            .arg(&fifo)
            .status()
            .expect("mkfifo")
            .success()
    );
    let t0 = Instant::now();
    let e = read_input(&fifo).expect_err("a FIFO is refused");
    assert!(e.to_string().contains("FIFO"), "{e}");
    for device in ["/dev/zero", "/dev/null", "/dev/urandom"] {
        let e = read_input(Path::new(device)).expect_err("a device is refused");
        assert!(e.to_string().contains("device"), "{e}");
    }
    let e = read_input(dir.path()).expect_err("a folder is refused");
    assert!(e.to_string().contains("directory"), "{e}");
    assert!(t0.elapsed() < Duration::from_secs(1));
    let sparse = dir.path().join("sparse.bin");
    std::fs::File::create(&sparse)
        .and_then(|f| f.set_len(MAX_INPUT_BYTES + 1))
        .expect("sparse");
    let e = read_input(&sparse).expect_err("too large");
    assert!(e.to_string().contains("bytes"), "{e}");
}

#[test]
fn uris_resolve_inside_the_folder_and_read_only_byte_length() {
    let top = tempfile::tempdir().expect("temp dir");
    let dir = top.path().join("m");
    std::fs::create_dir(&dir).expect("mkdir");
    std::fs::write(dir.join("buf.bin"), [1u8, 2, 3, 4, 5, 6, 7, 8]).expect("write");
    std::fs::write(top.path().join("secret.bin"), [9u8; 8]).expect("write");
    std::os::unix::fs::symlink("../secret.bin", dir.join("out.bin")).expect("link");
    std::os::unix::fs::symlink("buf.bin", dir.join("in.bin")).expect("link");
    let (bytes, _) = read_relative_uri(&dir, "buf.bin", 3).expect("inside");
    assert_eq!(bytes, [1, 2, 3]);
    let (bytes, _) = read_relative_uri(&dir, "in.bin", 8).expect("link inside");
    assert_eq!(bytes.len(), 8);
    for (uri, len) in [
        ("out.bin", 8),
        ("../secret.bin", 8),
        ("%2e%2e/secret.bin", 8),
        ("/etc/hostname", 1),
        ("buf.bin", 9),
    ] {
        assert!(read_relative_uri(&dir, uri, len).is_err(), "{uri}");
    }
}

#[test]
fn outputs_are_staged_together_and_leave_nothing_on_failure() {
    let dir = tempfile::tempdir().expect("temp dir");
    let d = dir.path();
    let input = d.join("in.json");
    std::fs::write(&input, "{}").expect("write");
    std::fs::hard_link(&input, d.join("alias.json")).expect("hard link");
    // Refusals before anything is written.
    let e = check_outputs(&[&input], &[&d.join("alias.json")]).expect_err("same file");
    assert!(e.to_string().contains("is the input"), "{e}");
    let e = check_outputs(&[], &[&d.join("a.json"), &d.join("./a.json")]).expect_err("twice");
    assert!(e.to_string().contains("two outputs"), "{e}");
    check_outputs(&[&input], &[&d.join("a.json"), &d.join("b.json")]).expect("fine");
    // A staged output dropped without commit leaves no temporary.
    let a = stage(&d.join("a.json"), b"a").expect("stage");
    drop(a);
    assert_eq!(names(d), ["alias.json", "in.json"]);
    // Several staged outputs appear together on commit.
    let a = stage(&d.join("a.json"), b"a").expect("stage");
    let b = stage(&d.join("b.json"), b"b").expect("stage");
    assert_eq!(names(d).len(), 4, "two temporaries: {:?}", names(d));
    commit_all(vec![a, b]).expect("commit");
    assert_eq!(names(d), ["a.json", "alias.json", "b.json", "in.json"]);
    // A target that became a link after staging is not written through.
    let c = stage(&d.join("c.json"), b"c").expect("stage");
    std::os::unix::fs::symlink(&input, d.join("c.json")).expect("link");
    assert!(c.commit().is_err());
    assert_eq!(std::fs::read_to_string(&input).expect("read"), "{}");
    assert_eq!(
        names(d),
        ["a.json", "alias.json", "b.json", "c.json", "in.json"]
    );
}

#[test]
fn deep_bvh_chains_write_in_linear_size() {
    let depth = 50_000;
    let mut t = String::from(
        "HIERARCHY\nROOT j0\n{\nOFFSET 0 0 0\nCHANNELS 3 Xposition Yposition Zposition\n",
    );
    for i in 1..depth {
        t.push_str(&format!(
            "JOINT j{i}\n{{\nOFFSET 0 1 0\nCHANNELS 1 Zrotation\n"
        ));
    }
    t.push_str(&"}\n".repeat(depth));
    t.push_str("MOTION\nFrames: 1\nFrame Time: 0.04\n0 0 0");
    t.push_str(&" 0".repeat(depth - 1));
    t.push('\n');
    let t0 = Instant::now();
    let doc = rigfit_formats::bvh::parse_bvh(t.as_bytes()).expect("parses");
    let rig = doc.to_rig(Some(0));
    let out = doc.to_bvh_string();
    assert_eq!(rig.skeleton.len(), depth);
    // 32 levels of tabs at most on each of 5 lines a joint (uncapped: 6e9 bytes).
    assert!(out.len() < 300 * depth, "{} bytes", out.len());
    assert!(t0.elapsed() < Duration::from_secs(5), "{:?}", t0.elapsed());
}

/// A glTF chain of `n` skin joints, no buffers.
fn chain_gltf(n: usize) -> String {
    let nodes: Vec<String> = (0..n)
        .map(|i| {
            if i + 1 < n {
                format!(
                    r#"{{"name":"j{i}","translation":[0,1,0],"children":[{}]}}"#,
                    i + 1
                )
            } else {
                format!(r#"{{"name":"j{i}","translation":[0,1,0]}}"#)
            }
        })
        .collect();
    let joints: Vec<String> = (0..n).map(|i| i.to_string()).collect();
    format!(
        r#"{{"asset":{{"version":"2.0"}},"nodes":[{}],"skins":[{{"joints":[{}]}}]}}"#,
        nodes.join(","),
        joints.join(",")
    )
}

#[test]
fn deep_rigs_convert_between_formats_in_near_linear_time() {
    use rigfit_formats::rig_file::{RigOptions, read_rig};
    let depth = 20_000;
    let dir = tempfile::tempdir().expect("temp dir");
    let gltf = dir.path().join("chain.gltf");
    std::fs::write(&gltf, chain_gltf(depth)).expect("write");
    let t0 = Instant::now();
    let rig = read_rig(&gltf, &RigOptions::default()).expect("reads");
    let pose = rig.rig.pose.clone();
    let as_bvh = rig
        .pose_bytes(&dir.path().join("o.bvh"), &pose, None)
        .expect("to BVH");
    let as_glb = rig
        .poses_bytes(&dir.path().join("o.glb"), &[pose.clone(), pose], 24.0)
        .expect("to GLB");
    let bvh_path = dir.path().join("chain.bvh");
    std::fs::write(&bvh_path, &as_bvh).expect("write");
    let bvh = read_rig(&bvh_path, &RigOptions::default()).expect("reads back");
    assert!(
        bvh.rig.skeleton.len() >= depth,
        "{}",
        bvh.rig.skeleton.len()
    );
    let pose = bvh.rig.pose.clone();
    bvh.pose_bytes(&dir.path().join("b.glb"), &pose, None)
        .expect("BVH to GLB");
    bvh.pose_bytes(&dir.path().join("b.bvh"), &pose, Some(5))
        .expect("BVH keyed");
    let report = rigfit_formats::report::pose_report(&bvh.rig, &pose, &[], 0, 0.0, 0.0);
    assert!(
        report["joints"]
            .as_array()
            .is_some_and(|j| j.len() >= depth)
    );
    assert!(!as_glb.is_empty());
    let seconds = t0.elapsed().as_secs_f64();
    eprintln!("{depth}-deep chain: read, to BVH, to GLB, back, report in {seconds:.2} s");
    assert!(seconds < 5.0, "{seconds:.2} s");
}
