//! Output folders: claimed in place (reports, the loop's folder) or built aside and swapped
//! into place whole (campaigns, the demo's and the twin's folders).

use crate::file::{parent_dir, resolve, sync_dir};
use crate::kind::DirMatch;
use crate::temp::{sweep, TempDir};
use crate::{FileError, Kind};
use std::path::{Path, PathBuf};

/// What a folder write finds at its (resolved) destination.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum FoundDir {
    Missing,
    Empty,
    /// A folder of the kind written (replaced or written into with `--force`).
    Same,
}

fn judge_dir(dir: &Path, kind: Kind, force: bool) -> Result<FoundDir, FileError> {
    let meta = match std::fs::symlink_metadata(dir) {
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(FoundDir::Missing),
        Err(e) => return Err(FileError::io(dir, "inspect", e)),
        Ok(m) => m,
    };
    if !meta.is_dir() {
        return Err(FileError::refused(dir, kind, "exists and is not a folder"));
    }
    let empty = std::fs::read_dir(dir)
        .map_err(|e| FileError::io(dir, "read", e))?
        .next()
        .is_none();
    if empty {
        return Ok(FoundDir::Empty);
    }
    match kind.matches_dir(dir) {
        DirMatch::No(why) => Err(FileError::refused(dir, kind, why)),
        DirMatch::Yes if force => Ok(FoundDir::Same),
        DirMatch::Yes => Err(FileError::Exists {
            path: dir.to_path_buf(),
        }),
    }
}

/// Checks, before any work, that a folder of `kind` can be written at `dir` (what
/// [`write_dir`] and [`claim_dir`] check first).
pub fn check_dir(dir: &Path, kind: Kind, force: bool) -> Result<(), FileError> {
    judge_dir(&resolve(dir)?, kind, force).map(|_| ())
}

/// The text of a folder's marker file.
fn marker_text(kind: Kind) -> String {
    format!(
        "This folder holds {} written by zmp-toolkit; `--force` may replace its files.\n",
        kind.describe()
    )
}

/// A folder being built aside: its files are written with [`Staging::write`] or
/// [`Staging::create`]; it is removed if the build fails or the process ends before
/// [`write_dir`] swaps it into place (by the next write beside it, if the process was killed).
pub struct Staging {
    tmp: TempDir,
}

impl Staging {
    /// The folder being built (a hidden sibling of the destination).
    pub fn path(&self) -> &Path {
        &self.tmp.path
    }

    /// Writes the file `rel` (a relative path; its folders are created) into the folder.
    pub fn write(&self, rel: &Path, bytes: &[u8]) -> Result<(), FileError> {
        use std::io::Write;
        let mut f = self.create(rel)?;
        let path = self.tmp.path.join(rel);
        f.write_all(bytes)
            .map_err(|e| FileError::io(&path, "write", e))
    }

    /// Creates the file `rel` (its folders too) for the caller to write; it must not exist.
    pub fn create(&self, rel: &Path) -> Result<std::fs::File, FileError> {
        if rel.is_absolute()
            || rel
                .components()
                .any(|c| !matches!(c, std::path::Component::Normal(_)))
        {
            return Err(FileError::refused(
                rel,
                Kind::Record,
                "is not a plain relative path inside the folder",
            ));
        }
        let path = self.tmp.path.join(rel);
        if let Some(p) = path.parent() {
            std::fs::create_dir_all(p).map_err(|e| FileError::io(p, "create", e))?;
        }
        std::fs::OpenOptions::new()
            .write(true)
            .create_new(true)
            .open(&path)
            .map_err(|e| FileError::io(&path, "create", e))
    }
}

/// Every file and folder under `dir` synced to disk (before the folder is swapped in).
fn sync_tree(dir: &Path) -> Result<(), FileError> {
    let entries = std::fs::read_dir(dir).map_err(|e| FileError::io(dir, "read", e))?;
    for e in entries {
        let e = e.map_err(|e| FileError::io(dir, "read", e))?;
        let p = e.path();
        let t = e.file_type().map_err(|e| FileError::io(&p, "inspect", e))?;
        if t.is_dir() {
            sync_tree(&p)?;
        } else if t.is_file() {
            std::fs::File::open(&p)
                .and_then(|f| f.sync_all())
                .map_err(|e| FileError::io(&p, "sync to disk", e))?;
        }
    }
    sync_dir(dir)
}

/// Writes a folder of `kind` at `dir`: `fill` builds it in a hidden sibling (with the kind's
/// marker already in it), which then takes the destination's place in one step, so `dir`
/// holds either the complete old folder or the complete new one, never a mix or nothing.
///
/// The destination may be missing or empty; a folder of the same kind is replaced only with
/// `force` (it is swapped out with `RENAME_EXCHANGE` and then deleted); anything else is
/// refused, `force` or not. Symbolic links are followed and the folder they lead to is judged.
/// On an error (of `fill` too) the sibling is removed. Returns `fill`'s value and where the
/// folder is.
pub fn write_dir<T, E: From<FileError>>(
    dir: &Path,
    kind: Kind,
    force: bool,
    fill: impl FnOnce(&Staging) -> Result<T, E>,
) -> Result<(T, PathBuf), E> {
    let target = resolve(dir)?;
    judge_dir(&target, kind, force)?;
    let name = target
        .file_name()
        .ok_or_else(|| FileError::refused(&target, kind, "does not end in a folder name"))?;
    let parent = parent_dir(&target).to_path_buf();
    std::fs::create_dir_all(&parent).map_err(|e| FileError::io(&parent, "create", e))?;
    sweep(&parent);
    let staging = Staging {
        tmp: TempDir::create(&parent, name)?,
    };
    // Like a plain mkdir: 0777 less the umask.
    if let Some(marker) = kind.marker() {
        staging.write(Path::new(marker), marker_text(kind).as_bytes())?;
    }
    let value = fill(&staging)?;
    sync_tree(staging.path())?;
    // Judged again: another run may have written the destination meanwhile.
    let found = judge_dir(&target, kind, force)?;
    swap_in(staging, &target, found)?;
    sync_dir(&parent)?;
    Ok((value, target))
}

