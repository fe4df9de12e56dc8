//! Reads of inputs within a size limit: a file of any size, a device that never ends
//! (`/dev/zero`) or a FIFO stops at its limit with [`FileError::TooLarge`], and memory is
//! reserved fallibly, so that a limit on the process's memory gives an error, not an abort.

use crate::FileError;
use std::io::Read;
use std::path::Path;

/// The documented size limits of the toolkit's inputs (`docs/src/files-and-safety.md`).
pub mod limits {
    /// `campaign.toml`: 64 MiB (about 400 000 records; a 10 000-record campaign's is 1.5 MB).
    pub const MANIFEST_BYTES: u64 = 64 << 20;
    /// One record CSV: 256 MiB (about 3 million rows of five full-precision columns: over an
    /// hour and a half at 500 Hz).
    pub const RECORD_BYTES: u64 = 256 << 20;
    /// A model file or an experiment design: 16 MiB (the largest model is a few kB).
    pub const MODEL_BYTES: u64 = 16 << 20;
    /// A model ledger: 256 MiB (about a million entries).
    pub const LEDGER_BYTES: u64 = 256 << 20;
}

/// Reads the whole of `path`, at most `limit` bytes; `what` names the input in the error.
pub fn read_limited(path: &Path, limit: u64, what: &'static str) -> Result<Vec<u8>, FileError> {
    let mut buf = Vec::new();
    read_limited_into(path, limit, what, &mut buf)?;
    Ok(buf)
}

/// [`read_limited`] as UTF-8 text; `what` names the input in the error.
pub fn read_limited_text(path: &Path, limit: u64, what: &'static str) -> Result<String, FileError> {
    let bytes = read_limited(path, limit, what)?;
    String::from_utf8(bytes).map_err(|e| {
        FileError::io(
            path,
            "read",
            std::io::Error::new(
                std::io::ErrorKind::InvalidData,
                format!(
                    "not UTF-8 text (bad byte at offset {})",
                    e.utf8_error().valid_up_to()
                ),
            ),
        )
    })
}

/// [`read_limited`] into `buf` (cleared first; its capacity is reused).
pub fn read_limited_into(
    path: &Path,
    limit: u64,
    what: &'static str,
    buf: &mut Vec<u8>,
) -> Result<(), FileError> {
    buf.clear();
    let too_large = || FileError::TooLarge {
        path: path.to_path_buf(),
        what,
        limit,
    };
    let mut f = std::fs::File::open(path).map_err(|e| FileError::io(path, "read", e))?;
    let meta = f.metadata().map_err(|e| FileError::io(path, "read", e))?;
    if meta.is_dir() {
        return Err(FileError::io(
            path,
            "read",
            std::io::Error::new(std::io::ErrorKind::IsADirectory, "is a folder"),
        ));
    }
    if meta.is_file() {
        if meta.len() > limit {
            return Err(too_large());
        }
        reserve(buf, meta.len() as usize + 1, path)?;
    }
    // Reads in steps of at most 1 MiB into memory reserved fallibly, up to the limit + 1.
    let mut chunk: u64 = 64 * 1024;
    loop {
        let len = buf.len() as u64;
        if len > limit {
            return Err(too_large());
        }
        if buf.len() == buf.capacity() {
            reserve(buf, chunk.min(limit + 1 - len) as usize, path)?;
            chunk = (chunk * 2).min(64 << 20);
        }
        let start = buf.len();
        let step = ((buf.capacity() - start) as u64)
            .min(limit + 1 - len)
            .min(1 << 20) as usize;
        buf.resize(start + step, 0);
        match f.read(&mut buf[start..]) {
            Ok(0) => {
                buf.truncate(start);
                break;
            }
            Ok(n) => buf.truncate(start + n),
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => buf.truncate(start),
            Err(e) => {
                buf.truncate(start);
                return Err(FileError::io(path, "read", e));
            }
        }
    }
    Ok(())
}

fn reserve(buf: &mut Vec<u8>, additional: usize, path: &Path) -> Result<(), FileError> {
    buf.try_reserve(additional).map_err(|e| {
        FileError::io(
            path,
            "read",
            std::io::Error::new(std::io::ErrorKind::OutOfMemory, e.to_string()),
        )
    })
}

/// The first [`crate::kind::HEAD_BYTES`] of a regular file (what kinds are recognised from).
pub(crate) fn head(path: &Path) -> std::io::Result<Vec<u8>> {
    let f = std::fs::File::open(path)?;
    let mut out = Vec::new();
    f.take(crate::kind::HEAD_BYTES as u64)
        .read_to_end(&mut out)?;
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_stop_at_the_limit() {
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join("a");
        std::fs::write(&p, vec![7u8; 300_000]).unwrap();
        assert_eq!(read_limited(&p, 300_000, "a test").unwrap().len(), 300_000);
        let e = read_limited(&p, 299_999, "a test").unwrap_err();
        assert!(
            matches!(e, FileError::TooLarge { limit: 299_999, .. }),
            "{e}"
        );
        std::fs::write(&p, b"").unwrap();
        assert!(read_limited(&p, 10, "a test").unwrap().is_empty());
        // A device without end.
        let e = read_limited(Path::new("/dev/zero"), 1 << 20, "a test").unwrap_err();
        assert!(e.to_string().contains("larger than 1048576 bytes"), "{e}");
        let mut buf = vec![1, 2, 3];
        std::fs::write(&p, b"xyz").unwrap();
        read_limited_into(&p, 3, "a test", &mut buf).unwrap();
        assert_eq!(buf, b"xyz");
    }
}
