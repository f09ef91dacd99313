//! `rigfit demo-rig -o humanoid.glb`: the built-in character, written out.

use std::path::PathBuf;

use anyhow::bail;
use rigfit_formats::bvh::BvhDocument;
use rigfit_formats::error::extension;

#[derive(Debug, clap::Args)]
pub struct DemoRigArgs {
    /// Output file: .glb (skinned mesh, skeleton and a wave animation) or .bvh.
    #[arg(short, long, default_value = "humanoid.glb")]
    output: PathBuf,
}

pub fn run(args: &DemoRigArgs) -> anyhow::Result<()> {
    let rig = rigfit_core::humanoid::humanoid();
    match extension(&args.output).as_str() {
        "glb" => rigfit_formats::gltf::write_rig_glb(&args.output, &rig)?,
        "bvh" => {
            let poses: Vec<_> = (0..=48)
                .map(|f| rig.animations[0].sample(&rig.pose, f as f64 / 24.0))
                .collect();
            BvhDocument::from_skeleton(&rig.skeleton, &poses, 1.0 / 24.0).write(&args.output)?;
        }
        _ => bail!(
            "{}: unsupported output type (expected .glb or .bvh)",
            args.output.display()
        ),
    }
    println!(
        "wrote {} ({} joints, {} vertices)",
        args.output.display(),
        rig.skeleton.len(),
        rig.meshes.iter().map(|m| m.positions.len()).sum::<usize>()
    );
    Ok(())
}
