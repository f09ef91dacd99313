//! Every endpoint of docs/serve-api.md against the router in-process, on the real assets:
//! characters (list, upload, get, delete, model.glb), solve (strokes drawn from the rigs' own
//! animations) and export (read back with rigfit-formats), and every kind of bad request,
//! after each of which the server still answers.

mod common;

use std::path::Path;

use axum::body::{Body, Bytes};
use axum::http::{Request, StatusCode, header};
use common::{
    Answer, app, assert_still_serving, asset, case_from_animation, get, malformed_dir, pose_json,
    post, post_json, send, upload,
};
use rigfit_core::animation::quat_from_xyzw;
use rigfit_formats::rig_file::{RigOptions, StartFrame, parse_rig, read_rig};
use serde_json::{Value, json};

fn assert_status(answer: &Answer, status: StatusCode) {
    assert_eq!(
        answer.status,
        status,
        "{}",
        String::from_utf8_lossy(&answer.body[..answer.body.len().min(400)])
    );
}

/// Checks a CHARACTER: the fields of the API, parents before children, nodes naming the
/// joint's node in `model.glb`.
fn check_character(value: &Value, model: &Value) {
    for key in ["id", "name", "format", "height", "joints"] {
        assert!(value.get(key).is_some(), "CHARACTER has {key}: {value}");
    }
    assert!(value["height"].as_f64().expect("height") > 0.0);
    let joints = value["joints"].as_array().expect("joints");
    assert!(!joints.is_empty());
    let nodes = model["nodes"].as_array().expect("model nodes");
    for (i, joint) in joints.iter().enumerate() {
        if let Some(parent) = joint["parent"].as_u64() {
            assert!((parent as usize) < i, "parents first: joint {i}");
        }
        let kind = joint["kind"].as_str().expect("kind");
        assert!(["skin", "helper", "end_site"].contains(&kind), "{kind}");
        for part in ["rest", "pose"] {
            assert_eq!(joint[part]["translation"].as_array().map(Vec::len), Some(3));
            assert_eq!(joint[part]["rotation"].as_array().map(Vec::len), Some(4));
            assert_eq!(joint[part]["scale"].as_array().map(Vec::len), Some(3));
        }
        assert_eq!(joint["position"].as_array().map(Vec::len), Some(3));
        let node = joint["node"].as_u64().expect("every joint here has a node") as usize;
        assert_eq!(
            nodes[node]["name"], joint["name"],
            "joint {i} drives the node of its name"
        );
    }
}

/// The JSON chunk of a GLB.
fn glb_json(bytes: &[u8]) -> Value {
    assert_eq!(&bytes[..4], b"glTF", "a GLB");
    let length = u32::from_le_bytes(bytes[12..16].try_into().expect("4 bytes")) as usize;
    serde_json::from_slice(&bytes[20..20 + length]).expect("GLB JSON")
}

#[tokio::test]
async fn the_humanoid_is_c0_and_listed() {
    let (_, router) = app();
    let list = get(&router, "/api/characters").await;
    assert_status(&list, StatusCode::OK);
    assert!(list.header("content-type").starts_with("application/json"));
    let characters = list.json()["characters"].clone();
    assert_eq!(characters.as_array().map(Vec::len), Some(1));
    assert_eq!(characters[0]["id"], "c0");
    assert_eq!(characters[0]["name"], "humanoid");
    assert_eq!(characters[0]["format"], "glb");
    let one = get(&router, "/api/characters/c0").await;
    assert_status(&one, StatusCode::OK);
    assert_eq!(one.json(), characters[0]);
    let model = get(&router, "/api/characters/c0/model.glb").await;
    assert_status(&model, StatusCode::OK);
    assert_eq!(model.header("content-type"), "model/gltf-binary");
    check_character(&one.json(), &glb_json(&model.body));
    assert_eq!(one.json()["joints"].as_array().map(Vec::len), Some(26));
}

