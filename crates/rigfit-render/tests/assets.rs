//! Every real asset in ../shared/data drawn from three views: the picture has the right size,
//! is not blank, and is drawn where the geometry projects.

use rigfit_core::{Point3, Stroke};
use rigfit_formats::rig_file::{RigOptions, read_rig};
use rigfit_render::color::BACKGROUND;
use rigfit_render::{
    Camera, FrameStats, Image, RenderOptions, Scene, View, contact_sheet, contact_sheet_cameras,
    pick_frames, render, render_cameras, render_side_by_side, side_by_side_cameras, tracking_sheet,
};

use rigfit_testkit::assets::asset as data;

/// Width and height from a PNG's IHDR chunk.
fn png_size(bytes: &[u8]) -> (u32, u32) {
    assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n", "PNG signature");
    assert_eq!(&bytes[12..16], b"IHDR");
    let be = |b: &[u8]| u32::from_be_bytes([b[0], b[1], b[2], b[3]]);
    (be(&bytes[16..20]), be(&bytes[20..24]))
}

fn drawn_fraction(image: &Image) -> f64 {
    let mut drawn = 0usize;
    for y in 0..image.height() {
        for x in 0..image.width() {
            if image.pixel(x, y) != Some(BACKGROUND) {
                drawn += 1;
            }
        }
    }
    drawn as f64 / (image.width() * image.height()) as f64
}

/// True when a pixel within `radius` of where `p` projects is not background.
fn drawn_near(image: &Image, camera: &Camera, p: &Point3, radius: i64) -> bool {
    let (x, y, _) = camera.project(p);
    let (x, y) = (x.round() as i64, y.round() as i64);
    (-radius..=radius).any(|dy| {
        (-radius..=radius).any(|dx| {
            let (px, py) = (x + dx, y + dy);
            px >= 0
                && py >= 0
                && image
                    .pixel(px as u32, py as u32)
                    .is_some_and(|c| c != BACKGROUND)
        })
    })
}

/// Asserts every point lands inside its tile on drawn pixels.
fn assert_drawn_at(image: &Image, cameras: &[Camera], points: &[Point3], what: &str) {
    for camera in cameras {
        let (tx, ty, tw, th) = camera.tile;
        for p in points {
            let (x, y, _) = camera.project(p);
            assert!(
                (tx as f64..(tx + tw) as f64).contains(&x)
                    && (ty as f64..(ty + th) as f64).contains(&y),
                "{what}: {p:?} projects outside its {:?} tile",
                camera.view
            );
            assert!(
                drawn_near(image, camera, p, 2),
                "{what}: nothing drawn at {p:?} in the {:?} view",
                camera.view
            );
        }
    }
}

#[test]
fn every_real_rig_is_drawn_where_its_joints_and_vertices_project() {
    let options = RenderOptions::default();
    let files = rigfit_testkit::assets::GLTF_RIGS
        .into_iter()
        .chain(["cmu/01_01.bvh"]);
    for file in files {
        let rig = read_rig(&data(file), &RigOptions::default())
            .expect("the asset reads")
            .rig;
        let mut scene = Scene::new();
        scene.add_rig(&rig, &rig.pose);
        let image = render(&scene, &options);
        let (w, h) = png_size(&image.png().expect("PNG"));
        assert_eq!((w, h), (3 * options.tile, options.tile), "{file}");
        let drawn = drawn_fraction(&image);
        assert!(
            drawn > 0.01,
            "{file}: only {drawn:.4} of the picture is drawn"
        );
        let cameras = render_cameras(&scene, &options);
        let joints: Vec<Point3> = rig
            .reported_joints()
            .map(|j| rig.skeleton.joint_positions(&rig.pose)[j])
            .collect();
        assert_drawn_at(&image, &cameras, &joints, file);
        let vertices: Vec<Point3> = rig
            .extent_points(&rig.pose)
            .into_iter()
            .step_by(37)
            .collect();
        assert_drawn_at(&image, &cameras, &vertices, file);
    }
}

