//! Ground-truth posing over the corpus of real rigs, for tuning the posing solver on one
//! half of the corpus and judging it on the other.
//!
//! - [`corpus`]: the manifest (`data/corpus.json`, or `RIGFIT_CORPUS_MANIFEST`), the folder
//!   of rig files (`RIGFIT_CORPUS`), each rig read with its start pose and height.
//! - [`scenario`]: the named ways of drawing cases ([`Scenario`]) and the deterministic
//!   case of a rig, scenario and index ([`generate_case`]), over the generator of
//!   `rigfit_core::pose::cases`.
//! - [`sweep`]: every chosen case solved, with its errors ([`Outcome`]).
//! - [`report`]: tables per rig and per half, the worst cases, the held-out check.
//!
//! The `pose_corpus` example prints the tables; `tests/pose_corpus.rs` asserts the bounds.

pub mod assets;
pub mod corpus;
pub mod report;
pub mod scenario;
pub mod sweep;

pub use corpus::{Corpus, CorpusError, CorpusRig, Half, RigEntry, RigKind, StartPose};
pub use scenario::{GeneratedCase, Scenario, TargetKind, case_seed, generate_case};
pub use sweep::{
    Outcome, SUCCESS_MAX_ERROR, SUCCESS_MEAN_ERROR, SweepOptions, pinned_to_markers, solve_case,
    sweep,
};
