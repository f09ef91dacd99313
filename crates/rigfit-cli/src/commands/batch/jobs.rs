//! The job file of `rigfit batch` (docs/batch.md): its takes, checked, and each take's
//! command line.

use std::ffi::OsString;
use std::path::{Path, PathBuf};

use anyhow::{Context, anyhow, bail};
use rigfit_formats::files::read_input;
use serde_json::{Map, Value};

/// The commands a take may run.
pub const TAKE_COMMANDS: [&str; 3] = ["pose", "track", "surface"];

/// The most takes one job file may hold.
pub const MAX_TAKES: usize = 100_000;

/// One take of a job file as written: its name, command and arguments, and the folder its
/// relative paths start from. It is turned into a command line only when it runs, so
/// wildcards and inputs are resolved where it runs.
#[derive(Debug, Clone)]
pub struct Take {
    pub name: String,
    pub command: String,
    /// Every key of the take but `name` and `command`, in the file's order.
    pub arguments: Map<String, Value>,
    pub base: PathBuf,
}

/// The takes of a job file.
#[derive(Debug, Clone)]
pub struct JobFile {
    /// The folder the takes' relative paths start from (the file's own).
    pub base: PathBuf,
    pub takes: Vec<Take>,
}

/// Reads and checks a job file: its structure, the takes' names and commands, and that no
/// two takes write the same output. The takes' own arguments are checked when they run.
pub fn read_jobs(path: &Path) -> anyhow::Result<JobFile> {
    let bytes = read_input(path)?;
    let base = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::new(),
    };
    parse_jobs(&bytes, path, &base)
}

/// Parses job-file text; errors name `path` and the place in the file.
pub fn parse_jobs(bytes: &[u8], path: &Path, base: &Path) -> anyhow::Result<JobFile> {
    let here = path.display();
    let value: Value =
        serde_json::from_slice(bytes).map_err(|e| anyhow!("{here}: not a JSON job file: {e}"))?;
    let takes = value
        .get("takes")
        .and_then(Value::as_array)
        .ok_or_else(|| anyhow!("{here}: expected an object with a \"takes\" array"))?;
    if takes.is_empty() {
        bail!("{here}: takes: the job file has no takes");
    }
    if takes.len() > MAX_TAKES {
        bail!(
            "{here}: takes: {} takes, at most {MAX_TAKES} in one job file",
            takes.len()
        );
    }
    let takes = takes
        .iter()
        .enumerate()
        .map(|(i, t)| take_from_json(t, i, base).map_err(|e| anyhow!("{here}: takes[{i}]: {e}")))
        .collect::<anyhow::Result<Vec<Take>>>()?;
    check_distinct(&takes).map_err(|e| anyhow!("{here}: {e}"))?;
    Ok(JobFile {
        base: base.to_path_buf(),
        takes,
    })
}

/// One take from its JSON object; `index` names it when it has no name.
pub fn take_from_json(value: &Value, index: usize, base: &Path) -> anyhow::Result<Take> {
    let object = value
        .as_object()
        .ok_or_else(|| anyhow!("expected an object (a take)"))?;
    let command = match object.get("command") {
        Some(Value::String(c)) if TAKE_COMMANDS.contains(&c.as_str()) => c.clone(),
        Some(Value::String(c)) => bail!("command: '{c}' is not one of pose, track, surface"),
        Some(_) => bail!("command: expected a string (pose, track or surface)"),
        None => bail!("command: missing (pose, track or surface)"),
    };
    let name = match object.get("name") {
        Some(Value::String(n)) if !n.trim().is_empty() && !n.contains(['\n', '\r']) => n.clone(),
        Some(_) => bail!("name: expected a non-empty one-line string"),
        None => format!("take-{}", index + 1),
    };
    let arguments = object
        .iter()
        .filter(|(k, _)| !matches!(k.as_str(), "name" | "command"))
        .map(|(k, v)| (k.clone(), v.clone()))
        .collect();
    Ok(Take {
        name,
        command,
        arguments,
        base: base.to_path_buf(),
    })
}

/// No two takes share a name or an output (a file or, for `surface`, a folder).
fn check_distinct(takes: &[Take]) -> anyhow::Result<()> {
    let mut names = std::collections::HashSet::new();
    let mut outputs: std::collections::HashMap<PathBuf, &str> = std::collections::HashMap::new();
    for take in takes {
        if !names.insert(take.name.as_str()) {
            bail!("two takes are named '{}'", take.name);
        }
        for output in take.outputs() {
            if let Some(other) = outputs.insert(lexical(&output), take.name.as_str()) {
                bail!(
                    "takes '{other}' and '{}' both write {}",
                    take.name,
                    output.display()
                );
            }
        }
    }
    Ok(())
}

