//! The one error type of the crate: every variant names the path it is about.

use crate::Kind;
use std::path::{Path, PathBuf};

/// Why a write (or a bounded read) was refused or failed.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum FileError {
    /// The destination exists and `--force` was not given.
    #[error("{} already exists; pass --force to replace it", .path.display())]
    Exists {
        /// The destination.
        path: PathBuf,
    },
    /// The destination exists and is not what would be written there (another kind of file,
    /// a folder this tool did not write, a block device, ...): never replaced, `--force` or not.
    #[error("{}: {why}; refusing to replace it, even with --force", .path.display())]
    Refused {
        /// The destination.
        path: PathBuf,
        /// What the destination is and why that stops the write.
        why: String,
        /// The kind that was to be written.
        writing: Kind,
    },
    /// A special file that cannot take the write now (a FIFO nobody reads).
    #[error("{}: {why}", .path.display())]
    Special {
        /// The special file.
        path: PathBuf,
        /// Why it cannot take the write.
        why: String,
    },
    /// An input larger than its limit (`limits`).
    #[error(
        "{}: larger than {limit} bytes, the limit for {what} (see docs/src/files-and-safety.md)",
        .path.display()
    )]
    TooLarge {
        /// The input.
        path: PathBuf,
        /// What the input is ("a model file").
        what: &'static str,
        /// The limit, bytes.
        limit: u64,
    },
    /// An operating-system error.
    #[error("{}: cannot {action}: {source}", .path.display())]
    Io {
        /// The file or folder acted on.
        path: PathBuf,
        /// What was being done ("create", "rename into").
        action: &'static str,
        /// The operating system's error.
        #[source]
        source: std::io::Error,
    },
}

impl FileError {
    pub(crate) fn io(path: &Path, action: &'static str, source: std::io::Error) -> FileError {
        FileError::Io {
            path: path.to_path_buf(),
            action,
            source,
        }
    }

    pub(crate) fn refused(path: &Path, writing: Kind, why: impl Into<String>) -> FileError {
        FileError::Refused {
            path: path.to_path_buf(),
            why: why.into(),
            writing,
        }
    }

    /// The path the error is about.
    pub fn path(&self) -> &Path {
        match self {
            FileError::Exists { path }
            | FileError::Refused { path, .. }
            | FileError::Special { path, .. }
            | FileError::TooLarge { path, .. }
            | FileError::Io { path, .. } => path,
        }
    }

    /// True when the destination was refused because it exists and `--force` was not given.
    pub fn is_exists(&self) -> bool {
        matches!(self, FileError::Exists { .. })
    }
}
