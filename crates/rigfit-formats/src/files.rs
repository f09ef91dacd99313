//! The files rigfit touches: what it reads (regular files only, bounded in size; a glTF's
//! external URIs only inside the glTF's own folder) and how it writes (every output checked
//! before anything is written, written to an exclusively created temporary file with a
//! random name beside it, then renamed; an output that is an input or is not a regular file
//! is refused).

use std::collections::{HashMap, HashSet};
use std::ffi::OsString;
use std::fs::{File, OpenOptions};
use std::hash::{BuildHasher, Hasher};
use std::io::{self, Read, Write};
use std::path::{Component, Path, PathBuf};

use crate::error::FormatError;

/// The largest input file rigfit reads: 1 GiB.
pub const MAX_INPUT_BYTES: u64 = 1 << 30;

/// What kind of file a metadata describes, for messages ("a directory", "a FIFO", ...).
fn kind_of(file_type: std::fs::FileType) -> &'static str {
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if file_type.is_fifo() {
            return "a FIFO (named pipe)";
        }
        if file_type.is_char_device() || file_type.is_block_device() {
            return "a device";
        }
        if file_type.is_socket() {
            return "a socket";
        }
    }
    if file_type.is_dir() {
        "a directory"
    } else if file_type.is_symlink() {
        "a symbolic link"
    } else {
        "not a regular file"
    }
}

fn refused(message: String) -> io::Error {
    io::Error::other(message)
}

#[cfg(target_os = "linux")]
const O_NONBLOCK: i32 = 0o4000;
#[cfg(any(
    target_os = "macos",
    target_os = "ios",
    target_os = "freebsd",
    target_os = "openbsd",
    target_os = "netbsd"
))]
const O_NONBLOCK: i32 = 0x0004;

/// Opens `path` for reading: it must be a regular file (after symbolic links) of at most
/// `limit` bytes. It is opened non-blocking, so a FIFO put in its place cannot block, and
/// checked again on the open handle. Returns the file and its length.
pub fn open_regular(path: &Path, limit: u64) -> io::Result<(File, u64)> {
    let not_regular = |meta: &std::fs::Metadata| {
        refused(format!(
            "is {}, not a regular file; rigfit reads regular files only",
            kind_of(meta.file_type())
        ))
    };
    let meta = std::fs::metadata(path)?;
    if !meta.is_file() {
        return Err(not_regular(&meta));
    }
    let mut options = OpenOptions::new();
    options.read(true);
    #[cfg(any(
        target_os = "linux",
        target_os = "macos",
        target_os = "ios",
        target_os = "freebsd",
        target_os = "openbsd",
        target_os = "netbsd"
    ))]
    {
        use std::os::unix::fs::OpenOptionsExt;
        options.custom_flags(O_NONBLOCK);
    }
    let file = options.open(path)?;
    let meta = file.metadata()?;
    if !meta.is_file() {
        return Err(not_regular(&meta));
    }
    let len = meta.len();
    if len > limit {
        return Err(refused(format!(
            "is {len} bytes, more than the {limit} bytes rigfit reads from one file"
        )));
    }
    Ok((file, len))
}

/// Reads at most `limit` bytes of a regular file (see [`open_regular`]).
pub fn read_regular(path: &Path, limit: u64) -> io::Result<Vec<u8>> {
    let (file, len) = open_regular(path, limit)?;
    let mut bytes = Vec::with_capacity(len as usize);
    file.take(limit.saturating_add(1)).read_to_end(&mut bytes)?;
    if bytes.len() as u64 > limit {
        return Err(refused(format!(
            "grew past the {limit} bytes rigfit reads from one file while being read"
        )));
    }
    Ok(bytes)
}

/// Reads an input file (regular, at most [`MAX_INPUT_BYTES`]), naming it in the error.
pub fn read_input(path: &Path) -> Result<Vec<u8>, FormatError> {
    read_regular(path, MAX_INPUT_BYTES).map_err(|e| FormatError::io(path, e))
}

