//! The fuzz corpus of the strokes file through the solver (fuzz/seeds/strokes_solve: the
//! seeds, the hardening issue's hostile examples and the minimised findings of
//! scripts/fuzz.sh), replayed through the real command: `rigfit pose` on the built-in
//! humanoid either poses (exit 0, the output written) or refuses with one line (exit 2,
//! nothing written). Never a panic.

mod common;

use std::path::PathBuf;

use common::{rigfit, stderr};

fn corpus(target: &str) -> Vec<PathBuf> {
    let dir = PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../../fuzz/seeds")).join(target);
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|entry| entry.expect("a directory entry").path())
        .collect();
    files.sort();
    files
}

#[test]
fn every_strokes_corpus_file_poses_or_is_refused_in_one_line() {
    let dir = tempfile::tempdir().expect("a temporary directory");
    let rig = dir.path().join("humanoid.glb");
    let made = rigfit(&["demo-rig", "-o", rig.to_str().expect("utf-8 path")]);
    assert!(made.status.success(), "{}", stderr(&made));
    let files: Vec<PathBuf> = ["strokes_solve", "strokes"]
        .iter()
        .flat_map(|t| corpus(t))
        .collect();
    assert!(files.len() >= 8, "the corpus is there: {files:?}");
    for file in files {
        let out = dir.path().join("posed.glb");
        let _ = std::fs::remove_file(&out);
        let o = rigfit(&[
            "pose",
            rig.to_str().expect("utf-8 path"),
            file.to_str().expect("utf-8 path"),
            "-o",
            out.to_str().expect("utf-8 path"),
        ]);
        let err = stderr(&o);
        assert!(!err.contains("panicked"), "{}: {err}", file.display());
        match o.status.code() {
            Some(0) => assert!(
                out.is_file(),
                "{}: posed but nothing written",
                file.display()
            ),
            Some(2) => {
                let lines = err.lines().filter(|l| !l.trim().is_empty()).count();
                assert_eq!(lines, 1, "{}: one line: {err}", file.display());
                assert!(!out.exists(), "{}: refused but written", file.display());
            }
            other => panic!("{}: exit {other:?}: {err}", file.display()),
        }
    }
}
