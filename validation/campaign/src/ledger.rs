//! The model ledger: one JSON line per model version written by `identify` or `augment`, kept
//! beside the model files (`zmp-ledger.jsonl` in their folder), so that the history of a model
//! (which effect was added when, and what it did to the error) can be shown as a waterfall.
//!
//! # Lineage by content
//!
//! Each entry records the SHA-256 of the model file as written (`hash`) and of the parent it
//! was made from (`parent_hash`). [`history`] follows these hashes, not the file names: a
//! parent rewritten with `--force`, or a second run into the same folder, has entries of its
//! own with other hashes and never joins another run's chain; a version whose file no longer
//! matches its entry is named. Entries written before content lineage (an FNV-1a `hash`, no
//! `parent_hash`) still read: they are linked by name to the parent's latest entry before
//! them, and the history says so.
//!
//! # Concurrency and damage
//!
//! Many runs may write models into one folder at once (a batch of `identify` runs, say). An
//! entry is appended, never rewritten: the ledger is opened with `O_APPEND`, an advisory
//! exclusive lock (`flock`) is taken, and the whole line goes out in one `write` and is synced
//! before the lock is released, so concurrent writers never lose or interleave entries. Readers
//! take a shared lock, so they never see half a line from a live writer.
//!
//! A line that is not an entry (a crash mid-write on a file system without the lock, a
//! hand edit) is skipped with a warning naming the file and line; it never blocks the history
//! of the other models nor new entries (an entry appended after a truncated last line starts on
//! a line of its own).
//!
//! Why not an embedded database (SQLite): the ledger is small, append-only and meant to be read
//! by people and scripts (`grep`, `jq`); a JSON-lines file under a lock gives the same safety
//! for appends without a C dependency or a binary file in the user's model folder.

use anyhow::{Context, Result};
use serde::{Deserialize, Deserializer, Serialize};
use std::path::{Path, PathBuf};
use zmp_files::{append_locked, limits, read_locked, Kind};

/// File name of the ledger in a model's folder.
pub const LEDGER_FILE: &str = zmp_files::LEDGER_FILE;

/// One model version.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Entry {
    /// Model file name (relative to the ledger's folder).
    pub model: String,
    /// Hash of the model file's contents when written: SHA-256, 64 hex digits (entries written
    /// before content lineage hold FNV-1a 64, 16 hex digits; an entry without one, "").
    #[serde(default)]
    pub hash: String,
    /// The model this one was made from (file name in the same folder), if any.
    pub parent: Option<String>,
    /// SHA-256 of the parent's contents when this version was made from it: the history
    /// follows this, not the parent's name (`None`: no parent, or an entry written before
    /// content lineage, linked by name only).
    #[serde(default)]
    pub parent_hash: Option<String>,
    /// What made it: `identified`, `+time_delay`, `refit`.
    pub change: String,
    /// Campaign the error is measured on, as given.
    pub campaign: String,
    /// The diagnosis error measure on that campaign, and its noise floor (JSON `null` when
    /// not a number).
    #[serde(deserialize_with = "null_as_nan")]
    pub error: f64,
    /// The noise floor of that error measure (JSON `null` when not a number).
    #[serde(deserialize_with = "null_as_nan")]
    pub noise_floor: f64,
    /// When the entry was written (UTC, RFC 3339).
    pub date: String,
    /// The tool and version that wrote it (`zmp-toolkit 0.1.0`).
    pub tool: String,
}

/// serde_json writes NaN as `null`; read it back as NaN.
fn null_as_nan<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    Ok(Option::<f64>::deserialize(d)?.unwrap_or(f64::NAN))
}

/// What [`read`] found: the entries, in file order, and one warning per line skipped.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Contents {
    /// The entries that parse, in file order.
    pub entries: Vec<Entry>,
    /// `"<file>:<line>: ... skipped"`, one per damaged line.
    pub warnings: Vec<String>,
}

/// A model's history: see [`history`].
#[derive(Debug, Clone, PartialEq)]
pub struct History {
    /// The versions leading to the model, oldest first.
    pub chain: Vec<Entry>,
    /// The model file no longer matches any of its entries' hashes.
    pub edited: bool,
    /// Damaged ledger lines that were skipped.
    pub warnings: Vec<String>,
    /// What the reader should know about the chain: a version's file rewritten or gone since,
    /// entries from before content hashes linked by name, a parent without an entry.
    pub notes: Vec<String>,
}

