//! Drawing speed: one tracked frame of 10,000 points (the surface tracker's size, ~100 ms a
//! frame to solve) with the humanoid's skeleton and its inlier flags, from three 400-pixel
//! views; the same with its skinned mesh; and the PNG encoding.
//!
//! `cargo bench -p rigfit-render --bench render`

use criterion::{Criterion, black_box, criterion_group, criterion_main};
use rand::{Rng, SeedableRng};
use rigfit_core::{Point3, Vector3};
use rigfit_render::{RenderOptions, Scene, render};

/// 10,000 points spread over the humanoid's skinned surface, 10% of them outliers.
fn frame_points(count: usize) -> (Vec<Point3>, Vec<bool>) {
    let rig = rigfit_core::humanoid::humanoid();
    let world = rig.skeleton.world_matrices(&rig.pose);
    let mut surface = Vec::new();
    for mesh in &rig.meshes {
        let (v, _) = mesh.skin(&world);
        for t in &mesh.triangles {
            surface.push(t.map(|i| v[i as usize]));
        }
    }
    let mut rng = rand::rngs::StdRng::seed_from_u64(8);
    let mut points = Vec::with_capacity(count);
    let mut inliers = Vec::with_capacity(count);
    for i in 0..count {
        let [a, b, c] = surface[rng.random_range(0..surface.len())];
        let (mut u, mut v): (f64, f64) = (rng.random(), rng.random());
        if u + v > 1.0 {
            (u, v) = (1.0 - u, 1.0 - v);
        }
        let mut p = a + (b - a) * u + (c - a) * v;
        let outlier = i % 10 == 0;
        if outlier {
            p += Vector3::new(rng.random(), rng.random(), rng.random()) * 0.3;
        }
        points.push(p);
        inliers.push(!outlier);
    }
    (points, inliers)
}

fn bench(c: &mut Criterion) {
    let rig = rigfit_core::humanoid::humanoid();
    let (points, inliers) = frame_points(10_000);
    let options = RenderOptions::default();
    let mut frame = Scene::new();
    frame
        .add_skeleton(&rig.skeleton, &rig.pose)
        .add_points(&points, Some(&inliers));
    c.bench_function("10,000-point frame + skeleton, 3 views of 400 px", |b| {
        b.iter(|| render(black_box(&frame), &options))
    });
    let mut with_mesh = frame.clone();
    with_mesh.add_rig(&rig, &rig.pose);
    c.bench_function("same + skinned mesh (flat shaded)", |b| {
        b.iter(|| render(black_box(&with_mesh), &options))
    });
    let image = render(&frame, &options);
    c.bench_function("PNG encoding of the 1200 x 400 picture", |b| {
        b.iter(|| black_box(&image).png().expect("PNG"))
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
