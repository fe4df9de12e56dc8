//! The one error type of the crate: every variant names the path it is about.

use crate::Kind;
use std::path::{Path, PathBuf};

/// Why a write (or a bounded read) was refused or failed.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum FileError {
    /// The destination exists and `--force` was not given.
    #[error("{} already exists; pass --force to replace it", .path.display())]
    Exists { path: PathBuf },
    /// The destination exists and is not what would be written there (another kind of file,
    /// a folder this tool did not write, a block device, ...): never replaced, `--force` or not.
    #[error("{}: {why}; refusing to replace it, even with --force", .path.display())]
    Refused {
        path: PathBuf,
        /// What the destination is and why that stops the write.
        why: String,
        /// The kind that was to be written.
        writing: Kind,
    },
    /// A special file that cannot take the write now (a FIFO nobody reads).
    #[error("{}: {why}", .path.display())]
    Special { path: PathBuf, why: String },
    /// An input larger than its limit (`limits`).
    #[error(
        "{}: larger than {limit} bytes, the limit for {what} (see docs/src/files-and-safety.md)",
        .path.display()
    )]
    TooLarge {
        path: PathBuf,
        what: &'static str,
        limit: u64,
    },
    /// An operating-system error.
    #[error("{}: cannot {action}: {source}", .path.display())]
    Io {
        path: PathBuf,
        action: &'static str,
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
