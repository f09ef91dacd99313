//! rigfit-formats: readers and writers for the files rigfit works with.
//!
//! Parsers take bytes and return a [`ParseError`] saying where and what; the `read_*` /
//! `write_*` functions add file access and name the file in a [`FormatError`]. Writers write
//! to a temporary file and rename it, so no output is ever left half-written.

pub mod bvh;
pub mod error;
pub mod files;
pub mod gltf;
pub mod joints_file;
pub mod json;
pub mod mesh_file;
pub mod obj;
pub mod ply;
pub mod report;
pub mod rig_file;
pub mod strokes;

pub use error::{FormatError, ParseError};