/// Checks that `path` can be read as an input (exists, regular, not too large) without
/// reading it: the command line checks every input before the work starts.
pub fn check_input(path: &Path) -> Result<(), FormatError> {
    open_regular(path, MAX_INPUT_BYTES)
        .map(|_| ())
        .map_err(|e| FormatError::io(path, e))
}

/// Percent-decodes a URI's path (`%2e%2e` is `..`).
pub(crate) fn percent_decode_bytes(uri: &str) -> Vec<u8> {
    let bytes = uri.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        if bytes[i] == b'%' && i + 2 < bytes.len() {
            let hex = std::str::from_utf8(&bytes[i + 1..i + 3]).ok();
            if let Some(v) = hex.and_then(|h| u8::from_str_radix(h, 16).ok()) {
                out.push(v);
                i += 3;
                continue;
            }
        }
        out.push(bytes[i]);
        i += 1;
    }
    out
}

/// The relative path a glTF URI names, when it may be followed: decoded, relative, with no
/// scheme, no `..` and no NUL. `Err` says why not.
pub fn relative_uri_path(uri: &str) -> Result<PathBuf, String> {
    if uri.is_empty() {
        return Err("the URI is empty".into());
    }
    let decoded = String::from_utf8(percent_decode_bytes(uri))
        .map_err(|_| format!("URI '{uri}' is not UTF-8 once decoded"))?;
    if decoded.contains('\0') {
        return Err(format!("URI '{uri}' holds a NUL character"));
    }
    // A scheme (`file:`, `http:`, `C:`) before the first '/'.
    let first_part = decoded.split('/').next().unwrap_or("");
    if first_part.contains(':') {
        return Err(format!(
            "URI '{uri}' is not a relative file path (only files beside the glTF are read)"
        ));
    }
    if decoded.starts_with('/') || decoded.starts_with('\\') {
        return Err(format!(
            "URI '{uri}' is an absolute path (only files beside the glTF are read)"
        ));
    }
    let path = PathBuf::from(&decoded);
    for c in path.components() {
        match c {
            Component::Normal(_) | Component::CurDir => {}
            Component::ParentDir => {
                return Err(format!(
                    "URI '{uri}' leaves the glTF's folder ('..'; only files beside it are read)"
                ));
            }
            Component::RootDir | Component::Prefix(_) => {
                return Err(format!(
                    "URI '{uri}' is an absolute path (only files beside the glTF are read)"
                ));
            }
        }
    }
    if decoded.split(['/', '\\']).any(|part| part == "..") {
        return Err(format!(
            "URI '{uri}' leaves the glTF's folder ('..'; only files beside it are read)"
        ));
    }
    Ok(path)
}

/// Reads the external file a glTF `uri` names, relative to `dir` (the glTF's folder): the
/// URI must pass [`relative_uri_path`], the file must resolve (through any symbolic links)
/// to a regular file inside `dir`, hold at least `byte_length` bytes, and only those are
/// read. Returns the bytes and the file's resolved path.
pub fn read_relative_uri(
    dir: &Path,
    uri: &str,
    byte_length: u64,
) -> Result<(Vec<u8>, PathBuf), String> {
    let relative = relative_uri_path(uri)?;
    if byte_length > MAX_INPUT_BYTES {
        return Err(format!(
            "byteLength {byte_length} is more than the {MAX_INPUT_BYTES} bytes rigfit reads"
        ));
    }
    let base = if dir.as_os_str().is_empty() {
        Path::new(".")
    } else {
        dir
    };
    let joined = base.join(&relative);
    let shown = joined.display().to_string();
    let base_real = base
        .canonicalize()
        .map_err(|e| format!("cannot resolve the folder '{}': {e}", base.display()))?;
    let real = joined
        .canonicalize()
        .map_err(|e| format!("cannot read '{shown}': {e}"))?;
    if !real.starts_with(&base_real) {
        return Err(format!(
            "'{shown}' leads outside the glTF's folder (a symbolic link); only files beside it are read"
        ));
    }
    let (file, len) = open_regular(&real, MAX_INPUT_BYTES).map_err(|e| format!("'{shown}' {e}"))?;
    if len < byte_length {
        return Err(format!(
            "byteLength is {byte_length} but '{shown}' holds only {len} bytes (truncated?)"
        ));
    }
    let mut bytes = Vec::with_capacity(byte_length as usize);
    file.take(byte_length)
        .read_to_end(&mut bytes)
        .map_err(|e| format!("cannot read '{shown}': {e}"))?;
    if (bytes.len() as u64) < byte_length {
        return Err(format!(
            "byteLength is {byte_length} but only {} bytes of '{shown}' could be read",
            bytes.len()
        ));
    }
    Ok((bytes, real))
}

