//! The characters the server holds: rigs read with the command line's readers, kept in
//! memory under ids `c0`, `c1`, ... and described to the page as CHARACTER JSON.

use std::path::Path;
use std::sync::{Arc, PoisonError, RwLock};

use rigfit_core::joint_model;
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
    /// The skeleton a solve poses, as `rigfit pose` does: the rig's, with the ranges its
    /// clips show choosing among poses that explain the strokes alike.
    pub posing_skeleton: rigfit_core::Skeleton,
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
        let rig = &rig_file.rig;
        let posing_skeleton = joint_model::with_clip_ranges(&rig.skeleton, &rig.animations);
        Self {
            id,
            name,
            format,
            rig_file,
            display_nodes,
            posing_skeleton,
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
        JointKind::EndSite | JointKind::SkinTip => "end_site",
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
pub enum StoreFull {
    /// The store holds [`MAX_CHARACTERS`] characters.
    Count,
    /// The character (or the upload being read) would take the store past its memory
    /// budget: `needed` bytes more while `used` of `budget` are taken.
    Memory {
        needed: usize,
        used: usize,
        budget: usize,
    },
}

/// The characters, shared by every request, within a count and a memory budget.
#[derive(Debug)]
pub struct CharacterStore {
    inner: RwLock<StoreInner>,
    budget: usize,
}

impl Default for CharacterStore {
    fn default() -> Self {
        Self::with_budget(crate::DEFAULT_MEMORY_BUDGET)
    }
}

#[derive(Debug, Default)]
struct StoreInner {
    /// Each character with its estimated size in bytes.
    characters: Vec<(Arc<Character>, usize)>,
    next_id: usize,
    /// The bytes of the stored characters.
    stored_bytes: usize,
    /// The bytes reserved by uploads being read.
    reserved_bytes: usize,
}

impl StoreInner {
    fn used(&self) -> usize {
        self.stored_bytes + self.reserved_bytes
    }
}

/// Memory of the budget held for an upload being read; given back when dropped.
#[derive(Debug)]
pub struct Reservation<'a> {
    store: &'a CharacterStore,
    bytes: usize,
}

impl Drop for Reservation<'_> {
    fn drop(&mut self) {
        let mut inner = self.store.write();
        inner.reserved_bytes = inner.reserved_bytes.saturating_sub(self.bytes);
    }
}

impl Reservation<'_> {
    /// The bytes held.
    pub fn bytes(&self) -> usize {
        self.bytes
    }

    /// Holds `bytes` instead: less always succeeds; more only if it fits in the budget beside
    /// the stored characters and the other reservations (else the reservation is unchanged).
    pub fn resize(&mut self, bytes: usize) -> Result<(), StoreFull> {
        let mut inner = self.store.write();
        let others = inner.used().saturating_sub(self.bytes);
        if bytes > self.bytes {
            self.store.room_for(others, bytes)?;
        }
        inner.reserved_bytes = others.saturating_sub(inner.stored_bytes) + bytes;
        self.bytes = bytes;
        Ok(())
    }
}

impl CharacterStore {
    pub fn new() -> Self {
        Self::default()
    }

    /// An empty store whose characters may take `budget` bytes.
    pub fn with_budget(budget: usize) -> Self {
        Self {
            inner: RwLock::new(StoreInner::default()),
            budget,
        }
    }

