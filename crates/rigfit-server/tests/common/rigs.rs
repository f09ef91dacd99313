//! Generated rigs for tests that need a slow solve or a big upload (shared with rigfit-cli's tests/serve.rs
//! through `#[path]`).

/// A BVH rig of `chains` chains of `depth` joints fanning out from the hips (one frame, at
/// rest), 1.05 units high for 20 joints a chain.
pub fn tree_bvh(chains: usize, depth: usize) -> String {
    let mut text = String::from(
        "HIERARCHY\nROOT Hips\n{\n OFFSET 0 0 0\n CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation\n",
    );
    for c in 0..chains {
        let a = std::f64::consts::TAU * c as f64 / chains as f64;
        for d in 0..depth {
            let r = if d == 0 { 0.05 } else { 0.025 };
            text.push_str(&format!(
                "JOINT C{c}_{d}\n{{\n OFFSET {:.4} 0.05 {:.4}\n CHANNELS 3 Zrotation Xrotation Yrotation\n",
                r * a.cos(),
                r * a.sin()
            ));
        }
        text.push_str("End Site\n{\n OFFSET 0 0.05 0\n}\n");
        text.push_str(&"}\n".repeat(depth));
    }
    text.push_str("}\nMOTION\nFrames: 1\nFrame Time: 0.04\n");
    let channels = 6 + 3 * chains * depth;
    text.push_str(&vec!["0"; channels].join(" "));
    text.push('\n');
    text
}

/// A BVH of one moving joint with `frames` frames (about 18 bytes a frame).
pub fn long_bvh(frames: usize) -> Vec<u8> {
    let mut text = String::from(
        "HIERARCHY\nROOT Hips\n{\n OFFSET 0 0 0\n CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation\n End Site\n {\n  OFFSET 0 1 0\n }\n}\nMOTION\n",
    );
    text.push_str(&format!("Frames: {frames}\nFrame Time: 0.0083333\n"));
    text.push_str(&"0.1 0.2 0.3 0 0 0\n".repeat(frames));
    text.into_bytes()
}