/// `path` with `.` components dropped and `dir/..` folded, without touching the disk.
pub(super) fn lexical(path: &Path) -> PathBuf {
    let mut out = PathBuf::new();
    for part in path.components() {
        match part {
            std::path::Component::CurDir => {}
            std::path::Component::ParentDir if out.file_name().is_some() => {
                out.pop();
            }
            other => out.push(other),
        }
    }
    out
}

/// The keys naming files or folders a take reads or writes, resolved from its folder.
const PATH_KEYS: [&str; 8] = [
    "rig", "strokes", "mesh", "frames", "output", "report", "render", "truth",
];
const OUTPUT_KEYS: [&str; 3] = ["output", "report", "render"];

impl Take {
    /// The positional arguments of the take's command, in order.
    fn positionals(&self) -> &'static [&'static str] {
        match self.command.as_str() {
            "pose" => &["rig", "strokes"],
            "track" => &["rig", "frames"],
            _ => &["mesh", "frames"],
        }
    }

    /// The outputs it names (resolved), for the check that no two takes share one.
    pub fn outputs(&self) -> Vec<PathBuf> {
        OUTPUT_KEYS
            .iter()
            .filter_map(|k| self.argument(k))
            .filter_map(Value::as_str)
            .map(|p| self.resolve(p))
            .collect()
    }

    fn argument(&self, key: &str) -> Option<&Value> {
        self.arguments
            .iter()
            .find(|(k, _)| k.replace('_', "-") == key.replace('_', "-"))
            .map(|(_, v)| v)
    }

    fn resolve(&self, path: &str) -> PathBuf {
        let path = Path::new(path);
        if path.is_absolute() {
            path.to_path_buf()
        } else {
            self.base.join(path)
        }
    }

    /// The command line this take runs: `rigfit COMMAND POSITIONALS... --key=value...`.
    /// Relative paths are taken from the job file's folder; `frames` may be a list or a
    /// pattern with `*` and `?` in its file name (the matches in name order).
    pub fn command_line(&self) -> anyhow::Result<Vec<OsString>> {
        let mut argv: Vec<OsString> = vec!["rigfit".into(), self.command.clone().into()];
        for &key in self.positionals() {
            let value = self
                .argument(key)
                .ok_or_else(|| anyhow!("{key}: missing (rigfit {} needs it)", self.command))?;
            if key == "frames" {
                let frames = self.frames(value)?;
                argv.extend(frames.into_iter().map(OsString::from));
            } else {
                let path = value
                    .as_str()
                    .ok_or_else(|| anyhow!("{key}: expected a path (a string)"))?;
                argv.push(self.resolve(path).into());
            }
        }
        for (key, value) in &self.arguments {
            let option = key.replace('_', "-");
            if self.positionals().contains(&option.as_str()) {
                continue;
            }
            if option.is_empty()
                || !option
                    .bytes()
                    .all(|b| b.is_ascii_alphanumeric() || b == b'-')
            {
                bail!("'{key}': not an option name");
            }
            let is_path = PATH_KEYS.contains(&option.as_str());
            let text = match value {
                Value::Null | Value::Bool(false) => continue,
                Value::Bool(true) => {
                    argv.push(format!("--{option}").into());
                    continue;
                }
                Value::Array(items) => items
                    .iter()
                    .map(|item| self.scalar(key, item, is_path))
                    .collect::<anyhow::Result<Vec<String>>>()?
                    .join(","),
                other => self.scalar(key, other, is_path)?,
            };
            let mut arg = OsString::from(format!("--{option}="));
            arg.push(text);
            argv.push(arg);
        }
        Ok(argv)
    }

    /// One option value as text: a string (a path resolved) or a number.
    fn scalar(&self, key: &str, value: &Value, is_path: bool) -> anyhow::Result<String> {
        match value {
            Value::String(s) if is_path => Ok(self.resolve(s).display().to_string()),
            Value::String(s) => Ok(s.clone()),
            Value::Number(n) => Ok(n.to_string()),
            _ => bail!("{key}: expected a string, a number, true/false or a list of them"),
        }
    }

    /// The frame files: a list of paths or patterns, each pattern's matches in name order.
    fn frames(&self, value: &Value) -> anyhow::Result<Vec<PathBuf>> {
        let patterns: Vec<&str> = match value {
            Value::String(s) => vec![s.as_str()],
            Value::Array(items) => items
                .iter()
                .map(|i| {
                    i.as_str()
                        .ok_or_else(|| anyhow!("frames: expected paths (strings)"))
                })
                .collect::<anyhow::Result<_>>()?,
            _ => bail!("frames: expected a path, a pattern or a list of them"),
        };
        let mut frames = Vec::new();
        for pattern in patterns {
            frames.extend(expand(&self.resolve(pattern))?);
        }
        if frames.is_empty() {
            bail!("frames: the list is empty");
        }
        Ok(frames)
    }
}

