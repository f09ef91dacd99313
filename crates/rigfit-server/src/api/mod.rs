//! The `/api` handlers of docs/serve-api.md: characters (list, upload, get, delete,
//! `model.glb`), solve and export. Readers, solver and writers run on the blocking pool,
//! at most one job per core at a time, never on the async runtime.
//!
//! This module holds what the handlers share: the request limits, reading a body, running
//! a job on the blocking pool, finding a character, and file and bad-body answers.

mod characters;
mod export;
mod solve;

use std::sync::Arc;

use axum::body::{Body, Bytes};
use axum::extract::Request;
use axum::http::{HeaderMap, HeaderValue, StatusCode, header};
use axum::response::{IntoResponse, Response};
use http_body_util::{BodyExt, LengthLimitError, Limited};
use rigfit_formats::ParseError;

use crate::AppState;
use crate::characters::Character;
use crate::error::ApiError;

pub use characters::{
    delete_character, get_character, list_characters, model_glb, upload_character,
};
pub use export::export;
pub use solve::solve;

/// The largest upload (a rig file).
pub const UPLOAD_LIMIT: usize = 64 << 20;
/// The largest body of any other request.
pub const REQUEST_LIMIT: usize = 4 << 20;
/// The last frame an export may key (about 14 minutes at 24 frames per second), so a BVH's
/// frame count stays in proportion to the request.
pub const MAX_EXPORT_FRAME: u64 = 20_000;
/// The most keys one export request may hold.
pub const MAX_EXPORT_KEYS: usize = 1_000;

/// The length a request declares (`Content-Length`), if any.
fn declared_length(request: &Request) -> Option<u64> {
    request
        .headers()
        .get(header::CONTENT_LENGTH)
        .and_then(|v| v.to_str().ok())
        .and_then(|v| v.parse::<u64>().ok())
}

/// 413 when the request declares a body over `limit` bytes.
fn check_declared_length(request: &Request, limit: usize) -> Result<(), ApiError> {
    if declared_length(request).is_some_and(|n| n > limit as u64) {
        return Err(too_large(limit));
    }
    Ok(())
}

fn too_large(limit: usize) -> ApiError {
    ApiError::new(
        StatusCode::PAYLOAD_TOO_LARGE,
        format!(
            "request body too large (the limit is {} MiB for this request)",
            limit >> 20
        ),
    )
}

/// Reads a request body of at most `limit` bytes within the server's body timeout: 413 when
/// the declared or actual length is over it (checked before reading when the length is
/// declared), 408 when the body does not arrive in time.
async fn read_body(state: &AppState, request: Request, limit: usize) -> Result<Bytes, ApiError> {
    check_declared_length(&request, limit)?;
    let timeout = state.config().body_timeout;
    let collect = Limited::new(request.into_body(), limit).collect();
    match tokio::time::timeout(timeout, collect).await {
        Err(_) => Err(ApiError::new(
            StatusCode::REQUEST_TIMEOUT,
            format!(
                "the request body did not arrive within {} s",
                timeout.as_secs_f64()
            ),
        )),
        Ok(Ok(collected)) => Ok(collected.to_bytes()),
        Ok(Err(e)) if e.downcast_ref::<LengthLimitError>().is_some() => Err(too_large(limit)),
        Ok(Err(e)) => Err(ApiError::bad_request(format!(
            "could not read the request body: {e}"
        ))),
    }
}

/// Reads a refused request's body to its end without keeping it (at most the upload limit,
/// within the body timeout).
async fn discard_body(state: &AppState, request: Request) {
    let mut body = Limited::new(request.into_body(), UPLOAD_LIMIT);
    let drain = async { while let Some(Ok(_)) = body.frame().await {} };
    let _ = tokio::time::timeout(state.config().body_timeout, drain).await;
}

/// Runs `job` on the blocking pool once a worker slot is free (one per core, so solves queue
/// instead of all slowing down); a panic in it becomes a 500. The slot is held by the job
/// itself: when the request is dropped (its client gone), the slot frees only once the job
/// has stopped, so `AppState::busy_workers` counts what really runs.
async fn run_blocking<T: Send + 'static>(
    state: &AppState,
    job: impl FnOnce() -> T + Send + 'static,
) -> Result<T, ApiError> {
    let slot = Arc::clone(&state.workers)
        .acquire_owned()
        .await
        .map_err(|_| ApiError::internal("the server is shutting down"))?;
    tokio::task::spawn_blocking(move || {
        let _slot = slot;
        job()
    })
    .await
    .map_err(|e| {
        if e.is_panic() {
            crate::error::panic_error(e.into_panic().as_ref())
        } else {
            ApiError::internal("the job was cancelled")
        }
    })
}

/// The character with this id, or 404.
fn character(state: &AppState, id: &str) -> Result<Arc<Character>, ApiError> {
    state
        .characters
        .get(id)
        .ok_or_else(|| ApiError::not_found(format!("{id}: no such character")))
}

/// A file answer: its bytes, type, and a download name.
fn file_response(bytes: Vec<u8>, content_type: &'static str, download: Option<&str>) -> Response {
    let mut headers = HeaderMap::new();
    headers.insert(header::CONTENT_TYPE, HeaderValue::from_static(content_type));
    headers.insert(header::CACHE_CONTROL, HeaderValue::from_static("no-store"));
    if let Some(name) = download {
        if let Ok(v) = HeaderValue::from_str(&format!("attachment; filename=\"{name}\"")) {
            headers.insert(header::CONTENT_DISPOSITION, v);
        }
    }
    (headers, Body::from(bytes)).into_response()
}

/// A request-body problem: 400 with `what: PLACE: PROBLEM`.
fn bad_body(what: &str, e: &ParseError) -> ApiError {
    ApiError::bad_request(format!("{what}: {e}"))
}