    // A panic elsewhere while the lock was held leaves the list itself consistent.
    fn write(&self) -> std::sync::RwLockWriteGuard<'_, StoreInner> {
        self.inner.write().unwrap_or_else(PoisonError::into_inner)
    }

    fn read(&self) -> std::sync::RwLockReadGuard<'_, StoreInner> {
        self.inner.read().unwrap_or_else(PoisonError::into_inner)
    }

    /// Whether `bytes` more fit in the budget beside `used` bytes already taken.
    fn room_for(&self, used: usize, bytes: usize) -> Result<(), StoreFull> {
        if used.saturating_add(bytes) > self.budget {
            return Err(StoreFull::Memory {
                needed: bytes,
                used,
                budget: self.budget,
            });
        }
        Ok(())
    }

    /// The memory budget, in bytes.
    pub fn budget(&self) -> usize {
        self.budget
    }

    /// The estimated bytes of the stored characters (reservations not counted).
    pub fn stored_bytes(&self) -> usize {
        self.read().stored_bytes
    }

    /// Holds `bytes` of the budget for an upload being read; refused when the stored
    /// characters and the other uploads leave less, or when the store is full by count.
    pub fn reserve(&self, bytes: usize) -> Result<Reservation<'_>, StoreFull> {
        let mut inner = self.write();
        if inner.characters.len() >= MAX_CHARACTERS {
            return Err(StoreFull::Count);
        }
        self.room_for(inner.used(), bytes)?;
        inner.reserved_bytes += bytes;
        Ok(Reservation { store: self, bytes })
    }

    /// Adds a character made by `make` from its new id, taking `bytes` of the budget;
    /// refuses when the store is full by count (the budget is not checked: see
    /// [`Self::add_within_budget`]).
    pub fn add(
        &self,
        make: impl FnOnce(String) -> Character,
        bytes: usize,
    ) -> Result<Arc<Character>, StoreFull> {
        self.insert(make, bytes, None)
    }

    /// As [`Self::add`], for an upload read under `reservation` (given back): refused when
    /// `bytes` does not fit in the budget beside the stored characters and the other
    /// uploads' reservations.
    pub fn add_within_budget(
        &self,
        reservation: Reservation<'_>,
        make: impl FnOnce(String) -> Character,
        bytes: usize,
    ) -> Result<Arc<Character>, StoreFull> {
        let held = reservation.bytes;
        let result = self.insert(make, bytes, Some(held));
        drop(reservation);
        result
    }

    fn insert(
        &self,
        make: impl FnOnce(String) -> Character,
        bytes: usize,
        reserved: Option<usize>,
    ) -> Result<Arc<Character>, StoreFull> {
        let mut inner = self.write();
        if inner.characters.len() >= MAX_CHARACTERS {
            return Err(StoreFull::Count);
        }
        if let Some(held) = reserved {
            self.room_for(inner.used().saturating_sub(held), bytes)?;
        }
        let id = format!("c{}", inner.next_id);
        inner.next_id += 1;
        let character = Arc::new(make(id));
        inner.characters.push((Arc::clone(&character), bytes));
        inner.stored_bytes += bytes;
        Ok(character)
    }

    /// The character with this id.
    pub fn get(&self, id: &str) -> Option<Arc<Character>> {
        self.read()
            .characters
            .iter()
            .find(|(c, _)| c.id == id)
            .map(|(c, _)| Arc::clone(c))
    }

    /// Every character, in the order they were added.
    pub fn list(&self) -> Vec<Arc<Character>> {
        self.read()
            .characters
            .iter()
            .map(|(c, _)| Arc::clone(c))
            .collect()
    }

    /// Removes a character and gives back its share of the budget (its memory is freed
    /// once no request uses it any more); false when there was none with this id. Ids are
    /// not reused.
    pub fn remove(&self, id: &str) -> bool {
        let mut inner = self.write();
        let Some(k) = inner.characters.iter().position(|(c, _)| c.id == id) else {
            return false;
        };
        let (_, bytes) = inner.characters.remove(k);
        inner.stored_bytes = inner.stored_bytes.saturating_sub(bytes);
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tiny(id: String) -> Character {
        let rig_file = crate::humanoid_rig_file().expect("humanoid");
        Character::new(id, Path::new("tiny.glb"), RigFormat::Glb, rig_file)
    }

    #[test]
    fn the_budget_counts_stored_characters_and_reservations() {
        let store = CharacterStore::with_budget(1000);
        let a = store.add(tiny, 400).expect("fits");
        let held = store.reserve(500).expect("400 + 500 fit");
        assert!(matches!(
            store.reserve(200),
            Err(StoreFull::Memory {
                needed: 200,
                used: 900,
                budget: 1000
            })
        ));
        // The upload turned out bigger than it reserved, but fits beside the others.
        let b = store
            .add_within_budget(held, tiny, 600)
            .expect("400 + 600 fit");
        assert_eq!(store.stored_bytes(), 1000);
        assert!(store.reserve(1).is_err());
        assert!(store.remove(&a.id));
        assert_eq!(store.stored_bytes(), 600);
        let held = store.reserve(300).expect("room again");
        assert!(matches!(
            store.add_within_budget(held, tiny, 500),
            Err(StoreFull::Memory { .. })
        ));
        assert_eq!(
            store.stored_bytes(),
            600,
            "a refused character takes nothing"
        );
        assert!(store.remove(&b.id));
        assert_eq!(store.stored_bytes(), 0);
        let mut held = store.reserve(1000).expect("all of it");
        held.resize(100).expect("less");
        let other = store.reserve(900).expect("the rest");
        assert!(held.resize(101).is_err());
        assert_eq!(held.bytes(), 100);
        drop(other);
        held.resize(1000).expect("all of it again");
        drop(held);
        assert!(store.reserve(1000).is_ok());
    }
}
