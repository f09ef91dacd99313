//! glTF on the real assets: loading, round trips, skinning and Jacobians.

use rigfit_core::kinematics::numeric_point_jacobian;
use rigfit_core::{DofLayout, ForwardKinematics, Point3, Quat, Rig, Vector3};
use rigfit_formats::gltf::{GltfDocument, parse_gltf, read_gltf, rig_to_glb};

use rigfit_testkit::assets::asset as data;

const RIGS: &[&str] = &rigfit_testkit::assets::GLTF_RIGS;

fn no_uri(_: &str) -> Result<Vec<u8>, String> {
    Err("no external files here".into())
}

fn reparse(bytes: &[u8]) -> GltfDocument {
    parse_gltf(bytes, &mut no_uri, None).expect("rigfit's own output parses")
}

fn rig(doc: &GltfDocument) -> &Rig {
    doc.rig.as_ref().expect("has a skin")
}

#[test]
fn every_real_rig_loads() {
    for (file, joints, vertices) in [
        ("assimp/BCN_Epileptic.glb", 54, 3014),
        ("assimp/Testwuson.glb", 37, 3205),
        ("assimp/animation_with_skeleton.glb", 14, 2464),
        ("assimp/simple_skin.gltf", 2, 10),
        ("webxr_hand/left.glb", 25, 1360),
        ("webxr_hand/right.glb", 25, 1360),
    ] {
        let doc = read_gltf(&data(file), None).unwrap_or_else(|e| panic!("{file}: {e}"));
        let rig = rig(&doc);
        let skin = rig
            .skeleton
            .joints()
            .iter()
            .filter(|j| j.kind == rigfit_core::JointKind::Skin)
            .count();
        assert_eq!(skin, joints, "{file}: skin joints");
        let v: usize = rig.meshes.iter().map(|m| m.positions.len()).sum();
        assert_eq!(v, vertices, "{file}: vertices");
        assert!(rig.height() > 0.0, "{file}: height");
    }
}

/// World positions of every joint at time `t` of animation `a` (or the stored pose).
fn positions_at(rig: &Rig, a: Option<usize>, t: f64) -> Vec<Point3> {
    let pose = match a {
        Some(a) => rig.animations[a].sample(&rig.pose, t),
        None => rig.pose.clone(),
    };
    rig.skeleton.joint_positions(&pose)
}

#[test]
fn read_write_read_keeps_joint_positions_at_three_times() {
    for file in RIGS {
        let doc = read_gltf(&data(file), None).expect("loads");
        let original = rig(&doc);
        for glb in [true, false] {
            let bytes = doc.to_bytes(glb, &original.pose, &[], None);
            let back = reparse(&bytes);
            let again = rig(&back);
            assert_eq!(again.skeleton.len(), original.skeleton.len());
            let mut checks = vec![(None, 0.0)];
            for (a, anim) in original.animations.iter().enumerate() {
                let (s, e) = (anim.start(), anim.end());
                checks.extend([(Some(a), s), (Some(a), s + 0.37 * (e - s)), (Some(a), e)]);
            }
            for (a, t) in checks {
                let p0 = positions_at(original, a, t);
                let p1 = positions_at(again, a, t);
                for (j, (x, y)) in p0.iter().zip(&p1).enumerate() {
                    assert!(
                        (x - y).norm() < 1e-6,
                        "{file} glb={glb} anim {a:?} t={t}: joint {j} moved by {}",
                        (x - y).norm()
                    );
                }
            }
            // The meshes survive too.
            assert_eq!(again.meshes.len(), original.meshes.len());
            for (m0, m1) in original.meshes.iter().zip(&again.meshes) {
                assert_eq!(m0.positions, m1.positions);
                assert_eq!(m0.triangles, m1.triangles);
            }
        }
    }
}