#[test]
fn the_bunny_is_drawn_as_a_mesh_and_as_a_cloud() {
    let mesh = rigfit_formats::ply::read_ply(&data("bunny/bunny.ply")).expect("bunny");
    let options = RenderOptions {
        tile: 300,
        views: vec![View::Front, View::Top],
    };
    let sample: Vec<Point3> = mesh.vertices.iter().step_by(11).copied().collect();
    let mut as_mesh = Scene::new();
    as_mesh.add_mesh(&mesh);
    let image = render(&as_mesh, &options);
    assert_eq!((image.width(), image.height()), (600, 300));
    assert!(drawn_fraction(&image) > 0.2);
    assert_drawn_at(
        &image,
        &render_cameras(&as_mesh, &options),
        &sample,
        "bunny mesh",
    );

    let flags: Vec<bool> = (0..mesh.vertices.len()).map(|i| i % 5 != 0).collect();
    let mut cloud = Scene::new();
    cloud.add_points(&mesh.vertices, Some(&flags));
    let image = render(&cloud, &options);
    assert_drawn_at(
        &image,
        &render_cameras(&cloud, &options),
        &sample,
        "bunny cloud",
    );
    // Outliers show in their own colour.
    let outliers = (0..image.height())
        .flat_map(|y| (0..image.width()).map(move |x| (x, y)))
        .filter(|&(x, y)| {
            image
                .pixel(x, y)
                .is_some_and(|c| c.r > 200 && c.g < 150 && c.b < 150)
        })
        .count();
    assert!(outliers > 100, "{outliers} outlier pixels");
}

#[test]
fn strokes_are_drawn_in_their_colours_over_the_rig() {
    let rig = read_rig(&data("assimp/BCN_Epileptic.glb"), &RigOptions::default())
        .expect("rig")
        .rig;
    let positions = rig.skeleton.joint_positions(&rig.pose);
    let arm: Vec<Point3> = ["B_UpperArm_Left", "B_ForeArm_Left", "B_Hand_Left"]
        .iter()
        .filter_map(|n| rig.skeleton.find(n))
        .map(|j| positions[j] + rigfit_core::Vector3::new(0.0, 0.0, 0.3))
        .collect();
    assert_eq!(arm.len(), 3);
    let strokes = [Stroke {
        points: arm.clone(),
        bones: None,
    }];
    let green = rigfit_render::Color::rgb(0, 200, 0);
    let mut start = Scene::new();
    start
        .add_rig(&rig, &rig.pose)
        .add_strokes(&strokes, &[green]);
    let options = RenderOptions::default();
    let panels = [("start", &start), ("result", &start)];
    let image = render_side_by_side(&panels, &options);
    assert_eq!((image.width(), image.height()), (800, 1200));
    let cameras = side_by_side_cameras(&panels, &options);
    let mid = nalgebra_mid(&arm[0], &arm[1]);
    let (x, y, _) = cameras[1][0].project(&mid);
    assert_eq!(image.pixel(x.round() as u32, y.round() as u32), Some(green));
}

fn nalgebra_mid(a: &Point3, b: &Point3) -> Point3 {
    Point3::from((a.coords + b.coords) / 2.0)
}

#[test]
fn a_contact_sheet_draws_every_frame_at_one_scale() {
    let file = read_rig(&data("cmu/01_01.bvh"), &RigOptions::default()).expect("bvh");
    let rig = &file.rig;
    let animation = &rig.animations[0];
    let frame_time = animation.frame_time.expect("BVH frames are timed");
    let shown = pick_frames(animation.frame_count(), 6);
    assert_eq!(shown.len(), 6);
    let frames: Vec<(String, Scene)> = shown
        .iter()
        .map(|&i| {
            let pose = animation.sample(&rig.pose, i as f64 * frame_time);
            let mut scene = Scene::new();
            scene.add_skeleton(&rig.skeleton, &pose);
            (format!("frame {i}"), scene)
        })
        .collect();
    let options = RenderOptions {
        tile: 200,
        views: vec![View::Front, View::Top],
    };
    let cells: Vec<(&str, &Scene)> = frames.iter().map(|(l, s)| (l.as_str(), s)).collect();
    let sheet = contact_sheet(&cells, &options, 3);
    assert_eq!((sheet.width(), sheet.height()), (600, 800));
    let cameras = contact_sheet_cameras(&cells, &options, 3);
    // One scale for every frame.
    assert!(cameras.iter().all(|c| c[0].scale == cameras[0][0].scale));
    for ((label, scene), cams) in frames.iter().zip(&cameras) {
        let joints: Vec<Point3> = scene
            .layers
            .iter()
            .flat_map(|l| match l {
                rigfit_render::Layer::Skeleton(s) => s.joints.clone(),
                _ => Vec::new(),
            })
            .collect();
        assert_drawn_at(&sheet, cams, &joints, label);
    }
    let stats = FrameStats {
        error: Some(vec![0.01; 40]),
        error_label: "m".into(),
        inliers: (0..40).map(|i| 800.0 + i as f64).collect(),
        seconds: vec![0.004; 40],
    };
    let with_plots = tracking_sheet(&frames, &stats, &options);
    // Four frames a row: two rows of two views, then three plots.
    assert_eq!(with_plots.width(), 4 * 200);
    assert_eq!(with_plots.height(), 2 * 2 * 200 + 3 * 240);
}
