//! A job folder and running a shard of it.

use crate::partition::{check_units, lpt_order, shard_units};
use crate::unit::{read_unit, unit_path, write_unit, Status, UnitResult};
use crate::{Shard, UnitSpec};
use anyhow::{bail, Context, Result};
use serde::{Deserialize, Serialize};
use serde_json::Value;
use std::path::Path;
use std::time::{Duration, Instant};

/// Format tag of `job.json`.
pub const JOB_FORMAT: &str = "zmp-job/1";
/// The job's description inside its folder.
pub const JOB_FILE: &str = "job.json";
/// Marker of a job folder (see `zmp_files::claim_dir`).
pub use zmp_files::JOB_MARKER;

/// The command a job belongs to (which merge renders it).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum JobKind {
    /// `cargo xtask suite`: one unit per draw of the out-of-sample suite.
    Suite,
    /// `cargo xtask fleet`: one unit per campaign folder.
    Fleet,
    /// `cargo xtask calibrate-com`: blocks of noise draws and walks on the SABIAN twin.
    CalibrateCom,
}

/// A job: its command, the command's parameters and its units.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Job {
    /// Format tag of `job.json` ([`JOB_FORMAT`]).
    pub format: String,
    /// The command that runs the units.
    pub kind: JobKind,
    /// The command's parameters: two runs with the same parameters are the same job.
    pub params: Value,
    /// The units, in the job's order (the order of the merge).
    pub units: Vec<UnitSpec>,
}

impl Job {
    /// A job; its unit ids must be unique file names and its costs finite.
    pub fn new(kind: JobKind, params: Value, units: Vec<UnitSpec>) -> Result<Job> {
        check_units(&units)?;
        Ok(Job {
            format: JOB_FORMAT.into(),
            kind,
            params,
            units,
        })
    }

    /// The unit of id `id`, if the job has it.
    pub fn unit(&self, id: &str) -> Option<&UnitSpec> {
        self.units.iter().find(|u| u.id == id)
    }
}

/// Reads `DIR/job.json`.
pub fn read_job(dir: &Path) -> Result<Job> {
    let path = dir.join(JOB_FILE);
    let text = std::fs::read_to_string(&path).with_context(|| {
        format!(
            "reading {} (is {} a job folder written by a sharded command?)",
            path.display(),
            dir.display()
        )
    })?;
    let job: Job = serde_json::from_str(&text).map_err(|e| {
        anyhow::anyhow!(
            "{}: line {} column {}: {e}",
            path.display(),
            e.line(),
            e.column()
        )
    })?;
    if job.format != JOB_FORMAT {
        bail!(
            "{}: field `format` is {:?}, expected {JOB_FORMAT:?}",
            path.display(),
            job.format
        );
    }
    check_units(&job.units).with_context(|| path.display().to_string())?;
    Ok(job)
}

/// Makes `dir` the folder of `job`: a new or empty folder is claimed (marker and `job.json`
/// written); a folder of the same job is accepted (a shard joins it, or a run is resumed); a
/// folder of another job, or one the toolkit did not write, is refused. Safe when the shards
/// of one job start at once on a shared file system: `job.json` is written without
/// overwriting, and a shard that loses the race compares it with its own.
pub fn open_job(dir: &Path, job: &Job) -> Result<()> {
    claim_job_dir(dir)?;
    let mut text = serde_json::to_string_pretty(job)?;
    text.push('\n');
    let path = dir.join(JOB_FILE);
    if zmp_files::write_file(&path, zmp_files::Kind::Json, text.as_bytes(), false).is_ok() {
        return Ok(());
    }
    let there = read_job(dir)?;
    if there != *job {
        bail!(
            "{} holds another job ({} with {}; this one is {} with {}): choose a new folder",
            dir.display(),
            serde_json::to_string(&there.kind)?,
            there.params,
            serde_json::to_string(&job.kind)?,
            job.params
        );
    }
    Ok(())
}

/// How long a shard waits for another shard's claim of the job folder to land: the claim is
/// one small synced file renamed into place, milliseconds even on a loaded shared file system;
/// a folder still holding only temporary files after this is a crashed claim, refused.
const CLAIM_WAIT: Duration = Duration::from_secs(30);

