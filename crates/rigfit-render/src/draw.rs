//! Drawing scenes: one scene from several views, scenes side by side, contact sheets.

use rigfit_core::{Aabb, Point3};
use tiny_skia::{FillRule, LineCap, LineJoin, Paint, PathBuilder, Stroke, Transform};

use crate::camera::{Camera, View};
use crate::color::{self, Color};
use crate::image::Image;
use crate::scene::{Layer, Scene};

/// How scenes are drawn.
#[derive(Clone, Debug, PartialEq)]
pub struct RenderOptions {
    /// The side of one view's square tile, in pixels.
    pub tile: u32,
    /// The views drawn, in order.
    pub views: Vec<View>,
}

impl Default for RenderOptions {
    /// 400-pixel tiles; front, side and top.
    fn default() -> Self {
        Self {
            tile: 400,
            views: View::ALL.to_vec(),
        }
    }
}

impl RenderOptions {
    fn views(&self) -> Vec<View> {
        if self.views.is_empty() {
            vec![View::Front]
        } else {
            self.views.clone()
        }
    }

    /// The scale of text in tiles (font pixels per image pixel).
    fn text_scale(&self) -> u32 {
        if self.tile >= 300 { 2 } else { 1 }
    }

    fn label_height(&self) -> f64 {
        8.0 * self.text_scale() as f64 + 8.0
    }
}

/// One scene from every view of `options`, the views in a row.
pub fn render(scene: &Scene, options: &RenderOptions) -> Image {
    let cells = [("", scene)];
    draw_grid(&cells, options, &grid(&cells, options, Grid::Row))
}

/// The cameras [`render`] uses, one per view (to find where a world point lands).
pub fn render_cameras(scene: &Scene, options: &RenderOptions) -> Vec<Camera> {
    grid(&[("", scene)], options, Grid::Row)
        .into_iter()
        .map(|(_, c)| c)
        .collect()
}

/// Scenes side by side (for `pose`: the start and the result), each labelled, each framed
/// on its own content; the views of a scene one below the other.
pub fn render_side_by_side(panels: &[(&str, &Scene)], options: &RenderOptions) -> Image {
    draw_grid(panels, options, &grid(panels, options, Grid::SideBySide))
}

/// The cameras [`render_side_by_side`] uses: for each panel, one per view.
pub fn side_by_side_cameras(
    panels: &[(&str, &Scene)],
    options: &RenderOptions,
) -> Vec<Vec<Camera>> {
    per_cell(grid(panels, options, Grid::SideBySide), panels.len())
}

/// A contact sheet: one cell per frame (labelled, the views one below the other), at most
/// `columns` cells per row, every frame at the same scale (fitting the largest frame) and
/// centred on its own content. Pick the frames with [`pick_frames`].
pub fn contact_sheet(frames: &[(&str, &Scene)], options: &RenderOptions, columns: usize) -> Image {
    draw_grid(
        frames,
        options,
        &grid(frames, options, Grid::Sheet(columns.max(1))),
    )
}

/// The cameras [`contact_sheet`] uses: for each frame, one per view.
pub fn contact_sheet_cameras(
    frames: &[(&str, &Scene)],
    options: &RenderOptions,
    columns: usize,
) -> Vec<Vec<Camera>> {
    per_cell(
        grid(frames, options, Grid::Sheet(columns.max(1))),
        frames.len(),
    )
}

/// The `count` views (at most three) that show the most of `scene`: largest projected
/// bounding-box area first (a flat hand seen from its palm before its edge).
pub fn best_views(scene: &Scene, count: usize) -> Vec<View> {
    let e = scene.bounds().unwrap_or_else(unit_box).extent();
    let area = |v: View| match v {
        View::Front => e.x * e.y,
        View::Side => e.z * e.y,
        View::Top => e.x * e.z,
    };
    let mut views = View::ALL.to_vec();
    // Stable: ties keep front, side, top.
    views.sort_by(|a, b| area(*b).total_cmp(&area(*a)));
    views.truncate(count.clamp(1, 3));
    views
}

