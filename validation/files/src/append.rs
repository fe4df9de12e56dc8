//! Append-only files (the model ledger, the bench history): appended under an exclusive lock
//! in one write, synced; read under a shared lock.

use crate::file::{parent_dir, resolve, sync_dir};
use crate::kind::{describe_file, HEAD_BYTES};
use crate::{FileError, Kind};
use std::fs::{File, OpenOptions};
use std::io::{Read, Seek, SeekFrom, Write};
use std::path::Path;

/// Checks the (resolved) append-only file `path` of `kind`: missing or a regular file.
fn check(path: &Path, kind: Kind) -> Result<bool, FileError> {
    match std::fs::symlink_metadata(path) {
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(false),
        Err(e) => Err(FileError::io(path, "inspect", e)),
        Ok(m) if m.is_file() => Ok(true),
        Ok(m) if m.is_dir() => Err(FileError::refused(path, kind, "is a folder")),
        Ok(_) => Err(FileError::refused(
            path,
            kind,
            "is a special file: the toolkit appends only to a regular file, under a lock",
        )),
    }
}

fn read_all(file: &mut File, path: &Path, limit: u64) -> Result<Vec<u8>, FileError> {
    let len = file
        .metadata()
        .map_err(|e| FileError::io(path, "inspect", e))?
        .len();
    if len > limit {
        return Err(FileError::TooLarge {
            path: path.to_path_buf(),
            what: "an append-only file",
            limit,
        });
    }
    let mut bytes = Vec::new();
    bytes
        .try_reserve(len as usize)
        .map_err(|e| FileError::io(path, "read", std::io::Error::other(e.to_string())))?;
    file.seek(SeekFrom::Start(0))
        .and_then(|_| file.take(limit + 1).read_to_end(&mut bytes))
        .map_err(|e| FileError::io(path, "read", e))?;
    Ok(bytes)
}

/// Appends to the file of `kind` at `path` (created if missing) under an exclusive lock:
/// `line(existing)` gets the file's bytes (read under the same lock, at most `limit`) and
/// returns what to append, or `None` to append nothing. The bytes go out in one `write` and
/// are synced before the lock is released. A file that is not of `kind` is refused. Returns
/// whether it wrote.
pub fn append_locked(
    path: &Path,
    kind: Kind,
    limit: u64,
    line: impl FnOnce(&[u8]) -> Option<Vec<u8>>,
) -> Result<bool, FileError> {
    let target = resolve(path)?;
    let existed = check(&target, kind)?;
    let mut file = OpenOptions::new()
        .read(true)
        .append(true)
        .create(true)
        .open(&target)
        .map_err(|e| FileError::io(&target, "open for appending", e))?;
    file.lock().map_err(|e| FileError::io(&target, "lock", e))?;
    let bytes = read_all(&mut file, &target, limit)?;
    let head = &bytes[..bytes.len().min(HEAD_BYTES)];
    if !bytes.is_empty() && !kind.matches_file(&target, head) {
        return Err(FileError::refused(
            &target,
            kind,
            format!(
                "is {}, not {}: nothing appended",
                describe_file(&target, head),
                kind.describe()
            ),
        ));
    }
    let Some(out) = line(&bytes) else {
        return Ok(false);
    };
    // O_APPEND: the write goes to the end whatever the file position.
    file.write_all(&out)
        .map_err(|e| FileError::io(&target, "append", e))?;
    file.sync_data()
        .map_err(|e| FileError::io(&target, "sync to disk", e))?;
    if !existed {
        sync_dir(parent_dir(&target))?;
    }
    Ok(true)
}

/// The bytes of the append-only file at `path` (`None` if it does not exist), read under a
/// shared lock (a writer holding the exclusive one finishes first), at most `limit`.
pub fn read_locked(path: &Path, limit: u64) -> Result<Option<Vec<u8>>, FileError> {
    let target = resolve(path)?;
    let mut file = match File::open(&target) {
        Ok(f) => f,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(e) => return Err(FileError::io(&target, "open", e)),
    };
    if !file
        .metadata()
        .map_err(|e| FileError::io(&target, "inspect", e))?
        .is_file()
    {
        return Err(FileError::io(
            &target,
            "read",
            std::io::Error::other("not a regular file"),
        ));
    }
    file.lock_shared()
        .map_err(|e| FileError::io(&target, "lock for reading", e))?;
    read_all(&mut file, &target, limit).map(Some)
}
