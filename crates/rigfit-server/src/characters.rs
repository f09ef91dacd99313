//! The characters the server holds: rigs read with the command line's readers, kept in
//! memory under ids `c0`, `c1`, ... and described to the page as CHARACTER JSON.

use std::path::Path;
use std::sync::{Arc, PoisonError, RwLock};

use rigfit_core::{JointKind, Pose, Trs};
use rigfit_formats::FormatError;
use rigfit_formats::rig_file::{RigFile, RigFormat, RigOptions, parse_rig};
use serde_json::{Value, json};

/// The most characters one server holds at once (each may be a 64 MiB upload).
pub const MAX_CHARACTERS: usize = 32;

/// One loaded character.
#[derive(Debug)]
pub struct Character {
    /// `c0`, `c1`, ...
    pub id: String,
    /// The file's name without its extension (`humanoid` for the built-in one).
    pub name: String,
    pub format: RigFormat,
    pub rig_file: RigFile,
    /// For each joint of the rig, its node in the display model (`model.glb`).
    pub display_nodes: Vec<usize>,
}

impl Character {
    /// A character from a rig file; `file_name` gives its name.
    pub fn new(id: String, file_name: &Path, format: RigFormat, rig_file: RigFile) -> Self {
        let name = file_name
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .filter(|s| !s.is_empty())
            .unwrap_or_else(|| id.clone());
        let display_nodes = rig_file.display_nodes();
        Self {
            id,
            name,
            format,
            rig_file,
            display_nodes,
        }
    }

    /// The CHARACTER JSON of docs/serve-api.md.
    pub fn to_json(&self) -> Value {
        let rig = &self.rig_file.rig;
        let skeleton = &rig.skeleton;
        let positions = skeleton.joint_positions(&rig.pose);
        let joints: Vec<Value> = skeleton
            .joints()
            .iter()
            .enumerate()
            .map(|(j, joint)| {
                let p = positions[j];
                let mut value = json!({
                    "name": joint.name,
                    "parent": joint.parent,
                    "kind": kind_name(joint.kind),
                    "rest": trs_json(&joint.rest),
                    "pose": trs_json(&rig.pose.local[j]),
                    "position": [p.x, p.y, p.z],
                });
                if let Some(node) = self.display_nodes.get(j) {
                    value["node"] = json!(node);
                }
                value
            })
            .collect();
        json!({
            "id": self.id,
            "name": self.name,
            "format": self.format.extension(),
            "height": rig.height(),
            "joints": joints,
        })
    }

    /// The stored pose: the one the solver starts from by default.
    pub fn stored_pose(&self) -> &Pose {
        &self.rig_file.rig.pose
    }
}

/// `skin`, `helper` or `end_site`.
fn kind_name(kind: JointKind) -> &'static str {
    match kind {
        JointKind::Skin => "skin",
        JointKind::Helper => "helper",
        JointKind::EndSite => "end_site",
    }
}

/// `{"translation": [..], "rotation": [x, y, z, w], "scale": [..]}`.
pub fn trs_json(trs: &Trs) -> Value {
    let t = trs.translation;
    let s = trs.scale;
    json!({
        "translation": [t.x, t.y, t.z],
        "rotation": rigfit_core::animation::quat_to_xyzw(&trs.rotation),
        "scale": [s.x, s.y, s.z],
    })
}

/// Reads an uploaded file with the command line's reader: `file_name`'s extension gives the
/// format, errors name the file.
pub fn read_upload(
    bytes: &[u8],
    file_name: &Path,
    options: &RigOptions,
) -> Result<(RigFormat, RigFile), FormatError> {
    let rig_file = parse_rig(bytes, file_name, options)?;
    // parse_rig refuses any other extension, so the format is known here.
    let format = RigFormat::from_path(file_name).unwrap_or(RigFormat::Glb);
    Ok((format, rig_file))
}

/// Why a character could not be added.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct StoreFull;

/// The characters, shared by every request.
#[derive(Debug, Default)]
pub struct CharacterStore {
    inner: RwLock<StoreInner>,
}

#[derive(Debug, Default)]
struct StoreInner {
    characters: Vec<Arc<Character>>,
    next_id: usize,
}

impl CharacterStore {
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds a character made by `make` from its new id; refuses when the store is full.
    pub fn add(&self, make: impl FnOnce(String) -> Character) -> Result<Arc<Character>, StoreFull> {
        // A panic elsewhere while the lock was held leaves the list itself consistent.
        let mut inner = self.inner.write().unwrap_or_else(PoisonError::into_inner);
        if inner.characters.len() >= MAX_CHARACTERS {
            return Err(StoreFull);
        }
        let id = format!("c{}", inner.next_id);
        inner.next_id += 1;
        let character = Arc::new(make(id));
        inner.characters.push(Arc::clone(&character));
        Ok(character)
    }

    /// The character with this id.
    pub fn get(&self, id: &str) -> Option<Arc<Character>> {
        let inner = self.inner.read().unwrap_or_else(PoisonError::into_inner);
        inner.characters.iter().find(|c| c.id == id).cloned()
    }

    /// Every character, in the order they were added.
    pub fn list(&self) -> Vec<Arc<Character>> {
        let inner = self.inner.read().unwrap_or_else(PoisonError::into_inner);
        inner.characters.clone()
    }

    /// Removes a character; false when there was none with this id. Ids are not reused.
    pub fn remove(&self, id: &str) -> bool {
        let mut inner = self.inner.write().unwrap_or_else(PoisonError::into_inner);
        let before = inner.characters.len();
        inner.characters.retain(|c| c.id != id);
        inner.characters.len() != before
    }
}
