//! Reading a job folder back for a merge.

use crate::cost::{cost_model, CostModel, WORKERS};
use crate::job::{read_job, Job, JOB_FILE, JOB_MARKER};
use crate::unit::{read_unit, Status, UNITS_DIR};
use crate::UnitSpec;
use anyhow::{bail, Context, Result};
use serde::Serialize;
use serde_json::Value;
use std::collections::BTreeMap;
use std::path::Path;

/// A unit with a result.
#[derive(Debug, Clone, PartialEq)]
pub struct Done {
    /// The unit as the job lists it (id and expected cost).
    pub spec: UnitSpec,
    /// The command's JSON for this unit.
    pub outcome: Value,
    /// Wall time of the unit where it ran, s.
    pub wall_s: f64,
    /// The build that ran it (`unit::build_id`; empty in older files).
    pub build: String,
}

/// A unit whose result is an error (or whose file cannot be read).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Failed {
    /// The unit's id.
    pub unit: String,
    /// The error that stopped it, or why its file cannot be read.
    pub error: String,
    /// Its wall time, when its file says.
    pub wall_s: Option<f64>,
}

/// A job folder as a merge sees it, keyed by unit id.
#[derive(Debug, Clone)]
pub struct Collected {
    /// The job (`job.json`).
    pub job: Job,
    /// Units with a result, in the job's order.
    pub done: Vec<Done>,
    /// Units whose result is an error or whose file cannot be read.
    pub failed: Vec<Failed>,
    /// Units of the job without a result file.
    pub missing: Vec<String>,
    /// Result files of units the job does not have (left out of the merge).
    pub unknown: Vec<String>,
    /// Of the missing units, those a shard has claimed ([`crate::claim`]): begun, not finished
    /// (that shard's process stopped, or still runs). Unit id and claim.
    pub begun: Vec<(String, crate::claim::Claim)>,
}

/// Reads the job and every unit file of `dir`.
pub fn collect(dir: &Path) -> Result<Collected> {
    if !dir.join(JOB_MARKER).is_file() && !dir.join(JOB_FILE).is_file() {
        bail!(
            "{} is not a job folder (no {JOB_FILE}): give the --out folder of `cargo xtask \
             suite`, `fleet` or `calibrate-com --shard`",
            dir.display()
        );
    }
    let job = read_job(dir)?;
    let mut files: BTreeMap<String, Result<crate::unit::UnitResult>> = BTreeMap::new();
    let units = dir.join(UNITS_DIR);
    if units.is_dir() {
        for entry in
            std::fs::read_dir(&units).with_context(|| format!("reading {}", units.display()))?
        {
            let path = entry?.path();
            let name = path.file_name().map(|n| n.to_string_lossy().into_owned());
            let Some(id) = name
                .as_deref()
                .filter(|n| !n.starts_with('.'))
                .and_then(|n| n.strip_suffix(".json"))
            else {
                continue;
            };
            let r = read_unit(&path).and_then(|r| {
                if r.id != id {
                    bail!(
                        "{}: field `id` is {:?}, but the file is named for {id:?}",
                        path.display(),
                        r.id
                    );
                }
                Ok(r)
            });
            files.insert(id.to_string(), r);
        }
    }
    let mut c = Collected {
        job: job.clone(),
        done: Vec::new(),
        failed: Vec::new(),
        missing: Vec::new(),
        unknown: Vec::new(),
        begun: Vec::new(),
    };
    for spec in &job.units {
        match files.remove(&spec.id) {
            None => c.missing.push(spec.id.clone()),
            Some(Err(e)) => c.failed.push(Failed {
                unit: spec.id.clone(),
                error: format!("{e:#}"),
                wall_s: None,
            }),
            Some(Ok(r)) => match r.status {
                Status::Ok { outcome } => c.done.push(Done {
                    spec: spec.clone(),
                    outcome,
                    wall_s: r.wall_s,
                    build: r.build,
                }),
                Status::Failed { error } => c.failed.push(Failed {
                    unit: spec.id.clone(),
                    error,
                    wall_s: Some(r.wall_s),
                }),
            },
        }
    }
    c.unknown = files.into_keys().collect();
    c.begun = c
        .missing
        .iter()
        .filter_map(|id| crate::claim::read_claim(dir, id).map(|cl| (id.clone(), cl)))
        .collect();
    check_one_build(dir, &c.done)?;
    Ok(c)
}