/// A path whose file name may hold `*` and `?`: the files it matches, in name order.
fn expand(pattern: &Path) -> anyhow::Result<Vec<PathBuf>> {
    let name = pattern
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    if !name.contains(['*', '?']) {
        return Ok(vec![pattern.to_path_buf()]);
    }
    let dir = pattern.parent().unwrap_or(Path::new("."));
    if dir.to_string_lossy().contains(['*', '?']) {
        bail!(
            "frames: {}: wildcards may only stand in the file name",
            pattern.display()
        );
    }
    let entries = std::fs::read_dir(dir)
        .with_context(|| format!("frames: {}: cannot list the folder", dir.display()))?;
    let mut matches: Vec<PathBuf> = entries
        .filter_map(Result::ok)
        .filter(|e| wildcard_match(name.as_bytes(), e.file_name().to_string_lossy().as_bytes()))
        .map(|e| e.path())
        .collect();
    if matches.is_empty() {
        bail!("frames: no file matches {}", pattern.display());
    }
    matches.sort();
    Ok(matches)
}

/// Whether `text` matches `pattern` (`*`: any run of bytes, `?`: one byte).
fn wildcard_match(pattern: &[u8], text: &[u8]) -> bool {
    // The classic two-pointer match with one backtrack point: linear in practice.
    let (mut p, mut t) = (0, 0);
    let mut star: Option<(usize, usize)> = None;
    while t < text.len() {
        if p < pattern.len() && (pattern[p] == b'?' || pattern[p] == text[t]) {
            p += 1;
            t += 1;
        } else if p < pattern.len() && pattern[p] == b'*' {
            star = Some((p, t));
            p += 1;
        } else if let Some((sp, st)) = star {
            p = sp + 1;
            t = st + 1;
            star = Some((sp, st + 1));
        } else {
            return false;
        }
    }
    pattern[p..].iter().all(|&b| b == b'*')
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wildcards_match_names() {
        assert!(wildcard_match(b"f_*.ply", b"f_0001.ply"));
        assert!(wildcard_match(b"f_????.ply", b"f_0001.ply"));
        assert!(!wildcard_match(b"f_???.ply", b"f_0001.ply"));
        assert!(wildcard_match(b"*", b""));
        assert!(!wildcard_match(b"*.ply", b"a.obj"));
        assert!(wildcard_match(b"a*b*c", b"aXbYbZc"));
    }

    #[test]
    fn a_take_becomes_its_command_line() {
        let value: Value = serde_json::from_str(
            r#"{"name": "a", "command": "track", "rig": "r.glb", "frames": ["f1.ply", "/abs/f2.ply"],
                "output": "out/a.bvh", "noise": 0.02, "start_frame": "rest", "views": ["front", "side"],
                "render": null}"#,
        )
        .expect("json");
        let take = take_from_json(&value, 0, Path::new("/jobs")).expect("take");
        let argv: Vec<String> = take
            .command_line()
            .expect("argv")
            .into_iter()
            .map(|a| a.to_string_lossy().into_owned())
            .collect();
        assert_eq!(
            argv,
            [
                "rigfit",
                "track",
                "/jobs/r.glb",
                "/jobs/f1.ply",
                "/abs/f2.ply",
                "--output=/jobs/out/a.bvh",
                "--noise=0.02",
                "--start-frame=rest",
                "--views=front,side",
            ]
        );
        assert_eq!(take.outputs(), [PathBuf::from("/jobs/out/a.bvh")]);
    }

    #[test]
    fn bad_job_files_name_the_place() {
        let path = Path::new("jobs.json");
        let base = Path::new(".");
        let err = |text: &str| {
            format!(
                "{:#}",
                parse_jobs(text.as_bytes(), path, base).expect_err("refused")
            )
        };
        assert!(err("[").contains("jobs.json: not a JSON job file"));
        assert!(err("{}").contains("\"takes\" array"));
        assert!(err(r#"{"takes": []}"#).contains("no takes"));
        assert!(err(r#"{"takes": [{"command": "dance"}]}"#).contains("takes[0]: command: 'dance'"));
        assert!(
            err(
                r#"{"takes": [{"command": "pose", "name": "a"}, {"command": "pose", "name": "a"}]}"#
            )
            .contains("two takes are named 'a'")
        );
        assert!(
            err(r#"{"takes": [{"command": "pose", "output": "x/../o.glb"}, {"command": "track", "output": "o.glb"}]}"#)
                .contains("takes 'take-1' and 'take-2' both write")
        );
    }
}
