//! rigfit-render: headless software pictures (no GPU, no display) of skeletons, meshes,
//! point clouds and strokes from orthographic views, contact sheets of tracked frames,
//! and line charts. Rasterising is tiny-skia's; text is the public-domain 8x8 bitmap font
//! of `font8x8`. No solver code and no file I/O: it takes core types and returns an
//! [`Image`], whose [`Image::png`] gives the bytes to write (the CLI writes them with
//! `rigfit_formats::error::write_atomic`).
//!
//! The world is Y-up (glTF, BVH). Views: [`View::Front`] (from +Z), [`View::Side`]
//! (from +X), [`View::Top`] (from +Y).
//!
//! # Calling it from a command
//!
//! One scene (`rigfit render`):
//! ```
//! use rigfit_render::{RenderOptions, Scene, render};
//! # let (skeleton, pose, cloud) = rigfit_render::doc_example();
//! let mut scene = Scene::new();
//! scene.add_skeleton(&skeleton, &pose).add_points(&cloud, None);
//! let png: Vec<u8> = render(&scene, &RenderOptions::default()).png()?;
//! # Ok::<(), rigfit_render::RenderError>(())
//! ```
//!
//! `track` / `surface --render`: a contact sheet of evenly spaced frames (build scenes only
//! for the frames [`pick_frames`] picks), with the per-frame plots below it. For `surface`,
//! add the moved reference mesh with [`Scene::add_mesh`] and the scan with
//! [`Scene::add_points`] and its inlier flags.
//! ```
//! use rigfit_render::{FrameStats, RenderOptions, Scene, View, pick_frames, tracking_sheet};
//! # let (skeleton, pose, cloud) = rigfit_render::doc_example();
//! # let frame_count = 40;
//! let shown = pick_frames(frame_count, 8);
//! let frames: Vec<(String, Scene)> = shown
//!     .iter()
//!     .map(|&i| {
//!         let mut scene = Scene::new();
//!         // The solved skeleton of frame i, and its cloud with the inlier flags.
//!         let inliers = vec![true; cloud.len()];
//!         scene.add_skeleton(&skeleton, &pose).add_points(&cloud, Some(&inliers));
//!         (format!("frame {i}"), scene)
//!     })
//!     .collect();
//! let stats = FrameStats {
//!     error: None, // Some(per-frame error) when ground truth is given
//!     error_label: String::new(),
//!     inliers: vec![812.0; frame_count],
//!     seconds: vec![0.004; frame_count],
//! };
//! let options = RenderOptions { tile: 240, views: vec![View::Front, View::Side] };
//! let png = tracking_sheet(&frames, &stats, &options).png()?;
//! # Ok::<(), rigfit_render::RenderError>(())
//! ```
//!
//! Benchmarks: [`line_chart`] with a [`Chart`] of named [`Series`] (set `x_log`/`y_log`
//! for log-log time against size).

mod camera;
pub mod color;
mod draw;
mod image;
mod plot;
mod scene;

pub use camera::{Camera, View};
pub use color::{Color, chain_colors};
pub use draw::{
    RenderOptions, best_views, contact_sheet, contact_sheet_cameras, pick_frames, render,
    render_cameras, render_side_by_side, side_by_side_cameras,
};
pub use image::{Image, RenderError};
pub use plot::{Chart, FrameStats, Series, frame_plots, line_chart, plot_series};
pub use scene::{Layer, MeshLayer, PointLayer, PolylineLayer, Scene, SkeletonLayer, stroke_colors};

/// Columns of a tracking contact sheet.
pub const SHEET_COLUMNS: usize = 4;

/// A contact sheet of `frames` (label and scene; pick them with [`pick_frames`]) with the
/// per-frame plots of `stats` below it: what `track --render` and `surface --render` write.
pub fn tracking_sheet(
    frames: &[(String, Scene)],
    stats: &FrameStats,
    options: &RenderOptions,
) -> Image {
    let cells: Vec<(&str, &Scene)> = frames.iter().map(|(l, s)| (l.as_str(), s)).collect();
    let sheet = contact_sheet(&cells, options, SHEET_COLUMNS);
    let plots = frame_plots(stats, sheet.width().max(480));
    Image::stack_vertical(&[sheet, plots], color::BACKGROUND)
}

/// A small skeleton, pose and cloud for the examples in these docs.
#[doc(hidden)]
pub fn doc_example() -> (
    rigfit_core::Skeleton,
    rigfit_core::Pose,
    Vec<rigfit_core::Point3>,
) {
    let rig = rigfit_core::humanoid::humanoid();
    let cloud = rig.extent_points(&rig.pose);
    (rig.skeleton, rig.pose, cloud)
}