#[tokio::test]
async fn uploads_are_read_with_the_command_line_readers() {
    let (_, router) = app();
    for (rel, format, id) in [
        ("assimp/BCN_Epileptic.glb", "glb", "c1"),
        ("cmu/01_01.bvh", "bvh", "c2"),
        ("webxr_hand/left.glb", "glb", "c3"),
    ] {
        let created = upload(&router, rel, "").await;
        assert_eq!(created["id"], id);
        assert_eq!(created["format"], format);
        let expected = read_rig(&asset(rel), &RigOptions::default()).expect("reads");
        assert_eq!(
            created["joints"].as_array().map(Vec::len),
            Some(expected.rig.skeleton.len()),
            "{rel}"
        );
        assert!((created["height"].as_f64().expect("height") - expected.rig.height()).abs() < 1e-9);
        let fetched = get(&router, &format!("/api/characters/{id}")).await;
        assert_eq!(fetched.json(), created);
        let model = get(&router, &format!("/api/characters/{id}/model.glb")).await;
        assert_status(&model, StatusCode::OK);
        // The display model reads back as a rig with the same joints.
        let shown = parse_rig(&model.body, Path::new("model.glb"), &RigOptions::default())
            .expect("model.glb is a rig");
        assert_eq!(
            shown.rig.skeleton.len(),
            expected.rig.skeleton.len(),
            "{rel}"
        );
        check_character(&created, &glb_json(&model.body));
    }
    let list = get(&router, "/api/characters").await.json();
    assert_eq!(list["characters"].as_array().map(Vec::len), Some(4));
    // BVH frame options of the command line, as query parameters.
    let rest = upload(&router, "cmu/01_01.bvh", "&start_frame=rest").await;
    assert_eq!(rest["id"], "c4");
    assert_eq!(rest["name"], "01_01");
}

#[tokio::test]
async fn delete_forgets_a_character() {
    let (_, router) = app();
    upload(&router, "webxr_hand/left.glb", "").await;
    let request = Request::delete("/api/characters/c1")
        .body(Body::empty())
        .expect("request");
    assert_status(&send(&router, request).await, StatusCode::NO_CONTENT);
    assert_status(
        &get(&router, "/api/characters/c1").await,
        StatusCode::NOT_FOUND,
    );
    let request = Request::delete("/api/characters/c1")
        .body(Body::empty())
        .expect("request");
    assert_status(&send(&router, request).await, StatusCode::NOT_FOUND);
    // Ids are not reused.
    assert_eq!(upload(&router, "webxr_hand/left.glb", "").await["id"], "c2");
}

/// Solves strokes drawn from the rig's animation; the answer's joints must be near the
/// true pose's.
async fn solve_from_animation(router: &axum::Router, id: &str, rig: &rigfit_core::Rig) {
    for (k, fraction) in [0.3, 0.7].into_iter().enumerate() {
        let case = case_from_animation(rig, fraction, 7 + k as u64);
        let answer = post_json(
            router,
            &format!("/api/characters/{id}/solve"),
            &json!({ "strokes": case.strokes }),
        )
        .await;
        assert_status(&answer, StatusCode::OK);
        let report = answer.json();
        let error = common::answer_error(rig, &report, &case.truth, &case.drawn_joints);
        assert!(
            error < 0.03,
            "{id} at {fraction}: error {error:.4} of the height"
        );
        for key in ["joints", "strokes", "iterations", "energy", "seconds"] {
            assert!(report.get(key).is_some(), "report has {key}");
        }
        let joint = &report["joints"][0];
        for key in [
            "index",
            "name",
            "parent",
            "position",
            "rotation",
            "translation",
        ] {
            assert!(joint.get(key).is_some(), "joint has {key}: {joint}");
        }
        assert_eq!(
            report["strokes"].as_array().map(Vec::len),
            case.strokes.as_array().map(Vec::len)
        );
    }
}

#[tokio::test]
async fn solve_poses_the_humanoid_from_its_own_animation() {
    let (_, router) = app();
    let rig = rigfit_server::humanoid_rig_file().expect("humanoid").rig;
    solve_from_animation(&router, "c0", &rig).await;
}

#[tokio::test]
async fn solve_poses_uploaded_rigs_from_their_own_animations() {
    let (_, router) = app();
    upload(&router, "assimp/BCN_Epileptic.glb", "").await;
    let bcn = read_rig(&asset("assimp/BCN_Epileptic.glb"), &RigOptions::default()).expect("rig");
    solve_from_animation(&router, "c1", &bcn.rig).await;
    upload(&router, "cmu/01_01.bvh", "&start_frame=rest").await;
    let options = RigOptions {
        start_frame: StartFrame::Rest,
        ..Default::default()
    };
    let bvh = read_rig(&asset("cmu/01_01.bvh"), &options).expect("rig");
    solve_from_animation(&router, "c2", &bvh.rig).await;
}

