//! Writes a ground-truth tracking sequence of the accuracy suites as files, for trying
//! `rigfit track` by hand: the start rig (the first true pose), one `.ply` cloud per frame,
//! and the true joint positions per frame as a track report (`truth.json`).
//!
//! `cargo run --release -p rigfit-testkit --example track_sequence -- hand target/track-demo`
//! (suites: BCN_Epileptic, Testwuson, hand, 01_01), then
//! `rigfit track target/track-demo/start.glb target/track-demo/frame_*.ply -o track.glb`

use rigfit_testkit::track_suites;

use std::path::PathBuf;

use rigfit_core::TriMesh;
use rigfit_formats::ply::write_ply;
use rigfit_formats::report::{to_text, track_frame_json};
use rigfit_formats::rig_file::{RigOptions, read_rig};
use rigfit_testkit::track_cases::SequenceOptions;

fn main() {
    let mut args = std::env::args().skip(1);
    let name: &'static str = match args.next().as_deref() {
        Some("BCN_Epileptic") => "BCN_Epileptic",
        Some("Testwuson") => "Testwuson",
        Some("01_01") => "01_01",
        _ => "hand",
    };
    let dir = PathBuf::from(args.next().unwrap_or_else(|| "target/track-demo".into()));
    std::fs::create_dir_all(&dir).expect("output folder");
    let suite = track_suites::suite(name, track_suites::FRAMES, &SequenceOptions::default());
    let source = match name {
        "BCN_Epileptic" => "assimp/BCN_Epileptic.glb",
        "Testwuson" => "assimp/Testwuson.glb",
        "01_01" => "cmu/01_01.bvh",
        _ => "webxr_hand/left.glb",
    };
    let rig_file = read_rig(
        &rigfit_testkit::assets::asset(source),
        &RigOptions::default(),
    )
    .expect("rig");
    let start = dir.join(if name == "01_01" {
        "start.bvh"
    } else {
        "start.glb"
    });
    rig_file
        .write_pose(&start, &suite.frames[0].truth, None)
        .expect("start rig");
    let mut truth = Vec::new();
    for (k, frame) in suite.frames.iter().enumerate() {
        let file = dir.join(format!("frame_{k:04}.ply"));
        let cloud = TriMesh {
            vertices: frame.points.clone(),
            ..TriMesh::default()
        };
        write_ply(&file, &cloud).expect("frame");
        truth.push(track_frame_json(
            &suite.rig,
            &frame.truth,
            &file.display().to_string(),
            frame.outlier.iter().filter(|&&o| !o).count(),
            0.0,
        ));
    }
    std::fs::write(
        dir.join("truth.json"),
        to_text(&serde_json::json!({ "frames": truth })),
    )
    .expect("truth");
    println!(
        "wrote {} and {} frames to {}",
        start.display(),
        suite.frames.len(),
        dir.display()
    );
}