#[test]
fn skinning_at_the_bind_pose_reproduces_the_mesh() {
    for file in [
        "assimp/BCN_Epileptic.glb",
        "assimp/Testwuson.glb",
        "webxr_hand/left.glb",
    ] {
        let doc = read_gltf(&data(file), None).expect("loads");
        let rig = rig(&doc);
        // The bind pose: every skin joint's world matrix is the inverse of its inverse bind
        // matrix. Helpers keep the stored pose.
        let stored = rig.skeleton.world_matrices(&rig.pose);
        for mesh in &rig.meshes {
            let world: Vec<_> = stored
                .iter()
                .enumerate()
                .map(|(j, w)| match rig.skeleton.joint(j).kind {
                    rigfit_core::JointKind::Skin => {
                        mesh.inverse_bind[j].try_inverse().expect("invertible")
                    }
                    _ => *w,
                })
                .collect();
            let (skinned, normals) = mesh.skin(&world);
            let diag = rig.bounds(&rig.pose).expect("has points").diagonal();
            for (a, b) in skinned.iter().zip(&mesh.positions) {
                assert!((a - b).norm() < 1e-6 * diag, "{file}: {a} vs {b}");
            }
            if let (Some(n0), Some(n1)) = (&mesh.normals, &normals) {
                for (a, b) in n0.iter().zip(n1) {
                    if a.norm() > 0.5 {
                        assert!(
                            (a.normalize() - b).norm() < 1e-4,
                            "{file}: normal {a} vs {b}"
                        );
                    }
                }
            }
            // The bind pose rebuilt as local transforms gives the same skin.
            let bind_pose = rig.skeleton.pose_from_world(&world);
            let (again, _) = mesh.skin(&rig.skeleton.world_matrices(&bind_pose));
            for (a, b) in again.iter().zip(&mesh.positions) {
                assert!(
                    (a - b).norm() < 1e-6 * diag,
                    "{file}: rebuilt bind pose {a} vs {b}"
                );
            }
        }
    }
}

#[test]
fn stored_pose_of_the_converted_assets_is_their_bind_pose() {
    let doc = read_gltf(&data("assimp/BCN_Epileptic.glb"), None).expect("loads");
    let rig = rig(&doc);
    let world = rig.skeleton.world_matrices(&rig.pose);
    let (skinned, _) = rig.meshes[0].skin(&world);
    let diag = rig.bounds(&rig.pose).expect("points").diagonal();
    let worst = skinned
        .iter()
        .zip(&rig.meshes[0].positions)
        .map(|(a, b)| (a - b).norm())
        .fold(0.0, f64::max);
    assert!(worst < 1e-4 * diag, "worst {worst}");
}

#[test]
fn jacobians_of_every_real_rig_match_finite_differences() {
    for file in RIGS {
        let doc = read_gltf(&data(file), None).expect("loads");
        let rig = rig(&doc);
        let s = &rig.skeleton;
        let layout = DofLayout::new(s);
        let mut pose = rig
            .animations
            .first()
            .map_or_else(|| rig.pose.clone(), |a| a.sample(&rig.pose, 0.5 * a.end()));
        // Bend every joint a little so no Jacobian is evaluated at a special configuration.
        for (j, local) in pose.local.iter_mut().enumerate() {
            local.rotation *= Quat::from_euler_angles(0.05 * (j % 3) as f64, 0.04, -0.03);
        }
        let fk = ForwardKinematics::new(s, &pose);
        let scale = rig.height();
        let h = 1e-6;
        for j in 0..s.len() {
            let local = Point3::new(0.01, 0.02, -0.01) * scale;
            let p = fk.point(j, &local);
            let mut analytic = vec![Vector3::zeros(); layout.len()];
            fk.point_jacobian(&layout, j, &p, |c, v| analytic[c] = v);
            let numeric_columns = numeric_point_jacobian(s, &layout, &pose, j, &local, h);
            for (c, numeric) in numeric_columns.iter().enumerate() {
                let err = (numeric - analytic[c]).norm();
                assert!(
                    err < 1e-5 * (1.0 + numeric.norm()) * scale.max(1.0),
                    "{file}: joint {j} column {c}: {err}"
                );
            }
        }
    }
}