/// Claims the job folder ([`zmp_files::claim_dir`]). The shards of one job start at once: a
/// shard may find the folder another shard has just made with the marker not yet renamed into
/// place (only temporary files in it, or the marker landing while `claim_dir` looked); it waits
/// for the marker instead of refusing the folder.
fn claim_job_dir(dir: &Path) -> Result<()> {
    let deadline = Instant::now() + CLAIM_WAIT;
    loop {
        match zmp_files::claim_dir(dir, zmp_files::Kind::Job, true) {
            Err(_) if Instant::now() < deadline && being_claimed(dir) => {
                std::thread::sleep(Duration::from_millis(20));
            }
            r => return r.map(|_| ()).map_err(Into::into),
        }
    }
}

/// Whether `dir` holds nothing but another writer's temporary files and perhaps the marker it
/// has just renamed into place (a claim under way, or one that landed after `claim_dir` looked
/// for the marker and before it listed the folder).
fn being_claimed(dir: &Path) -> bool {
    std::fs::read_dir(dir).is_ok_and(|entries| {
        entries.flatten().all(|e| {
            let name = e.file_name();
            let name = name.to_string_lossy();
            name.contains(".zmp-tmp-") || name.starts_with(".tmp-") || name == JOB_MARKER
        })
    })
}

/// Which units a run takes.
#[derive(Debug, Clone)]
pub struct RunOptions {
    /// The part of the job's partition to run (`--shard i/n`).
    pub shard: Shard,
    /// Only this unit (`--unit ID`: re-running one unit alone), whatever its shard.
    pub only: Option<String>,
    /// Leave units that already have a result without error (a held-out range is resumed, never
    /// run twice).
    pub keep_done: bool,
    /// Units run at once inside this process.
    pub threads: usize,
    /// No progress lines on standard error.
    pub quiet: bool,
}

/// What a run did.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ShardRun {
    /// Units run.
    pub ran: Vec<String>,
    /// Of those, the ones that failed.
    pub failed: Vec<String>,
    /// Units left as they were ([`RunOptions::keep_done`]).
    pub kept: Vec<String>,
}

fn panic_text(p: &(dyn std::any::Any + Send)) -> String {
    p.downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| p.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "a panic without a message".into())
}