#[tokio::test]
async fn solve_starts_from_the_given_pose_and_moves_only_the_given_bones() {
    let (_, router) = app();
    let rig = rigfit_server::humanoid_rig_file().expect("humanoid").rig;
    let case = case_from_animation(&rig, 0.5, 3);
    // Start from the true pose: the answer stays there.
    let answer = post_json(
        &router,
        "/api/characters/c0/solve",
        &json!({ "pose": pose_json(&rig, &case.truth), "strokes": case.strokes, "method": "rigfit" }),
    )
    .await;
    assert_status(&answer, StatusCode::OK);
    let error = common::answer_error(&rig, &answer.json(), &case.truth, &case.drawn_joints);
    assert!(error < 0.02, "from the truth: {error}");
    // The answer is a pose the next request can start from.
    let next = json!({ "pose": { "joints": answer.json()["joints"] }, "strokes": case.strokes });
    assert_status(
        &post_json(&router, "/api/characters/c0/solve", &next).await,
        StatusCode::OK,
    );
    // Only the left arm may move: every other joint keeps its stored rotation.
    let answer = post_json(
        &router,
        "/api/characters/c0/solve",
        &json!({ "strokes": case.strokes, "bones": ["LeftArm", "LeftForeArm"], "method": "paper" }),
    )
    .await;
    assert_status(&answer, StatusCode::OK);
    for joint in answer.json()["joints"].as_array().expect("joints") {
        let name = joint["name"].as_str().expect("name");
        if name == "LeftArm" || name == "LeftForeArm" {
            continue;
        }
        let j = rig.skeleton.find(name).expect("known joint");
        let r: Vec<f64> = joint["rotation"]
            .as_array()
            .expect("rotation")
            .iter()
            .map(|x| x.as_f64().expect("number"))
            .collect();
        let q = quat_from_xyzw([r[0], r[1], r[2], r[3]]);
        assert!(
            q.angle_to(&rig.pose.local[j].rotation) < 1e-9,
            "{name} kept its rotation"
        );
    }
}

#[tokio::test]
async fn solve_can_keep_the_root_in_place_or_fixed() {
    let (_, router) = app();
    let rig = rigfit_server::humanoid_rig_file().expect("humanoid").rig;
    let hips = rig.skeleton.find("Hips").expect("Hips");
    // Strokes of a pose drawn 0.3 m to the side: a free root follows them.
    let mut case = case_from_animation(&rig, 0.5, 5);
    for stroke in case.strokes.as_array_mut().expect("strokes") {
        for point in stroke["points"].as_array_mut().expect("points") {
            let x = point[0].as_f64().expect("x");
            point[0] = json!(x + 0.3);
        }
    }
    let numbers = |v: &Value| -> Vec<f64> {
        v.as_array()
            .expect("list")
            .iter()
            .map(|x| x.as_f64().expect("number"))
            .collect()
    };
    let stored = rig.pose.local[hips];
    let mut roots = Vec::new();
    for root in ["free", "rotate", "fixed"] {
        let answer = post_json(
            &router,
            "/api/characters/c0/solve",
            &json!({ "strokes": case.strokes, "root": root }),
        )
        .await;
        assert_status(&answer, StatusCode::OK);
        let joint = answer.json()["joints"][hips].clone();
        let t = numbers(&joint["translation"]);
        let r = numbers(&joint["rotation"]);
        let moved = (t[0] - stored.translation.x).abs();
        let turned = quat_from_xyzw([r[0], r[1], r[2], r[3]]).angle_to(&stored.rotation);
        roots.push((root, moved, turned));
    }
    assert!(
        roots[0].1 > 0.1,
        "a free root moves onto the strokes: {roots:?}"
    );
    assert!(roots[1].1 < 1e-9, "rotate keeps the translation: {roots:?}");
    assert!(
        roots[2].1 < 1e-9 && roots[2].2 < 1e-9,
        "fixed keeps all: {roots:?}"
    );
    // Every joint of the CHARACTER is in the answer, helpers too (BCN_Epileptic has one).
    let created = upload(&router, "assimp/BCN_Epileptic.glb", "").await;
    let bcn = read_rig(&asset("assimp/BCN_Epileptic.glb"), &RigOptions::default()).expect("rig");
    let case = case_from_animation(&bcn.rig, 0.5, 9);
    let answer = post_json(
        &router,
        "/api/characters/c1/solve",
        &json!({ "strokes": case.strokes, "root": "rotate" }),
    )
    .await;
    assert_status(&answer, StatusCode::OK);
    let names = |v: &Value| -> Vec<Value> {
        v.as_array()
            .expect("joints")
            .iter()
            .map(|j| j["name"].clone())
            .collect()
    };
    assert_eq!(names(&answer.json()["joints"]), names(&created["joints"]));
    assert!(
        created["joints"]
            .as_array()
            .expect("joints")
            .iter()
            .any(|j| j["kind"] == "helper")
    );
}

