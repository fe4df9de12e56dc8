//! A job folder and running a shard of it.

use crate::partition::{check_units, lpt_order, shard_sequence};
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
    /// After its part, take the units of other parts no shard has claimed (`--steal`: the
    /// shards share the job folder; see [`crate::claim`]).
    pub steal: bool,
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
    /// Of the units run, those of other shards' parts ([`RunOptions::steal`]).
    pub taken: Vec<String>,
    /// Units of this shard's part another shard had claimed (it runs or ran them).
    pub left: Vec<String>,
}

fn panic_text(p: &(dyn std::any::Any + Send)) -> String {
    p.downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| p.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "a panic without a message".into())
}

/// The units a run considers, in order, each with whether it is the run's own (not taken from
/// another shard's part).
fn pick(dir: &Path, job: &Job, opts: &RunOptions) -> Result<Vec<(usize, bool)>> {
    Ok(match &opts.only {
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
            vec![(k, true)]
        }
        None if opts.shard == Shard::WHOLE => lpt_order(&job.units)
            .into_iter()
            .map(|k| (k, true))
            .collect(),
        None => shard_sequence(&job.units, opts.shard, opts.steal),
    })
}

/// With `keep_done`, leaves out the units that have a result without error (into `kept`),
/// refusing a folder whose results another build wrote.
fn leave_done(
    dir: &Path,
    job: &Job,
    picked: &mut Vec<(usize, bool)>,
    kept: &mut Vec<String>,
) -> Result<()> {
    let build = crate::unit::build_id();
    let mut other: Vec<String> = Vec::new();
    picked.retain(|&(k, own)| {
        let id = &job.units[k].id;
        let r = read_unit(&unit_path(dir, id)).ok().filter(|r| r.is_ok());
        if let Some(r) = &r {
            if !r.build.is_empty() && r.build != build {
                other.push(format!("{id} (build {})", r.build));
            }
            if own {
                kept.push(id.clone());
            }
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
    Ok(())
}

/// Runs the units of `opts.shard` (or the one unit `opts.only`) of a job whose folder
/// [`open_job`] opened, longest expected first, `opts.threads` at a time, and writes each
/// one's result file as soon as it ends; with `opts.steal`, then the units of other parts that
/// no shard has claimed. A shard claims each unit before it runs it ([`crate::claim`]) and
/// leaves the units another shard has claimed; the whole job and `--unit` run without claims.
/// A unit's error or panic is its failed result; nothing else is affected. Errors: an unknown
/// `--unit`, a claim or a result file that cannot be written.
pub fn run_units(
    dir: &Path,
    job: &Job,
    opts: &RunOptions,
    run: impl Fn(&UnitSpec) -> Result<Value> + Sync,
) -> Result<ShardRun> {
    let mut picked = pick(dir, job, opts)?;
    let mut out = ShardRun::default();
    // Read before any unit runs: the executable may be rebuilt while they do.
    let _ = crate::unit::build_id();
    if opts.keep_done {
        leave_done(dir, job, &mut picked, &mut out.kept)?;
    }
    let claims = opts.only.is_none() && opts.shard != Shard::WHOLE;
    let total = picked.iter().filter(|p| p.1).count();
    let finished = std::sync::atomic::AtomicUsize::new(0);
    let stolen = std::sync::atomic::AtomicUsize::new(0);
    let results = zmp_campaign::par::parallel_map(picked.len(), opts.threads, |k| {
        let (index, own) = picked[k];
        let spec = &job.units[index];
        if claims && !crate::claim::claim(dir, &spec.id, opts.shard, own)? {
            return Ok((spec.id.clone(), own, None));
        }
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
        if !opts.quiet {
            use std::sync::atomic::Ordering::Relaxed;
            let (n, whose) = if own {
                (
                    format!("{}/{total}", finished.fetch_add(1, Relaxed) + 1),
                    "",
                )
            } else {
                (
                    format!("+{}", stolen.fetch_add(1, Relaxed) + 1),
                    ", from another shard",
                )
            };
            match &result.status {
                Status::Ok { .. } => eprintln!("[{n}] {} ok ({wall_s:.1} s{whose})", spec.id),
                Status::Failed { error } => {
                    eprintln!("[{n}] {} FAILED ({wall_s:.1} s{whose}): {error}", spec.id)
                }
            }
        }
        written.map(|()| (spec.id.clone(), own, Some(result.is_ok())))
    });
    for r in results {
        match r? {
            (id, true, None) => out.left.push(id),
            (_, false, None) => {}
            (id, own, Some(ok)) => {
                if !ok {
                    out.failed.push(id.clone());
                }
                if !own {
                    out.taken.push(id.clone());
                }
                out.ran.push(id);
            }
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests;
