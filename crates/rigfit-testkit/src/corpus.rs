//! The corpus of real rigs: the manifest (`data/corpus.json`), where the rig files are, and
//! each rig read with the start pose, height and vertical axis the cases need.

use std::path::{Path, PathBuf};

use rigfit_core::Skeleton;
use rigfit_core::joint_model::{
    ClipModelOptions, apply_joint_model, joint_model_from_clips, with_clip_ranges,
};
use rigfit_core::pose::sketch::deforming_joints;
use rigfit_core::{Pose, Rig, Vector3};
use rigfit_formats::joints_file::read_joints_file;
use rigfit_formats::rig_file::{RigOptions, StartFrame, read_rig};
use serde::Deserialize;

/// The environment variable naming the folder the manifest's files are relative to.
pub const CORPUS_ENV: &str = "RIGFIT_CORPUS";
/// The environment variable naming the manifest, when it is not the workspace's
/// `data/corpus.json`.
pub const MANIFEST_ENV: &str = "RIGFIT_CORPUS_MANIFEST";

/// The workspace root (two folders above this crate).
fn workspace_root() -> PathBuf {
    let crate_dir = Path::new(env!("CARGO_MANIFEST_DIR"));
    crate_dir
        .ancestors()
        .nth(2)
        .map_or_else(|| crate_dir.join("../.."), Path::to_path_buf)
}

/// Which half of the corpus a rig belongs to: the solver is tuned on one and judged on the
/// other.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Half {
    Tune,
    HeldOut,
}

impl Half {
    pub const ALL: [Half; 2] = [Half::Tune, Half::HeldOut];

    /// The manifest's name: `tune` or `held-out`.
    pub fn name(self) -> &'static str {
        match self {
            Half::Tune => "tune",
            Half::HeldOut => "held-out",
        }
    }

    /// The half named `name` (`tune` or `held-out`).
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|h| h.name() == name)
    }
}

/// What kind of character a rig is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum RigKind {
    Human,
    HumanFingersFace,
    Hand,
    Quadruped,
    Creature,
    Robot,
    Marker,
    Other,
}

/// The pose the solver starts from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum StartPose {
    /// Every joint at its rest transform (a BVH's zero channels).
    Rest,
    /// The pose stored in the file (glTF node transforms, a BVH's first frame).
    Stored,
}

/// One rig of the manifest. The fields the sweep does not use are kept as they are written.
#[derive(Clone, Debug, Deserialize)]
pub struct RigEntry {
    pub id: String,
    /// The rig's file, relative to the corpus folder.
    pub file: String,
    pub half: Half,
    pub kind: RigKind,
    pub start: StartPose,
    /// The glTF skin to read (the first when absent).
    #[serde(default)]
    pub skin: Option<String>,
    /// The vertical axis (`y`, `z`, `-z`, ...); `y` when absent.
    #[serde(default)]
    pub up: Option<String>,
    #[serde(default)]
    pub units: serde_json::Value,
    #[serde(default)]
    pub joints: serde_json::Value,
    #[serde(default)]
    pub height: serde_json::Value,
    #[serde(default)]
    pub clips: serde_json::Value,
    #[serde(default)]
    pub frames: serde_json::Value,
    #[serde(default)]
    pub source: serde_json::Value,
    #[serde(default)]
    pub converted: serde_json::Value,
    #[serde(default)]
    pub licence: serde_json::Value,
    #[serde(default)]
    pub notes: serde_json::Value,
}

#[derive(Deserialize)]
struct Manifest {
    rigs: Vec<RigEntry>,
}

/// Why the corpus cannot be used. Each is one line naming what to set or run.
#[derive(Debug, thiserror::Error)]
pub enum CorpusError {
    #[error(
        "the rig corpus is missing: no manifest at {} (set {MANIFEST_ENV} to the manifest and {CORPUS_ENV} to the corpus folder, or run scripts/fetch-data.sh)",
        manifest.display()
    )]
    MissingManifest { manifest: PathBuf },
    #[error("{}: {problem}", manifest.display())]
    BadManifest { manifest: PathBuf, problem: String },
    #[error(
        "the rig corpus is missing: {missing} of {listed} rig files are not under {} (set {CORPUS_ENV} to the corpus folder or run scripts/fetch-data.sh); first missing: {first}",
        folder.display()
    )]
    MissingFiles {
        folder: PathBuf,
        missing: usize,
        listed: usize,
        first: String,
    },
    #[error("corpus rig {id}: {problem}")]
    Rig { id: String, problem: String },
}

