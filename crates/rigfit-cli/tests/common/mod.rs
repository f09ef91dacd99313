//! Helpers shared by the command-line tests.
#![allow(dead_code)]

use std::path::Path;
use std::process::{Command, Output};

#[allow(unused_imports)]
pub use rigfit_testkit::assets::{asset as data, malformed_dir};

/// Runs `rigfit` with arguments.
pub fn rigfit(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_rigfit"))
        .args(args)
        .output()
        .expect("the rigfit binary runs")
}

pub fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

pub fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Asserts a bad-input failure: exit status 2, one line on stderr naming `file`.
pub fn assert_bad_input(o: &Output, file: &Path) {
    let err = stderr(o);
    assert_eq!(
        o.status.code(),
        Some(2),
        "exit status for {}: stderr {err}",
        file.display()
    );
    let lines: Vec<&str> = err.lines().filter(|l| !l.trim().is_empty()).collect();
    assert_eq!(lines.len(), 1, "one line for {}: {err}", file.display());
    let name = file.file_name().expect("file name").to_string_lossy();
    assert!(
        lines[0].contains(name.as_ref()),
        "the line names {name}: {err}"
    );
    assert!(!err.contains("panicked"), "no panic: {err}");
}

/// Width and height from a PNG's IHDR chunk (after checking the signature and that IHDR
/// comes first), and the file's length.
pub fn png_size(path: &Path) -> (u32, u32, usize) {
    let bytes = std::fs::read(path).expect("the picture was written");
    assert!(bytes.len() > 24, "{}: too short for a PNG", path.display());
    assert_eq!(
        &bytes[..8],
        b"\x89PNG\r\n\x1a\n",
        "{}: PNG signature",
        path.display()
    );
    assert_eq!(&bytes[12..16], b"IHDR", "{}: IHDR first", path.display());
    let be = |b: &[u8]| u32::from_be_bytes([b[0], b[1], b[2], b[3]]);
    (be(&bytes[16..20]), be(&bytes[20..24]), bytes.len())
}