/// The folder of an output path ("." for a bare name).
fn folder_of(path: &Path) -> &Path {
    match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    }
}

/// Checks that `path` may be written: its folder exists, and it is either absent or a
/// regular file (not a symbolic link, directory, device or FIFO, which rigfit will not
/// replace).
pub fn check_output(path: &Path) -> Result<(), FormatError> {
    if path.file_name().is_none() {
        return Err(FormatError::io(
            path,
            refused("is not a file name to write to".into()),
        ));
    }
    match std::fs::symlink_metadata(path) {
        Ok(meta) if meta.file_type().is_symlink() => {
            return Err(FormatError::io(
                path,
                refused(
                    "is a symbolic link; rigfit does not write through or replace links".into(),
                ),
            ));
        }
        Ok(meta) if !meta.is_file() => {
            return Err(FormatError::io(
                path,
                refused(format!(
                    "is {}; rigfit only replaces regular files",
                    kind_of(meta.file_type())
                )),
            ));
        }
        Ok(_) => {}
        Err(e) if e.kind() == io::ErrorKind::NotFound => {}
        Err(e) => return Err(FormatError::io(path, e)),
    }
    let dir = folder_of(path);
    match std::fs::metadata(dir) {
        Ok(meta) if meta.is_dir() => Ok(()),
        Ok(_) => Err(FormatError::io(
            path,
            refused(format!("cannot write: {} is not a folder", dir.display())),
        )),
        Err(e) => Err(FormatError::io(
            path,
            refused(format!("cannot write: folder {}: {e}", dir.display())),
        )),
    }
}

/// The identity of an existing file (device and inode), to tell whether two paths are the
/// same file.
#[cfg(unix)]
fn file_id(path: &Path) -> Option<(u64, u64)> {
    use std::os::unix::fs::MetadataExt;
    std::fs::metadata(path).ok().map(|m| (m.dev(), m.ino()))
}

#[cfg(not(unix))]
fn file_id(path: &Path) -> Option<(u64, u64)> {
    use std::hash::Hash;
    let real = path.canonicalize().ok()?;
    let mut h = std::collections::hash_map::DefaultHasher::new();
    real.hash(&mut h);
    Some((0, h.finish()))
}

/// `path` with its folder resolved (for comparing outputs that may not exist yet).
fn resolved_name(path: &Path) -> PathBuf {
    let dir = folder_of(path);
    let dir = dir.canonicalize().unwrap_or_else(|_| dir.to_path_buf());
    match path.file_name() {
        Some(name) => dir.join(name),
        None => dir,
    }
}

/// Checks a command's outputs against its inputs before any work: every output passes
/// [`check_output`], none is one of the inputs (same device and inode, whatever the path's
/// spelling or links), and no output is named twice. Cost linear in the counts.
pub fn check_outputs(inputs: &[&Path], outputs: &[&Path]) -> Result<(), FormatError> {
    let mut by_id: HashMap<(u64, u64), &Path> = HashMap::with_capacity(inputs.len());
    for &input in inputs {
        if let Some(id) = file_id(input) {
            by_id.entry(id).or_insert(input);
        }
    }
    let mut names: HashSet<PathBuf> = HashSet::with_capacity(outputs.len());
    for &out in outputs {
        check_output(out)?;
        if let Some(input) = file_id(out).and_then(|id| by_id.get(&id)) {
            return Err(FormatError::io(
                out,
                refused(format!(
                    "is the input {}; rigfit does not overwrite its inputs",
                    input.display()
                )),
            ));
        }
        if !names.insert(resolved_name(out)) {
            return Err(FormatError::io(
                out,
                refused("is named as two outputs".into()),
            ));
        }
    }
    Ok(())
}

