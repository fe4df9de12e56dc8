//! One file: where it really is (symbolic links followed), what is there, and the write.

use crate::kind::describe_file;
use crate::temp::{sweep, TempFile};
use crate::{FileError, Kind};
use std::io::Write;
use std::os::unix::fs::{FileTypeExt, OpenOptionsExt};
use std::path::{Path, PathBuf};

/// The folder a path is in (`.` for a bare name).
pub(crate) fn parent_dir(path: &Path) -> &Path {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    }
}

/// `path` with every symbolic link at its end followed (a chain of them too): the file that a
/// write to `path` changes. A dangling link gives the path it points to (created by the write).
pub fn resolve(path: &Path) -> Result<PathBuf, FileError> {
    let mut p = path.to_path_buf();
    for _ in 0..40 {
        match std::fs::symlink_metadata(&p) {
            Ok(m) if m.file_type().is_symlink() => {
                let to =
                    std::fs::read_link(&p).map_err(|e| FileError::io(&p, "read the link", e))?;
                p = if to.is_absolute() {
                    to
                } else {
                    parent_dir(&p).join(to)
                };
            }
            _ => return Ok(p),
        }
    }
    Err(FileError::io(
        path,
        "follow the link",
        std::io::Error::other("more than 40 symbolic links in a chain"),
    ))
}

/// What a write of a file finds at its (resolved) destination.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Found {
    /// Nothing: the file is created.
    Missing,
    /// A regular file the write may replace (empty, or of the kind written, with `--force`).
    Replaceable,
    /// A FIFO or a character device: written into, never replaced.
    Special,
}

/// Judges the resolved destination `path` of a file of `kind` (see the crate docs).
pub(crate) fn judge_file(path: &Path, kind: Kind, force: bool) -> Result<Found, FileError> {
    let meta = match std::fs::symlink_metadata(path) {
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            let dir = parent_dir(path);
            return match std::fs::metadata(dir) {
                Ok(m) if !m.is_dir() => Err(FileError::refused(
                    path,
                    kind,
                    format!("cannot be written: {} is not a folder", dir.display()),
                )),
                _ => Ok(Found::Missing),
            };
        }
        Err(e) => return Err(FileError::io(path, "inspect", e)),
        Ok(m) => m,
    };
    let t = meta.file_type();
    if t.is_dir() {
        return Err(FileError::refused(
            path,
            kind,
            "is a folder, not a file name",
        ));
    }
    if t.is_fifo() || t.is_char_device() {
        return Ok(Found::Special);
    }
    if t.is_block_device() {
        return Err(FileError::refused(
            path,
            kind,
            "is a block device (a disk or a partition): the toolkit never writes into one",
        ));
    }
    if t.is_socket() {
        return Err(FileError::refused(path, kind, "is a socket"));
    }
    if !force {
        return Err(FileError::Exists {
            path: path.to_path_buf(),
        });
    }
    let head = crate::read::head(path).map_err(|e| FileError::io(path, "read", e))?;
    if head.is_empty() || kind.matches_file(path, &head) {
        Ok(Found::Replaceable)
    } else {
        Err(FileError::refused(
            path,
            kind,
            format!(
                "is {}, and this would write {} over it",
                describe_file(path, &head),
                kind.describe()
            ),
        ))
    }
}

/// Checks, before any work, that a file of `kind` can be written at `path` (the checks
/// [`write_file`] makes first), so that a run that would be refused at its end is refused at
/// once.
pub fn check_file(path: &Path, kind: Kind, force: bool) -> Result<(), FileError> {
    judge_file(&resolve(path)?, kind, force).map(|_| ())
}

/// A file written by [`write_file`].
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Written {
    /// Where the bytes went (the destination with its links followed).
    pub path: PathBuf,
    /// It is a FIFO or a character device the bytes were written into (no ledger, no hash on
    /// disk to check later).
    pub special: bool,
}