#[tokio::test]
async fn bad_solve_requests_get_one_line_and_the_server_goes_on() {
    let (_, router) = app();
    let rig = rigfit_server::humanoid_rig_file().expect("humanoid").rig;
    let strokes = case_from_animation(&rig, 0.5, 1).strokes;
    let cases: Vec<(Body, StatusCode, &str)> = vec![
        ("{\"strokes\": [".into(), StatusCode::BAD_REQUEST, "solve request: line 1"),
        ("not json".into(), StatusCode::BAD_REQUEST, "not valid JSON"),
        ("[1, 2]".into(), StatusCode::BAD_REQUEST, "top level"),
        ("{}".into(), StatusCode::BAD_REQUEST, "missing \"strokes\""),
        (
            "{\"strokes\": [{\"points\": [[0, 1, 0]]}]}".into(),
            StatusCode::BAD_REQUEST,
            "strokes[0]: a stroke needs at least 2 points",
        ),
        (
            "{\"strokes\": [{\"points\": [[0, 1, NaN], [0, 2, 0]]}]}".into(),
            StatusCode::BAD_REQUEST,
            "NaN",
        ),
        (
            json!({ "strokes": strokes, "method": "magic" }).to_string().into(),
            StatusCode::BAD_REQUEST,
            "method: expected one of \"rigfit\", \"paper\"",
        ),
        (
            json!({ "strokes": strokes, "pose": { "joints": [{ "name": "Tail" }] } })
                .to_string()
                .into(),
            StatusCode::BAD_REQUEST,
            "pose.joints[0].name: unknown joint 'Tail'",
        ),
        (
            json!({ "strokes": strokes, "pose": { "joints": [{ "name": "Hips", "rotation": [0, 0, 0, 0] }] } })
                .to_string()
                .into(),
            StatusCode::BAD_REQUEST,
            "pose.joints[0].rotation",
        ),
        (
            json!({ "strokes": strokes, "pose": { "joints": [{ "name": "Hips", "translation": [0, 1] }] } })
                .to_string()
                .into(),
            StatusCode::BAD_REQUEST,
            "pose.joints[0].translation: expected a list of 3 numbers",
        ),
        (
            json!({ "strokes": strokes, "root": "pinned" }).to_string().into(),
            StatusCode::BAD_REQUEST,
            "root: expected one of \"free\", \"rotate\", \"fixed\"",
        ),
        (
            json!({ "strokes": strokes, "bones": "LeftArm" }).to_string().into(),
            StatusCode::BAD_REQUEST,
            "bones: expected a list",
        ),
        (
            "{\"strokes\": []}".into(),
            StatusCode::UNPROCESSABLE_ENTITY,
            "solve request: no strokes",
        ),
        (
            json!({ "strokes": strokes, "bones": ["Wing"] }).to_string().into(),
            StatusCode::UNPROCESSABLE_ENTITY,
            "humanoid.glb: unknown bone 'Wing'",
        ),
        (
            // The request's own pose shrinks every bone to nothing: the request is at fault.
            json!({ "strokes": strokes,
                    "pose": { "joints": [{ "name": "Hips", "scale": [0, 0, 0] }] } })
            .to_string()
            .into(),
            StatusCode::UNPROCESSABLE_ENTITY,
            "solve request: pose: the rig has no bones",
        ),
        (
            json!({ "strokes": [{ "points": [[0, 1, 0], [1e9, 1, 0]] }] })
                .to_string()
                .into(),
            StatusCode::UNPROCESSABLE_ENTITY,
            "character heights away",
        ),
    ];
    for (body, status, needle) in cases {
        let answer = post(&router, "/api/characters/c0/solve", body).await;
        assert_status(&answer, status);
        let line = answer.error();
        assert!(line.contains(needle), "'{line}' names '{needle}'");
        assert_still_serving(&router).await;
    }
}

