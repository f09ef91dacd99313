//! `rigfit surface` end to end on small synthetic scenes: outputs, the report, several
//! objects with a floor of outliers, frames without normals, and bad input.

mod common;

use std::path::{Path, PathBuf};

use common::*;
use rigfit_core::TriMesh;
use rigfit_core::math::{Point3, Quat, Vector3};
use rigfit_formats::ply::{read_ply, write_ply};
use rigfit_formats::rig_file::{RigOptions, read_rig};
use rigfit_testkit::surface_cases::sample_surface;
use serde_json::Value;

fn s(p: &Path) -> &str {
    p.to_str().expect("utf-8 path")
}

/// A UV sphere of `rings` x `segments` around `centre`.
fn sphere(centre: Point3, radius: f64, rings: usize, segments: usize) -> TriMesh {
    let mut vertices = vec![centre + Vector3::new(0.0, radius, 0.0)];
    for r in 1..rings {
        let phi = std::f64::consts::PI * r as f64 / rings as f64;
        for s in 0..segments {
            let theta = 2.0 * std::f64::consts::PI * s as f64 / segments as f64;
            vertices.push(
                centre
                    + Vector3::new(
                        radius * phi.sin() * theta.cos(),
                        radius * phi.cos(),
                        radius * phi.sin() * theta.sin(),
                    ),
            );
        }
    }
    vertices.push(centre - Vector3::new(0.0, radius, 0.0));
    let seg = segments as u32;
    let ring = |r: usize, s: u32| 1 + (r as u32 - 1) * seg + (s % seg);
    let mut triangles = Vec::new();
    for s in 0..seg {
        triangles.push([0, ring(1, s + 1), ring(1, s)]);
    }
    for r in 1..rings - 1 {
        for s in 0..seg {
            let (a, b, c, d) = (
                ring(r, s),
                ring(r, s + 1),
                ring(r + 1, s),
                ring(r + 1, s + 1),
            );
            triangles.push([a, b, d]);
            triangles.push([a, d, c]);
        }
    }
    let last = vertices.len() as u32 - 1;
    for s in 0..seg {
        triangles.push([last, ring(rings - 1, s), ring(rings - 1, s + 1)]);
    }
    let mut mesh = TriMesh {
        vertices,
        normals: None,
        triangles,
    };
    mesh.normals = Some(mesh.vertex_normals_from_faces());
    mesh
}

/// Two objects (ellipsoids with three different axes, so that no motion of one slides it
/// along itself) as one reference.
fn two_objects() -> TriMesh {
    let mut a = sphere(Point3::new(0.0, 1.0, 0.0), 0.5, 16, 24);
    for p in &mut a.vertices {
        p.x *= 1.6;
        p.z *= 0.6;
    }
    let mut b = sphere(Point3::new(2.0, 0.8, 0.0), 0.4, 12, 18);
    for p in &mut b.vertices {
        p.x = 2.0 + (p.x - 2.0) * 0.6;
        p.z *= 1.4;
    }
    let offset = a.vertices.len() as u32;
    a.vertices.extend(b.vertices);
    a.triangles
        .extend(b.triangles.iter().map(|t| t.map(|i| i + offset)));
    a.normals = Some(a.vertex_normals_from_faces());
    a
}

/// The reference moved for frame `f`: the first object turns and rises, the second slides.
fn truth_at(reference: &TriMesh, split: usize, f: usize) -> Vec<Point3> {
    let turn = Quat::from_euler_angles(0.0, 0.08 * f as f64, 0.03 * f as f64);
    let c = Point3::new(0.0, 1.0, 0.0);
    reference
        .vertices
        .iter()
        .enumerate()
        .map(|(i, p)| {
            if i < split {
                c + turn * (p - c) + Vector3::new(0.0, 0.02 * f as f64, 0.0)
            } else {
                p + Vector3::new(-0.03 * f as f64, 0.0, 0.02 * f as f64)
            }
        })
        .collect()
}

