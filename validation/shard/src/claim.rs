//! Claims: which shard took a unit, so that shards sharing a job folder can take each other's
//! units (`--steal`) without running one twice.
//!
//! Before a shard runs a unit it claims it: `claims/<id>.json` in the job folder, made only if
//! absent (of two shards claiming one unit at once, exactly one wins: `zmp_files::write_file`
//! without force). The claim names the shard (`i/n`) and the process (host, pid, start), and
//! stays after the unit ends: it is the record of who ran it.
//!
//! A claim blocks every other shard of the same partition. Two cases are not blocked:
//!
//! - **An earlier attempt of the same shard.** One process runs shard `i/n` at a time (a Slurm
//!   array task, a Ray task whose retry starts after its worker died), so a claim of `i/n` by
//!   another process is an attempt that stopped: the new attempt takes its units back, own or
//!   stolen. A killed shard loses nothing when it is re-run, and nothing runs twice.
//! - **Another partition.** A claim of `i/m` with `m != n` comes from an earlier run of the
//!   job in `m` shards: the unit's owner in this partition takes it.
//!
//! A claim whose shard stopped and is never re-run leaves its unit without a result: the merge
//! names it missing, with the shard that claimed it, and `--unit ID` re-runs it alone.

use crate::Shard;
use anyhow::{Context, Result};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// The folder of the claims inside a job folder.
pub const CLAIMS_DIR: &str = "claims";

/// Who took a unit.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct Claim {
    /// The shard, `i/n`.
    pub shard: String,
    /// The process: `host:pid:start` (start in ms since the Unix epoch).
    pub process: String,
}

impl Claim {
    /// The shard that made the claim, when it parses.
    pub fn shard(&self) -> Option<Shard> {
        self.shard.parse().ok()
    }
}

/// This process's identity in claims (read once).
pub fn this_process() -> &'static str {
    static ID: std::sync::OnceLock<String> = std::sync::OnceLock::new();
    ID.get_or_init(|| {
        let host = std::fs::read_to_string("/proc/sys/kernel/hostname")
            .ok()
            .or_else(|| std::env::var("HOSTNAME").ok())
            .map(|h| h.trim().to_string())
            .filter(|h| !h.is_empty())
            .unwrap_or_else(|| "unknown-host".into());
        let start = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map(|d| d.as_millis())
            .unwrap_or(0);
        format!("{host}:{}:{start}", std::process::id())
    })
}

/// Where unit `id`'s claim lives in job folder `dir`.
pub fn claim_path(dir: &Path, id: &str) -> PathBuf {
    dir.join(CLAIMS_DIR).join(format!("{id}.json"))
}

/// Reads unit `id`'s claim (`None` when it has none or it cannot be read).
pub fn read_claim(dir: &Path, id: &str) -> Option<Claim> {
    let text = std::fs::read_to_string(claim_path(dir, id)).ok()?;
    serde_json::from_str(&text).ok()
}

/// Whether `shard` may take a unit over `existing`, its claim (made by another process, or
/// by this one for another shard).
/// `own`: the unit is in `shard`'s part.
fn may_take(existing: &Claim, shard: Shard, own: bool) -> bool {
    match existing.shard() {
        Some(s) if s == shard => true,
        Some(s) if s.count() != shard.count() => own,
        // Another shard of this partition has it (or a claim that does not parse: leave it).
        _ => false,
    }
}

/// Claims unit `id` for `shard` (this process): `true` if this shard may run it now (the
/// claim is made, or taken over from an earlier attempt of the same shard or from another
/// partition: see the module docs), `false` if another shard of this partition has it.
/// `own`: the unit is in `shard`'s part. Errors: the claim cannot be written.
pub fn claim(dir: &Path, id: &str, shard: Shard, own: bool) -> Result<bool> {
    let me = Claim {
        shard: shard.to_string(),
        process: this_process().to_string(),
    };
    let mut text = serde_json::to_string(&me)?;
    text.push('\n');
    let path = claim_path(dir, id);
    let write = |force: bool| {
        zmp_files::write_file(&path, zmp_files::Kind::Json, text.as_bytes(), force).map(|_| ())
    };
    match write(false) {
        Ok(()) => return Ok(true),
        Err(zmp_files::FileError::Exists { .. }) => {}
        Err(e) => return Err(e).with_context(|| format!("claiming unit {id}")),
    }
    let Some(existing) = read_claim(dir, id) else {
        return Ok(false);
    };
    if existing == me {
        return Ok(true);
    }
    if !may_take(&existing, shard, own) {
        return Ok(false);
    }
    write(true).with_context(|| format!("taking over the claim of unit {id}"))?;
    Ok(true)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn claim_of(shard: &str, process: &str) -> Claim {
        Claim {
            shard: shard.into(),
            process: process.into(),
        }
    }

    #[test]
    fn who_may_take_a_claimed_unit() {
        let s = |t: &str| t.parse::<Shard>().unwrap();
        // Another shard of the partition, running or stopped: never.
        assert!(!may_take(&claim_of("1/4", "h:1:1"), s("2/4"), true));
        assert!(!may_take(&claim_of("1/4", "h:1:1"), s("2/4"), false));
        // An earlier attempt of the same shard: always, own unit or stolen.
        assert!(may_take(&claim_of("2/4", "h:1:1"), s("2/4"), false));
        assert!(may_take(&claim_of("2/4", "h:1:1"), s("2/4"), true));
        // Another partition: the owner in this one only.
        assert!(may_take(&claim_of("1/3", "h:1:1"), s("2/4"), true));
        assert!(!may_take(&claim_of("1/3", "h:1:1"), s("2/4"), false));
        // A claim that does not parse: left alone.
        assert!(!may_take(&claim_of("x", "h:1:1"), s("2/4"), true));
    }

    #[test]
    fn two_claims_of_one_unit_one_wins() {
        for _ in 0..50 {
            let d = tempfile::tempdir().unwrap();
            let won: Vec<bool> = std::thread::scope(|sc| {
                let hs: Vec<_> = (1..=4)
                    .map(|i| {
                        let dir = d.path();
                        sc.spawn(move || {
                            claim(dir, "u1", Shard::new(i, 4).unwrap(), i == 1).unwrap()
                        })
                    })
                    .collect();
                hs.into_iter().map(|h| h.join().unwrap()).collect()
            });
            assert_eq!(won.iter().filter(|w| **w).count(), 1, "{won:?}");
            let c = read_claim(d.path(), "u1").unwrap();
            let i = won.iter().position(|w| *w).unwrap() + 1;
            assert_eq!(c.shard, format!("{i}/4"));
        }
    }
}
