//! One module per subcommand.

pub mod batch;
pub mod demo;
pub mod demo_rig;
pub mod info;
pub mod pose;
pub mod render;
#[cfg(feature = "serve")]
pub mod serve;
pub mod surface;
pub mod track;

use std::path::Path;

use rigfit_formats::error::extension;

/// The files a rig was read from: the rig and the external buffers of a glTF.
pub fn rig_inputs(rig_file: &rigfit_formats::rig_file::RigFile) -> Vec<std::path::PathBuf> {
    let mut files = vec![rig_file.path.clone()];
    if let rigfit_formats::rig_file::RigSource::Gltf(doc) = &rig_file.source {
        files.extend(doc.external_files.iter().cloned());
    }
    files
}

/// Before any work: every input is a regular file rigfit may read (not a FIFO or device,
/// not too large), every output may be written (absent or a regular file, in an existing
/// folder), and no output is an input or named twice.
pub fn check_files(inputs: &[&Path], outputs: &[&Path]) -> anyhow::Result<()> {
    for input in inputs {
        rigfit_formats::files::check_input(input)?;
    }
    rigfit_formats::files::check_outputs(inputs, outputs)?;
    Ok(())
}

/// Refuses rig options that do not apply to the rig's format, instead of ignoring them.
pub fn check_rig_options(
    rig: &Path,
    skin: Option<&str>,
    start_frame: Option<&str>,
) -> anyhow::Result<()> {
    let ext = extension(rig);
    if start_frame.is_some() && matches!(ext.as_str(), "glb" | "gltf") {
        anyhow::bail!(
            "{}: --start-frame applies to BVH rigs only (a glTF starts from its stored node pose)",
            rig.display()
        );
    }
    if skin.is_some() && ext == "bvh" {
        anyhow::bail!(
            "{}: --skin applies to glTF rigs only (a BVH has no skins)",
            rig.display()
        );
    }
    Ok(())
}

/// A clap error as one line: the first paragraph of its message without the `error: `
/// prefix, and a pointer to the help of `command` (empty: the top level).
pub fn argument_line(e: &clap::Error, command: &str) -> String {
    let help = if command.is_empty() {
        "rigfit --help".to_string()
    } else {
        format!("rigfit {command} --help")
    };
    if e.kind() == clap::error::ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand {
        return format!("a command is required (see {help})");
    }
    // The first paragraph (a missing-arguments message lists them on the lines below).
    let text = e.render().to_string();
    let first: Vec<&str> = text
        .lines()
        .map(str::trim)
        .skip_while(|l| l.is_empty())
        .take_while(|l| !l.is_empty())
        .collect();
    let first = first.join(" ");
    let first = first.strip_prefix("error:").unwrap_or(&first).trim();
    if first.is_empty() {
        return format!("invalid arguments (see {help})");
    }
    format!("{first} (see {help})")
}