#[tokio::test]
async fn export_writes_the_pose_and_keys_with_the_cli_writers() {
    let (_, router) = app();
    upload(&router, "assimp/BCN_Epileptic.glb", "").await;
    let bcn = read_rig(&asset("assimp/BCN_Epileptic.glb"), &RigOptions::default()).expect("rig");
    let rig = &bcn.rig;
    let anim = &rig.animations[0];
    let at = |f: f64| anim.sample(&rig.pose, anim.start() + (anim.end() - anim.start()) * f);
    let (a, b) = (at(0.2), at(0.8));
    let request = json!({
        "format": "glb", "fps": 24,
        "pose": pose_json(rig, &b),
        "keys": [ { "frame": 12, "pose": pose_json(rig, &b) }, { "frame": 0, "pose": pose_json(rig, &a) } ],
    });
    let answer = post_json(&router, "/api/characters/c1/export", &request).await;
    assert_status(&answer, StatusCode::OK);
    assert_eq!(answer.header("content-type"), "model/gltf-binary");
    assert_eq!(
        answer.header("content-disposition"),
        "attachment; filename=\"BCN_Epileptic.glb\""
    );
    let back = parse_rig(&answer.body, Path::new("out.glb"), &RigOptions::default()).expect("GLB");
    let positions = |pose: &rigfit_core::Pose| back.rig.skeleton.joint_positions(pose);
    let close = |p: &[rigfit_core::Point3], q: &[rigfit_core::Point3]| {
        p.iter()
            .zip(q)
            .map(|(x, y)| (x - y).norm())
            .fold(0.0, f64::max)
            < 1e-4 * rig.height()
    };
    // The stored pose is `pose`; the `rigfit` animation has the keys at frame / fps.
    assert!(close(
        &positions(&back.rig.pose),
        &rig.skeleton.joint_positions(&b)
    ));
    let keyed = back
        .rig
        .animations
        .iter()
        .find(|x| x.name == "rigfit")
        .expect("the rigfit animation");
    assert!((keyed.start() - 0.0).abs() < 1e-9 && (keyed.end() - 0.5).abs() < 1e-6);
    assert!(close(
        &positions(&keyed.sample(&back.rig.pose, 0.0)),
        &rig.skeleton.joint_positions(&a)
    ));
    assert!(close(
        &positions(&keyed.sample(&back.rig.pose, 0.5)),
        &rig.skeleton.joint_positions(&b)
    ));

    // BVH: one frame per frame number up to the last key, 1 / fps apart.
    let request = json!({
        "format": "bvh", "fps": 30,
        "keys": [ { "frame": 0, "pose": pose_json(rig, &a) }, { "frame": 6, "pose": pose_json(rig, &b) } ],
    });
    let answer = post_json(&router, "/api/characters/c1/export", &request).await;
    assert_status(&answer, StatusCode::OK);
    assert_eq!(
        answer.header("content-disposition"),
        "attachment; filename=\"BCN_Epileptic.bvh\""
    );
    let bvh = rigfit_formats::bvh::parse_bvh(&answer.body).expect("BVH");
    assert_eq!(bvh.frames.len(), 7);
    assert!((bvh.frame_time - 1.0 / 30.0).abs() < 1e-9);
    let skeleton = bvh.skeleton();
    let last = skeleton.joint_positions(&bvh.pose_at_frame(6));
    // The BVH holds the rig's joints in its order (helpers included).
    let truth = rig.skeleton.joint_positions(&b);
    assert_eq!(last.len(), truth.len());
    assert!(close(&last, &truth), "frame 6 is the last key");

    // glTF JSON with embedded buffers.
    let answer = post_json(
        &router,
        "/api/characters/c1/export",
        &json!({ "format": "gltf" }),
    )
    .await;
    assert_status(&answer, StatusCode::OK);
    assert_eq!(answer.header("content-type"), "model/gltf+json");
    let back =
        parse_rig(&answer.body, Path::new("out.gltf"), &RigOptions::default()).expect("glTF");
    assert_eq!(back.rig.skeleton.len(), rig.skeleton.len());
}

#[tokio::test]
async fn export_of_a_bvh_character() {
    let (_, router) = app();
    upload(&router, "cmu/01_01.bvh", "").await;
    let bvh = read_rig(&asset("cmu/01_01.bvh"), &RigOptions::default()).expect("rig");
    let rig = &bvh.rig;
    let later = rig.animations[0].sample(&rig.pose, 1.0);
    let request = json!({
        "format": "bvh", "fps": 24,
        "keys": [ { "frame": 2, "pose": pose_json(rig, &rig.pose) }, { "frame": 4, "pose": pose_json(rig, &later) } ],
    });
    let answer = post_json(&router, "/api/characters/c1/export", &request).await;
    assert_status(&answer, StatusCode::OK);
    let back = rigfit_formats::bvh::parse_bvh(&answer.body).expect("BVH");
    assert_eq!(back.frames.len(), 5, "frames 0..=4");
    let skeleton = back.skeleton();
    let close = |p: Vec<rigfit_core::Point3>, q: Vec<rigfit_core::Point3>| {
        p.iter()
            .zip(&q)
            .map(|(x, y)| (x - y).norm())
            .fold(0.0, f64::max)
            < 1e-3 * rig.height()
    };
    // Before the first key: the first key's pose.
    assert!(close(
        skeleton.joint_positions(&back.pose_at_frame(0)),
        rig.skeleton.joint_positions(&rig.pose)
    ));
    assert!(close(
        skeleton.joint_positions(&back.pose_at_frame(4)),
        rig.skeleton.joint_positions(&later)
    ));
    for format in ["glb", "gltf"] {
        let answer = post_json(
            &router,
            "/api/characters/c1/export",
            &json!({ "format": format, "keys": [ { "frame": 0 }, { "frame": 24, "pose": pose_json(rig, &later) } ] }),
        )
        .await;
        assert_status(&answer, StatusCode::OK);
        let back = parse_rig(
            &answer.body,
            Path::new(&format!("out.{format}")),
            &RigOptions::default(),
        )
        .expect("reads back");
        let keyed = back
            .rig
            .animations
            .iter()
            .find(|x| x.name == "rigfit")
            .expect("rigfit animation");
        assert!((keyed.end() - 1.0).abs() < 1e-6, "frame 24 at 24 fps");
    }
}