#[test]
fn a_new_pose_is_written_as_node_rotations_and_animation_keys() {
    let path = data("assimp/BCN_Epileptic.glb");
    let doc = read_gltf(&path, None).expect("loads");
    let original = rig(&doc);
    let mut pose = original.pose.clone();
    let arm = original
        .skeleton
        .joints()
        .iter()
        .position(|j| j.name.contains("Arm"))
        .expect("an arm joint");
    pose.local[arm].rotation *= Quat::from_euler_angles(0.3, 0.2, -0.4);
    let mut pose2 = pose.clone();
    pose2.local[arm].rotation *= Quat::from_euler_angles(0.0, 0.5, 0.0);
    let keys = vec![(0.0, pose.clone()), (1.0, pose2.clone())];
    let bytes = doc.to_bytes(true, &pose, &keys, None);
    let back = reparse(&bytes);
    let r = rig(&back);
    assert!(
        r.pose.local[arm]
            .rotation
            .angle_to(&pose.local[arm].rotation)
            < 1e-9
    );
    let anim = r
        .animations
        .iter()
        .find(|a| a.name == "rigfit")
        .expect("rigfit animation");
    for (t, p) in &keys {
        let sampled = anim.sample(&r.pose, *t);
        let a = r.skeleton.joint_positions(&sampled);
        let b = r.skeleton.joint_positions(p);
        for (x, y) in a.iter().zip(&b) {
            assert!((x - y).norm() < 1e-5 * original.height());
        }
    }
    // The original clip is still there, unchanged.
    assert_eq!(r.animations.len(), original.animations.len() + 1);
    // Writing again replaces the rigfit animation instead of piling up data.
    let keys_back = back.rigfit_keys();
    assert_eq!(keys_back.len(), 2);
    let again = back.to_bytes(true, &pose, &keys_back, None);
    assert_eq!(again.len(), bytes.len());
    assert_eq!(
        rig_of(&again).animations.len(),
        original.animations.len() + 1
    );
}

fn rig_of(bytes: &[u8]) -> Rig {
    reparse(bytes).rig.expect("skin")
}

#[test]
fn the_built_in_humanoid_survives_glb() {
    let rig = rigfit_core::humanoid::humanoid();
    let bytes = rig_to_glb(&rig);
    let back = rig_of(&bytes);
    assert_eq!(back.skeleton.len(), rig.skeleton.len());
    let a = rig.skeleton.joint_positions(&rig.pose);
    let b = back.skeleton.joint_positions(&back.pose);
    for (x, y) in a.iter().zip(&b) {
        assert!((x - y).norm() < 1e-6);
    }
    let t = 0.8;
    let pa = rig
        .skeleton
        .joint_positions(&rig.animations[0].sample(&rig.pose, t));
    let pb = back
        .skeleton
        .joint_positions(&back.animations[0].sample(&back.pose, t));
    for (x, y) in pa.iter().zip(&pb) {
        assert!((x - y).norm() < 1e-5);
    }
    let (sa, _) = rig.meshes[0].skin(&rig.skeleton.world_matrices(&rig.pose));
    let (sb, _) = back.meshes[0].skin(&back.skeleton.world_matrices(&back.pose));
    for (x, y) in sa.iter().zip(&sb) {
        assert!((x - y).norm() < 1e-5);
    }
}

#[test]
fn truncated_and_corrupted_glb_never_panic() {
    let bytes = std::fs::read(data("webxr_hand/left.glb")).expect("read");
    for cut in (0..bytes.len()).step_by(97) {
        let _ = parse_gltf(&bytes[..cut], &mut no_uri, None);
    }
    let mut state = 12345u64;
    for _ in 0..300 {
        let mut b = bytes.clone();
        for _ in 0..4 {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            let i = (state >> 33) as usize % b.len();
            b[i] = (state >> 17) as u8;
        }
        let _ = parse_gltf(&b, &mut no_uri, None);
    }
}
