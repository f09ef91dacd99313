//! Writes the posing accuracy suites' cases as files (see tests/common/pose_suites.rs): per
//! suite and true pose, the strokes drawn through every chain (`strokes.json`) and with one
//! limb dropped and one stray (`strokes_hard.json`), and `cases.json` listing each case's
//! rig file and start frame, for `rigfit pose` by hand or in a batch (scripts/compare-builds.sh).
//!
//! `cargo run --release -p rigfit-testkit --example pose_cases -- OUT`

use rigfit_testkit::pose_suites;

use std::path::PathBuf;

use rand::SeedableRng;
use rigfit_core::pose::sketch::{CaseOptions, make_case};
use rigfit_formats::strokes::write_strokes;

fn main() -> anyhow::Result<()> {
    let out = PathBuf::from(
        std::env::args()
            .nth(1)
            .ok_or_else(|| anyhow::anyhow!("usage: pose_cases OUT"))?,
    );
    std::fs::create_dir_all(&out)?;
    let scenarios = [
        ("strokes", CaseOptions::default()),
        (
            "strokes_hard",
            CaseOptions {
                drop_limbs: 1,
                stray_strokes: 1,
                ..CaseOptions::default()
            },
        ),
    ];
    let mut cases = Vec::new();
    for suite in pose_suites::suites() {
        let height = suite.rig.height();
        let stem = suite.name.replace(['/', '.'], "_");
        // The suites name the BVH by its file name alone.
        let source = if suite.name == "01_01.bvh" {
            "cmu/01_01.bvh"
        } else {
            suite.name.as_str()
        };
        for (t, truth) in suite.truths.iter().enumerate() {
            for (s, (label, scenario)) in scenarios.iter().enumerate() {
                let mut rng = rand::rngs::StdRng::seed_from_u64(1000 + t as u64 + 100 * s as u64);
                let case = make_case(&suite.rig.skeleton, truth, height, scenario, &mut rng);
                let file = out.join(format!("{stem}_{t}_{label}.json"));
                write_strokes(&file, &case.strokes)?;
                cases.push(serde_json::json!({
                    "rig": rigfit_testkit::assets::asset(source).display().to_string(),
                    "start_frame": suite.name.ends_with(".bvh").then_some("rest"),
                    "strokes": file.display().to_string(),
                    "name": format!("{stem}_{t}_{label}"),
                }));
            }
        }
    }
    std::fs::write(
        out.join("cases.json"),
        serde_json::to_string_pretty(&serde_json::json!({ "cases": cases }))? + "\n",
    )?;
    println!("wrote {} cases to {}", cases.len(), out.display());
    Ok(())
}