/// Refuses units of more than one build (`unit::build_id`): their merged table would mix two
/// versions of the code. Units without a recorded build (older files) are not counted.
fn check_one_build(dir: &Path, done: &[Done]) -> Result<()> {
    let mut builds: BTreeMap<&str, Vec<&str>> = BTreeMap::new();
    for d in done.iter().filter(|d| !d.build.is_empty()) {
        builds.entry(&d.build).or_default().push(&d.spec.id);
    }
    if builds.len() > 1 {
        let list: Vec<String> = builds
            .iter()
            .map(|(b, ids)| format!("build {b}: {} units (first {})", ids.len(), ids[0]))
            .collect();
        bail!(
            "{}: its units ran on {} builds ({}): a merged table would mix versions of the \
             code. Re-run the units of all but one build with that build (`--unit ID`), or \
             run the job again in a new folder",
            dir.display(),
            builds.len(),
            list.join("; ")
        );
    }
    Ok(())
}

/// The units' state, for a merge's `--json`.
#[derive(Debug, Clone, Serialize)]
pub struct UnitsSummary {
    /// Units of the job.
    pub units: usize,
    /// Units with a result.
    pub done: usize,
    /// Units that failed, with their errors.
    pub failed: Vec<Failed>,
    /// Ids of the units without a result file.
    pub missing: Vec<String>,
    /// Ids of result files the job does not list.
    pub unknown: Vec<String>,
    /// Missing units a shard has begun (claimed): unit id and the shard that claimed it.
    pub begun: BTreeMap<String, String>,
}

impl Collected {
    /// Every unit of the job has a result and none failed.
    pub fn complete(&self) -> bool {
        self.failed.is_empty() && self.missing.is_empty()
    }

    /// The outcomes of the units done, in job order.
    pub fn outcomes(&self) -> Vec<&Value> {
        self.done.iter().map(|d| &d.outcome).collect()
    }

    /// The measured wall times (units done and failed units that say theirs).
    pub fn times(&self) -> Vec<(String, f64)> {
        let mut t: Vec<(String, f64)> = self
            .done
            .iter()
            .map(|d| (d.spec.id.clone(), d.wall_s))
            .collect();
        t.extend(
            self.failed
                .iter()
                .filter_map(|f| f.wall_s.map(|s| (f.unit.clone(), s))),
        );
        t
    }

    /// The cost model of the measured times on 1, 2, 8, 64 and 256 workers.
    pub fn cost(&self) -> CostModel {
        cost_model(&self.times(), &WORKERS)
    }

    /// The units' state: counts, failures, missing and unknown ids.
    pub fn summary(&self) -> UnitsSummary {
        UnitsSummary {
            units: self.job.units.len(),
            done: self.done.len(),
            failed: self.failed.clone(),
            missing: self.missing.clone(),
            unknown: self.unknown.clone(),
            begun: self
                .begun
                .iter()
                .map(|(id, c)| (id.clone(), c.shard.clone()))
                .collect(),
        }
    }

    /// Lines naming the failed, missing and unknown units (empty when complete and clean), with
    /// how to re-run one.
    pub fn problems_text(&self, rerun: &str) -> String {
        let mut s = String::new();
        for f in &self.failed {
            s.push_str(&format!("failed unit {}: {}\n", f.unit, f.error));
        }
        if !self.missing.is_empty() {
            // The first few by name (`--json` lists every one): a job stopped early misses
            // hundreds.
            const NAMED: usize = 12;
            let more = self.missing.len().saturating_sub(NAMED);
            s.push_str(&format!(
                "missing units ({}): {}{}\n",
                self.missing.len(),
                self.missing[..self.missing.len().min(NAMED)].join(", "),
                if more > 0 {
                    format!(", and {more} more")
                } else {
                    String::new()
                }
            ));
        }
        for (id, claim) in &self.begun {
            s.push_str(&format!(
                "unit {id} was begun by shard {} (process {}) and has no result: that shard \
                 stopped (or still runs); running shard {} again takes its units back\n",
                claim.shard, claim.process, claim.shard
            ));
        }
        if !self.unknown.is_empty() {
            s.push_str(&format!(
                "result files of units this job does not have (left out): {}\n",
                self.unknown.join(", ")
            ));
        }
        if !self.complete() {
            s.push_str(&format!("re-run one unit alone with: {rerun} --unit ID\n"));
        }
        s
    }
}

