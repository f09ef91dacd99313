//! A `rigfit serve` solve request, as the page (or any local client) sends it: the bytes are
//! the body of `POST /api/characters/c0/solve` to the real router in-process, with the
//! built-in humanoid loaded. Every answer must be a success or a 4xx with a one-line JSON
//! error: never a 500 (a panic caught by the server) nor a crash, hang or runaway allocation.
#![no_main]

use std::sync::OnceLock;

use axum::Router;
use axum::body::Body;
use axum::http::{Request, header};
use http_body_util::BodyExt;
use libfuzzer_sys::fuzz_target;
use rigfit_server::{AppState, ServerConfig};
use tower::ServiceExt;

static APP: OnceLock<(tokio::runtime::Runtime, Router)> = OnceLock::new();

fn app() -> &'static (tokio::runtime::Runtime, Router) {
    APP.get_or_init(|| {
        let runtime = tokio::runtime::Builder::new_multi_thread()
            .worker_threads(1)
            .enable_all()
            .build()
            .expect("a tokio runtime");
        let state = AppState::new(&ServerConfig::default());
        state.add_humanoid().expect("the humanoid loads");
        (runtime, rigfit_server::router(state))
    })
}

fuzz_target!(|data: &[u8]| {
    let (runtime, router) = app();
    let request = Request::post("/api/characters/c0/solve")
        .header(header::HOST, "127.0.0.1:8717")
        .header(header::CONTENT_TYPE, "application/json")
        .body(Body::from(data.to_vec()))
        .expect("a request");
    let (status, body) = runtime.block_on(async {
        let response = router
            .clone()
            .oneshot(request)
            .await
            .expect("the router answers");
        let status = response.status();
        let body = response
            .into_body()
            .collect()
            .await
            .expect("a body")
            .to_bytes();
        (status, body)
    });
    let text = String::from_utf8_lossy(&body);
    assert!(
        status.is_success() || status.is_client_error(),
        "status {status}: {text}"
    );
    if !status.is_success() {
        let value: serde_json::Value = serde_json::from_slice(&body).expect("a JSON error");
        let line = value["error"].as_str().expect("an error line");
        assert!(!line.contains('\n'), "one line: {line}");
    }
});