/// At most `max_shown` frame indices of `0..frame_count`, evenly spaced, first and last
/// included.
pub fn pick_frames(frame_count: usize, max_shown: usize) -> Vec<usize> {
    let shown = max_shown.min(frame_count);
    match shown {
        0 => Vec::new(),
        1 => vec![0],
        _ => (0..shown)
            .map(|i| (i * (frame_count - 1) + (shown - 1) / 2) / (shown - 1))
            .collect(),
    }
}

#[derive(Clone, Copy, Debug)]
enum Grid {
    /// One cell, views in a row.
    Row,
    /// Cells in a row, views in a column, each cell framed alone.
    SideBySide,
    /// Cells wrapping after this many columns, views in a column, one scale for all.
    Sheet(usize),
}

fn per_cell(cameras: Vec<(usize, Camera)>, cells: usize) -> Vec<Vec<Camera>> {
    let mut out = vec![Vec::new(); cells];
    for (cell, camera) in cameras {
        out[cell].push(camera);
    }
    out
}

/// The bounds used when a scene is empty.
fn unit_box() -> Aabb {
    Aabb {
        min: Point3::new(-1.0, -1.0, -1.0),
        max: Point3::new(1.0, 1.0, 1.0),
    }
}

/// Every tile's camera, with the cell it belongs to.
fn grid(cells: &[(&str, &Scene)], options: &RenderOptions, layout: Grid) -> Vec<(usize, Camera)> {
    let views = options.views();
    let t = options.tile.clamp(16, 2048);
    let margin = (t as f64 * 0.04).max(4.0);
    let top = options.label_height() + margin * 0.5;
    let largest_extent = cells
        .iter()
        .filter_map(|(_, s)| s.bounds())
        .map(|b| b.extent())
        .reduce(|a, b| a.sup(&b))
        .unwrap_or_else(|| unit_box().extent());
    let mut out = Vec::new();
    for (c, (_, scene)) in cells.iter().enumerate() {
        let own = scene.bounds().unwrap_or_else(unit_box);
        let bounds = match layout {
            // One scale for every frame (the largest extent), each centred on its content.
            Grid::Sheet(_) => {
                let half = largest_extent / 2.0;
                Aabb {
                    min: own.center() - half,
                    max: own.center() + half,
                }
            }
            _ => own,
        };
        for (v, &view) in views.iter().enumerate() {
            let (col, row) = match layout {
                Grid::Row => (v, 0),
                Grid::SideBySide => (c, v),
                Grid::Sheet(columns) => (c % columns, (c / columns) * views.len() + v),
            };
            let tile = (col as u32 * t, row as u32 * t, t, t);
            out.push((c, Camera::fit(view, &bounds, tile, margin, top)));
        }
    }
    out
}

fn draw_grid(
    cells: &[(&str, &Scene)],
    options: &RenderOptions,
    cameras: &[(usize, Camera)],
) -> Image {
    let width = cameras
        .iter()
        .map(|(_, c)| c.tile.0 + c.tile.2)
        .max()
        .unwrap_or(1);
    let height = cameras
        .iter()
        .map(|(_, c)| c.tile.1 + c.tile.3)
        .max()
        .unwrap_or(1);
    let mut image = Image::new(width, height, color::BACKGROUND);
    for &(cell, camera) in cameras {
        let (label, scene) = cells[cell];
        draw_tile(&mut image, scene, &camera, options);
        let title = if label.is_empty() {
            camera.view.name().to_string()
        } else {
            format!("{label} - {}", camera.view.name())
        };
        let scale = options.text_scale();
        image.text(
            camera.tile.0 as i64 + 6,
            camera.tile.1 as i64 + 6,
            &title,
            scale,
            color::INK,
        );
    }
    // Tile borders.
    for &(_, camera) in cameras {
        let (x, y, w, h) = camera.tile;
        image.fill_pixels(x as i64 + w as i64 - 1, y as i64, 1, h as i64, color::GRID);
        image.fill_pixels(x as i64, y as i64 + h as i64 - 1, w as i64, 1, color::GRID);
    }
    image
}