/// What a merge writes and prints: the command's own rendering of the units' outcomes.
#[derive(Debug, Clone, PartialEq)]
pub struct Merged {
    /// Files for the job folder (e.g. `table.md`, `report.md`, `result.json`).
    pub files: Vec<(String, Vec<u8>)>,
    /// The result as JSON (`--json`).
    pub json: Value,
    /// The result for a terminal.
    pub text: String,
}

/// Writes a merge's output files into the job folder. They are the merge's own (it replaces
/// them when run again, e.g. after a failed unit was re-run); the job's files and the unit
/// files cannot be named.
pub fn write_outputs(dir: &Path, files: &[(String, Vec<u8>)]) -> Result<()> {
    for (name, bytes) in files {
        if name == JOB_FILE || name == JOB_MARKER || name.contains('/') || name == UNITS_DIR {
            bail!("a merge cannot write {name:?} into a job folder");
        }
        let kind = match name.rsplit_once('.').map(|(_, ext)| ext) {
            Some("md") => zmp_files::Kind::Markdown,
            Some("json") => zmp_files::Kind::Json,
            Some("html") => zmp_files::Kind::Html,
            Some("svg") => zmp_files::Kind::Svg,
            _ => bail!("a merge writes Markdown, JSON, HTML or SVG files, not {name:?}"),
        };
        zmp_files::write_file(&dir.join(name), kind, bytes, true)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::job::{open_job, JobKind};
    use crate::unit::{unit_path, write_unit, UnitResult};

    #[test]
    fn collect_keys_by_id_and_names_failed_missing_and_unknown() {
        let d = tempfile::tempdir().unwrap();
        let dir = d.path().join("job");
        let units = ["a", "b", "c", "d"]
            .iter()
            .map(|id| UnitSpec::new(*id, 1.0))
            .collect();
        let job = Job::new(JobKind::Fleet, serde_json::json!({}), units).unwrap();
        open_job(&dir, &job).unwrap();
        let ok = |id: &str, x: f64| {
            UnitResult::new(
                id,
                x,
                Status::Ok {
                    outcome: serde_json::json!(x),
                },
            )
        };
        write_unit(&dir, &ok("c", 3.0)).unwrap();
        write_unit(&dir, &ok("a", 1.0)).unwrap();
        // Written twice (a shard re-run): counted once, the last result.
        write_unit(&dir, &ok("a", 1.5)).unwrap();
        write_unit(
            &dir,
            &UnitResult::new(
                "b",
                0.2,
                Status::Failed {
                    error: "malformed".into(),
                },
            ),
        )
        .unwrap();
        write_unit(&dir, &ok("zz", 9.0)).unwrap();
        // A half-written temporary file of a killed worker is not a result.
        std::fs::write(dir.join(UNITS_DIR).join(".tmp-x1"), "{").unwrap();
        let c = collect(&dir).unwrap();
        let ids: Vec<&str> = c.done.iter().map(|d| d.spec.id.as_str()).collect();
        assert_eq!(ids, ["a", "c"]);
        assert_eq!(
            c.outcomes(),
            [&serde_json::json!(1.5), &serde_json::json!(3.0)]
        );
        assert_eq!(c.failed[0].unit, "b");
        assert_eq!(c.missing, ["d"]);
        assert_eq!(c.unknown, ["zz"]);
        assert!(!c.complete());
        let text = c.problems_text("cargo xtask fleet DIR --out OUT");
        assert!(text.contains("failed unit b: malformed"), "{text}");
        assert!(text.contains("missing units (1): d"), "{text}");
        // A job stopped early: the first twelve missing named, the count of the rest.
        let mut many = c.clone();
        many.missing = (0..30).map(|k| format!("u{k}")).collect();
        let text = many.problems_text("cargo xtask fleet DIR --out OUT");
        assert!(text.contains("missing units (30): u0, u1,"), "{text}");
        assert!(text.contains("u11, and 18 more\n"), "{text}");
        assert!(!text.contains("u12"), "{text}");
        assert_eq!(c.cost().total_s, 1.5 + 3.0 + 0.2);
        // A file whose id does not match its name is a failure of that unit, named.
        std::fs::copy(unit_path(&dir, "a"), unit_path(&dir, "d")).unwrap();
        let c = collect(&dir).unwrap();
        assert!(c
            .failed
            .iter()
            .any(|f| f.unit == "d" && f.error.contains("named for")));
        assert!(collect(d.path())
            .unwrap_err()
            .to_string()
            .contains("not a job folder"));
        assert!(write_outputs(&dir, &[("job.json".into(), vec![])]).is_err());
    }
}
