//! The `/api` handlers of docs/serve-api.md: characters (list, upload, get, delete,
//! `model.glb`), solve and export. Readers, solver and writers run on the blocking pool,
//! at most one job per core at a time, never on the async runtime.

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

use axum::Json;
use axum::body::{Body, Bytes};
use axum::extract::rejection::QueryRejection;
use axum::extract::{Path as UrlPath, Query, Request, State};
use axum::http::{HeaderMap, HeaderValue, StatusCode, header};
use axum::response::{IntoResponse, Response};
use http_body_util::{BodyExt, LengthLimitError, Limited};
use rigfit_core::JointDof;
use rigfit_core::interrupt::Interrupt;
use rigfit_core::pose::{PoseError, PoseOptions, PoseProblem, solve_pose_interruptible};
use rigfit_formats::ParseError;
use rigfit_formats::json::parse_json;
use rigfit_formats::report::pose_report;
use rigfit_formats::rig_file::{RigFormat, RigOptions, StartFrame};
use rigfit_formats::strokes::strokes_from_json;
use serde_json::{Value, json};

use crate::AppState;
use crate::characters::{Character, MAX_CHARACTERS, StoreFull, read_upload};
use crate::error::ApiError;
use crate::guard::{JSON_TYPES, UPLOAD_TYPES, require_content_type};
use crate::request::{self, Limits};

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

/// Sets its flag when dropped: a request whose future is dropped before it finished (the
/// client closed the connection, or the server is shutting down) cancels its solve.
#[derive(Debug)]
struct CancelOnDrop(Arc<AtomicBool>);

impl Drop for CancelOnDrop {
    fn drop(&mut self) {
        self.0.store(true, Ordering::Relaxed);
    }
}

/// The character with this id, or 404.
fn character(state: &AppState, id: &str) -> Result<Arc<Character>, ApiError> {
    state
        .characters
        .get(id)
        .ok_or_else(|| ApiError::not_found(format!("{id}: no such character")))
}

/// `GET /api/characters`: every character, and the memory they take (estimated) of the
/// server's budget.
pub async fn list_characters(State(state): State<AppState>) -> Json<Value> {
    let characters: Vec<Value> = state
        .characters
        .list()
        .iter()
        .map(|c| c.to_json())
        .collect();
    let store = &state.characters;
    Json(json!({
        "characters": characters,
        "memory": { "bytes": store.stored_bytes(), "budget": store.budget() },
    }))
}

/// `GET /api/characters/{id}`.
pub async fn get_character(
    State(state): State<AppState>,
    UrlPath(id): UrlPath<String>,
) -> Result<Json<Value>, ApiError> {
    Ok(Json(character(&state, &id)?.to_json()))
}

/// `DELETE /api/characters/{id}`: forgets a character (204).
pub async fn delete_character(
    State(state): State<AppState>,
    UrlPath(id): UrlPath<String>,
) -> Result<StatusCode, ApiError> {
    if state.characters.remove(&id) {
        Ok(StatusCode::NO_CONTENT)
    } else {
        Err(ApiError::not_found(format!("{id}: no such character")))
    }
}

/// The last part of an uploaded file's name (a name is only ever used in messages and to
/// pick the reader).
fn upload_name(name: &str) -> PathBuf {
    let base = name.rsplit(['/', '\\']).next().unwrap_or(name).trim();
    PathBuf::from(if base.is_empty() { "upload" } else { base })
}

