//! File output that never leaves half-written files, never overwrites without being asked, and
//! lets `--force` replace only what the tool wrote.
//!
//! - [`atomic_write`]: a file is written to a temporary sibling, synced, and renamed into place;
//!   without `overwrite` the rename refuses an existing target (`persist_noclobber`: an atomic
//!   link or `RENAME_NOREPLACE`), so of two concurrent writers of one path exactly one wins and
//!   the file holds that writer's bytes. Every I/O error (sync included) is reported.
//! - [`check_output_file`] and [`claim_dir`]: the same checks made before the work starts, so a
//!   run that would be refused at the end is refused at once.
//! - Output folders (reports) carry a marker file ([`REPORT_MARKER`]); `--force` replaces files
//!   in a folder with the marker and never touches a folder without it.

pub mod sections;

use anyhow::{bail, Context, Result};
use std::io::Write;
use std::path::Path;

/// Marker file of a report folder written by this toolkit.
pub const REPORT_MARKER: &str = ".zmp-report";

fn parent_dir(path: &Path) -> &Path {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    }
}

/// The error of a write refused because `path` exists.
fn exists_error(path: &Path) -> anyhow::Error {
    anyhow::anyhow!("{} exists; pass --force to overwrite it", path.display())
}

/// Checks, before any work, that a file can be written at `path`: it must not be a folder,
/// and must not exist unless `overwrite`.
pub fn check_output_file(path: &Path, overwrite: bool) -> Result<()> {
    match std::fs::symlink_metadata(path) {
        Ok(m) if m.is_dir() => bail!("{} is a folder, not a file name", path.display()),
        Ok(_) if !overwrite => Err(exists_error(path)),
        Ok(_) => Ok(()),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            let dir = parent_dir(path);
            match std::fs::metadata(dir) {
                Ok(m) if !m.is_dir() => bail!(
                    "{}: cannot write it, {} is not a folder",
                    path.display(),
                    dir.display()
                ),
                _ => Ok(()),
            }
        }
        Err(e) => Err(e).with_context(|| format!("inspecting {}", path.display())),
    }
}

/// Writes `bytes` to `path` through a temporary sibling file and a rename.
/// With `overwrite` false an existing file is an error, also when another process creates it
/// while this one writes (the rename itself refuses to replace it).
pub fn atomic_write(path: &Path, bytes: &[u8], overwrite: bool) -> Result<()> {
    check_output_file(path, overwrite)?;
    let dir = parent_dir(path);
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let mut tmp = tempfile::Builder::new()
        .prefix(".tmp-")
        .tempfile_in(dir)
        .with_context(|| format!("creating a temporary file in {}", dir.display()))?;
    tmp.write_all(bytes)
        .with_context(|| format!("writing {}", path.display()))?;
    // Temporary files are private; the result gets ordinary permissions.
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        tmp.as_file()
            .set_permissions(std::fs::Permissions::from_mode(0o644))
            .with_context(|| format!("setting the permissions of {}", path.display()))?;
    }
    tmp.as_file()
        .sync_all()
        .with_context(|| format!("syncing {} to disk", path.display()))?;
    if overwrite {
        tmp.persist(path)
            .map_err(|e| e.error)
            .with_context(|| format!("renaming into {}", path.display()))?;
    } else {
        match tmp.persist_noclobber(path) {
            Ok(_) => {}
            Err(e) if e.error.kind() == std::io::ErrorKind::AlreadyExists => {
                return Err(exists_error(path))
            }
            Err(e) => {
                return Err(e.error).with_context(|| format!("renaming into {}", path.display()))
            }
        }
    }
    sync_dir(dir)
}

/// Makes a rename in `dir` durable (fsync of the folder).
fn sync_dir(dir: &Path) -> Result<()> {
    #[cfg(unix)]
    {
        std::fs::File::open(dir)
            .and_then(|d| d.sync_all())
            .with_context(|| format!("syncing the folder {}", dir.display()))?;
    }
    #[cfg(not(unix))]
    let _ = dir;
    Ok(())
}

/// Makes `dir` an output folder of this toolkit, before any work is done:
/// - missing or empty: created, and the marker `marker` written into it;
/// - holding `marker` (an earlier output): accepted with `force`, otherwise an error that
///   says to pass `--force`;
/// - anything else (a folder the tool did not write, a file): refused, also with `force`.
pub fn claim_dir(dir: &Path, marker: &str, force: bool, what: &str) -> Result<()> {
    match std::fs::symlink_metadata(dir) {
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
        Err(e) => return Err(e).with_context(|| format!("inspecting {}", dir.display())),
        Ok(m) if m.file_type().is_symlink() => bail!(
            "{} is a symbolic link; write the {what} to its target instead",
            dir.display()
        ),
        Ok(m) if !m.is_dir() => bail!("{} exists and is not a folder", dir.display()),
        Ok(_) => {
            if dir.join(marker).is_file() {
                if !force {
                    bail!(
                        "{} holds an earlier {what}; pass --force to replace its files",
                        dir.display()
                    );
                }
                return Ok(());
            }
            let empty = std::fs::read_dir(dir)
                .with_context(|| format!("reading {}", dir.display()))?
                .next()
                .is_none();
            if !empty {
                bail!(
                    "{} exists and was not written by zmp-toolkit (it has no {marker} marker); \
                     refusing to write the {what} into it, even with --force: choose a new \
                     folder",
                    dir.display()
                );
            }
        }
    }
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let text = format!(
        "This folder holds a {what} written by zmp-toolkit; `--force` may replace its files.\n"
    );
    atomic_write(&dir.join(marker), text.as_bytes(), true)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn refuses_to_overwrite_unless_asked() {
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join("a/b.txt");
        atomic_write(&p, b"one", false).unwrap();
        let e = atomic_write(&p, b"two", false).unwrap_err();
        assert!(e.to_string().contains("--force"));
        assert_eq!(std::fs::read(&p).unwrap(), b"one");
        atomic_write(&p, b"two", true).unwrap();
        assert_eq!(std::fs::read(&p).unwrap(), b"two");
        // No temporary files left behind.
        assert_eq!(std::fs::read_dir(p.parent().unwrap()).unwrap().count(), 1);
        // A folder is not a file name, even with --force.
        let e = atomic_write(d.path(), b"x", true).unwrap_err();
        assert!(e.to_string().contains("is a folder"), "{e}");
    }

    #[test]
    fn claim_dir_replaces_only_marked_folders() {
        let d = tempfile::tempdir().unwrap();
        let new = d.path().join("report");
        claim_dir(&new, REPORT_MARKER, false, "report").unwrap();
        assert!(new.join(REPORT_MARKER).is_file());
        let e = claim_dir(&new, REPORT_MARKER, false, "report").unwrap_err();
        assert!(e.to_string().contains("--force"), "{e}");
        claim_dir(&new, REPORT_MARKER, true, "report").unwrap();

        let users = d.path().join("mine");
        std::fs::create_dir(&users).unwrap();
        std::fs::write(users.join("thesis.tex"), "precious").unwrap();
        for force in [false, true] {
            let e = claim_dir(&users, REPORT_MARKER, force, "report").unwrap_err();
            assert!(e.to_string().contains("not written by zmp-toolkit"), "{e}");
        }
        assert_eq!(std::fs::read_dir(&users).unwrap().count(), 1);
        assert_eq!(
            std::fs::read_to_string(users.join("thesis.tex")).unwrap(),
            "precious"
        );
        let file = d.path().join("file");
        std::fs::write(&file, "x").unwrap();
        assert!(claim_dir(&file, REPORT_MARKER, true, "report").is_err());
    }
}
