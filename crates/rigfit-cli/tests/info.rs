//! `rigfit info` and `rigfit demo-rig` on the real assets and on the malformed corpus.

mod common;

use common::*;

#[test]
fn info_describes_every_real_asset() {
    for (file, expect) in [
        ("assimp/BCN_Epileptic.glb", "joints: 55 (54 skin joints"),
        ("assimp/Testwuson.glb", "Wuson_Run"),
        ("assimp/animation_with_skeleton.glb", "14 skin joints"),
        ("assimp/simple_skin.gltf", "2 skin joints"),
        ("webxr_hand/left.glb", "wrist"),
        ("webxr_hand/right.glb", "25 skin joints"),
        ("cmu/01_01.bvh", "frames: 2752"),
        ("bunny/bunny.ply", "triangles: 3674"),
    ] {
        let path = data(file);
        let o = rigfit(&["info", path.to_str().expect("utf-8 path")]);
        let out = stdout(&o);
        assert!(o.status.success(), "{file}: {}", stderr(&o));
        assert!(
            out.contains(expect),
            "{file}: expected '{expect}' in\n{out}"
        );
        assert!(out.contains("bounding box: min"), "{file}: {out}");
    }
}

#[test]
fn the_damaged_pond_scan_is_rejected_clearly() {
    // pond.0.ply is damaged in its Debian package itself (69 bytes short: CR bytes of CR LF
    // pairs were stripped from the binary data), so rows past 624 are misaligned garbage.
    let path = data("assimp/pond.0.ply");
    let o = rigfit(&["info", path.to_str().expect("utf-8")]);
    assert_bad_input(&o, &path);
    assert!(stderr(&o).contains("ends early"), "{}", stderr(&o));
}

#[test]
fn info_shows_animation_duration_frames_and_height() {
    let path = data("assimp/BCN_Epileptic.glb");
    let out = stdout(&rigfit(&["info", path.to_str().expect("utf-8")]));
    assert!(out.contains("Epileptisch: 3.3"), "{out}");
    assert!(out.contains("height: 1."), "{out}");
    assert!(out.contains("Torso:"), "{out}");
}

#[test]
fn demo_rig_writes_a_humanoid_that_info_reads() {
    let dir = tempfile::tempdir().expect("temp dir");
    for name in ["humanoid.glb", "humanoid.bvh"] {
        let out = dir.path().join(name);
        let o = rigfit(&["demo-rig", "-o", out.to_str().expect("utf-8")]);
        assert!(o.status.success(), "{}", stderr(&o));
        let info = rigfit(&["info", out.to_str().expect("utf-8")]);
        let text = stdout(&info);
        assert!(info.status.success(), "{}", stderr(&info));
        assert!(text.contains("LeftForeArm"), "{text}");
    }
}

#[test]
fn malformed_files_exit_2_with_one_line() {
    let mut n = 0;
    for entry in std::fs::read_dir(malformed_dir()).expect("corpus") {
        let path = entry.expect("entry").path();
        let name = path
            .file_name()
            .expect("name")
            .to_string_lossy()
            .into_owned();
        if name.starts_with("gltf_no_skin") {
            continue; // a valid file for `info`; a bad rig for `pose`
        }
        let o = rigfit(&["info", path.to_str().expect("utf-8")]);
        assert_bad_input(&o, &path);
        n += 1;
    }
    assert!(n >= 20, "the corpus has {n} files");
}

#[test]
fn missing_file_and_unknown_type_exit_2() {
    let o = rigfit(&["info", "/nonexistent/rig.glb"]);
    assert_bad_input(&o, std::path::Path::new("/nonexistent/rig.glb"));
    let o = rigfit(&["info", "notes.txt"]);
    assert_bad_input(&o, std::path::Path::new("notes.txt"));
}

#[test]
fn unwritable_output_exits_2_and_leaves_nothing() {
    let o = rigfit(&["demo-rig", "-o", "/nonexistent-dir/humanoid.glb"]);
    assert_bad_input(&o, std::path::Path::new("/nonexistent-dir/humanoid.glb"));
}

#[test]
fn info_shows_the_ik_goals_tied_to_the_arms() {
    // mrfixit's hands hang from IK goals its clip keeps at the ends of its arms.
    let (_, folder) = rigfit_testkit::Corpus::locations();
    let path = folder.join("assimp/mrfixit.glb");
    let out = stdout(&rigfit(&["info", path.to_str().expect("utf-8")]));
    assert!(out.contains("ArmIK.L [free] (tied to Hand.L)"), "{out}");
    assert!(out.contains("ArmIK.R [free] (tied to Hand.R)"), "{out}");
}