/// `POST /api/characters?name=FILE.glb[&skin=NAME][&start_frame=K|rest]`: reads the body
/// with the command line's reader; 201 and the new CHARACTER.
pub async fn upload_character(
    State(state): State<AppState>,
    query: Result<Query<HashMap<String, String>>, QueryRejection>,
    request: Request,
) -> Result<Response, ApiError> {
    let Query(query) = query.map_err(|e| ApiError::bad_request(format!("query: {e}")))?;
    let Some(name) = query.get("name") else {
        return Err(ApiError::bad_request(
            "name: missing (upload to /api/characters?name=FILE.glb)",
        ));
    };
    let file_name = upload_name(name);
    let Some(format) = RigFormat::from_path(&file_name) else {
        let error = rigfit_formats::FormatError::Unsupported {
            path: file_name,
            expected: "a rig: .glb, .gltf or .bvh".into(),
        };
        return Err(ApiError::from_format(&error));
    };
    let start_frame = match query.get("start_frame").map(String::as_str) {
        None => StartFrame::First,
        Some("rest") => StartFrame::Rest,
        Some(k) => StartFrame::Frame(k.parse().map_err(|_| {
            ApiError::bad_request(format!(
                "start_frame: expected a frame number or 'rest', got '{k}'"
            ))
        })?),
    };
    let options = RigOptions {
        skin: query.get("skin").cloned(),
        start_frame,
    };
    require_content_type(request.headers(), "upload", UPLOAD_TYPES)?;
    check_declared_length(&request, UPLOAD_LIMIT)?;
    // The upload's share of the memory budget is held while it is read and parsed: what the
    // reader may take at its peak for the declared length (the upload limit itself while an
    // undeclared body is read), then for the actual length.
    let factor = crate::memory::parse_factor(format);
    let reading = declared_length(&request).map_or(UPLOAD_LIMIT, |n| {
        usize::try_from(n).map_or(usize::MAX, |n| n.saturating_mul(factor))
    });
    let mut held = match state.characters.reserve(reading) {
        Ok(held) => held,
        Err(why) => {
            // Read (and drop) the body first, so that a browser sees the answer rather than
            // a connection closed while it sends.
            discard_body(&state, request).await;
            return Err(store_full(why));
        }
    };
    let bytes = read_body(&state, request, UPLOAD_LIMIT).await?;
    held.resize(bytes.len().saturating_mul(factor))
        .map_err(store_full)?;
    let parse_name = file_name.clone();
    let (_, rig_file) = run_blocking(&state, move || read_upload(&bytes, &parse_name, &options))
        .await?
        .map_err(|e| ApiError::from_format(&e))?;
    let size = crate::memory::rig_file_bytes(&rig_file);
    let added = state
        .characters
        .add_within_budget(
            held,
            |id| Character::new(id, &file_name, format, rig_file),
            size,
        )
        .map_err(store_full)?;
    let mut response = (StatusCode::CREATED, Json(added.to_json())).into_response();
    if let Ok(location) = HeaderValue::from_str(&format!("/api/characters/{}", added.id)) {
        response.headers_mut().insert(header::LOCATION, location);
    }
    Ok(response)
}

/// 409 when the store holds its most characters, 507 when the upload does not fit in the
/// memory budget.
fn store_full(why: StoreFull) -> ApiError {
    const MIB: usize = 1 << 20;
    match why {
        StoreFull::Count => ApiError::new(
            StatusCode::CONFLICT,
            format!(
                "the server holds {MAX_CHARACTERS} characters, the most it keeps: delete one first (DELETE /api/characters/ID)"
            ),
        ),
        StoreFull::Memory {
            needed,
            used,
            budget,
        } => ApiError::new(
            StatusCode::INSUFFICIENT_STORAGE,
            format!(
                "the upload needs about {} MiB of memory and the server's characters may take {} MiB ({} MiB in use): delete a character first (DELETE /api/characters/ID)",
                needed.div_ceil(MIB),
                budget / MIB,
                used.div_ceil(MIB)
            ),
        ),
    }
}

