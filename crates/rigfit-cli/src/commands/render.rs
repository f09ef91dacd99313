//! `rigfit render INPUT... -o FILE.png`: a picture of rigs, meshes, clouds and strokes from
//! several views, all inputs overlaid in one scene; and the PNG writing `--render` shares.

use std::path::{Path, PathBuf};

use anyhow::{Context, bail};
use rigfit_formats::error::{extension, write_atomic};
use rigfit_formats::mesh_file::read_mesh;
use rigfit_formats::rig_file::{RigOptions, read_rig};
use rigfit_render::{Image, RenderOptions, Scene, View};

/// A view of `--views`.
#[derive(Debug, Clone, Copy, clap::ValueEnum, PartialEq, Eq)]
pub enum ViewArg {
    /// From +Z (x right, y up).
    Front,
    /// From +X (-z right, y up).
    Side,
    /// From +Y, looking down.
    Top,
    /// The two views that show the most (largest projected extent).
    Auto,
}

/// Picture options shared by `render` and `--render`.
#[derive(Debug, Clone, clap::Args)]
pub struct PictureArgs {
    /// The side of each view's square tile, in pixels.
    #[arg(long, default_value_t = 400, value_parser = clap::value_parser!(u32).range(64..=2048))]
    pub tile: u32,
    /// The views to draw (comma-separated): front, side, top, or auto (the two that show the
    /// most).
    #[arg(
        long,
        value_enum,
        value_delimiter = ',',
        default_value = "front,side,top"
    )]
    pub views: Vec<ViewArg>,
}

impl PictureArgs {
    /// The options for drawing `scene` (`auto` picks its views from it).
    pub fn options(&self, scene: &Scene) -> RenderOptions {
        let mut views = Vec::new();
        for v in &self.views {
            match v {
                ViewArg::Front => views.push(View::Front),
                ViewArg::Side => views.push(View::Side),
                ViewArg::Top => views.push(View::Top),
                ViewArg::Auto => views.extend(rigfit_render::best_views(scene, 2)),
            }
        }
        views.dedup();
        RenderOptions {
            tile: self.tile,
            views,
        }
    }
}

#[derive(Debug, clap::Args)]
pub struct RenderArgs {
    /// Files to draw, overlaid: rigs (.glb, .gltf, .bvh: skeleton and skinned meshes),
    /// meshes or point clouds (.ply, .obj), strokes (.json).
    #[arg(required = true)]
    pub inputs: Vec<PathBuf>,
    /// The picture to write (.png).
    #[arg(short, long)]
    pub output: PathBuf,
    #[command(flatten)]
    pub picture: PictureArgs,
    /// The glTF skin to draw (by name); the first by default.
    #[arg(long)]
    pub skin: Option<String>,
    /// BVH: the frame to draw (a number, or `rest` for all channels zero).
    #[arg(long)]
    pub start_frame: Option<String>,
}

pub fn run(args: &RenderArgs) -> anyhow::Result<()> {
    check_png_path(&args.output)?;
    if args.start_frame.is_some() && !args.inputs.iter().any(|p| extension(p) == "bvh") {
        bail!("--start-frame applies to BVH rigs only, and no input is a .bvh");
    }
    if args.skin.is_some()
        && !args
            .inputs
            .iter()
            .any(|p| matches!(extension(p).as_str(), "glb" | "gltf"))
    {
        bail!("--skin applies to glTF rigs only, and no input is a .glb or .gltf");
    }
    let inputs: Vec<&Path> = args.inputs.iter().map(PathBuf::as_path).collect();
    super::check_files(&inputs, &[&args.output])?;
    let rig_options = RigOptions {
        skin: args.skin.clone(),
        start_frame: super::pose::start_frame(args.start_frame.as_deref())?,
    };
    let mut scene = Scene::new();
    for input in &args.inputs {
        add_file(&mut scene, input, &rig_options)?;
    }
    let image = rigfit_render::render(&scene, &args.picture.options(&scene));
    write_png(&args.output, &image)?;
    println!(
        "drew {} points from {} file(s) into {} ({} x {})",
        scene.point_count(),
        args.inputs.len(),
        args.output.display(),
        image.width(),
        image.height()
    );
    Ok(())
}

/// Adds what one file holds to `scene`.
fn add_file(scene: &mut Scene, path: &Path, rig_options: &RigOptions) -> anyhow::Result<()> {
    match extension(path).as_str() {
        "glb" | "gltf" | "bvh" => {
            let file = read_rig(path, rig_options)?;
            scene.add_rig(&file.rig, &file.rig.pose);
        }
        "ply" | "obj" => {
            scene.add_mesh(&read_mesh(path)?);
        }
        "json" => {
            let strokes = rigfit_formats::strokes::read_strokes(path)?;
            scene.add_strokes(&strokes, &[]);
        }
        _ => bail!(
            "{}: unsupported file type (expected .glb, .gltf, .bvh, .ply, .obj or a strokes .json)",
            path.display()
        ),
    }
    Ok(())
}

/// Fails early (before any solving) when `path` is no `.png` or its folder does not exist.
pub fn check_png_path(path: &Path) -> anyhow::Result<()> {
    if extension(path) != "png" {
        bail!("{}: the picture must be a .png file", path.display());
    }
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    if !dir.is_dir() {
        bail!(
            "{}: cannot write the picture: folder {} does not exist",
            path.display(),
            dir.display()
        );
    }
    Ok(())
}

/// The PNG bytes of `image` (`path` names it in errors).
pub fn png_bytes(path: &Path, image: &Image) -> anyhow::Result<Vec<u8>> {
    image
        .png()
        .with_context(|| format!("{}: encoding the picture", path.display()))
}

/// Writes `image` as a PNG, atomically.
pub fn write_png(path: &Path, image: &Image) -> anyhow::Result<()> {
    write_atomic(path, &png_bytes(path, image)?)?;
    Ok(())
}