/// Puts the built folder in place of `target`.
fn swap_in(staging: Staging, target: &Path, found: FoundDir) -> Result<(), FileError> {
    let tmp = &staging.tmp.path;
    match found {
        FoundDir::Missing | FoundDir::Empty => {
            // rename(2) replaces a missing or empty folder and refuses a non-empty one,
            // atomically: of two writers that both found the destination free, one gets it.
            match std::fs::rename(tmp, target) {
                Ok(()) => {}
                Err(e)
                    if matches!(
                        e.kind(),
                        std::io::ErrorKind::DirectoryNotEmpty | std::io::ErrorKind::AlreadyExists
                    ) =>
                {
                    return Err(FileError::Exists {
                        path: target.to_path_buf(),
                    })
                }
                Err(e) => return Err(FileError::io(target, "rename into", e)),
            }
            staging.tmp.keep();
        }
        FoundDir::Same => {
            use rustix::fs::{renameat_with, RenameFlags, CWD};
            match renameat_with(CWD, tmp.as_path(), CWD, target, RenameFlags::EXCHANGE) {
                // The old folder now has the temporary name: dropping `staging` deletes it (a
                // kill before that leaves it to the next run's sweep).
                Ok(()) => drop(staging),
                Err(rustix::io::Errno::INVAL | rustix::io::Errno::NOSYS) => {
                    // No exchange on this file system: the old folder is moved aside first.
                    let aside = TempDir::create(
                        parent_dir(target),
                        target.file_name().unwrap_or_default(),
                    )?;
                    let old = aside.path.join("old");
                    std::fs::rename(target, &old)
                        .map_err(|e| FileError::io(target, "move aside", e))?;
                    if let Err(e) = std::fs::rename(tmp, target) {
                        let _ = std::fs::rename(&old, target);
                        return Err(FileError::io(target, "rename into", e));
                    }
                    staging.tmp.keep();
                    drop(aside);
                }
                Err(e) => return Err(FileError::io(target, "swap into", e.into())),
            }
        }
    }
    Ok(())
}

/// Makes `dir` an output folder of `kind` written file by file in place (reports, the loop's
/// folder), before any work is done:
/// - missing: created with the kind's marker in one step (built aside and renamed, so a killed
///   run never leaves a folder without its marker);
/// - empty: the marker is written into it;
/// - of the same kind (its marker is there): accepted with `force`, otherwise
///   [`FileError::Exists`];
/// - anything else (a folder the tool did not write, a file, a special file): refused, also
///   with `force`.
///
/// Returns the folder (its symbolic links followed).
pub fn claim_dir(dir: &Path, kind: Kind, force: bool) -> Result<PathBuf, FileError> {
    let target = resolve(dir)?;
    let marker = kind.marker().ok_or_else(|| {
        FileError::refused(
            &target,
            kind,
            "is not a kind of folder that is claimed in place",
        )
    })?;
    match judge_dir(&target, kind, force)? {
        // Created, never swapped: a folder another run made meanwhile (and may be writing
        // into) is judged as it is now, not replaced, also with `force`.
        FoundDir::Missing => match write_dir(&target, kind, false, |_| Ok::<_, FileError>(())) {
            Ok(_) => {}
            // Created by another run meanwhile: judged as it is now.
            Err(FileError::Exists { .. }) => return claim_dir(&target, kind, force),
            Err(e) => return Err(e),
        },
        FoundDir::Empty => {
            crate::file::write_file(
                &target.join(marker),
                Kind::Marker,
                marker_text(kind).as_bytes(),
                true,
            )?;
        }
        FoundDir::Same => {}
    }
    Ok(target)
}

/// Removes the file or folder `path` if it is of `kind` (a folder is first renamed to a
/// temporary name beside it, so that a run killed while deleting it leaves a temporary the
/// next write there sweeps, never a half-deleted folder without its marker). Returns whether
/// it removed anything: a missing path or one of another kind is left alone.
pub fn remove(path: &Path, kind: Kind) -> Result<bool, FileError> {
    let meta = match std::fs::symlink_metadata(path) {
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(false),
        Err(e) => return Err(FileError::io(path, "inspect", e)),
        Ok(m) => m,
    };
    if kind.is_dir() {
        if !meta.is_dir() || !matches!(kind.matches_dir(path), DirMatch::Yes) {
            return Ok(false);
        }
        let name = path.file_name().unwrap_or_default();
        let parent = parent_dir(path);
        let aside = TempDir::create(parent, name)?;
        let gone = aside.path.join("old");
        std::fs::rename(path, &gone).map_err(|e| FileError::io(path, "move aside", e))?;
        drop(aside);
        return Ok(true);
    }
    if !meta.is_file() {
        return Ok(false);
    }
    let head = crate::read::head(path).map_err(|e| FileError::io(path, "read", e))?;
    if !kind.matches_file(path, &head) {
        return Ok(false);
    }
    std::fs::remove_file(path).map_err(|e| FileError::io(path, "remove", e))?;
    Ok(true)
}
