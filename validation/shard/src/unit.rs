//! One result file per unit: `units/<id>.json` in the job folder.

use anyhow::{Context, Result};
use serde::{Deserialize, Serialize};
use serde_json::Value;
use std::path::{Path, PathBuf};

/// Format tag of a unit file.
pub const UNIT_FORMAT: &str = "zmp-unit/1";
/// The folder of the unit files inside a job folder.
pub const UNITS_DIR: &str = "units";

/// What a unit gave: its outcome (the command's JSON), or the error that stopped it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "status", rename_all = "snake_case")]
pub enum Status {
    /// The unit finished.
    Ok {
        /// The command's JSON for this unit.
        outcome: Value,
    },
    /// The unit stopped with an error (or panicked).
    Failed {
        /// The error's text.
        error: String,
    },
}

/// The content of a unit file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct UnitResult {
    /// Format tag ([`UNIT_FORMAT`]).
    pub format: String,
    /// The unit's id.
    pub id: String,
    /// Wall time of the unit (s), measured where it ran.
    pub wall_s: f64,
    /// The build that ran it ([`build_id`]); empty in files written before it was recorded.
    #[serde(default)]
    pub build: String,
    /// Its outcome or its error.
    #[serde(flatten)]
    pub status: Status,
}

impl UnitResult {
    /// The result of unit `id` that took `wall_s` seconds, in the current format.
    pub fn new(id: &str, wall_s: f64, status: Status) -> UnitResult {
        UnitResult {
            format: UNIT_FORMAT.into(),
            id: id.into(),
            wall_s,
            build: build_id().to_string(),
            status,
        }
    }

    /// Whether the unit finished (not failed).
    pub fn is_ok(&self) -> bool {
        matches!(self.status, Status::Ok { .. })
    }
}

/// The identity of the running build: the first 16 hex digits of the SHA-256 of the running
/// executable, read once per process (empty when it cannot be read). Units of one job must
/// come from one build, or a merged table would mix the results of two versions of the code:
/// a resumed run refuses a folder whose results another build wrote, and a merge refuses units
/// of more than one build. Shards on many machines run one binary (a shared path, as the Ray
/// driver and the Slurm script do); two compilations of one commit are two builds.
pub fn build_id() -> &'static str {
    static ID: std::sync::OnceLock<String> = std::sync::OnceLock::new();
    ID.get_or_init(|| {
        std::env::current_exe()
            .and_then(std::fs::read)
            .map(|b| zmp_files::sha256_hex(&b)[..16].to_string())
            .unwrap_or_default()
    })
}

/// Where unit `id`'s result lives in job folder `dir`.
pub fn unit_path(dir: &Path, id: &str) -> PathBuf {
    dir.join(UNITS_DIR).join(format!("{id}.json"))
}

/// Writes a unit's result (atomically: a reader sees the old file or the new one, never half
/// of one; a unit run again replaces its own file and no other).
pub fn write_unit(dir: &Path, r: &UnitResult) -> Result<()> {
    let mut text = serde_json::to_string_pretty(r)?;
    text.push('\n');
    zmp_files::write_file(
        &unit_path(dir, &r.id),
        zmp_files::Kind::Json,
        text.as_bytes(),
        true,
    )?;
    Ok(())
}

/// Reads a unit file; errors name the file and, for bad JSON, the line and column.
pub fn read_unit(path: &Path) -> Result<UnitResult> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    let r: UnitResult = serde_json::from_str(&text).map_err(|e| {
        anyhow::anyhow!(
            "{}: line {} column {}: {e}",
            path.display(),
            e.line(),
            e.column()
        )
    })?;
    if r.format != UNIT_FORMAT {
        anyhow::bail!(
            "{}: field `format` is {:?}, expected {UNIT_FORMAT:?}",
            path.display(),
            r.format
        );
    }
    Ok(r)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_unit_file_round_trips_and_a_bad_one_is_named() {
        let d = tempfile::tempdir().unwrap();
        let ok = UnitResult::new(
            "draw-7",
            1.25,
            Status::Ok {
                outcome: serde_json::json!({"x": 0.1, "found": ["time_delay"]}),
            },
        );
        write_unit(d.path(), &ok).unwrap();
        assert_eq!(read_unit(&unit_path(d.path(), "draw-7")).unwrap(), ok);
        let failed = UnitResult::new(
            "draw-7",
            0.5,
            Status::Failed {
                error: "campaign.toml: line 3".into(),
            },
        );
        // Written again: replaced, never appended.
        write_unit(d.path(), &failed).unwrap();
        let back = read_unit(&unit_path(d.path(), "draw-7")).unwrap();
        assert_eq!(back, failed);
        assert!(!back.is_ok());
        assert_eq!(
            std::fs::read_dir(d.path().join(UNITS_DIR)).unwrap().count(),
            1
        );
        // Every f64 comes back with its bits (serde_json's float_roundtrip): a merge must equal
        // the one-process run to the last digit.
        let xs: Vec<f64> = (1..2000)
            .map(|k| (k as f64 * 0.7390851332151607).sin() * 10f64.powi(k % 40 - 20))
            .chain([
                4.1970970339864496e-7,
                f64::MIN_POSITIVE,
                f64::MAX,
                1.0 / 3.0,
            ])
            .collect();
        let r = UnitResult::new(
            "xs",
            0.0,
            Status::Ok {
                outcome: serde_json::json!(xs),
            },
        );
        write_unit(d.path(), &r).unwrap();
        let back = read_unit(&unit_path(d.path(), "xs")).unwrap();
        let Status::Ok { outcome } = back.status else {
            panic!()
        };
        let ys: Vec<f64> = serde_json::from_value(outcome).unwrap();
        for (x, y) in xs.iter().zip(&ys) {
            assert_eq!(x.to_bits(), y.to_bits(), "{x:e} came back as {y:e}");
        }
        let bad = d.path().join("bad.json");
        std::fs::write(&bad, "{\n \"format\": \"zmp-unit/1\",\n \"id\": 3\n}").unwrap();
        let e = read_unit(&bad).unwrap_err().to_string();
        assert!(e.contains("bad.json: line 3"), "{e}");
    }
}
