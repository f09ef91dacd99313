//! BVH (Biovision Hierarchy) motion files: a tree of joints with offsets and channels, and
//! a block of frames that holds every channel's value.
//!
//! A joint's local transform is `T(offset + position channels) * R`, where `R` is the
//! product of its rotation channels in the order the file lists them, angles in degrees:
//! `CHANNELS 3 Zrotation Xrotation Yrotation` means `R = Rz(z) * Rx(x) * Ry(y)`. Scale is
//! always 1. `End Site`s are joints too (no channels), named after their parent
//! (`LeftHand` -> `LeftHand_End`). Joints are kept in file order, which is parents first.
//!
//! The parser copes with what real files do (any channel order or subset, several roots,
//! names with colons and spaces, CRLF, a `Frames:` header that disagrees with the rows
//! present) and fails with one line naming the place for anything else. The writer prints
//! every number with Rust's shortest round-trip formatting, so read -> write -> read keeps
//! every value exactly.

mod convert;
mod euler;
mod hierarchy;
mod lexer;
mod motion;
mod parse;
mod types;
mod write;

pub use parse::{parse_bvh, read_bvh};
pub use types::{BvhChannel, BvhDocument, BvhJoint};
