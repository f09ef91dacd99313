//! The export handler of `/api`: an export request (format, fps, pose, keys) parsed and
//! the character's file written with them, answered as a download.

use std::path::Path;

use axum::extract::{Path as UrlPath, Request, State};
use axum::response::Response;
use rigfit_formats::ParseError;
use rigfit_formats::json::parse_json;
use rigfit_formats::rig_file::RigFormat;

use super::{
    MAX_EXPORT_FRAME, MAX_EXPORT_KEYS, REQUEST_LIMIT, bad_body, character, file_response,
    read_body, run_blocking,
};
use crate::AppState;
use crate::characters::Character;
use crate::error::ApiError;
use crate::guard::{JSON_TYPES, require_content_type};
use crate::request::{self, Limits};

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
    fn download_names_are_header_safe() {
        assert_eq!(
            download_name("BCN_Epileptic", RigFormat::Glb),
            "BCN_Epileptic.glb"
        );
        assert_eq!(download_name("a \"b\"\r\n", RigFormat::Bvh), "a__b___.bvh");
        assert_eq!(download_name("..", RigFormat::Gltf), "character.gltf");
    }
}
