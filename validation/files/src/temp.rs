//! Temporary files and folders beside their destination, and the removal of those a killed
//! run left behind.
//!
//! A temporary entry is named `.<destination name>.zmp-tmp-<pid>-<n>` and lives in the
//! destination's folder (so that the final rename never crosses a file system). While its
//! writer works it holds an exclusive `flock` on it. [`sweep`] (run before every write into a
//! folder) removes an entry only when both say its writer is gone: the process `<pid>` does not
//! exist and the lock can be taken. A live writer is never disturbed (its pid exists; in
//! another pid namespace its lock is held), and a killed one's entry goes at the next write.

use crate::FileError;
use std::ffi::{OsStr, OsString};
use std::fs::File;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

/// What every temporary name holds between the destination's name and the writer's pid.
pub(crate) const TMP_TAG: &str = ".zmp-tmp-";

/// A fresh temporary name for `dest_name` (unique in this process; the pid makes it unique
/// between processes).
pub(crate) fn temp_name(dest_name: &OsStr) -> OsString {
    static SEQ: AtomicU64 = AtomicU64::new(0);
    let mut name = OsString::from(".");
    // Long names are cut: the temporary name must stay within NAME_MAX (255 bytes).
    let shown = dest_name.to_string_lossy();
    let cut: String = shown.chars().take(160).collect();
    name.push(cut);
    name.push(format!(
        "{TMP_TAG}{}-{}",
        std::process::id(),
        SEQ.fetch_add(1, Ordering::Relaxed)
    ));
    name
}

/// The writer's pid in a temporary name, if it is one.
fn writer_pid(name: &str) -> Option<u32> {
    if !name.starts_with('.') {
        return None;
    }
    let at = name.rfind(TMP_TAG)? + TMP_TAG.len();
    let (pid, seq) = name[at..].split_once('-')?;
    seq.parse::<u64>().ok()?;
    pid.parse().ok()
}

/// Whether process `pid` exists (a process we may not signal exists too).
fn alive(pid: u32) -> bool {
    let Ok(raw) = i32::try_from(pid) else {
        return false;
    };
    let Some(pid) = rustix::process::Pid::from_raw(raw) else {
        return false;
    };
    !matches!(
        rustix::process::test_kill_process(pid),
        Err(rustix::io::Errno::SRCH)
    )
}

/// Removes the temporary files and folders in `dir` whose writers are gone (see the module
/// docs); returns what it removed. Errors are ignored: what cannot be removed now is tried
/// again at the next write.
pub fn sweep(dir: &Path) -> Vec<PathBuf> {
    let mut removed = Vec::new();
    let Ok(entries) = std::fs::read_dir(dir) else {
        return removed;
    };
    for e in entries.flatten() {
        let name = e.file_name();
        let Some(pid) = name.to_str().and_then(writer_pid) else {
            continue;
        };
        if pid == std::process::id() || alive(pid) {
            continue;
        }
        let path = e.path();
        let Ok(meta) = std::fs::symlink_metadata(&path) else {
            continue;
        };
        // The lock is taken on the entry itself (a folder's descriptor can be locked too).
        let Ok(f) = File::open(&path) else {
            continue;
        };
        if f.try_lock().is_err() {
            continue;
        }
        let gone = if meta.is_dir() {
            std::fs::remove_dir_all(&path)
        } else {
            std::fs::remove_file(&path)
        };
        if gone.is_ok() {
            removed.push(path);
        }
    }
    removed
}

/// A temporary file being written: created exclusively, locked, removed on drop unless kept.
pub(crate) struct TempFile {
    pub(crate) path: PathBuf,
    pub(crate) file: File,
    kept: bool,
}

impl TempFile {
    /// A new temporary file for the destination named `dest_name` in `dir`.
    pub(crate) fn create(dir: &Path, dest_name: &OsStr) -> Result<TempFile, FileError> {
        loop {
            let path = dir.join(temp_name(dest_name));
            match std::fs::OpenOptions::new()
                .write(true)
                .create_new(true)
                .open(&path)
            {
                Ok(file) => {
                    // New and ours: the lock cannot be held by anyone else.
                    let _ = file.try_lock();
                    return Ok(TempFile {
                        path,
                        file,
                        kept: false,
                    });
                }
                Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => continue,
                Err(e) => return Err(FileError::io(dir, "create a temporary file in", e)),
            }
        }
    }

    /// The file was renamed into place: nothing to remove.
    pub(crate) fn keep(mut self) {
        self.kept = true;
    }
}

impl Drop for TempFile {
    fn drop(&mut self) {
        if !self.kept {
            let _ = std::fs::remove_file(&self.path);
        }
    }
}

/// A temporary folder being filled: created, locked, removed on drop unless kept.
pub(crate) struct TempDir {
    pub(crate) path: PathBuf,
    _lock: File,
    kept: bool,
}

impl TempDir {
    pub(crate) fn create(dir: &Path, dest_name: &OsStr) -> Result<TempDir, FileError> {
        loop {
            let path = dir.join(temp_name(dest_name));
            match std::fs::create_dir(&path) {
                Ok(()) => {
                    let lock = File::open(&path)
                        .map_err(|e| FileError::io(&path, "open the temporary folder", e))?;
                    let _ = lock.try_lock();
                    return Ok(TempDir {
                        path,
                        _lock: lock,
                        kept: false,
                    });
                }
                Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => continue,
                Err(e) => return Err(FileError::io(dir, "create a temporary folder in", e)),
            }
        }
    }

    pub(crate) fn keep(mut self) {
        self.kept = true;
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        if !self.kept {
            let _ = std::fs::remove_dir_all(&self.path);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_carry_the_writer() {
        let n = temp_name(OsStr::new("campaign"));
        let s = n.to_str().unwrap();
        assert!(s.starts_with(".campaign.zmp-tmp-"), "{s}");
        assert_eq!(writer_pid(s), Some(std::process::id()));
        assert_eq!(writer_pid("campaign.zmp-tmp-12-3"), None);
        assert_eq!(writer_pid(".a.zmp-tmp-x-3"), None);
        assert!(alive(std::process::id()));
    }

    #[test]
    fn only_entries_of_gone_writers_are_swept() {
        let d = tempfile::tempdir().unwrap();
        // A writer that is gone: a child that has exited (its pid is free).
        let mut child = std::process::Command::new("true").spawn().unwrap();
        let dead = child.id();
        child.wait().unwrap();
        let stale_dir = d.path().join(format!(".c{TMP_TAG}{dead}-0"));
        std::fs::create_dir_all(stale_dir.join("records")).unwrap();
        std::fs::write(stale_dir.join("records/r.csv"), "x").unwrap();
        let stale_file = d.path().join(format!(".m.toml{TMP_TAG}{dead}-1"));
        std::fs::write(&stale_file, "half").unwrap();
        // A live writer: this process, and a folder another live process holds locked.
        let mine = TempDir::create(d.path(), OsStr::new("c")).unwrap();
        let user = d.path().join("keep.txt");
        std::fs::write(&user, "mine").unwrap();
        let removed = sweep(d.path());
        assert_eq!(removed.len(), 2, "{removed:?}");
        assert!(!stale_dir.exists() && !stale_file.exists());
        assert!(mine.path.exists() && user.exists());
        drop(mine);
        assert_eq!(std::fs::read_dir(d.path()).unwrap().count(), 1);
    }
}