/// Runs the units of `opts.shard` (or the one unit `opts.only`) of a job whose folder
/// [`open_job`] opened, longest expected first, `opts.threads` at a time, and writes each
/// one's result file as soon as it ends. A unit's error or panic is its failed result;
/// nothing else is affected. Errors: an unknown `--unit`, a result file that cannot be written.
pub fn run_units(
    dir: &Path,
    job: &Job,
    opts: &RunOptions,
    run: impl Fn(&UnitSpec) -> Result<Value> + Sync,
) -> Result<ShardRun> {
    let mut picked: Vec<usize> = match &opts.only {
        Some(id) => {
            let k = job
                .units
                .iter()
                .position(|u| &u.id == id)
                .with_context(|| {
                    format!(
                        "--unit {id}: no such unit in the job of {} (its units: {}{})",
                        dir.display(),
                        job.units
                            .iter()
                            .take(5)
                            .map(|u| u.id.as_str())
                            .collect::<Vec<_>>()
                            .join(", "),
                        if job.units.len() > 5 { ", ..." } else { "" }
                    )
                })?;
            vec![k]
        }
        None if opts.shard == Shard::WHOLE => lpt_order(&job.units),
        None => shard_units(&job.units, opts.shard),
    };
    let mut out = ShardRun::default();
    // Read before any unit runs: the executable may be rebuilt while they do.
    let build = crate::unit::build_id();
    if opts.keep_done {
        let mut other: Vec<String> = Vec::new();
        picked.retain(|&k| {
            let id = &job.units[k].id;
            let r = read_unit(&unit_path(dir, id)).ok().filter(|r| r.is_ok());
            if let Some(r) = &r {
                if !r.build.is_empty() && r.build != build {
                    other.push(format!("{id} (build {})", r.build));
                }
                out.kept.push(id.clone());
            }
            r.is_none()
        });
        if !other.is_empty() {
            bail!(
                "{}: {} units have results from another build than this one ({build}): {}{}; \
                 a resumed job runs on the build that began it (the same binary), or its table \
                 would mix two versions of the code. Run that binary, or choose a new folder",
                dir.display(),
                other.len(),
                other.iter().take(3).cloned().collect::<Vec<_>>().join(", "),
                if other.len() > 3 { ", ..." } else { "" }
            );
        }
    }
    let total = picked.len();
    let finished = std::sync::atomic::AtomicUsize::new(0);
    let results = zmp_campaign::par::parallel_map(total, opts.threads, |k| {
        let spec = &job.units[picked[k]];
        let t = Instant::now();
        let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| run(spec)));
        let wall_s = t.elapsed().as_secs_f64();
        let status = match r {
            Ok(Ok(outcome)) => Status::Ok { outcome },
            Ok(Err(e)) => Status::Failed {
                error: format!("{e:#}"),
            },
            Err(p) => Status::Failed {
                error: format!("panicked: {}", panic_text(p.as_ref())),
            },
        };
        let result = UnitResult::new(&spec.id, wall_s, status);
        let written = write_unit(dir, &result);
        let n = finished.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
        if !opts.quiet {
            match &result.status {
                Status::Ok { .. } => eprintln!("[{n}/{total}] {} ok ({wall_s:.1} s)", spec.id),
                Status::Failed { error } => {
                    eprintln!("[{n}/{total}] {} FAILED ({wall_s:.1} s): {error}", spec.id)
                }
            }
        }
        written.map(|()| (spec.id.clone(), result.is_ok()))
    });
    for r in results {
        let (id, ok) = r?;
        if !ok {
            out.failed.push(id.clone());
        }
        out.ran.push(id);
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::unit::UNITS_DIR;

    fn job(n: usize) -> Job {
        let units = (0..n)
            .map(|k| UnitSpec::new(format!("u{k}"), 1.0 + k as f64))
            .collect();
        Job::new(JobKind::Suite, serde_json::json!({"range": "test"}), units).unwrap()
    }

    fn opts(shard: Shard) -> RunOptions {
        RunOptions {
            shard,
            only: None,
            keep_done: false,
            threads: 2,
            quiet: true,
        }
    }

    #[test]
    fn shards_write_each_unit_once_and_a_rerun_replaces_only_its_own() {
        let d = tempfile::tempdir().unwrap();
        let dir = d.path().join("job");
        let j = job(7);
        open_job(&dir, &j).unwrap();
        let calls = std::sync::Mutex::new(Vec::new());
        let run = |u: &UnitSpec| -> Result<Value> {
            calls.lock().unwrap().push(u.id.clone());
            if u.id == "u3" {
                bail!("bad campaign");
            }
            if u.id == "u5" {
                panic!("index out of range");
            }
            Ok(serde_json::json!({"id": u.id}))
        };
        let mut ran = Vec::new();
        for i in 1..=3 {
            let r = run_units(&dir, &j, &opts(Shard::new(i, 3).unwrap()), run).unwrap();
            ran.extend(r.ran);
        }
        ran.sort();
        assert_eq!(ran.len(), 7);
        ran.dedup();
        assert_eq!(ran.len(), 7, "a unit ran in two shards");
        let files = std::fs::read_dir(dir.join(UNITS_DIR)).unwrap().count();
        assert_eq!(files, 7);
        let u3 = read_unit(&unit_path(&dir, "u3")).unwrap();
        assert_eq!(
            u3.status,
            Status::Failed {
                error: "bad campaign".into()
            }
        );
        let u5 = read_unit(&unit_path(&dir, "u5")).unwrap();
        assert!(
            matches!(&u5.status, Status::Failed { error } if error.contains("panicked: index")),
            "{u5:?}"
        );
        // One unit alone, then a shard again: files replaced, none added.
        let before = std::fs::read(unit_path(&dir, "u0")).unwrap();
        calls.lock().unwrap().clear();
        let one = RunOptions {
            only: Some("u3".into()),
            ..opts(Shard::WHOLE)
        };
        let r = run_units(&dir, &j, &one, |u| Ok(serde_json::json!({"id": u.id}))).unwrap();
        assert_eq!(r.ran, vec!["u3".to_string()]);
        assert!(read_unit(&unit_path(&dir, "u3")).unwrap().is_ok());
        assert_eq!(std::fs::read(unit_path(&dir, "u0")).unwrap(), before);
        // Resuming with keep_done runs only what has no good result (u5).
        let resume = RunOptions {
            keep_done: true,
            ..opts(Shard::WHOLE)
        };
        let r = run_units(&dir, &j, &resume, |u| Ok(serde_json::json!({"id": u.id}))).unwrap();
        assert_eq!(r.ran, vec!["u5".to_string()]);
        assert_eq!(r.kept.len(), 6);
        assert_eq!(std::fs::read_dir(dir.join(UNITS_DIR)).unwrap().count(), 7);
        let bad = RunOptions {
            only: Some("nope".into()),
            ..opts(Shard::WHOLE)
        };
        let e = run_units(&dir, &j, &bad, run).unwrap_err().to_string();
        assert!(e.contains("--unit nope: no such unit"), "{e}");
    }

    /// Units of another build: a resumed run refuses the folder, keeping its results; a
    /// merge refuses to mix them with this build's; older files without a build count as none.
    #[test]
    fn one_job_holds_the_results_of_one_build() {
        let d = tempfile::tempdir().unwrap();
        let dir = d.path().join("job");
        let j = job(3);
        open_job(&dir, &j).unwrap();
        let ok = |u: &UnitSpec| Ok(serde_json::json!({"id": u.id}));
        run_units(&dir, &j, &opts(Shard::WHOLE), ok).unwrap();
        let this = crate::unit::build_id();
        assert_eq!(this.len(), 16, "{this:?}");
        assert!(crate::collect(&dir).is_ok());
        let mut u1 = read_unit(&unit_path(&dir, "u1")).unwrap();
        assert_eq!(u1.build, this);
        u1.build = "0123456789abcdef".into();
        write_unit(&dir, &u1).unwrap();
        let resume = RunOptions {
            keep_done: true,
            ..opts(Shard::WHOLE)
        };
        let e = run_units(&dir, &j, &resume, ok).unwrap_err().to_string();
        assert!(e.contains("u1 (build 0123456789abcdef)"), "{e}");
        assert!(e.contains(&format!("than this one ({this})")), "{e}");
        assert_eq!(
            read_unit(&unit_path(&dir, "u1")).unwrap(),
            u1,
            "kept as it was"
        );
        let e = format!("{:#}", crate::collect(&dir).unwrap_err());
        assert!(e.contains("ran on 2 builds"), "{e}");
        assert!(
            e.contains("build 0123456789abcdef: 1 units (first u1)"),
            "{e}"
        );
        // A file from before builds were recorded: neither refused nor counted.
        u1.build.clear();
        write_unit(&dir, &u1).unwrap();
        let r = run_units(&dir, &j, &resume, ok).unwrap();
        assert_eq!(r.kept.len(), 3);
        assert!(crate::collect(&dir).is_ok());
        let text = std::fs::read_to_string(unit_path(&dir, "u1")).unwrap();
        let old: UnitResult = serde_json::from_str(&text.replace("\"build\": \"\",", "")).unwrap();
        assert_eq!(old.build, "");
    }

    #[test]
    fn a_folder_holds_one_job() {
        let d = tempfile::tempdir().unwrap();
        let dir = d.path().join("job");
        open_job(&dir, &job(3)).unwrap();
        // The same job again (another shard, a resume): accepted.
        open_job(&dir, &job(3)).unwrap();
        let e = open_job(&dir, &job(4)).unwrap_err().to_string();
        assert!(e.contains("holds another job"), "{e}");
        // A folder the toolkit did not write is refused.
        let mine = d.path().join("mine");
        std::fs::create_dir(&mine).unwrap();
        std::fs::write(mine.join("notes.txt"), "x").unwrap();
        let e = open_job(&mine, &job(3)).unwrap_err().to_string();
        assert!(e.contains("not written by zmp-toolkit"), "{e}");
        assert_eq!(read_job(&dir).unwrap(), job(3));
    }

    #[test]
    fn shards_starting_at_once_all_join_a_new_folder() {
        // The race of an array job's tasks: every shard sees a missing (or just made) folder.
        for round in 0..100 {
            let d = tempfile::tempdir().unwrap();
            let dir = d.path().join("job");
            let results: Vec<Result<()>> = std::thread::scope(|s| {
                let hs: Vec<_> = (0..8)
                    .map(|_| s.spawn(|| open_job(&dir, &job(5))))
                    .collect();
                hs.into_iter().map(|h| h.join().unwrap()).collect()
            });
            for r in results {
                r.unwrap_or_else(|e| panic!("round {round}: {e:#}"));
            }
            assert_eq!(read_job(&dir).unwrap(), job(5));
        }
        // A folder holding only a stale temporary file still is not the toolkit's after the wait
        // (checked without the wait: a non-temporary file ends it at once).
        let d = tempfile::tempdir().unwrap();
        std::fs::write(d.path().join(".tmp-x"), "x").unwrap();
        std::fs::write(d.path().join("y"), "y").unwrap();
        assert!(!being_claimed(d.path()));
    }
}
