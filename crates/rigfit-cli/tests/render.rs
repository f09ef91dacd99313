//! `rigfit render` and `rigfit pose --render` end to end: every real asset drawn to a PNG of
//! the right size with content, the pose picture, and bad input.

mod common;

use std::path::Path;

use common::*;

fn s(p: &Path) -> &str {
    p.to_str().expect("utf-8 path")
}

/// Width and height from a PNG's IHDR chunk, and the share of its bytes that differ from a
/// blank picture's (a rough non-blank check; the render crate's tests check pixels).
fn png_size(path: &Path) -> (u32, u32, usize) {
    let bytes = std::fs::read(path).expect("the picture was written");
    assert_eq!(
        &bytes[..8],
        b"\x89PNG\r\n\x1a\n",
        "{}: PNG signature",
        path.display()
    );
    let be = |b: &[u8]| u32::from_be_bytes([b[0], b[1], b[2], b[3]]);
    (be(&bytes[16..20]), be(&bytes[20..24]), bytes.len())
}

#[test]
fn renders_every_real_asset() {
    let dir = tempfile::tempdir().expect("temp dir");
    // A blank 400 x 400 white picture compresses to well under 2 kB.
    for file in [
        "assimp/BCN_Epileptic.glb",
        "assimp/Testwuson.glb",
        "assimp/animation_with_skeleton.glb",
        "assimp/simple_skin.gltf",
        "webxr_hand/left.glb",
        "webxr_hand/right.glb",
        "cmu/01_01.bvh",
        "bunny/bunny.ply",
    ] {
        let input = data(file);
        let out = dir.path().join("picture.png");
        let o = rigfit(&["render", s(&input), "-o", s(&out), "--tile", "200"]);
        assert!(o.status.success(), "{file}: {}", stderr(&o));
        assert!(
            stderr(&o).is_empty(),
            "{file}: nothing on stderr: {}",
            stderr(&o)
        );
        let (w, h, len) = png_size(&out);
        assert_eq!((w, h), (600, 200), "{file}");
        assert!(len > 4000, "{file}: {len} bytes looks blank");
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
}

#[test]
fn pose_render_draws_start_and_result_side_by_side() {
    let dir = tempfile::tempdir().expect("temp dir");
    let demo = dir.path().join("demo");
    let o = rigfit(&["demo", "-o", s(&demo)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let picture = dir.path().join("pose.png");
    let o = rigfit(&[
        "pose",
        s(&demo.join("humanoid.glb")),
        s(&demo.join("strokes.json")),
        "--render",
        s(&picture),
        "--tile",
        "300",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    // Two panels (start, result) of three views each, one below the other.
    let (w, h, len) = png_size(&picture);
    assert_eq!((w, h), (600, 900));
    assert!(len > 10_000, "{len} bytes");
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
