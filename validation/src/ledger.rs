//! The model ledger: one JSON line per model version written by `identify` or `augment`, kept
//! beside the model files (`zmp-ledger.jsonl` in their folder), so that the history of a model
//! (which effect was added when, and what it did to the error) can be shown as a waterfall.

use crate::io::atomic_write;
use anyhow::{Context, Result};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// File name of the ledger in a model's folder.
pub const LEDGER_FILE: &str = "zmp-ledger.jsonl";

/// One model version.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Entry {
    /// Model file name (relative to the ledger's folder).
    pub model: String,
    /// Hash of the model file's contents when written (FNV-1a, hex).
    pub hash: String,
    /// The model this one was made from (file name in the same folder), if any.
    pub parent: Option<String>,
    /// What made it: `identified`, `+time_delay`, `refit`.
    pub change: String,
    /// Campaign the error is measured on, as given.
    pub campaign: String,
    /// The diagnosis error measure on that campaign, and its noise floor.
    pub error: f64,
    pub noise_floor: f64,
    pub date: String,
    pub tool: String,
}

/// FNV-1a 64 of `bytes`, hex.
pub fn content_hash(bytes: &[u8]) -> String {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for b in bytes {
        h ^= *b as u64;
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
    format!("{h:016x}")
}

/// The ledger file of the folder `model` is in.
pub fn ledger_path(model: &Path) -> PathBuf {
    model
        .parent()
        .map(|p| {
            if p.as_os_str().is_empty() {
                Path::new(".")
            } else {
                p
            }
        })
        .unwrap_or(Path::new("."))
        .join(LEDGER_FILE)
}

/// Every entry of the ledger of `model`'s folder (empty if there is none). A malformed line
/// is an error naming the file and line.
pub fn read(model: &Path) -> Result<Vec<Entry>> {
    let path = ledger_path(model);
    let text = match std::fs::read_to_string(&path) {
        Ok(t) => t,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(Vec::new()),
        Err(e) => return Err(e).with_context(|| format!("{}: cannot read", path.display())),
    };
    let mut out = Vec::new();
    for (k, line) in text.lines().enumerate() {
        if line.trim().is_empty() {
            continue;
        }
        let e: Entry = serde_json::from_str(line)
            .with_context(|| format!("{}:{}: not a ledger entry", path.display(), k + 1))?;
        out.push(e);
    }
    Ok(out)
}

/// Appends an entry for `model` (already written) to its folder's ledger (rewritten whole,
/// atomically).
pub fn append(
    model: &Path,
    parent: Option<&Path>,
    change: &str,
    campaign: &str,
    error: f64,
    noise_floor: f64,
) -> Result<Entry> {
    let bytes =
        std::fs::read(model).with_context(|| format!("{}: cannot read", model.display()))?;
    let name = |p: &Path| {
        p.file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default()
    };
    let entry = Entry {
        model: name(model),
        hash: content_hash(&bytes),
        parent: parent.map(name),
        change: change.to_string(),
        campaign: campaign.to_string(),
        error,
        noise_floor,
        date: crate::identify::utc_now(),
        tool: format!("zmp-validation {}", env!("CARGO_PKG_VERSION")),
    };
    let mut all = read(model)?;
    all.push(entry.clone());
    let mut text = String::new();
    for e in &all {
        text.push_str(&serde_json::to_string(e)?);
        text.push('\n');
    }
    atomic_write(&ledger_path(model), text.as_bytes(), true)?;
    Ok(entry)
}

/// The versions leading to `model`, oldest first: its latest entry and its parents'. The
/// model file's current contents must match the entry's hash, or the chain says so with
/// `edited = true` on the last version.
pub fn history(model: &Path) -> Result<(Vec<Entry>, bool)> {
    let all = read(model)?;
    let name = model
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let Some(last) = all.iter().rev().find(|e| e.model == name) else {
        anyhow::bail!(
            "{}: no ledger entry for {name} (models get one when `cargo xtask identify` or \
             `cargo xtask augment` writes them)",
            ledger_path(model).display()
        );
    };
    let edited = std::fs::read(model)
        .map(|b| content_hash(&b) != last.hash)
        .unwrap_or(true);
    let mut chain = vec![last.clone()];
    let mut seen = vec![last.model.clone()];
    while let Some(p) = chain.last().and_then(|e| e.parent.clone()) {
        if seen.contains(&p) {
            break;
        }
        match all.iter().rev().find(|e| e.model == p) {
            Some(e) => {
                seen.push(p);
                chain.push(e.clone());
            }
            None => break,
        }
    }
    chain.reverse();
    Ok((chain, edited))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn chain_of_versions() {
        let dir = tempfile::tempdir().unwrap();
        let a = dir.path().join("robot.toml");
        let b = dir.path().join("robot+time_delay.toml");
        std::fs::write(&a, "a").unwrap();
        std::fs::write(&b, "b").unwrap();
        append(&a, None, "identified", "camp", 0.2, 0.01).unwrap();
        append(&b, Some(&a), "+time_delay", "camp", 0.011, 0.01).unwrap();
        let (h, edited) = history(&b).unwrap();
        assert_eq!(h.len(), 2);
        assert_eq!(h[0].change, "identified");
        assert_eq!(h[1].error, 0.011);
        assert!(!edited);
        std::fs::write(&b, "changed by hand").unwrap();
        assert!(history(&b).unwrap().1);
        let none = dir.path().join("other.toml");
        std::fs::write(&none, "x").unwrap();
        let err = history(&none).unwrap_err().to_string();
        assert!(err.contains("no ledger entry for other.toml"), "{err}");
        std::fs::write(dir.path().join(LEDGER_FILE), "{bad\n").unwrap();
        let err = format!("{:#}", read(&a).unwrap_err());
        assert!(err.contains("zmp-ledger.jsonl:1"), "{err}");
    }
}