/// Points sampled on the moved surface, plus a floor slab of outliers, without normals.
fn scan(reference: &TriMesh, moved: &[Point3], seed: u64) -> TriMesh {
    use rand::{Rng, SeedableRng};
    let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
    let (mut points, _) = sample_surface(moved, &reference.triangles, 3000, &mut rng);
    for _ in 0..500 {
        points.push(Point3::new(
            rng.random_range(-1.5..3.0),
            rng.random_range(0.0..0.02),
            rng.random_range(-1.5..1.5),
        ));
    }
    TriMesh {
        vertices: points,
        normals: None,
        triangles: Vec::new(),
    }
}

fn write_scene(dir: &Path, frames: usize) -> (PathBuf, Vec<PathBuf>, Vec<Vec<Point3>>) {
    let reference = two_objects();
    let split = sphere(Point3::origin(), 1.0, 16, 24).vertices.len();
    let ref_path = dir.join("reference.ply");
    write_ply(&ref_path, &reference).expect("write reference");
    let mut paths = Vec::new();
    let mut truths = Vec::new();
    for f in 0..frames {
        let moved = truth_at(&reference, split, f);
        let path = dir.join(format!("scan_{f:03}.ply"));
        write_ply(&path, &scan(&reference, &moved, f as u64)).expect("write scan");
        paths.push(path);
        truths.push(moved);
    }
    (ref_path, paths, truths)
}

/// Every output frame in `out` is the reference's mesh (its vertex count and faces) within
/// 1.5% of the diagonal of the truth on average.
fn assert_frames_follow_the_truth(reference: &Path, out: &Path, truths: &[Vec<Point3>]) {
    let reference_mesh = read_ply(reference).expect("reference");
    let diagonal = reference_mesh.bounds().expect("bounds").diagonal();
    for (f, truth) in truths.iter().enumerate() {
        let fitted = read_ply(&out.join(format!("frame_{f:05}.ply"))).expect("output frame");
        assert_eq!(fitted.vertices.len(), reference_mesh.vertices.len());
        assert_eq!(fitted.triangles, reference_mesh.triangles);
        let mean = fitted
            .vertices
            .iter()
            .zip(truth)
            .map(|(a, b)| (a - b).norm())
            .sum::<f64>()
            / truth.len() as f64;
        assert!(mean < 0.015 * diagonal, "frame {f}: mean error {mean}");
    }
}

#[test]
fn tracks_two_objects_over_a_floor_and_writes_every_frame() {
    let dir = tempfile::tempdir().expect("tempdir");
    let (reference, frames, truths) = write_scene(dir.path(), 6);
    let out = dir.path().join("out");
    let report = dir.path().join("report.json");
    let mut args = vec!["surface", s(&reference)];
    args.extend(frames.iter().map(|p| s(p)));
    args.extend(["-o", s(&out), "--report", s(&report)]);
    let o = rigfit(&args);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_frames_follow_the_truth(&reference, &out, &truths);
    let value: Value =
        serde_json::from_str(&std::fs::read_to_string(&report).expect("report")).expect("json");
    let frames_json = value["frames"].as_array().expect("frames");
    assert_eq!(frames_json.len(), 6);
    assert_eq!(frames_json[0]["file"], "scan_000.ply");
    // 3000 surface points and 500 floor points: the floor is left out.
    for f in frames_json {
        let inliers = f["inliers"].as_u64().expect("inliers");
        assert!((2700..=3100).contains(&inliers), "inliers {inliers}");
        assert!(f["rms"].as_f64().expect("rms") > 0.0);
        assert!(f["seconds"].as_f64().expect("seconds") >= 0.0);
    }
}

#[test]
fn fast_motion_tracks_the_same_scene() {
    let dir = tempfile::tempdir().expect("tempdir");
    let (reference, frames, truths) = write_scene(dir.path(), 4);
    let out = dir.path().join("out");
    let mut args = vec!["surface", s(&reference)];
    args.extend(frames.iter().map(|p| s(p)));
    args.extend(["-o", s(&out), "--fast-motion"]);
    let o = rigfit(&args);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_frames_follow_the_truth(&reference, &out, &truths);
    // A bad value after it is still named.
    let mut args = vec!["surface", s(&reference), s(&frames[0])];
    args.extend(["-o", s(&out), "--fast-motion", "--coarse", "0"]);
    let o = rigfit(&args);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("--coarse"), "{}", stderr(&o));
}