/// Line widths and dot sizes for a tile.
struct Sizes {
    bone: f32,
    joint: f32,
    polyline: f32,
    dot: i64,
}

impl Sizes {
    fn for_tile(tile: u32, point_count: usize) -> Self {
        let t = tile as f32;
        Self {
            bone: (t / 110.0).max(1.5),
            joint: (t / 120.0).max(1.5),
            polyline: (t / 150.0).max(1.5),
            // Dense clouds get smaller dots.
            dot: if point_count > 20_000 {
                (t / 500.0) as i64
            } else {
                (t / 300.0) as i64
            },
        }
    }
}

fn draw_tile(image: &mut Image, scene: &Scene, camera: &Camera, options: &RenderOptions) {
    let cloud_points: usize = scene
        .layers
        .iter()
        .map(|l| match l {
            Layer::Points(p) => p.points.len(),
            _ => 0,
        })
        .sum();
    let sizes = Sizes::for_tile(options.tile, cloud_points);
    draw_meshes(image, scene, camera);
    draw_points(image, scene, camera, sizes.dot);
    for layer in &scene.layers {
        if let Layer::Skeleton(s) = layer {
            let px: Vec<(f32, f32)> = s.joints.iter().map(|q| to_px(camera, q)).collect();
            for &(a, b, c) in &s.bones {
                stroke_polyline(image, &[px[a], px[b]], color::INK, sizes.bone + 2.0);
                stroke_polyline(image, &[px[a], px[b]], c, sizes.bone);
            }
            for &(jx, jy) in &px {
                fill_circle(image, jx, jy, sizes.joint + 1.0, color::INK);
                fill_circle(image, jx, jy, sizes.joint, color::BACKGROUND);
            }
        }
    }
    for layer in &scene.layers {
        if let Layer::Polyline(p) = layer {
            let pts: Vec<(f32, f32)> = p.points.iter().map(|q| to_px(camera, q)).collect();
            stroke_polyline(image, &pts, p.color, sizes.polyline);
        }
    }
}

fn to_px(camera: &Camera, p: &Point3) -> (f32, f32) {
    let (x, y, _) = camera.project(p);
    (x as f32, y as f32)
}

fn paint(color: Color, anti_alias: bool) -> Paint<'static> {
    let mut paint = Paint::default();
    paint.set_color(color.to_skia());
    paint.anti_alias = anti_alias;
    paint
}

fn stroke_polyline(image: &mut Image, points: &[(f32, f32)], color: Color, width: f32) {
    let mut pb = PathBuilder::new();
    let mut first = true;
    for &(x, y) in points {
        if !(x.is_finite() && y.is_finite()) {
            continue;
        }
        if first {
            pb.move_to(x, y);
            first = false;
        } else {
            pb.line_to(x, y);
        }
    }
    if points.len() == 1 {
        let (x, y) = points[0];
        fill_circle(image, x, y, width / 2.0, color);
        return;
    }
    let Some(path) = pb.finish() else { return };
    let stroke = Stroke {
        width,
        line_cap: LineCap::Round,
        line_join: LineJoin::Round,
        ..Stroke::default()
    };
    image.pixmap.stroke_path(
        &path,
        &paint(color, true),
        &stroke,
        Transform::identity(),
        None,
    );
}

fn fill_circle(image: &mut Image, x: f32, y: f32, radius: f32, color: Color) {
    if let Some(path) = PathBuilder::from_circle(x, y, radius) {
        image.pixmap.fill_path(
            &path,
            &paint(color, true),
            FillRule::Winding,
            Transform::identity(),
            None,
        );
    }
}

/// A triangle ready to paint: summed depth toward the camera, pixel corners, shade.
type ShadedTriangle = (f64, [(f32, f32); 3], Color);