#[tokio::test]
async fn bad_export_requests_get_one_line() {
    let (_, router) = app();
    for (body, needle) in [
        ("{\"format\": \"fbx\"}", "format: expected one of"),
        ("{\"fps\": 0}", "fps: expected a positive number"),
        ("{\"fps\": \"24\"}", "fps: expected a positive number"),
        ("{\"keys\": {}}", "keys: expected a list"),
        ("{\"keys\": [{\"pose\": {}}]}", "keys[0]: missing \"frame\""),
        (
            "{\"keys\": [{\"frame\": -1}]}",
            "keys[0].frame: expected a whole number",
        ),
        (
            "{\"keys\": [{\"frame\": 1.5}]}",
            "keys[0].frame: expected a whole number",
        ),
        (
            "{\"keys\": [{\"frame\": 99999999}]}",
            "keys[0].frame: 99999999 is past",
        ),
        (
            "{\"keys\": [{\"frame\": 1, \"pose\": {\"joints\": [{\"name\": 3}]}}]}",
            "keys[0].pose.joints[0].name",
        ),
        ("{\"format\": \"glb\"", "export request: line 1"),
    ] {
        let answer = post(&router, "/api/characters/c0/export", body).await;
        assert_status(&answer, StatusCode::BAD_REQUEST);
        let line = answer.error();
        assert!(line.contains(needle), "'{line}' names '{needle}'");
        assert_still_serving(&router).await;
    }
}

#[tokio::test]
async fn unknown_characters_are_404() {
    let (_, router) = app();
    for answer in [
        get(&router, "/api/characters/c9").await,
        get(&router, "/api/characters/c9/model.glb").await,
        post(&router, "/api/characters/c9/solve", "{}").await,
        post(&router, "/api/characters/c9/export", "{}").await,
        get(&router, "/api/characters/..%2f..%2fCargo.toml").await,
    ] {
        assert_status(&answer, StatusCode::NOT_FOUND);
        assert!(answer.error().contains("no such character"));
    }
    assert_still_serving(&router).await;
}