/// `GET /api/characters/{id}/model.glb`: the GLB the page shows.
pub async fn model_glb(
    State(state): State<AppState>,
    UrlPath(id): UrlPath<String>,
) -> Result<Response, ApiError> {
    let found = character(&state, &id)?;
    let bytes = run_blocking(&state, move || found.rig_file.display_glb()).await?;
    Ok(file_response(bytes, "model/gltf-binary", None))
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

/// `POST /api/characters/{id}/solve`: poses the character from strokes. The solve stops
/// when the client goes (the request is dropped) or at the server's solve timeout (503).
pub async fn solve(
    State(state): State<AppState>,
    UrlPath(id): UrlPath<String>,
    request: Request,
) -> Result<Json<Value>, ApiError> {
    require_content_type(request.headers(), "solve request", JSON_TYPES)?;
    let found = character(&state, &id)?;
    let body = read_body(&state, request, REQUEST_LIMIT).await?;
    let cancelled = Arc::new(AtomicBool::new(false));
    let _cancel_on_drop = CancelOnDrop(Arc::clone(&cancelled));
    let timeout = state.config().solve_timeout;
    run_blocking(&state, move || {
        // The deadline runs from when the solve starts (not while it queues).
        let interrupt = Interrupt::never()
            .with_flag(cancelled)
            .with_deadline(Instant::now() + timeout);
        solve_request(&found, &body, &interrupt, timeout)
    })
    .await?
    .map(Json)
}

/// Parses and solves one solve request (on the blocking pool) until `interrupt`.
fn solve_request(
    character: &Character,
    body: &[u8],
    interrupt: &Interrupt,
    timeout: std::time::Duration,
) -> Result<Value, ApiError> {
    const WHAT: &str = "solve request";
    let rig = &character.rig_file.rig;
    let limits = Limits::for_rig(rig);
    let doc = parse_json(body).map_err(|e| bad_body(WHAT, &e))?;
    let obj = request::object(&doc).map_err(|e| bad_body(WHAT, &e))?;
    request::check_strokes(&doc, &limits).map_err(|e| bad_body(WHAT, &e))?;
    // An empty list is well-formed: the solver refuses it (422), as it does in the CLI.
    let strokes = match obj.get("strokes") {
        Some(Value::Array(list)) if list.is_empty() => Vec::new(),
        _ => strokes_from_json(&doc).map_err(|e| bad_body(WHAT, &e))?,
    };
    let posed_by_request = request::optional(obj, "pose").is_some();
    let start = match request::optional(obj, "pose") {
        None => rig.pose.clone(),
        Some(p) => request::pose("pose", p, &rig.skeleton, &rig.pose, &limits)
            .map_err(|e| bad_body(WHAT, &e))?,
    };
    let movable = request::optional(obj, "bones")
        .map(|b| request::names("bones", b, &limits))
        .transpose()
        .map_err(|e| bad_body(WHAT, &e))?;
    let options = match request::optional(obj, "method") {
        None => PoseOptions::default(),
        Some(m) => match request::word("method", m, &["rigfit", "paper"]) {
            Ok("paper") => PoseOptions::paper(),
            Ok(_) => PoseOptions::default(),
            Err(e) => return Err(bad_body(WHAT, &e)),
        },
    };
    let root = match request::optional(obj, "root") {
        None => RootMotion::Free,
        Some(r) => match request::word("root", r, &["free", "rotate", "fixed"]) {
            Ok("rotate") => RootMotion::Rotate,
            Ok("fixed") => RootMotion::Fixed,
            Ok(_) => RootMotion::Free,
            Err(e) => return Err(bad_body(WHAT, &e)),
        },
    };
    let restricted;
    let skeleton = match root {
        RootMotion::Free => &rig.skeleton,
        RootMotion::Rotate => {
            restricted = restrict_roots(&rig.skeleton, JointDof::Ball);
            &restricted
        }
        RootMotion::Fixed => {
            restricted = restrict_roots(&rig.skeleton, JointDof::Fixed);
            &restricted
        }
    };
    let problem = PoseProblem {
        skeleton,
        start: &start,
        strokes: &strokes,
        movable: movable.as_deref(),
        height: rig.height(),
    };
    let t0 = Instant::now();
    let result = solve_pose_interruptible(&problem, &options, interrupt).map_err(|e| match e {
        // Stopped: at the deadline (a cancelled request has nobody to answer).
        PoseError::Interrupted => ApiError::new(
            StatusCode::SERVICE_UNAVAILABLE,
            format!(
                "{WHAT}: the solve took longer than {} s, the server's limit (send fewer or shorter strokes)",
                timeout.as_secs_f64()
            ),
        ),
        // A pose the request sent that leaves no bone of any length is the request's.
        PoseError::NoBones if posed_by_request => {
            ApiError::unprocessable(format!("{WHAT}: pose: {e}"))
        }
        // As the command line: problems of the rig name the rig's file.
        e if e.is_rig_problem() => {
            ApiError::unprocessable(format!("{}: {e}", character.rig_file.path.display()))
        }
        _ => ApiError::unprocessable(format!("{WHAT}: {e}")),
    })?;
    let seconds = t0.elapsed().as_secs_f64();
    let mut report = pose_report(
        rig,
        &result.pose,
        &result.stroke_bones,
        result.iterations,
        result.energy,
        seconds,
    );
    report["joints"] = Value::Array(answer_joints(rig, &result.pose));
    Ok(report)
}

/// What a solve may do with the character's root joints (the joints free to move and turn:
/// the skin root, or every root of a forest).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum RootMotion {
    /// Move and turn (the solver's default).
    Free,
    /// Turn in place: the roots keep their translation.
    Rotate,
    /// Keep their transform.
    Fixed,
}