/// Every triangle of every mesh layer, back to front (painter's algorithm), shaded by the
/// angle between its normal and the view direction.
fn draw_meshes(image: &mut Image, scene: &Scene, camera: &Camera) {
    let toward = camera.view.toward_camera();
    let mut triangles: Vec<ShadedTriangle> = Vec::new();
    for layer in &scene.layers {
        let Layer::Mesh(mesh) = layer else { continue };
        let projected: Vec<(f64, f64, f64)> =
            mesh.vertices.iter().map(|p| camera.project(p)).collect();
        for t in &mesh.triangles {
            let Some([a, b, c]) = index3(t, mesh.vertices.len()) else {
                continue;
            };
            let n =
                (mesh.vertices[b] - mesh.vertices[a]).cross(&(mesh.vertices[c] - mesh.vertices[a]));
            let len = n.norm();
            if !(len > 0.0 && len.is_finite()) {
                continue;
            }
            let light = (n.dot(&toward) / len).abs() as f32;
            let shade = mesh.color.shaded(0.35 + 0.65 * light);
            let depth = projected[a].2 + projected[b].2 + projected[c].2;
            let px = [a, b, c].map(|i| (projected[i].0 as f32, projected[i].1 as f32));
            triangles.push((depth, px, shade));
        }
    }
    triangles.sort_by(|p, q| p.0.total_cmp(&q.0));
    for (_, [a, b, c], shade) in triangles {
        let twice_area = (b.0 - a.0) * (c.1 - a.1) - (b.1 - a.1) * (c.0 - a.0);
        if twice_area.abs() < 0.5 {
            // Seen edge-on: a line (a plane seen from its side still shows).
            let (lo, hi) = edge_on_extremes([a, b, c]);
            if (hi.0 - lo.0).abs() + (hi.1 - lo.1).abs() < 0.5 {
                image.fill_pixels(lo.0.round() as i64, lo.1.round() as i64, 1, 1, shade);
            } else {
                stroke_polyline(image, &[lo, hi], shade, 1.5);
            }
            continue;
        }
        let mut pb = PathBuilder::new();
        pb.move_to(a.0, a.1);
        pb.line_to(b.0, b.1);
        pb.line_to(c.0, c.1);
        pb.close();
        if let Some(path) = pb.finish() {
            // No anti-aliasing: neighbouring triangles meet without seams.
            image.pixmap.fill_path(
                &path,
                &paint(shade, false),
                FillRule::Winding,
                Transform::identity(),
                None,
            );
        }
    }
}

/// The two corners furthest apart of a triangle seen edge-on.
fn edge_on_extremes(corners: [(f32, f32); 3]) -> ((f32, f32), (f32, f32)) {
    let d = |p: (f32, f32), q: (f32, f32)| (p.0 - q.0).powi(2) + (p.1 - q.1).powi(2);
    let [a, b, c] = corners;
    [(a, b), (b, c), (a, c)]
        .into_iter()
        .max_by(|p, q| d(p.0, p.1).total_cmp(&d(q.0, q.1)))
        .unwrap_or((a, b))
}

fn index3(t: &[u32; 3], len: usize) -> Option<[usize; 3]> {
    let [a, b, c] = t.map(|i| i as usize);
    (a < len && b < len && c < len).then_some([a, b, c])
}

