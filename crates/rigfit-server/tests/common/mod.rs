//! Helpers shared by the server's tests: the real assets, in-process requests against the
//! router, and solve requests drawn from a rig's own animation.
#![allow(dead_code)]

pub mod http;
pub mod load;
pub mod rigs;

use axum::Router;
use axum::body::Body;
use axum::http::{HeaderMap, Request, StatusCode};
use rigfit_core::{Pose, Rig};
use rigfit_server::{AppState, ServerConfig};
use rigfit_testkit::pose_suites::case_from_clip;
use serde_json::{Value, json};
use tower::ServiceExt as _;

#[allow(unused_imports)]
pub use rigfit_testkit::assets::{asset, malformed_dir};

/// A server state holding the built-in humanoid as `c0`, and its router.
pub fn app() -> (AppState, Router) {
    let state = AppState::new(&ServerConfig::default());
    state.add_humanoid().expect("the humanoid loads");
    let router = rigfit_server::router(state.clone());
    (state, router)
}

/// An answer: status, headers and body.
#[derive(Debug)]
pub struct Answer {
    pub status: StatusCode,
    pub headers: HeaderMap,
    pub body: Vec<u8>,
}

impl Answer {
    /// The body as JSON (panics with the body when it is not).
    pub fn json(&self) -> Value {
        serde_json::from_slice(&self.body).unwrap_or_else(|e| {
            panic!(
                "not JSON ({e}): {}",
                String::from_utf8_lossy(&self.body[..self.body.len().min(300)])
            )
        })
    }

    /// The `error` line of an error answer, checking the shape `{"error": "one line"}`.
    pub fn error(&self) -> String {
        let value = self.json();
        let line = value
            .get("error")
            .and_then(Value::as_str)
            .unwrap_or_else(|| panic!("no \"error\" in {value}"))
            .to_string();
        assert_eq!(value.as_object().map(|o| o.len()), Some(1), "{value}");
        assert!(!line.contains('\n'), "one line: {line}");
        assert!(!line.is_empty());
        line
    }

    pub fn header(&self, name: &str) -> String {
        self.headers
            .get(name)
            .and_then(|v| v.to_str().ok())
            .unwrap_or("")
            .to_string()
    }
}

/// Sends one request to the router in-process.
pub async fn send(router: &Router, request: Request<Body>) -> Answer {
    let response = router
        .clone()
        .oneshot(request)
        .await
        .expect("the router never fails");
    let status = response.status();
    let headers = response.headers().clone();
    let body = axum::body::to_bytes(response.into_body(), usize::MAX)
        .await
        .expect("the body reads")
        .to_vec();
    Answer {
        status,
        headers,
        body,
    }
}

pub async fn get(router: &Router, uri: &str) -> Answer {
    let request = Request::get(uri).body(Body::empty()).expect("request");
    send(router, request).await
}

/// The `Content-Type` the page sends to `uri`: bytes for an upload, JSON otherwise.
pub fn content_type_for(uri: &str) -> &'static str {
    if uri.starts_with("/api/characters?") {
        "application/octet-stream"
    } else {
        "application/json"
    }
}

pub async fn post(router: &Router, uri: &str, body: impl Into<Body>) -> Answer {
    let request = Request::post(uri)
        .header("content-type", content_type_for(uri))
        .body(body.into())
        .expect("request");
    send(router, request).await
}

pub async fn post_json(router: &Router, uri: &str, value: &Value) -> Answer {
    post(router, uri, value.to_string()).await
}

/// Uploads an asset under its own file name; panics unless it gets 201.
pub async fn upload(router: &Router, rel: &str, query: &str) -> Value {
    let path = asset(rel);
    let name = path
        .file_name()
        .expect("name")
        .to_string_lossy()
        .into_owned();
    let bytes = std::fs::read(&path).expect("asset reads");
    let answer = post(
        router,
        &format!("/api/characters?name={name}{query}"),
        bytes,
    )
    .await;
    assert_eq!(
        answer.status,
        StatusCode::CREATED,
        "{rel}: {}",
        String::from_utf8_lossy(&answer.body)
    );
    answer.json()
}

/// Checks the server still answers a plain request.
pub async fn assert_still_serving(router: &Router) {
    let answer = get(router, "/api/characters").await;
    assert_eq!(answer.status, StatusCode::OK);
    assert!(answer.json()["characters"].is_array());
}

/// A pose as request JSON: every joint's local translation, rotation and scale.
pub fn pose_json(rig: &Rig, pose: &Pose) -> Value {
    let joints: Vec<Value> = rig
        .skeleton
        .joints()
        .iter()
        .zip(&pose.local)
        .map(|(joint, trs)| {
            let t = trs.translation;
            let s = trs.scale;
            json!({
                "name": joint.name,
                "translation": [t.x, t.y, t.z],
                "rotation": rigfit_core::animation::quat_to_xyzw(&trs.rotation),
                "scale": [s.x, s.y, s.z],
            })
        })
        .collect();
    json!({ "joints": joints })
}

/// A solve case drawn from the rig's own first animation at `fraction` of its length: the
/// true pose, the strokes JSON (one per limb, 1% noise) and the joints drawn.
pub struct SolveCase {
    pub truth: Pose,
    pub strokes: Value,
    pub drawn_joints: Vec<usize>,
}

pub fn case_from_animation(rig: &Rig, fraction: f64, seed: u64) -> SolveCase {
    let anim = rig.animations.first().expect("the rig has an animation");
    let (s, e) = (anim.start(), anim.end());
    let (truth, case) = case_from_clip(rig, s + (e - s) * fraction, seed);
    let strokes: Vec<Value> = case
        .strokes
        .iter()
        .map(|s| {
            let points: Vec<[f64; 3]> = s.points.iter().map(|p| [p.x, p.y, p.z]).collect();
            json!({ "points": points })
        })
        .collect();
    SolveCase {
        truth,
        strokes: Value::Array(strokes),
        drawn_joints: case.drawn_joints,
    }
}

/// Mean distance, as a fraction of the height, between the joint positions of a solve answer
/// and the true pose, over the drawn joints (the answer lists every joint in the rig's order).
pub fn answer_error(rig: &Rig, answer: &Value, truth: &Pose, drawn: &[usize]) -> f64 {
    let truth_positions = rig.skeleton.joint_positions(truth);
    let joints = answer["joints"].as_array().expect("joints");
    assert_eq!(
        joints.len(),
        rig.skeleton.len(),
        "every joint in the answer"
    );
    let mut sum = 0.0;
    for &j in drawn {
        let found = &joints[j];
        assert_eq!(found["index"], json!(j));
        assert_eq!(found["name"], json!(rig.skeleton.joint(j).name));
        let p: Vec<f64> = found["position"]
            .as_array()
            .expect("position")
            .iter()
            .map(|x| x.as_f64().expect("number"))
            .collect();
        let t = truth_positions[j];
        sum += ((p[0] - t.x).powi(2) + (p[1] - t.y).powi(2) + (p[2] - t.z).powi(2)).sqrt();
    }
    assert!(!drawn.is_empty(), "no drawn joint");
    sum / drawn.len() as f64 / rig.height()
}