/// The skeleton with its free (root) joints given `dof` instead: `Ball` turns them in place,
/// `Fixed` keeps them as they start. (The solver's rigid multi-start only moves a free root.)
fn restrict_roots(skeleton: &rigfit_core::Skeleton, dof: JointDof) -> rigfit_core::Skeleton {
    let mut restricted = skeleton.clone();
    for j in 0..restricted.len() {
        let joint = restricted.joint(j);
        if joint.dof == JointDof::Free {
            let limits = joint.limits;
            restricted.set_dof(j, dof, limits);
        }
    }
    restricted
}

/// The solve answer's joints: every joint of the CHARACTER in its order (helpers included),
/// each with its `index` there, its parent's name, world position, and local rotation and
/// translation (a pose the page can send back as the next request's start); BVH End Sites
/// with `"end_site": true` as in the command line's report.
fn answer_joints(rig: &rigfit_core::Rig, pose: &rigfit_core::Pose) -> Vec<Value> {
    let skeleton = &rig.skeleton;
    let positions = skeleton.joint_positions(pose);
    skeleton
        .joints()
        .iter()
        .enumerate()
        .map(|(j, joint)| {
            let p = positions[j];
            let local = &pose.local[j];
            let t = local.translation;
            let mut value = json!({
                "index": j,
                "name": joint.name,
                "parent": joint.parent.map(|q| skeleton.joint(q).name.clone()),
                "position": [p.x, p.y, p.z],
                "rotation": rigfit_core::animation::quat_to_xyzw(&local.rotation),
                "translation": [t.x, t.y, t.z],
            });
            if joint.kind == rigfit_core::JointKind::EndSite {
                value["end_site"] = json!(true);
            }
            value
        })
        .collect()
}

/// `POST /api/characters/{id}/export`: the character's file with a pose and keys.
pub async fn export(
    State(state): State<AppState>,
    UrlPath(id): UrlPath<String>,
    request: Request,
) -> Result<Response, ApiError> {
    require_content_type(request.headers(), "export request", JSON_TYPES)?;
    let found = character(&state, &id)?;
    let body = read_body(&state, request, REQUEST_LIMIT).await?;
    let (bytes, format, file_name) =
        run_blocking(&state, move || export_request(&found, &body)).await??;
    let content_type = match format {
        RigFormat::Glb => "model/gltf-binary",
        RigFormat::Gltf => "model/gltf+json",
        RigFormat::Bvh => "text/plain; charset=utf-8",
    };
    Ok(file_response(bytes, content_type, Some(&file_name)))
}

/// A download name from a character's name: letters, digits, `.`, `_` and `-` kept, anything
/// else `_` (the name goes into a header).
fn download_name(name: &str, format: RigFormat) -> String {
    let stem: String = name
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || matches!(c, '.' | '_' | '-') {
                c
            } else {
                '_'
            }
        })
        .collect();
    let stem = stem.trim_start_matches('.');
    let stem = if stem.is_empty() { "character" } else { stem };
    format!("{stem}.{}", format.extension())
}