/// Points as square dots, back to front, lighter with distance; outliers (same size, their
/// own colour) under the inliers.
fn draw_points(image: &mut Image, scene: &Scene, camera: &Camera, dot: i64) {
    for layer in &scene.layers {
        let Layer::Points(cloud) = layer else {
            continue;
        };
        let mut order: Vec<(bool, f64, f64, f64)> = cloud
            .points
            .iter()
            .enumerate()
            .map(|(i, p)| {
                let (x, y, depth) = camera.project(p);
                let outlier = cloud
                    .inliers
                    .as_ref()
                    .is_some_and(|f| !f.get(i).copied().unwrap_or(true));
                (outlier, depth, x, y)
            })
            .filter(|(_, d, x, y)| d.is_finite() && x.is_finite() && y.is_finite())
            .collect();
        order.sort_by(|p, q| q.0.cmp(&p.0).then(p.1.total_cmp(&q.1)));
        let (near, far) = order
            .iter()
            .fold((f64::MIN, f64::MAX), |(n, f), p| (n.max(p.1), f.min(p.1)));
        let span = (near - far).max(1e-12);
        for (outlier, depth, x, y) in order {
            let base = if outlier {
                cloud.outlier_color
            } else {
                cloud.color
            };
            let shade = base.mix(color::BACKGROUND, 0.55 * ((near - depth) / span) as f32);
            let size = if outlier { dot + 1 } else { dot };
            image.fill_pixels(
                x.round() as i64 - size,
                y.round() as i64 - size,
                2 * size + 1,
                2 * size + 1,
                shade,
            );
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn best_views_face_the_largest_side() {
        let mut plate = Scene::new();
        // Thin in x: seen best from the side.
        plate.add_points(
            &[Point3::new(0.0, 0.0, 0.0), Point3::new(0.01, 1.0, 2.0)],
            None,
        );
        assert_eq!(best_views(&plate, 2), vec![View::Side, View::Top]);
        assert_eq!(best_views(&Scene::new(), 3), View::ALL.to_vec());
    }

    #[test]
    fn pick_frames_spreads_evenly() {
        assert_eq!(pick_frames(0, 5), Vec::<usize>::new());
        assert_eq!(pick_frames(3, 5), vec![0, 1, 2]);
        assert_eq!(pick_frames(100, 1), vec![0]);
        let p = pick_frames(100, 5);
        assert_eq!(p.first(), Some(&0));
        assert_eq!(p.last(), Some(&99));
        assert_eq!(p.len(), 5);
        assert!(p.windows(2).all(|w| w[0] < w[1]));
    }

    #[test]
    fn empty_degenerate_and_non_finite_scenes_draw_without_panic() {
        let options = RenderOptions::default();
        let empty = Scene::new();
        let image = render(&empty, &options);
        assert_eq!((image.width(), image.height()), (1200, 400));
        let mut odd = Scene::new();
        let p = Point3::new(1.0, 2.0, 3.0);
        odd.add_points(&[p], None)
            .add_points(&[Point3::new(f64::NAN, 0.0, f64::INFINITY)], Some(&[false]))
            .add_polyline(&[p], color::palette(1))
            .add_polyline(&[p, Point3::new(f64::NAN, 1.0, 1.0), p], color::palette(2))
            .add_mesh(&rigfit_core::TriMesh {
                vertices: vec![p, p, Point3::new(f64::NAN, 0.0, 0.0)],
                normals: None,
                triangles: vec![[0, 1, 2], [0, 1, 7]],
            });
        let image = render(&odd, &options);
        // The single finite point lands in the middle of every tile.
        for camera in render_cameras(&odd, &options) {
            let (x, y, _) = camera.project(&p);
            assert!(image.pixel(x.round() as u32, y.round() as u32) != Some(color::BACKGROUND));
        }
        let sheet = contact_sheet(&[("a", &empty), ("b", &odd)], &options, 1);
        assert_eq!((sheet.width(), sheet.height()), (400, 2400));
        assert!(image.png().is_ok());
    }

    #[test]
    fn png_round_trip_keeps_the_pixels() {
        let mut scene = Scene::new();
        scene.add_polyline(
            &[Point3::new(0.0, 0.0, 0.0), Point3::new(1.0, 1.0, 1.0)],
            color::palette(3),
        );
        let options = RenderOptions {
            tile: 64,
            views: vec![View::Front],
        };
        let image = render(&scene, &options);
        let back = Image::from_png(&image.png().expect("PNG")).expect("decodes");
        assert_eq!((back.width(), back.height()), (64, 64));
        for (x, y) in [(0, 0), (32, 32), (40, 20)] {
            assert_eq!(back.pixel(x, y), image.pixel(x, y));
        }
        assert!(Image::from_png(b"not a png").is_err());
    }
}