/// SHA-256 of `bytes`, hex: the hash new entries record.
pub fn content_hash(bytes: &[u8]) -> String {
    zmp_files::sha256_hex(bytes)
}

/// FNV-1a 64 of `bytes`, hex: the hash of entries written before content lineage.
fn fnv_hash(bytes: &[u8]) -> String {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for b in bytes {
        h ^= *b as u64;
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
    format!("{h:016x}")
}

/// Whether `bytes` are the contents an entry's `hash` was made of (`None`: the entry has no
/// hash, so it cannot be told).
pub fn hash_matches(hash: &str, bytes: &[u8]) -> Option<bool> {
    match hash.len() {
        64 => Some(content_hash(bytes) == hash),
        16 => Some(fnv_hash(bytes) == hash),
        _ => None,
    }
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

fn file_name(p: &Path) -> String {
    p.file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default()
}

/// Parses the ledger's bytes: every line that is an entry, a warning for every other
/// non-blank line.
fn parse(path: &Path, bytes: &[u8]) -> Contents {
    let mut out = Contents::default();
    for (k, line) in bytes.split(|b| *b == b'\n').enumerate() {
        if line.iter().all(u8::is_ascii_whitespace) {
            continue;
        }
        let parsed = std::str::from_utf8(line)
            .map_err(|e| e.to_string())
            .and_then(|s| serde_json::from_str::<Entry>(s).map_err(|e| e.to_string()));
        match parsed {
            Ok(e) => out.entries.push(e),
            Err(why) => out.warnings.push(format!(
                "{}:{}: not a ledger entry ({why}); line skipped",
                path.display(),
                k + 1
            )),
        }
    }
    out
}

/// Every entry of the ledger of `model`'s folder (none if there is no ledger), with a warning
/// for each damaged line. Only an unreadable file is an error.
pub fn read(model: &Path) -> Result<Contents> {
    let path = ledger_path(model);
    // A shared lock: a writer holding the exclusive one finishes its line first.
    match read_locked(&path, limits::LEDGER_BYTES)? {
        None => Ok(Contents::default()),
        Some(bytes) => Ok(parse(&path, &bytes)),
    }
}

/// Appends `entry` to the ledger at `path` under an exclusive lock, in one write, synced.
/// With `unless_recorded`, nothing is written when the ledger (read under the same lock)
/// already has an entry for the same model with the same contents; returns whether it wrote.
fn append_locked_entry(path: &Path, entry: &Entry, unless_recorded: bool) -> Result<bool> {
    let json = serde_json::to_string(entry)?;
    let wrote = append_locked(path, Kind::Ledger, limits::LEDGER_BYTES, |bytes| {
        if unless_recorded
            && parse(path, bytes)
                .entries
                .iter()
                .any(|e| e.model == entry.model && e.hash == entry.hash)
        {
            return None;
        }
        let mut line = String::new();
        // A damaged (truncated) last line must not swallow the new entry.
        if bytes.last().is_some_and(|b| *b != b'\n') {
            line.push('\n');
        }
        line.push_str(&json);
        line.push('\n');
        Some(line.into_bytes())
    })?;
    Ok(wrote)
}

/// The contents of a model file as the ledger hashes them.
fn model_bytes(model: &Path) -> Result<Vec<u8>> {
    Ok(zmp_files::read_limited(
        model,
        limits::MODEL_BYTES,
        "a model file",
    )?)
}

fn new_entry(
    model: &Path,
    parent: Option<&Path>,
    change: &str,
    campaign: &str,
    error: f64,
    noise_floor: f64,
) -> Result<Entry> {
    let bytes = model_bytes(model).with_context(|| format!("{}: cannot read", model.display()))?;
    let parent_hash = match parent {
        Some(p) => Some(content_hash(
            &model_bytes(p).with_context(|| format!("{}: cannot read", p.display()))?,
        )),
        None => None,
    };
    Ok(Entry {
        model: file_name(model),
        hash: content_hash(&bytes),
        parent: parent.map(file_name),
        parent_hash,
        change: change.to_string(),
        campaign: campaign.to_string(),
        error,
        noise_floor,
        date: utc_now(),
        tool: format!("zmp-toolkit {}", env!("CARGO_PKG_VERSION")),
    })
}

/// Appends an entry for `model` (already written) to its folder's ledger, with the hash of
/// its contents and of its parent's. Safe to call from many processes at once; damaged lines
/// already in the ledger do not stop it.
pub fn append(
    model: &Path,
    parent: Option<&Path>,
    change: &str,
    campaign: &str,
    error: f64,
    noise_floor: f64,
) -> Result<Entry> {
    let entry = new_entry(model, parent, change, campaign, error, noise_floor)?;
    append_locked_entry(&ledger_path(model), &entry, false)?;
    Ok(entry)
}

/// Appends an entry for `model` unless its ledger already has one for these contents
/// (checked and written under one lock, so two runs starting from the same model record it
/// once; a model rewritten since gets an entry of its own). Returns whether it wrote.
pub fn append_unless_recorded(
    model: &Path,
    change: &str,
    campaign: &str,
    error: f64,
    noise_floor: f64,
) -> Result<bool> {
    let entry = new_entry(model, None, change, campaign, error, noise_floor)?;
    append_locked_entry(&ledger_path(model), &entry, true)
}

/// The entry the parent of `all[child]` has: the latest entry before it with the parent's
/// name and the recorded parent hash (by name alone for entries written before content
/// lineage; a note says so once).
fn parent_of(all: &[Entry], child: usize, notes: &mut Vec<String>) -> Option<usize> {
    let c = &all[child];
    let name = c.parent.as_deref()?;
    let by_name_note = |notes: &mut Vec<String>| {
        let note = "entries written before content hashes are linked to their parent, or \
                    their child to them, by file name only (the parent's latest entry before \
                    the child)"
            .to_owned();
        if !notes.contains(&note) {
            notes.push(note);
        }
    };
    match &c.parent_hash {
        Some(h) => {
            let exact = all[..child]
                .iter()
                .rposition(|e| e.model == name && &e.hash == h);
            // A parent recorded before content hashes has no SHA-256 to compare: its latest
            // such entry, by name.
            let found = exact.or_else(|| {
                let legacy = all[..child].iter().rposition(|e| e.model == name)?;
                (all[legacy].hash.len() != 64).then(|| {
                    by_name_note(notes);
                    legacy
                })
            });
            if found.is_none() {
                notes.push(format!(
                    "{} was made from {name} (contents {}), which has no ledger entry with \
                     those contents: the history starts after it",
                    c.model,
                    short(h)
                ));
            }
            found
        }
        None => {
            by_name_note(notes);
            all[..child].iter().rposition(|e| e.model == name)
        }
    }
}

fn short(hash: &str) -> &str {
    &hash[..hash.len().min(12)]
}

/// The versions leading to `model`, oldest first, followed by content: the model's entry is
/// the latest whose hash matches the file as it is (else its latest, and `edited` says the
/// file no longer matches), each parent the entry with the hash the child recorded, written
/// before the child. So a rerun into the same folder, or a parent rewritten with `--force`,
/// never mixes into the chain; a version whose file was rewritten or removed since is named in
/// `notes`. Damaged ledger lines are skipped and listed in `warnings`.
pub fn history(model: &Path) -> Result<History> {
    let Contents {
        entries: all,
        warnings,
    } = read(model)?;
    let name = file_name(model);
    let Some(latest) = all.iter().rposition(|e| e.model == name) else {
        let mut msg = format!(
            "{}: no ledger entry for {name} (models get one when `cargo xtask identify` or \
             `cargo xtask augment` writes them)",
            ledger_path(model).display()
        );
        if !warnings.is_empty() {
            msg.push_str(&format!("; {} damaged line(s) skipped", warnings.len()));
        }
        anyhow::bail!(msg);
    };
    let mut notes = Vec::new();
    let bytes = model_bytes(model).ok();
    let matching = bytes.as_ref().and_then(|b| {
        all.iter()
            .rposition(|e| e.model == name && hash_matches(&e.hash, b) == Some(true))
    });
    let (last, edited) = match (matching, &bytes) {
        (Some(k), _) => (k, false),
        (None, Some(b)) if hash_matches(&all[latest].hash, b).is_none() => {
            notes.push(format!(
                "{name}'s entry has no content hash: whether the file still matches it cannot \
                 be told"
            ));
            (latest, false)
        }
        _ => (latest, true),
    };
    let dir = model.parent().unwrap_or(Path::new(""));
    let mut chain = vec![last];
    while let Some(p) = parent_of(&all, *chain.last().expect("not empty"), &mut notes) {
        if chain.contains(&p) {
            break;
        }
        chain.push(p);
    }
    chain.reverse();
    // The versions before the model: is each file still the one this chain recorded?
    for &k in &chain[..chain.len() - 1] {
        let e = &all[k];
        match zmp_files::read_limited(&dir.join(&e.model), limits::MODEL_BYTES, "a model file") {
            Err(_) => notes.push(format!("{} is no longer on disk", e.model)),
            Ok(b) if hash_matches(&e.hash, &b) == Some(false) => notes.push(format!(
                "{} on disk no longer matches the version in this history (rewritten since; \
                 the version shown is its entry of {})",
                e.model, e.date
            )),
            Ok(_) => {}
        }
    }
    Ok(History {
        chain: chain.into_iter().map(|k| all[k].clone()).collect(),
        edited,
        warnings,
        notes,
    })
}

/// `YYYY-MM-DDTHH:MM:SSZ` from the system clock.
pub fn utc_now() -> String {
    let secs = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_secs() as i64)
        .unwrap_or(0);
    let days = secs.div_euclid(86_400);
    let rem = secs.rem_euclid(86_400);
    // Civil date from days since 1970-01-01 (H. Hinnant's algorithm).
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + i64::from(m <= 2);
    format!(
        "{y:04}-{m:02}-{d:02}T{:02}:{:02}:{:02}Z",
        rem / 3600,
        rem / 60 % 60,
        rem % 60
    )
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
        let h = history(&b).unwrap();
        assert_eq!(h.chain.len(), 2);
        assert_eq!(h.chain[0].change, "identified");
        assert_eq!(h.chain[1].error, 0.011);
        assert!(!h.edited && h.warnings.is_empty());
        std::fs::write(&b, "changed by hand").unwrap();
        assert!(history(&b).unwrap().edited);
        let none = dir.path().join("other.toml");
        std::fs::write(&none, "x").unwrap();
        let err = history(&none).unwrap_err().to_string();
        assert!(err.contains("no ledger entry for other.toml"), "{err}");
    }

    #[test]
    fn recorded_once_and_nan_survives() {
        let dir = tempfile::tempdir().unwrap();
        let a = dir.path().join("start.toml");
        std::fs::write(&a, "a").unwrap();
        assert!(append_unless_recorded(&a, "starting model", "c", f64::NAN, 0.01).unwrap());
        assert!(!append_unless_recorded(&a, "starting model", "c", 0.3, 0.01).unwrap());
        let c = read(&a).unwrap();
        assert_eq!(c.entries.len(), 1, "{c:?}");
        assert!(c.warnings.is_empty(), "{:?}", c.warnings);
        assert!(c.entries[0].error.is_nan());
    }

    /// A crash mid-write leaves a truncated last line: the history still works (with a
    /// warning naming file and line) and the next entry is appended on a line of its own.
    #[test]
    fn truncated_last_line_is_skipped_and_appended_after() {
        let dir = tempfile::tempdir().unwrap();
        let a = dir.path().join("a.toml");
        let b = dir.path().join("b.toml");
        std::fs::write(&a, "a").unwrap();
        std::fs::write(&b, "b").unwrap();
        append(&a, None, "identified", "camp", 0.2, 0.01).unwrap();
        let ledger = ledger_path(&a);
        let full = std::fs::read_to_string(&ledger).unwrap();
        let mut damaged = full.clone();
        damaged.push_str(&full[..full.len() / 2]);
        std::fs::write(&ledger, &damaged).unwrap();

        let h = history(&a).unwrap();
        assert_eq!(h.chain.len(), 1);
        assert_eq!(h.warnings.len(), 1, "{:?}", h.warnings);
        let w = &h.warnings[0];
        assert!(
            w.contains("zmp-ledger.jsonl:2") && w.contains("skipped"),
            "{w}"
        );

        append(&b, Some(&a), "+time_delay", "camp", 0.05, 0.01).unwrap();
        let h = history(&b).unwrap();
        assert_eq!(h.chain.len(), 2, "{h:?}");
        assert_eq!(h.chain[1].change, "+time_delay");
        let text = std::fs::read_to_string(&ledger).unwrap();
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines.len(), 3, "{text}");
        assert!(
            serde_json::from_str::<Entry>(lines[2]).is_ok(),
            "{}",
            lines[2]
        );
        // Garbage in the middle (not UTF-8) is skipped too.
        let mut bytes = std::fs::read(&ledger).unwrap();
        bytes.splice(0..0, b"\xff\xfe{\n".iter().copied());
        std::fs::write(&ledger, bytes).unwrap();
        let c = read(&b).unwrap();
        assert_eq!((c.entries.len(), c.warnings.len()), (2, 2), "{c:?}");
        assert!(
            c.warnings[0].contains("zmp-ledger.jsonl:1"),
            "{:?}",
            c.warnings
        );
    }
}