#[test]
fn surface_subcommand_usage_is_listed() {
    let o = rigfit(&["surface", "--help"]);
    assert!(o.status.success());
    assert!(stdout(&o).contains("OUTPUT"));
}

fn ascii_ply(vertices: &[[f64; 3]], faces: &[[u32; 3]]) -> String {
    let mut s = format!(
        "ply\nformat ascii 1.0\nelement vertex {}\nproperty float x\nproperty float y\nproperty float z\nelement face {}\nproperty list uchar int vertex_indices\nend_header\n",
        vertices.len(),
        faces.len()
    );
    for v in vertices {
        s.push_str(&format!("{} {} {}\n", v[0], v[1], v[2]));
    }
    for f in faces {
        s.push_str(&format!("3 {} {} {}\n", f[0], f[1], f[2]));
    }
    s
}

#[test]
fn bad_input_gives_one_line_and_no_output() {
    let dir = tempfile::tempdir().expect("tempdir");
    let (reference, frames, _) = write_scene(dir.path(), 1);
    let out = dir.path().join("out");
    let write = |name: &str, text: String| {
        let p = dir.path().join(name);
        std::fs::write(&p, text).expect("write");
        p
    };
    let cloud = write(
        "cloud.ply",
        ascii_ply(&[[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]], &[]),
    );
    let nan = write(
        "nan.ply",
        "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\nproperty float z\nend_header\n0 0 0\nnan 1 0\n".into(),
    );
    let empty = write("empty.ply", ascii_ply(&[], &[]));
    let text = write("frame.txt", "hello".into());
    let flat = write(
        "point.ply",
        ascii_ply(
            &[[1.0, 1.0, 1.0], [1.0, 1.0, 1.0], [1.0, 1.0, 1.0]],
            &[[0, 1, 2]],
        ),
    );
    let frame = s(&frames[0]);
    let cases: Vec<(Vec<&str>, &Path)> = vec![
        // A reference with no faces: normals and patches need them.
        (vec![s(&cloud), frame], &cloud),
        // NaN in a frame.
        (vec![s(&reference), s(&nan)], &nan),
        // An empty frame.
        (vec![s(&reference), frame, s(&empty)], &empty),
        // A frame of unknown type.
        (vec![s(&reference), s(&text)], &text),
        // A reference with no extent.
        (vec![s(&flat), frame], &flat),
        // A missing file.
        (
            vec![s(&reference), "does-not-exist.ply"],
            Path::new("does-not-exist.ply"),
        ),
    ];
    for (inputs, culprit) in cases {
        let mut args = vec!["surface"];
        args.extend(inputs);
        args.extend(["-o", s(&out)]);
        let o = common::rigfit(&args);
        assert_bad_input(&o, culprit);
        assert!(!out.exists(), "no output for a bad {}", culprit.display());
    }
}

