//! The fuzz corpus of solve requests (fuzz/seeds/solve_request: seeds, the hardening
//! issue's hostile examples and the minimised findings of scripts/fuzz.sh) replayed against
//! the router in-process, as the `solve_request` fuzz target sends them: every answer is a
//! success or a 4xx with a one-line JSON error, and the server answers afterwards.

mod common;

use std::path::PathBuf;

use axum::body::Body;
use axum::http::{Request, header};
use common::{app, assert_still_serving, send};

#[tokio::test]
async fn every_solve_request_in_the_corpus_is_answered_without_a_server_error() {
    let dir = PathBuf::from(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../fuzz/seeds/solve_request"
    ));
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|entry| entry.expect("a directory entry").path())
        .collect();
    files.sort();
    assert!(files.len() >= 6, "the corpus is there: {files:?}");
    let (_, router) = app();
    for file in files {
        let body = std::fs::read(&file).expect("a corpus file");
        let request = Request::post("/api/characters/c0/solve")
            .header(header::HOST, "127.0.0.1:8717")
            .header(header::CONTENT_TYPE, "application/json")
            .body(Body::from(body))
            .expect("a request");
        let answer = send(&router, request).await;
        let text = String::from_utf8_lossy(&answer.body).into_owned();
        assert!(
            answer.status.is_success() || answer.status.is_client_error(),
            "{}: {} {text}",
            file.display(),
            answer.status
        );
        if !answer.status.is_success() {
            let line = answer.json()["error"]
                .as_str()
                .map(str::to_owned)
                .unwrap_or_default();
            assert!(
                !line.is_empty() && !line.contains('\n'),
                "{}: {text}",
                file.display()
            );
        }
        assert_still_serving(&router).await;
    }
}