/// Parses one export request and writes the file (on the blocking pool).
fn export_request(
    character: &Character,
    body: &[u8],
) -> Result<(Vec<u8>, RigFormat, String), ApiError> {
    const WHAT: &str = "export request";
    let rig = &character.rig_file.rig;
    let bad = |e: ParseError| bad_body(WHAT, &e);
    let limits = Limits::for_rig(rig);
    let doc = parse_json(body).map_err(bad)?;
    let obj = request::object(&doc).map_err(bad)?;
    let format = match request::optional(obj, "format") {
        None => RigFormat::Glb,
        Some(f) => match request::word("format", f, &["glb", "gltf", "bvh"]).map_err(bad)? {
            "gltf" => RigFormat::Gltf,
            "bvh" => RigFormat::Bvh,
            _ => RigFormat::Glb,
        },
    };
    let fps = request::optional(obj, "fps")
        .map(|f| request::positive_number("fps", f))
        .transpose()
        .map_err(bad)?
        .unwrap_or(rigfit_formats::gltf::FRAMES_PER_SECOND);
    let pose = match request::optional(obj, "pose") {
        None => rig.pose.clone(),
        Some(p) => request::pose("pose", p, &rig.skeleton, &rig.pose, &limits).map_err(bad)?,
    };
    let mut keys: Vec<(usize, rigfit_core::Pose)> = Vec::new();
    if let Some(list) = request::optional(obj, "keys") {
        let list = list
            .as_array()
            .ok_or_else(|| ParseError::new("keys", "expected a list of keys"))
            .map_err(bad)?;
        if list.len() > MAX_EXPORT_KEYS {
            return Err(bad(ParseError::new(
                "keys",
                format!(
                    "{} keys: an export may hold at most {MAX_EXPORT_KEYS}",
                    list.len()
                ),
            )));
        }
        for (i, key) in list.iter().enumerate() {
            let here = format!("keys[{i}]");
            let fields = key
                .as_object()
                .ok_or_else(|| {
                    ParseError::new(&here, "expected an object with \"frame\" and \"pose\"")
                })
                .map_err(bad)?;
            let frame_value = fields
                .get("frame")
                .ok_or_else(|| ParseError::new(&here, "missing \"frame\""))
                .map_err(bad)?;
            let frame =
                request::whole_number(&format!("{here}.frame"), frame_value).map_err(bad)?;
            if frame > MAX_EXPORT_FRAME {
                return Err(bad(ParseError::new(
                    format!("{here}.frame"),
                    format!(
                        "{frame} is past the last frame an export may key ({MAX_EXPORT_FRAME})"
                    ),
                )));
            }
            let key_pose = match request::optional(fields, "pose") {
                None => pose.clone(),
                Some(p) => request::pose(
                    &format!("{here}.pose"),
                    p,
                    &rig.skeleton,
                    &rig.pose,
                    &limits,
                )
                .map_err(bad)?,
            };
            keys.push((frame as usize, key_pose));
        }
    }
    // Sorted by frame; of two keys at one frame the later in the list wins.
    keys.reverse();
    keys.sort_by_key(|(frame, _)| *frame);
    keys.dedup_by_key(|(frame, _)| *frame);
    let file_name = download_name(&character.name, format);
    let bytes = character
        .rig_file
        .keyed_bytes(format, Path::new(&file_name), &pose, &keys, fps)
        .map_err(|e| ApiError::from_format(&e))?;
    Ok((bytes, format, file_name))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn upload_names_keep_only_the_file_name() {
        assert_eq!(upload_name("../../etc/x.glb"), PathBuf::from("x.glb"));
        assert_eq!(upload_name("C:\\models\\a.bvh"), PathBuf::from("a.bvh"));
        assert_eq!(upload_name(""), PathBuf::from("upload"));
    }

    #[test]
    fn download_names_are_header_safe() {
        assert_eq!(
            download_name("BCN_Epileptic", RigFormat::Glb),
            "BCN_Epileptic.glb"
        );
        assert_eq!(download_name("a \"b\"\r\n", RigFormat::Bvh), "a__b___.bvh");
        assert_eq!(download_name("..", RigFormat::Gltf), "character.gltf");
    }
}
