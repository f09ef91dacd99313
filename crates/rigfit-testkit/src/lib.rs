//! rigfit's test support (not published): where the real assets are, the ground truth the
//! solvers' accuracy tests, benches and tables measure against, and the posing corpus of
//! real rigs, for tuning the posing solver on one half of it and judging it on the other.
//!
//! - [`assets`]: the real test assets (`RIGFIT_DATA`, or `../shared/data`), failing with
//!   how to get them when missing; the malformed-input corpus.
//! - [`targets`]: true poses for posing cases (a clip's frame, a random pose far from the
//!   start, a mirror-symmetric one), drawn with `rigfit_core::pose::sketch`.
//! - [`pose_suites`], [`track_suites`]: the posing and tracking suites on the real assets
//!   (rigfit-core's accuracy tests and benches, the accuracy tables).
//! - [`track_cases`], [`surface_cases`]: ground-truth tracking sequences (virtual depth
//!   cameras, noise, outliers) and surface scan sequences from skinned rigs.
//! - [`corpus`]: the manifest (`data/corpus.json`, or `RIGFIT_CORPUS_MANIFEST`), the folder
//!   of rig files (`RIGFIT_CORPUS`), each rig read with its start pose and height.
//! - [`scenario`]: the named ways of drawing cases ([`Scenario`]) and the deterministic
//!   case of a rig, scenario and index ([`generate_case`]), over the generator of
//!   `rigfit_core::pose::sketch` and [`targets`].
//! - [`mod@sweep`]: every chosen case solved, with its errors ([`Outcome`]); [`sweep::limb_motion`].
//! - [`report`]: tables per rig and per half, the worst cases, the held-out check.
//! - [`symmetry`]: a rig's own geometric symmetries (turns that map its body onto itself
//!   with joints relabelled), up to which tracking is judged ([`track_corpus`]), and the
//!   twins a posing case may expect instead of its truth
//!   ([`scenario::expected_labelling`]).
//!
//! The `pose_corpus` example prints the tables; `tests/pose_corpus.rs` asserts the bounds.

pub mod assets;
pub mod corpus;
pub mod pose_suites;
pub mod report;
pub mod scenario;
pub mod surface_cases;
pub mod surface_corpus;
pub mod sweep;
pub mod symmetry;
pub mod targets;
pub mod track_cases;
pub mod track_corpus;
pub mod track_suites;

pub use corpus::{Corpus, CorpusError, CorpusRig, Half, RigEntry, RigKind, StartPose};
pub use scenario::{GeneratedCase, Scenario, TargetKind, case_seed, generate_case};
pub use sweep::{
    Outcome, SUCCESS_MAX_ERROR, SUCCESS_MEAN_ERROR, SweepOptions, pinned_to_drawn_chains,
    pinned_to_markers, solve_case, sweep,
};
