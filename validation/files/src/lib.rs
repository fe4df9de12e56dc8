//! The one way zmp-toolkit writes its outputs, and reads its inputs within a size limit.
//!
//! Every file and folder a command writes (models, the ledger, reports, plots, campaigns,
//! FMUs, summaries, the twin's folders) goes through this crate, by these rules:
//!
//! 1. **Nothing is replaced without `--force`** (`force`): an existing destination is an
//!    error ([`FileError::Exists`]) that says to pass it.
//! 2. **Every file has a [`Kind`]**, and `--force` replaces only a file of the kind being
//!    written ([`Kind::rule`]: recognised by its content, its name, or a marker), or an empty
//!    file. A file of another kind (an SVG plot over the ledger, a model over a CSV, a report
//!    over a user's notes) is refused even with `--force` ([`FileError::Refused`]). A folder is
//!    replaced or written into only if it is empty or of the kind written (its marker file,
//!    or its `campaign.toml`); a folder the tool did not write is never touched.
//! 3. **Regular files are replaced atomically**: written to a temporary sibling, synced,
//!    renamed into place, the folder synced. A reader sees the old file or the new one, never
//!    part of one; of two writers of one new path without `--force`, exactly one wins.
//!    Folders are built aside and swapped in whole ([`write_dir`], `RENAME_EXCHANGE`).
//! 4. **Special files are written into, never replaced**: a FIFO (which must have a reader: a
//!    FIFO nobody reads is an error, not a wait) or a character device (`/dev/null`,
//!    `/dev/stdout`) receives the bytes, with or without `--force`, and stays what it is; no
//!    ledger entry is made for a model written into one. Block devices and sockets are refused.
//! 5. **Symbolic links are followed**: the file or folder a link leads to (through a chain of
//!    links) is judged by the same rules and written; the link stays. A dangling link creates
//!    its target.
//! 6. **Temporary files and folders live beside their destination** (`.NAME.zmp-tmp-PID-N`),
//!    are removed on error, and those a killed run left are removed by the next write into
//!    that folder ([`sweep`]: only when their process is gone and their lock is free).
//! 7. **Append-only files** (the ledger) are appended under an exclusive lock in one write
//!    and synced ([`append_locked`]); they must be regular files of their kind.
//! 8. **Inputs are read within a limit** ([`read_limited`], [`limits`]): a file larger than
//!    its limit, or a device that never ends, is an error naming the file and the limit, and
//!    memory is reserved fallibly (no abort under a memory limit).
#![warn(missing_docs)]

mod append;
mod dir;
mod error;
mod file;
mod kind;
mod read;
pub mod sections;
mod temp;

pub use append::{append_locked, read_locked};
pub use dir::{check_dir, claim_dir, remove, write_dir, Staging};
pub use error::FileError;
pub use file::{check_file, resolve, write_file, Written};
pub use kind::{
    describe_file, Kind, DEMO_MARKER, HEAD_BYTES, JOB_MARKER, LEDGER_FILE, LOOP_MARKER,
    REPORT_MARKER, TWIN_SILO2_MARKER,
};
pub use read::{limits, read_limited, read_limited_into, read_limited_text};
pub use temp::sweep;

/// SHA-256 of `bytes`, as 64 lowercase hex digits (the ledger's content hash).
pub fn sha256_hex(bytes: &[u8]) -> String {
    use sha2::Digest;
    let digest = sha2::Sha256::digest(bytes);
    let mut s = String::with_capacity(64);
    for b in digest.iter() {
        s.push_str(&format!("{b:02x}"));
    }
    s
}