/// Writes `bytes` as a file of `kind` at `path` by the rules of the crate docs: nothing is
/// replaced without `force`, a file of another kind never, a regular file atomically (a
/// temporary sibling, synced, renamed into place, the folder synced); a FIFO or a character
/// device is written into. Of two writers of one new path without `force`, exactly one wins.
pub fn write_file(
    path: &Path,
    kind: Kind,
    bytes: &[u8],
    force: bool,
) -> Result<Written, FileError> {
    let target = resolve(path)?;
    match judge_file(&target, kind, force)? {
        Found::Special => {
            write_into_special(&target, bytes)?;
            Ok(Written {
                path: target,
                special: true,
            })
        }
        found => {
            replace_atomically(&target, bytes, found == Found::Replaceable)?;
            Ok(Written {
                path: target,
                special: false,
            })
        }
    }
}

/// The regular-file write: temporary sibling, sync, rename (refusing an existing file unless
/// `replace`), sync of the folder.
fn replace_atomically(target: &Path, bytes: &[u8], replace: bool) -> Result<(), FileError> {
    let dir = parent_dir(target);
    std::fs::create_dir_all(dir).map_err(|e| FileError::io(dir, "create", e))?;
    sweep(dir);
    let name = target
        .file_name()
        .ok_or_else(|| FileError::refused(target, Kind::Marker, "does not end in a file name"))?;
    let mut tmp = TempFile::create(dir, name)?;
    tmp.file
        .write_all(bytes)
        .map_err(|e| FileError::io(target, "write", e))?;
    tmp.file
        .sync_all()
        .map_err(|e| FileError::io(target, "sync to disk", e))?;
    if replace {
        std::fs::rename(&tmp.path, target).map_err(|e| FileError::io(target, "rename into", e))?;
    } else {
        rename_noreplace(&tmp.path, target)?;
    }
    tmp.keep();
    sync_dir(dir)
}

/// Renames `from` to `to` unless `to` exists (atomically: `RENAME_NOREPLACE`, or a hard link
/// where the file system lacks it).
pub(crate) fn rename_noreplace(from: &Path, to: &Path) -> Result<(), FileError> {
    use rustix::fs::{renameat_with, RenameFlags, CWD};
    match renameat_with(CWD, from, CWD, to, RenameFlags::NOREPLACE) {
        Ok(()) => Ok(()),
        Err(rustix::io::Errno::EXIST) => Err(FileError::Exists {
            path: to.to_path_buf(),
        }),
        Err(rustix::io::Errno::INVAL | rustix::io::Errno::NOSYS) => {
            match std::fs::hard_link(from, to) {
                Ok(()) => {
                    let _ = std::fs::remove_file(from);
                    Ok(())
                }
                Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => Err(FileError::Exists {
                    path: to.to_path_buf(),
                }),
                Err(e) => Err(FileError::io(to, "rename into", e)),
            }
        }
        Err(e) => Err(FileError::io(to, "rename into", e.into())),
    }
}

/// Makes the renames in `dir` durable.
pub(crate) fn sync_dir(dir: &Path) -> Result<(), FileError> {
    std::fs::File::open(dir)
        .and_then(|d| d.sync_all())
        .map_err(|e| FileError::io(dir, "sync the folder", e))
}

/// Writes into a FIFO (which must have a reader: a write to a FIFO nobody reads would wait
/// for ever) or a character device; never creates, truncates or replaces it.
fn write_into_special(path: &Path, bytes: &[u8]) -> Result<(), FileError> {
    let nonblock = rustix::fs::OFlags::NONBLOCK.bits() as i32;
    let f = std::fs::OpenOptions::new()
        .write(true)
        .custom_flags(nonblock)
        .open(path)
        .map_err(|e| {
            if e.raw_os_error() == Some(rustix::io::Errno::NXIO.raw_os_error()) {
                FileError::Special {
                    path: path.to_path_buf(),
                    why: "is a FIFO that no process is reading; start its reader first".into(),
                }
            } else {
                FileError::io(path, "open for writing", e)
            }
        })?;
    // Blocking writes from here on (a reader that is slow is waited for).
    let flags = rustix::fs::fcntl_getfl(&f).map_err(|e| FileError::io(path, "write", e.into()))?;
    rustix::fs::fcntl_setfl(&f, flags - rustix::fs::OFlags::NONBLOCK)
        .map_err(|e| FileError::io(path, "write", e.into()))?;
    (&f).write_all(bytes)
        .map_err(|e| FileError::io(path, "write", e))
}
