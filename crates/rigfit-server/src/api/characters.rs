//! The character handlers of `/api`: list, get, delete, upload (with its memory
//! reservation), and the `model.glb` the page shows.

use std::collections::HashMap;
use std::path::PathBuf;

use axum::Json;
use axum::extract::rejection::QueryRejection;
use axum::extract::{Path as UrlPath, Query, Request, State};
use axum::http::{HeaderValue, StatusCode, header};
use axum::response::{IntoResponse, Response};
use rigfit_formats::rig_file::{RigFormat, RigOptions, StartFrame};
use serde_json::{Value, json};

use super::{
    UPLOAD_LIMIT, character, check_declared_length, declared_length, discard_body, file_response,
    read_body, run_blocking,
};
use crate::AppState;
use crate::characters::{Character, MAX_CHARACTERS, StoreFull, read_upload};
use crate::error::ApiError;
use crate::guard::{UPLOAD_TYPES, require_content_type};

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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn upload_names_keep_only_the_file_name() {
        assert_eq!(upload_name("../../etc/x.glb"), PathBuf::from("x.glb"));
        assert_eq!(upload_name("C:\\models\\a.bvh"), PathBuf::from("a.bvh"));
        assert_eq!(upload_name(""), PathBuf::from("upload"));
    }
}
