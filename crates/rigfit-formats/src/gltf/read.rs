//! From glTF JSON or GLB bytes to a [`GltfDocument`]: the JSON, its resolved buffers, and
//! the rig of the selected skin.

use base64::Engine as _;
use serde_json::Value;

use super::accessor::required_index;
use super::container::{is_glb, split_glb};
use super::skin::build_rig;
use super::{GltfDocument, LoadUri};
use crate::error::ParseError;

pub(super) fn parse(
    bytes: &[u8],
    load_uri: &mut LoadUri<'_>,
    skin_name: Option<&str>,
) -> Result<GltfDocument, ParseError> {
    let (json_bytes, bin) = if is_glb(bytes) {
        split_glb(bytes)?
    } else {
        (bytes, None)
    };
    // The node count first, by a pass that builds nothing: a JSON tree costs about a
    // kilobyte a node, so a file of millions of nodes is refused before it is built.
    #[derive(serde::Deserialize)]
    struct Shape {
        #[serde(default)]
        nodes: Vec<serde::de::IgnoredAny>,
    }
    if let Ok(shape) = serde_json::from_slice::<Shape>(json_bytes) {
        if shape.nodes.len() > crate::error::MAX_JOINTS {
            return Err(ParseError::new(
                "nodes",
                format!(
                    "{} nodes is too many (rigfit reads glTF files of at most {} nodes)",
                    shape.nodes.len(),
                    crate::error::MAX_JOINTS
                ),
            ));
        }
    }
    let json: Value = serde_json::from_slice(json_bytes).map_err(|e| {
        ParseError::new(
            format!("JSON line {} column {}", e.line(), e.column()),
            format!("invalid JSON: {e}"),
        )
    })?;
    if !json.is_object() {
        return Err(ParseError::new("JSON", "the top level is not an object"));
    }
    let version = json
        .pointer("/asset/version")
        .and_then(Value::as_str)
        .unwrap_or("");
    if !version.starts_with('2') {
        return Err(ParseError::new(
            "asset.version",
            format!("glTF version '{version}' is not supported (only 2.x)"),
        ));
    }
    let buffers = resolve_buffers(&json, bin, load_uri)?;
    let mut doc = GltfDocument {
        json,
        buffers,
        rig: None,
        joint_nodes: Vec::new(),
        skin: None,
        source_dir: None,
        external_files: Vec::new(),
    };
    let skins = doc
        .json
        .get("skins")
        .and_then(Value::as_array)
        .map_or(0, Vec::len);
    let skin = match skin_name {
        Some(name) => Some(
            (0..skins)
                .find(|&i| doc.json["skins"][i].get("name").and_then(Value::as_str) == Some(name))
                .ok_or_else(|| ParseError::new("skins", format!("no skin named '{name}'")))?,
        ),
        None => (skins > 0).then_some(0),
    };
    if let Some(skin) = skin {
        let (rig, joint_nodes) = build_rig(&doc.json, &doc.buffers, skin)?;
        doc.rig = Some(rig);
        doc.joint_nodes = joint_nodes;
        doc.skin = Some(skin);
    }
    Ok(doc)
}

fn resolve_buffers(
    json: &Value,
    bin: Option<&[u8]>,
    load_uri: &mut LoadUri<'_>,
) -> Result<Vec<Vec<u8>>, ParseError> {
    let Some(buffers) = json.get("buffers").and_then(Value::as_array) else {
        return Ok(Vec::new());
    };
    let mut out = Vec::with_capacity(buffers.len());
    for (i, b) in buffers.iter().enumerate() {
        let path = format!("buffers[{i}]");
        let length = required_index(b, "byteLength", &path)?;
        let data = match b.get("uri").and_then(Value::as_str) {
            None => match (i, bin) {
                (0, Some(bin)) => bin.to_vec(),
                _ => {
                    return Err(ParseError::new(
                        &path,
                        "has no uri and there is no GLB binary chunk",
                    ));
                }
            },
            Some(uri) if uri.starts_with("data:") => {
                let comma = uri
                    .find(',')
                    .ok_or_else(|| ParseError::new(&path, "data URI has no ','"))?;
                if !uri[..comma].ends_with(";base64") {
                    return Err(ParseError::new(
                        &path,
                        "only base64 data URIs are supported",
                    ));
                }
                base64::engine::general_purpose::STANDARD
                    .decode(uri[comma + 1..].trim())
                    .map_err(|e| ParseError::new(&path, format!("bad base64 data: {e}")))?
            }
            Some(uri) => load_uri(uri, length).map_err(|e| ParseError::new(&path, e))?,
        };
        if data.len() < length {
            return Err(ParseError::new(
                &path,
                format!(
                    "byteLength is {length} but only {} bytes are there (truncated?)",
                    data.len()
                ),
            ));
        }
        out.push(data);
    }
    Ok(out)
}