#[tokio::test]
async fn bad_uploads_get_the_readers_line() {
    let (_, router) = app();
    // Truncated and garbage files: the line read_rig gives for the same bytes.
    let bcn = std::fs::read(asset("assimp/BCN_Epileptic.glb")).expect("asset");
    let dir = std::env::temp_dir().join(format!("rigfit-server-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let cases: Vec<(&str, Vec<u8>)> = vec![
        ("BCN_Epileptic.glb", bcn[..bcn.len() / 2].to_vec()),
        ("BCN_Epileptic.glb", bcn[..10].to_vec()),
        ("garbage.glb", b"\x00\x01garbage\xff".to_vec()),
        (
            "garbage.gltf",
            b"{\"asset\": {\"version\": \"1.0\"}}".to_vec(),
        ),
        (
            "garbage.bvh",
            b"HIERARCHY\nROOT Hips\n{\n OFFSET 0 0\n".to_vec(),
        ),
        ("empty.bvh", Vec::new()),
    ];
    for (name, bytes) in cases {
        let file = dir.join(name);
        std::fs::write(&file, &bytes).expect("write");
        let expected = read_rig(&file, &RigOptions::default())
            .expect_err("bad file")
            .to_string()
            .replace(&file.display().to_string(), name);
        let answer = post(&router, &format!("/api/characters?name={name}"), bytes).await;
        assert_status(&answer, StatusCode::BAD_REQUEST);
        assert_eq!(answer.error(), expected);
        assert!(expected.starts_with(&format!("{name}: ")), "{expected}");
        assert_still_serving(&router).await;
    }
    let _ = std::fs::remove_dir_all(&dir);
    // The malformed-input corpus: every rig file gives read_rig's line.
    let mut checked = 0;
    for entry in std::fs::read_dir(malformed_dir()).expect("corpus") {
        let path = entry.expect("entry").path();
        let name = path
            .file_name()
            .expect("name")
            .to_string_lossy()
            .into_owned();
        let bytes = std::fs::read(&path).expect("reads");
        let answer = post(&router, &format!("/api/characters?name={name}"), bytes).await;
        match path.extension().and_then(|e| e.to_str()) {
            Some("glb" | "gltf" | "bvh") => {
                let expected = read_rig(&path, &RigOptions::default())
                    .expect_err("malformed")
                    .to_string()
                    .replace(&path.display().to_string(), &name);
                if expected.contains(": images[") {
                    // An image URI is a rule of files on disk (a written glTF keeps pointing
                    // at it); an upload reads no file and writes none, so it is taken.
                    assert_status(&answer, StatusCode::CREATED);
                    let id = answer.json()["id"].as_str().expect("an id").to_owned();
                    let request = Request::delete(format!("/api/characters/{id}"))
                        .body(Body::empty())
                        .expect("request");
                    let gone = send(&router, request).await;
                    assert_status(&gone, StatusCode::NO_CONTENT);
                    continue;
                }
                assert_status(&answer, StatusCode::BAD_REQUEST);
                let line = answer.error();
                // A buffer URI the command line refuses by its path is refused by an upload
                // before any path rule: uploads read no file at all.
                let uploads_read_no_file = expected.contains("URI")
                    && line.contains("external buffer")
                    && line.contains("cannot be read from memory");
                if !uploads_read_no_file {
                    assert_eq!(line, expected);
                }
                checked += 1;
            }
            _ => {
                assert_status(&answer, StatusCode::UNSUPPORTED_MEDIA_TYPE);
                let line = answer.error();
                assert!(
                    line.starts_with(&format!("{name}: unsupported file type")),
                    "{line}"
                );
            }
        }
        assert_still_serving(&router).await;
    }
    assert!(checked >= 15, "{checked} rig files in the corpus");
    // A .gltf naming an external buffer: nothing is read from the file system.
    let external = json!({ "asset": { "version": "2.0" }, "buffers": [ { "uri": "../../../etc/passwd", "byteLength": 4 } ] });
    let answer = post(&router, "/api/characters?name=x.gltf", external.to_string()).await;
    assert_status(&answer, StatusCode::BAD_REQUEST);
    assert!(
        answer.error().contains("cannot be read from memory"),
        "{}",
        answer.error()
    );
    // No name, a bad start frame, an unknown type.
    let answer = post(&router, "/api/characters", "x").await;
    assert_status(&answer, StatusCode::BAD_REQUEST);
    assert!(answer.error().starts_with("name: missing"));
    let answer = post(&router, "/api/characters?name=a.bvh&start_frame=first", "x").await;
    assert_status(&answer, StatusCode::BAD_REQUEST);
    let answer = post(&router, "/api/characters?name=notes.txt", "hello").await;
    assert_status(&answer, StatusCode::UNSUPPORTED_MEDIA_TYPE);
    assert_eq!(
        answer.error(),
        "notes.txt: unsupported file type (expected a rig: .glb, .gltf or .bvh)"
    );
    assert_eq!(
        get(&router, "/api/characters").await.json()["characters"]
            .as_array()
            .map(Vec::len),
        Some(1),
        "no bad upload was kept"
    );
}

#[tokio::test]
async fn oversized_bodies_are_413() {
    let (_, router) = app();
    // Declared lengths over the limits are refused before the body is read.
    for (uri, limit) in [
        ("/api/characters?name=big.glb", 64usize << 20),
        ("/api/characters/c0/solve", 4 << 20),
        ("/api/characters/c0/export", 4 << 20),
    ] {
        let request = Request::post(uri)
            .header(header::CONTENT_TYPE, common::content_type_for(uri))
            .header(header::CONTENT_LENGTH, limit + 1)
            .body(Body::from("{}"))
            .expect("request");
        let answer = send(&router, request).await;
        assert_status(&answer, StatusCode::PAYLOAD_TOO_LARGE);
        assert!(answer.error().contains("too large"));
        assert_still_serving(&router).await;
    }
    // Bodies with no declared length (in-process requests carry no Content-Length) are cut
    // off at the limit as they are read.
    for (uri, limit) in [
        ("/api/characters?name=big.glb", 64usize << 20),
        ("/api/characters/c0/solve", 4 << 20),
    ] {
        let request = Request::post(uri)
            .header(header::CONTENT_TYPE, common::content_type_for(uri))
            .body(Body::from(Bytes::from(vec![b' '; limit + 1])))
            .expect("request");
        assert!(request.headers().get(header::CONTENT_LENGTH).is_none());
        let answer = send(&router, request).await;
        assert_status(&answer, StatusCode::PAYLOAD_TOO_LARGE);
        assert_still_serving(&router).await;
    }
    // Just under the limit is read (and then judged on its content).
    let answer = post(
        &router,
        "/api/characters/c0/solve",
        vec![b' '; (4 << 20) - 1],
    )
    .await;
    assert_status(&answer, StatusCode::BAD_REQUEST);
}

#[tokio::test]
async fn static_files_come_only_from_the_embedded_set() {
    let (_, router) = app();
    let paths = rigfit_server::assets::embedded_paths();
    for path in &paths {
        assert!(
            path == "index.html" || path.starts_with("app/") || path.starts_with("vendor/"),
            "only the page's files are embedded: {path}"
        );
        let answer = get(&router, &format!("/{path}")).await;
        assert_status(&answer, StatusCode::OK);
        assert_eq!(
            answer.header("content-type"),
            rigfit_server::assets::content_type(path)
        );
    }
    if paths.iter().any(|p| p == "index.html") {
        let index = get(&router, "/").await;
        assert_status(&index, StatusCode::OK);
        assert_eq!(index.header("content-type"), "text/html; charset=utf-8");
    }
    if paths.iter().any(|p| p.ends_with(".js")) {
        let js = paths.iter().find(|p| p.ends_with(".js")).expect("a .js");
        let answer = get(&router, &format!("/{js}")).await;
        assert_eq!(
            answer.header("content-type"),
            "text/javascript; charset=utf-8"
        );
    }
    for path in [
        "/../Cargo.toml",
        "/app/../../etc/passwd",
        "/app/../../../../../../etc/passwd",
        "/app/%2e%2e/%2e%2e/Cargo.toml",
        "/app/%2e%2e%2f%2e%2e%2fCargo.toml",
        "/vendor/..%2f..%2f..%2fCargo.toml",
        "/%2e%2e/Cargo.toml",
        "/app/..\\..\\Cargo.toml",
        "/Cargo.toml",
        "/web/index.html",
        "/node_modules/.package-lock.json",
        "/package.json",
        "/tests/support.mjs",
        "/app/",
        "/app",
        "/api/nothing",
        "/api/characters/c0/nothing",
    ] {
        let answer = get(&router, path).await;
        assert_status(&answer, StatusCode::NOT_FOUND);
        assert!(answer.error().contains("not found"), "{path}");
        assert_still_serving(&router).await;
    }
}

#[tokio::test]
async fn wrong_methods_and_hosts_get_json_errors() {
    let (_, router) = app();
    let request = Request::put("/api/characters")
        .body(Body::empty())
        .expect("request");
    let answer = send(&router, request).await;
    assert_status(&answer, StatusCode::METHOD_NOT_ALLOWED);
    answer.error();
    // Only loopback names may address the server (no DNS rebinding).
    let request = Request::get("/api/characters")
        .header(header::HOST, "attacker.example:8717")
        .body(Body::empty())
        .expect("request");
    let answer = send(&router, request).await;
    assert_status(&answer, StatusCode::FORBIDDEN);
    assert!(answer.error().contains("attacker.example"));
    for host in ["localhost:8717", "127.0.0.1:8717", "[::1]:8717"] {
        let request = Request::get("/api/characters")
            .header(header::HOST, host)
            .body(Body::empty())
            .expect("request");
        assert_status(&send(&router, request).await, StatusCode::OK);
    }
}

#[tokio::test]
async fn a_panicking_handler_answers_500_and_the_server_goes_on() {
    let router = rigfit_server::guarded(
        axum::Router::new()
            .route(
                "/boom",
                axum::routing::get(|| async {
                    panic!("boom");
                    #[allow(unreachable_code)]
                    ""
                }),
            )
            .route("/fine", axum::routing::get(|| async { "fine" })),
    );
    let answer = get(&router, "/boom").await;
    assert_status(&answer, StatusCode::INTERNAL_SERVER_ERROR);
    assert!(answer.error().contains("boom"));
    assert_status(&get(&router, "/fine").await, StatusCode::OK);
}

#[tokio::test]
async fn the_store_is_bounded() {
    let (_, router) = app();
    let tiny = "HIERARCHY\nROOT Hips\n{\n OFFSET 0 0 0\n CHANNELS 3 Zrotation Xrotation Yrotation\n JOINT Leg\n {\n  OFFSET 0 -1 0\n  CHANNELS 3 Zrotation Xrotation Yrotation\n  End Site\n  {\n   OFFSET 0 -1 0\n  }\n }\n}\nMOTION\nFrames: 1\nFrame Time: 0.04\n0 0 0 0 0 0\n";
    for _ in 1..rigfit_server::MAX_CHARACTERS {
        let answer = post(&router, "/api/characters?name=tiny.bvh", tiny).await;
        assert_status(&answer, StatusCode::CREATED);
    }
    let answer = post(&router, "/api/characters?name=tiny.bvh", tiny).await;
    assert_status(&answer, StatusCode::CONFLICT);
    assert!(answer.error().contains("delete one first"));
    let request = Request::delete("/api/characters/c5")
        .body(Body::empty())
        .expect("request");
    assert_status(&send(&router, request).await, StatusCode::NO_CONTENT);
    let answer = post(&router, "/api/characters?name=tiny.bvh", tiny).await;
    assert_status(&answer, StatusCode::CREATED);
}
