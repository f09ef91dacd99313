//! `rigfit`: the command line. A thin shell: it parses arguments, calls the readers, the
//! solvers and the writers, and turns every error into one line on stderr and exit status 2.

use std::process::ExitCode;

use clap::error::ErrorKind;
use clap::{Parser, Subcommand};
use rigfit_cli::commands;

/// Fits skeletons and deformable surfaces to 3D data: strokes, point clouds, scans.
#[derive(Debug, Parser)]
#[command(name = "rigfit", version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Pose a rigged character (.glb/.gltf/.bvh) so its bones follow 3D strokes.
    Pose(commands::pose::PoseArgs),
    /// Track an articulated body or hand (a rig) through a sequence of point clouds.
    Track(commands::track::TrackArgs),
    /// The main job on the built-in humanoid: draw strokes, pose, write the results.
    Demo(commands::demo::DemoArgs),
    /// Show what a rig, mesh, point cloud or strokes file holds.
    Info(commands::info::InfoArgs),
    /// Write the built-in procedural humanoid as a .glb (or .bvh).
    DemoRig(commands::demo_rig::DemoRigArgs),
    /// Draw rigs, meshes, point clouds and strokes from several views into a .png.
    Render(commands::render::RenderArgs),
    /// Track a reference mesh through a sequence of point clouds or meshes.
    Surface(commands::surface::SurfaceArgs),
    /// The sketching page in a browser: serve it and its API on 127.0.0.1 (docs/serve-api.md).
    #[cfg(feature = "serve")]
    Serve(commands::serve::ServeArgs),
    /// Run many takes (pose, track and surface jobs) from a JSON job file, reporting each.
    Batch(commands::batch::BatchArgs),
}

fn main() -> ExitCode {
    tracing_subscriber::fmt()
        .with_writer(std::io::stderr)
        .with_target(false)
        // No colour codes in a log file or a pipe.
        .with_ansi(std::io::IsTerminal::is_terminal(&std::io::stderr()))
        .without_time()
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_env("RIGFIT_LOG")
                .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("warn")),
        )
        .init();
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) => return argument_error(&e),
    };
    let result = match cli.command {
        Command::Pose(args) => commands::pose::run(&args).map(|summary| print!("{summary}")),
        Command::Track(args) => commands::track::run(&args).map(|summary| print!("{summary}")),
        Command::Demo(args) => commands::demo::run(&args),
        Command::Info(args) => commands::info::run(&args),
        Command::DemoRig(args) => commands::demo_rig::run(&args),
        Command::Render(args) => commands::render::run(&args),
        Command::Surface(args) => commands::surface::run(&args).map(|summary| print!("{summary}")),
        #[cfg(feature = "serve")]
        Command::Serve(args) => commands::serve::run(&args),
        // Exit status 1 when some takes failed (each reported), 2 for a bad job file.
        Command::Batch(args) => match commands::batch::run(&args) {
            Ok(outcome) if outcome.failed() == 0 => Ok(()),
            Ok(_) => return ExitCode::from(1),
            Err(e) => Err(e),
        },
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            // One line: the file, the place and the problem.
            let line = format!("{e:#}").replace('\n', " ");
            eprintln!("rigfit: error: {line}");
            ExitCode::from(2)
        }
    }
}

/// `--help` and `--version` print as clap prints them (exit 0); every other argument error
/// is one line, `rigfit: error: ...`, with exit status 2.
fn argument_error(e: &clap::Error) -> ExitCode {
    match e.kind() {
        ErrorKind::DisplayHelp | ErrorKind::DisplayVersion => {
            // Printing to stdout failing (a closed pipe) is no error worth a message.
            let _ = e.print();
            ExitCode::SUCCESS
        }
        _ => {
            eprintln!("rigfit: error: {}", commands::argument_line(e, ""));
            ExitCode::from(2)
        }
    }
}
