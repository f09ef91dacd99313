//! Where the real test assets are: `$RIGFIT_DATA`, or `../shared/data` beside the
//! repository (scripts/test-data.sh sets the variable; scripts/fetch-data.sh rebuilds the
//! folder). A missing asset fails the test with the line that says how to get it.

use std::path::PathBuf;

use rigfit_core::Rig;
use rigfit_formats::rig_file::{RigOptions, read_rig};

/// The skinned glTF rigs among the real assets (characters, a simple skin, the WebXR hands).
pub const GLTF_RIGS: [&str; 6] = [
    "assimp/BCN_Epileptic.glb",
    "assimp/Testwuson.glb",
    "assimp/animation_with_skeleton.glb",
    "assimp/simple_skin.gltf",
    "webxr_hand/left.glb",
    "webxr_hand/right.glb",
];

/// The environment variable naming the folder of real assets.
pub const DATA_ENV: &str = "RIGFIT_DATA";

/// The folder of real assets: `$RIGFIT_DATA`, else `../shared/data` beside the repository.
/// Panics when it is missing.
pub fn data_dir() -> PathBuf {
    let dir = std::env::var_os(DATA_ENV).map_or_else(
        || PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/data")),
        PathBuf::from,
    );
    assert!(
        dir.is_dir(),
        "the test asset folder {} is missing: set {DATA_ENV} or run scripts/fetch-data.sh",
        dir.display()
    );
    dir
}

/// Path of a real test asset, `rel` below [`data_dir`]. Panics when it is missing.
pub fn asset(rel: &str) -> PathBuf {
    let path = data_dir().join(rel);
    assert!(
        path.exists(),
        "test asset {} is missing: set {DATA_ENV} or run scripts/fetch-data.sh",
        path.display()
    );
    path
}

/// The rig of a real asset, read with the default options. Panics with the reader's line.
pub fn asset_rig(rel: &str) -> Rig {
    read_rig(&asset(rel), &RigOptions::default())
        .unwrap_or_else(|e| panic!("{e}"))
        .rig
}

/// The corpus of malformed inputs (`crates/rigfit-formats/tests/malformed`): every file must
/// give exit status 2 and one line.
pub fn malformed_dir() -> PathBuf {
    PathBuf::from(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../rigfit-formats/tests/malformed"
    ))
}
