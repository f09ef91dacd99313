//! Writes a ground-truth scan sequence drawn from a skinned asset (see
//! `rigfit_core::surface::cases`), for the command line and the peer comparison:
//! `OUT/reference.ply` (the mesh at the first frame, with faces and normals),
//! `OUT/scan_NNNN.ply` (points and normals), `OUT/truth_NNNN.ply` (the true vertex positions,
//! with the reference's faces) and `OUT/sequence.json` (diagonal, counts, hole frames).
//!
//! `cargo run --release -p rigfit-testkit --example surface_sequence -- ASSET CLIP OUT [FRAMES] [POINTS] [SEED]`
//!
//! With `ASSET` written `corpus:ID`, the object `ID` of the many-part surface corpus
//! (`data/surface_corpus.json`) posed by its fast motion (`surface_corpus::parts_case`,
//! seed `SEED`, default 0; `CLIP` is not used; 30 frames of 8,000 points unless given).

use std::path::PathBuf;

use rand::SeedableRng;
use rand::rngs::StdRng;
use rigfit_core::TriMesh;
use rigfit_formats::ply::write_ply;
use rigfit_formats::rig_file::{RigOptions, read_rig};
use rigfit_testkit::surface_cases::{SequenceOptions, find_animation, make_sequence};
use rigfit_testkit::surface_corpus::{self, PartsOptions};

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.len() < 3 {
        anyhow::bail!("usage: surface_sequence ASSET CLIP OUT [FRAMES] [POINTS] [SEED]");
    }
    let asset = PathBuf::from(&args[0]);
    let out = PathBuf::from(&args[2]);
    let (seq, options, clip) = if let Some(id) = args[0].strip_prefix("corpus:") {
        let mut parts = PartsOptions::default();
        if let Some(f) = args.get(3) {
            parts.frames = f.parse()?;
        }
        if let Some(p) = args.get(4) {
            parts.scan.points = p.parse()?;
        }
        let seed: u64 = args.get(5).map(|s| s.parse()).transpose()?.unwrap_or(0);
        let corpus = surface_corpus::load()?;
        let entry = corpus
            .entry(id)
            .ok_or_else(|| anyhow::anyhow!("{id}: not in the surface corpus"))?;
        let case = surface_corpus::parts_case(&corpus, entry, seed, &parts)?;
        (case.sequence, parts.scan, None)
    } else {
        let mut options = SequenceOptions::default();
        if let Some(f) = args.get(3) {
            options.frames = f.parse()?;
        }
        if let Some(p) = args.get(4) {
            options.points = p.parse()?;
        }
        let seed: u64 = args.get(5).map(|s| s.parse()).transpose()?.unwrap_or(5);
        let rig = read_rig(&asset, &RigOptions::default())?.rig;
        let anim = find_animation(&rig, &args[1]);
        let mut rng = StdRng::seed_from_u64(seed);
        let seq = make_sequence(&rig, anim, &options, &mut rng);
        let clip = rig.animations.get(anim).map(|a| a.name.clone());
        (seq, options, clip)
    };
    std::fs::create_dir_all(&out)?;
    write_ply(&out.join("reference.ply"), &seq.reference)?;
    for (f, (scan, truth)) in seq.frames.iter().zip(&seq.truth).enumerate() {
        write_ply(&out.join(format!("scan_{f:04}.ply")), scan)?;
        let truth_mesh = TriMesh {
            vertices: truth.clone(),
            normals: None,
            triangles: seq.reference.triangles.clone(),
        };
        write_ply(&out.join(format!("truth_{f:04}.ply")), &truth_mesh)?;
    }
    let meta = serde_json::json!({
        "asset": asset.display().to_string(),
        "clip": clip,
        "frames": seq.frames.len(),
        "points": options.points,
        "noise": options.noise,
        "outlier_ratio": options.outlier_ratio,
        "hole_frames": [options.hole_frames.start, options.hole_frames.end],
        "hole_vertices": seq.hole_vertices.len(),
        "vertices": seq.reference.vertices.len(),
        "diagonal": seq.diagonal,
    });
    std::fs::write(
        out.join("sequence.json"),
        serde_json::to_string_pretty(&meta)? + "\n",
    )?;
    println!(
        "wrote {} frames of {} to {}",
        seq.frames.len(),
        asset.display(),
        out.display()
    );
    Ok(())
}
