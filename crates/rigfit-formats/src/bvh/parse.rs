//! The BVH reader: a file's bytes to a [`BvhDocument`], and the names of its End Sites.

use std::collections::{HashMap, HashSet};
use std::path::Path;

use crate::error::{FormatError, ParseError, read_bytes};

use super::hierarchy::parse_hierarchy;
use super::lexer::Lexer;
use super::motion::parse_motion;
use super::{BvhDocument, BvhJoint};

/// Reads a BVH file.
pub fn read_bvh(path: &Path) -> Result<BvhDocument, FormatError> {
    let bytes = read_bytes(path)?;
    let _span = tracing::warn_span!("reading", file = %path.display()).entered();
    parse_bvh(&bytes).map_err(|e| FormatError::parse(path, e))
}

/// Parses the bytes of a BVH file. Never panics; every error names a line.
pub fn parse_bvh(text: &[u8]) -> Result<BvhDocument, ParseError> {
    let text = String::from_utf8_lossy(text);
    let text = text.strip_prefix('\u{feff}').unwrap_or(&text);
    let text = if text.contains('\r') {
        text.replace("\r\n", "\n").replace('\r', "\n")
    } else {
        text.to_string()
    };
    let mut lx = Lexer {
        text: &text,
        pos: 0,
        line: 1,
    };
    let mut joints = parse_hierarchy(&mut lx)?;
    let (frame_time, frames) = parse_motion(&mut lx, &joints)?;
    name_end_sites(&mut joints);
    Ok(BvhDocument {
        joints,
        frame_time,
        frames,
    })
}

/// Names each End Site after its parent (`Parent_End`, or `Parent_End2`, ... when that is
/// taken), and warns about duplicate joint names.
fn name_end_sites(joints: &mut [BvhJoint]) {
    let mut taken: HashSet<String> = HashSet::new();
    let mut duplicate: Option<String> = None;
    for j in joints.iter().filter(|j| !j.end_site) {
        if !taken.insert(j.name.clone()) && duplicate.is_none() {
            duplicate = Some(j.name.clone());
        }
    }
    if let Some(name) = duplicate {
        tracing::warn!("BVH joint name '{name}' is used more than once (maybe others too)");
    }
    let mut next_suffix: HashMap<String, usize> = HashMap::new();
    for i in 0..joints.len() {
        if !joints[i].end_site {
            continue;
        }
        let parent_name = joints[i]
            .parent
            .and_then(|p| joints.get(p))
            .map(|p| p.name.clone())
            .unwrap_or_default();
        let base = format!("{parent_name}_End");
        let mut name = base.clone();
        let counter = next_suffix.entry(base.clone()).or_insert(1);
        while taken.contains(&name) {
            *counter += 1;
            name = format!("{base}{counter}");
        }
        taken.insert(name.clone());
        joints[i].name = name;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_a_minimal_file() {
        let text = "HIERARCHY\nROOT a\n{\nOFFSET 0 0 0\nCHANNELS 1 Yrotation\nEnd Site\n{\nOFFSET 0 1 0\n}\n}\nMOTION\nFrames: 1\nFrame Time: .5\n90\n";
        let doc = parse_bvh(text.as_bytes()).expect("valid");
        assert_eq!(doc.joints.len(), 2);
        assert_eq!(doc.joints[1].name, "a_End");
        assert_eq!(doc.frame_time, 0.5);
        assert_eq!(doc.frames, vec![vec![90.0]]);
    }

    #[test]
    fn end_site_names_stay_unique() {
        let text = "HIERARCHY\nROOT a\n{\nOFFSET 0 0 0\nCHANNELS 0\nEnd Site\n{\nOFFSET 0 1 0\n}\nEnd Site\n{\nOFFSET 0 2 0\n}\nJOINT a_End\n{\nOFFSET 1 0 0\nCHANNELS 0\n}\n}\nMOTION\nFrames: 0\nFrame Time: 1\n";
        let doc = parse_bvh(text.as_bytes()).expect("valid");
        let names: Vec<&str> = doc.joints.iter().map(|j| j.name.as_str()).collect();
        assert_eq!(names, ["a", "a_End2", "a_End3", "a_End"]);
    }
}