/// The corpus: the manifest's rigs and the folder their files are in.
#[derive(Clone, Debug)]
pub struct Corpus {
    pub manifest: PathBuf,
    pub folder: PathBuf,
    pub rigs: Vec<RigEntry>,
}

impl Corpus {
    /// The manifest and folder from `RIGFIT_CORPUS_MANIFEST` and `RIGFIT_CORPUS`, by default
    /// `<workspace>/data/corpus.json` and `<workspace>/target/test-data/corpus`.
    pub fn locations() -> (PathBuf, PathBuf) {
        let manifest = std::env::var_os(MANIFEST_ENV)
            .map(PathBuf::from)
            .unwrap_or_else(|| workspace_root().join("data/corpus.json"));
        let folder = std::env::var_os(CORPUS_ENV)
            .map(PathBuf::from)
            .unwrap_or_else(|| workspace_root().join("target/test-data/corpus"));
        (manifest, folder)
    }

    /// Reads the manifest at its [`Corpus::locations`] and checks that every file it lists
    /// is there.
    pub fn load() -> Result<Self, CorpusError> {
        let (manifest, folder) = Self::locations();
        let corpus = Self::read(&manifest, &folder)?;
        corpus.check_files()?;
        Ok(corpus)
    }

    /// Reads and checks a manifest (ids unique and not empty, at least one rig); files are
    /// not looked at.
    pub fn read(manifest: &Path, folder: &Path) -> Result<Self, CorpusError> {
        let bad = |problem: String| CorpusError::BadManifest {
            manifest: manifest.to_path_buf(),
            problem,
        };
        let text = match std::fs::read_to_string(manifest) {
            Ok(text) => text,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
                return Err(CorpusError::MissingManifest {
                    manifest: manifest.to_path_buf(),
                });
            }
            Err(e) => return Err(bad(e.to_string())),
        };
        let parsed: Manifest = serde_json::from_str(&text).map_err(|e| bad(e.to_string()))?;
        if parsed.rigs.is_empty() {
            return Err(bad("the manifest lists no rigs".into()));
        }
        let mut ids = std::collections::HashSet::new();
        for rig in &parsed.rigs {
            if rig.id.is_empty() || rig.file.is_empty() {
                return Err(bad(format!("rig '{}': empty id or file", rig.id)));
            }
            if !ids.insert(rig.id.as_str()) {
                return Err(bad(format!("rig id '{}' is listed twice", rig.id)));
            }
        }
        Ok(Self {
            manifest: manifest.to_path_buf(),
            folder: folder.to_path_buf(),
            rigs: parsed.rigs,
        })
    }

    /// The path of a rig's file.
    pub fn path(&self, rig: &RigEntry) -> PathBuf {
        self.folder.join(&rig.file)
    }

    /// Fails, naming the first and counting all, when listed files are not regular files.
    pub fn check_files(&self) -> Result<(), CorpusError> {
        let missing: Vec<&RigEntry> = self
            .rigs
            .iter()
            .filter(|r| !self.path(r).is_file())
            .collect();
        match missing.first() {
            None => Ok(()),
            Some(first) => Err(CorpusError::MissingFiles {
                folder: self.folder.clone(),
                missing: missing.len(),
                listed: self.rigs.len(),
                first: first.file.clone(),
            }),
        }
    }

    /// The rig with id `id`.
    pub fn entry(&self, id: &str) -> Option<&RigEntry> {
        self.rigs.iter().find(|r| r.id == id)
    }

    /// Reads a rig's file with its manifest options.
    pub fn read_rig(&self, entry: &RigEntry) -> Result<CorpusRig, CorpusError> {
        let start_frame = match entry.start {
            StartPose::Rest => StartFrame::Rest,
            StartPose::Stored => StartFrame::First,
        };
        let options = RigOptions {
            skin: entry.skin.clone(),
            start_frame,
        };
        let file = read_rig(&self.path(entry), &options).map_err(|e| CorpusError::Rig {
            id: entry.id.clone(),
            problem: e.to_string(),
        })?;
        let mut rig = file.rig;
        // As `rigfit pose` does: leaf bones need a length to be drawn along and fitted. The
        // joints get their model (hinges, limits) from a joints file beside the rig (the
        // robot descriptions' converter writes one) or else from the rig's clips: cases are
        // drawn in poses the rig's joints can take.
        rig.tip_skinned_leaves();
        // What `rigfit pose` sees without `--joints`: ball joints with the clips' ranges.
        let plain = with_clip_ranges(&rig.skeleton, &rig.animations);
        let sidecar = self.path(entry).with_extension("joints.json");
        let model = if sidecar.is_file() {
            read_joints_file(&sidecar, &rig.skeleton).map_err(|e| CorpusError::Rig {
                id: entry.id.clone(),
                problem: e.to_string(),
            })?
        } else {
            joint_model_from_clips(&rig.skeleton, &rig.animations, &ClipModelOptions::default())
        };
        apply_joint_model(&mut rig.skeleton, &model);
        let mut corpus_rig = CorpusRig::new(entry.clone(), rig)?;
        corpus_rig.plain_skeleton = plain;
        Ok(corpus_rig)
    }
}

