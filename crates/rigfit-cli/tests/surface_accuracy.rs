//! Surface tracking on the real skinned assets (issue 5's bar): 30 frames of the assets' own
//! clips, about 10,000 points a frame, 1% noise, 15% outliers (a floor slab and clutter), a
//! limb missing in three frames. Mean per-vertex error below 1% of the reference's
//! bounding-box diagonal over the sequence, 95th percentile below 3%.

mod common;

use common::*;
use rand::SeedableRng;
use rigfit_core::TriMesh;
use rigfit_core::surface::cases::{
    SequenceOptions, find_animation, make_sequence, mean_and_p95, sample_surface, skinned_surface,
    vertex_errors,
};
use rigfit_core::surface::{Observations, SurfaceOptions, SurfaceTracker};
use rigfit_formats::ply::{read_ply, write_ply};
use rigfit_formats::rig_file::{RigOptions, read_rig};

fn track_asset(file: &str, clip: &str) -> (f64, f64) {
    let rig = read_rig(&data(file), &RigOptions::default())
        .expect("asset")
        .rig;
    let anim = find_animation(&rig, clip);
    let mut rng = rand::rngs::StdRng::seed_from_u64(5);
    let seq = make_sequence(&rig, anim, &SequenceOptions::default(), &mut rng);
    assert_eq!(seq.frames.len(), 30);
    assert!(!seq.hole_vertices.is_empty());
    let mut tracker =
        SurfaceTracker::new(&seq.reference, &SurfaceOptions::default()).expect("tracker");
    let fitted: Vec<_> = seq
        .frames
        .iter()
        .map(|frame| {
            let obs = Observations::from_mesh(frame).expect("frame");
            tracker.track(&obs).expect("track").positions
        })
        .collect();
    let (mean, p95) = mean_and_p95(&vertex_errors(&fitted, &seq.truth, seq.diagonal));
    eprintln!(
        "{file} ({clip}): mean {:.3}%, p95 {:.3}%",
        mean * 100.0,
        p95 * 100.0
    );
    (mean, p95)
}

#[test]
fn bcn_epileptic_jump_is_tracked_within_the_bar() {
    let (mean, p95) = track_asset("assimp/BCN_Epileptic.glb", "jump");
    assert!(mean < 0.01, "mean {mean}");
    assert!(p95 < 0.03, "p95 {p95}");
}

#[test]
fn testwuson_run_is_tracked_within_the_bar() {
    let (mean, p95) = track_asset("assimp/Testwuson.glb", "run");
    assert!(mean < 0.01, "mean {mean}");
    assert!(p95 < 0.03, "p95 {p95}");
}

#[test]
fn a_glb_reference_is_its_skinned_mesh() {
    let path = data("assimp/BCN_Epileptic.glb");
    let rig = read_rig(&path, &RigOptions::default()).expect("asset").rig;
    let surface = skinned_surface(&rig, &rig.pose);
    let mut rng = rand::rngs::StdRng::seed_from_u64(1);
    let (points, normals) = sample_surface(&surface.vertices, &surface.triangles, 8000, &mut rng);
    let dir = tempfile::tempdir().expect("tempdir");
    let frame = dir.path().join("scan.ply");
    write_ply(
        &frame,
        &TriMesh {
            vertices: points,
            normals: Some(normals),
            triangles: Vec::new(),
        },
    )
    .expect("write");
    let out = dir.path().join("out");
    let o = rigfit(&[
        "surface",
        path.to_str().expect("utf-8"),
        frame.to_str().expect("utf-8"),
        "-o",
        out.to_str().expect("utf-8"),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let fitted = read_ply(&out.join("frame_00000.ply")).expect("output");
    assert_eq!(fitted.vertices.len(), surface.vertices.len());
    assert_eq!(fitted.triangles, surface.triangles);
    let diagonal = surface.bounds().expect("bounds").diagonal();
    let mean = fitted
        .vertices
        .iter()
        .zip(&surface.vertices)
        .map(|(a, b)| (a - b).norm())
        .sum::<f64>()
        / surface.vertices.len() as f64;
    assert!(mean < 0.01 * diagonal, "mean {mean}");
}