#[test]
fn non_manifold_and_disconnected_references_are_tracked() {
    let dir = tempfile::tempdir().expect("tempdir");
    // Three triangles on one edge (non-manifold), and a lone triangle far away.
    let vertices = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.5, 1.0, 0.0],
        [0.5, -1.0, 0.0],
        [0.5, 0.0, 1.0],
        [5.0, 0.0, 0.0],
        [6.0, 0.0, 0.0],
        [5.0, 1.0, 0.0],
        [9.0, 9.0, 9.0],
    ];
    let faces = [[0, 1, 2], [1, 0, 3], [0, 1, 4], [5, 6, 7]];
    let reference = dir.path().join("odd.ply");
    std::fs::write(&reference, ascii_ply(&vertices, &faces)).expect("write");
    let frame = dir.path().join("frame.ply");
    std::fs::write(&frame, ascii_ply(&vertices[..8], &[])).expect("write");
    let out = dir.path().join("out");
    let o = rigfit(&["surface", s(&reference), s(&frame), "-o", s(&out)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let fitted = read_ply(&out.join("frame_00000.ply")).expect("output");
    assert_eq!(fitted.vertices.len(), vertices.len());
    assert!(
        fitted
            .vertices
            .iter()
            .all(|p| p.iter().all(|x| x.is_finite()))
    );
}

#[test]
fn obj_frames_and_obj_references_are_read() {
    let dir = tempfile::tempdir().expect("tempdir");
    let reference = two_objects();
    let ref_path = dir.path().join("reference.obj");
    rigfit_formats::obj::write_obj(&ref_path, &reference).expect("write reference");
    // The frame: the reference's own surface as a mesh (face normals are used).
    let frame = dir.path().join("frame.obj");
    rigfit_formats::obj::write_obj(
        &frame,
        &TriMesh {
            normals: None,
            ..reference.clone()
        },
    )
    .expect("write frame");
    let out = dir.path().join("out");
    let o = rigfit(&["surface", s(&ref_path), s(&frame), "-o", s(&out)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let fitted = read_ply(&out.join("frame_00000.ply")).expect("output");
    let diagonal = reference.bounds().expect("bounds").diagonal();
    let worst = fitted
        .vertices
        .iter()
        .zip(&reference.vertices)
        .map(|(a, b)| (a - b).norm())
        .fold(0.0, f64::max);
    assert!(worst < 0.01 * diagonal, "worst {worst}");
}

#[test]
fn render_draws_a_contact_sheet_and_rejects_a_bad_picture_path() {
    let dir = tempfile::tempdir().expect("tempdir");
    let (reference, frames, truths) = write_scene(dir.path(), 3);
    let out = dir.path().join("out");
    let picture = dir.path().join("sheet.png");
    // The true vertex positions, for the picture's error plot.
    let truth_files: Vec<PathBuf> = truths
        .iter()
        .enumerate()
        .map(|(f, t)| {
            let path = dir.path().join(format!("truth_{f:04}.ply"));
            let mesh = TriMesh {
                vertices: t.clone(),
                ..TriMesh::default()
            };
            write_ply(&path, &mesh).expect("truth");
            path
        })
        .collect();
    let truth_list: Vec<&str> = truth_files.iter().map(|p| s(p)).collect();
    let truth_arg = truth_list.join(",");
    let mut args = vec!["surface", s(&reference)];
    args.extend(frames.iter().map(|f| s(f)));
    args.extend([
        "-o",
        s(&out),
        "--render",
        s(&picture),
        "--truth",
        &truth_arg,
    ]);
    let o = rigfit(&args);
    assert!(o.status.success(), "{}", stderr(&o));
    let png = std::fs::read(&picture).expect("picture written");
    assert_eq!(&png[1..4], b"PNG");
    assert!(png.len() > 2000);

    // The picture's folder is checked before any work.
    let bad = Path::new("/nonexistent/dir/sheet.png");
    let mut args = vec!["surface", s(&reference)];
    args.extend(frames.iter().map(|f| s(f)));
    args.extend(["-o", s(&out), "--render", s(bad)]);
    assert_bad_input(&rigfit(&args), bad);
}

#[test]
fn a_glb_reference_is_its_skinned_mesh() {
    use rand::SeedableRng;
    let path = data("assimp/BCN_Epileptic.glb");
    let rig = read_rig(&path, &RigOptions::default()).expect("asset").rig;
    let surface = rig.skinned_surface(&rig.pose);
    let mut rng = rand::rngs::StdRng::seed_from_u64(1);
    let (points, normals) = sample_surface(&surface.vertices, &surface.triangles, 8000, &mut rng);
    let dir = tempfile::tempdir().expect("tempdir");
    let frame = dir.path().join("scan.ply");
    write_ply(
        &frame,
        &TriMesh {
            vertices: points,
            normals: Some(normals),
            triangles: Vec::new(),
        },
    )
    .expect("write");
    let out = dir.path().join("out");
    let o = rigfit(&[
        "surface",
        path.to_str().expect("utf-8"),
        frame.to_str().expect("utf-8"),
        "-o",
        out.to_str().expect("utf-8"),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let fitted = read_ply(&out.join("frame_00000.ply")).expect("output");
    assert_eq!(fitted.vertices.len(), surface.vertices.len());
    assert_eq!(fitted.triangles, surface.triangles);
    let diagonal = surface.bounds().expect("bounds").diagonal();
    let mean = fitted
        .vertices
        .iter()
        .zip(&surface.vertices)
        .map(|(a, b)| (a - b).norm())
        .sum::<f64>()
        / surface.vertices.len() as f64;
    assert!(mean < 0.01 * diagonal, "mean {mean}");
}