/// A corpus rig read for posing: its start pose, vertical axis, height along it, and which
/// joints carry skin weight.
#[derive(Clone, Debug)]
pub struct CorpusRig {
    pub entry: RigEntry,
    pub rig: Rig,
    pub start: Pose,
    pub up: Vector3,
    /// The extent of the character along `up` in the start pose (the largest extent when
    /// that is under a quarter of it): errors are fractions of it.
    pub height: f64,
    pub deforming: Vec<bool>,
    /// What `rigfit pose` sees without `--joints`: the file's skeleton, every joint that
    /// turns a ball, with the ranges the rig's clips show.
    pub plain_skeleton: Skeleton,
    /// Give the solver the joint model (as `rigfit pose --joints` does); otherwise it gets
    /// [`CorpusRig::plain_skeleton`]. Cases are drawn with the model either way.
    pub solve_with_joint_model: bool,
    /// The rig's own symmetries in its start pose ([`crate::symmetry::rig_symmetries`]),
    /// the identity first: a pose and its twin under one of them draw the same strokes.
    pub symmetries: Vec<Vec<usize>>,
}

impl CorpusRig {
    /// The skeleton the solver is given.
    pub fn solver_skeleton(&self) -> &Skeleton {
        if self.solve_with_joint_model {
            &self.rig.skeleton
        } else {
            &self.plain_skeleton
        }
    }
}

impl CorpusRig {
    /// Prepares `rig` for the entry's start pose and vertical axis.
    pub fn new(entry: RigEntry, rig: Rig) -> Result<Self, CorpusError> {
        let start = match entry.start {
            StartPose::Rest => rig.skeleton.rest_pose(),
            StartPose::Stored => rig.pose.clone(),
        };
        let up = match entry.up.as_deref() {
            None => Vector3::y(),
            Some(text) => parse_up(text).ok_or_else(|| CorpusError::Rig {
                id: entry.id.clone(),
                problem: format!("up '{text}' is not an axis (x, y or z, optionally signed)"),
            })?,
        };
        let height = height_along(&rig, &start, &up);
        if !(height.is_finite() && height > 0.0) {
            return Err(CorpusError::Rig {
                id: entry.id,
                problem: "the character has no extent in its start pose".into(),
            });
        }
        let deforming = deforming_joints(&rig);
        let plain_skeleton = rig.skeleton.clone();
        let symmetries = crate::symmetry::rig_symmetries(&rig, &start, height);
        Ok(Self {
            entry,
            rig,
            start,
            up,
            height,
            deforming,
            plain_skeleton,
            solve_with_joint_model: false,
            symmetries,
        })
    }
}

/// The axis written as `y`, `+Z`, `-z`, `y-up`, `Z_UP`, ...: the first of x, y, z in the text,
/// negative when a `-` comes right before it.
pub fn parse_up(text: &str) -> Option<Vector3> {
    let lower = text.to_ascii_lowercase();
    let at = lower.find(['x', 'y', 'z'])?;
    let axis = match lower.as_bytes()[at] {
        b'x' => Vector3::x(),
        b'y' => Vector3::y(),
        _ => Vector3::z(),
    };
    let negative = at > 0 && lower.as_bytes()[at - 1] == b'-';
    Some(if negative { -axis } else { axis })
}

/// The extent of the character along `up` in `pose`, or its largest extent when that is
/// flat (under a quarter of it: a hand or a robot lying in the ground plane).
fn height_along(rig: &Rig, pose: &Pose, up: &Vector3) -> f64 {
    let largest = rig.bounds(pose).map_or(0.0, |b| b.extent().max());
    let points = rig.extent_points(pose);
    let (lo, hi) = points
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| {
            let h = p.coords.dot(up);
            (lo.min(h), hi.max(h))
        });
    if hi - lo > 0.25 * largest {
        hi - lo
    } else {
        largest
    }
}
