//! Inputs found while fuzzing that once made a reader use gigabytes of memory.

use std::path::PathBuf;

fn regression(name: &str) -> Vec<u8> {
    let p = PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/tests/regressions")).join(name);
    std::fs::read(p).expect("regression input")
}

#[test]
fn channelless_joints_with_a_million_frames_stay_small() {
    // 1.7 KB: 61 joints without channels and `Frames: 1048576`.
    let doc = rigfit_formats::bvh::parse_bvh(&regression("bvh_channelless_many_frames.bvh"))
        .expect("valid BVH");
    let rig = doc.to_rig(Some(0));
    let keys: usize = rig
        .animations
        .iter()
        .flat_map(|a| &a.channels)
        .map(|c| c.times.len())
        .sum();
    assert_eq!(keys, 0, "joints that never move get no keys");
}

#[test]
fn an_accessor_without_buffer_view_cannot_ask_for_gigabytes() {
    let mut no_files = |_: &str| -> Result<Vec<u8>, String> { Err("no files".into()) };
    let err = rigfit_formats::gltf::parse_gltf(
        &regression("gltf_viewless_huge_accessor.gltf"),
        &mut no_files,
        None,
    )
    .expect_err("rejected");
    assert!(err.to_string().contains("too large"), "{err}");
}