/// A random 64-bit number (the standard library's randomly seeded hasher).
fn random_u64() -> u64 {
    let mut h = std::collections::hash_map::RandomState::new().build_hasher();
    h.write_u32(std::process::id());
    if let Ok(t) = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH) {
        h.write_u128(t.as_nanos());
    }
    h.finish()
}

/// An output written to its temporary file, waiting to be renamed into place; dropped
/// without [`Staged::commit`], the temporary file is removed.
#[derive(Debug)]
pub struct Staged {
    target: PathBuf,
    temporary: Option<PathBuf>,
}

impl Staged {
    /// The output's path.
    pub fn target(&self) -> &Path {
        &self.target
    }

    /// Renames the temporary file over the target.
    pub fn commit(mut self) -> Result<(), FormatError> {
        let Some(tmp) = self.temporary.take() else {
            return Ok(());
        };
        // The target is checked again: it may have changed since it was staged.
        if let Err(e) = check_output(&self.target) {
            let _ = std::fs::remove_file(&tmp);
            return Err(e);
        }
        std::fs::rename(&tmp, &self.target).map_err(|e| {
            let _ = std::fs::remove_file(&tmp);
            FormatError::io(&self.target, e)
        })
    }
}

impl Drop for Staged {
    fn drop(&mut self) {
        if let Some(tmp) = self.temporary.take() {
            let _ = std::fs::remove_file(tmp);
        }
    }
}

/// Writes `bytes` to a new temporary file beside `target` (created exclusively, with a
/// random name: a file or link already there is never opened), after checking `target`
/// with [`check_output`].
pub fn stage(target: &Path, bytes: &[u8]) -> Result<Staged, FormatError> {
    check_output(target)?;
    let dir = folder_of(target);
    let name = target
        .file_name()
        .map_or_else(|| OsString::from("out"), OsString::from);
    let mut last_error = None;
    for _ in 0..16 {
        let mut tmp_name = OsString::from(".");
        tmp_name.push(&name);
        tmp_name.push(format!(".rigfit-{:016x}.tmp", random_u64()));
        let tmp = dir.join(tmp_name);
        let file = OpenOptions::new().write(true).create_new(true).open(&tmp);
        let mut file = match file {
            Ok(f) => f,
            Err(e) if e.kind() == io::ErrorKind::AlreadyExists => {
                last_error = Some(e);
                continue;
            }
            Err(e) => return Err(FormatError::io(target, e)),
        };
        let staged = Staged {
            target: target.to_path_buf(),
            temporary: Some(tmp),
        };
        file.write_all(bytes)
            .and_then(|()| file.sync_all())
            .map_err(|e| FormatError::io(target, e))?;
        return Ok(staged);
    }
    Err(FormatError::io(
        target,
        last_error.unwrap_or_else(|| refused("no free temporary name".into())),
    ))
}

/// Renames every staged output into place (all were written first, so a failure to write
/// one leaves none).
pub fn commit_all(staged: Vec<Staged>) -> Result<(), FormatError> {
    let mut first_error = None;
    for s in staged {
        if let Err(e) = s.commit() {
            first_error.get_or_insert(e);
        }
    }
    first_error.map_or(Ok(()), Err)
}

/// Writes a file atomically: to an exclusive temporary beside it, then renamed over it.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), FormatError> {
    stage(path, bytes)?.commit()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn uris_outside_the_folder_are_refused() {
        for bad in [
            "/etc/passwd",
            "../x.bin",
            "a/../../x.bin",
            "%2e%2e/x.bin",
            "%2E%2E%2Fx.bin",
            "file:///etc/passwd",
            "C:/x.bin",
            "",
            "a%00b",
            "\\etc\\passwd",
        ] {
            assert!(relative_uri_path(bad).is_err(), "{bad}");
        }
        for good in ["x.bin", "./x.bin", "sub/x%20y.bin", "a..b.bin"] {
            assert!(relative_uri_path(good).is_ok(), "{good}");
        }
    }
}
