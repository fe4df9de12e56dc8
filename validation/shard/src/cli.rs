//! What every sharded command prints: a part's run, and a merge's result, cost model and
//! failures (one wording for the suite, the fleet and `calibrate-com`).

use crate::collect::{write_outputs, Collected, Merged};
use crate::job::{open_job, run_units, Job, RunOptions, ShardRun};
use crate::{Shard, UnitSpec};
use anyhow::{bail, Result};
use serde_json::{json, Value};
use std::path::Path;

/// Opens the job folder `out`, runs the units `opts` picks (progress on standard error) and,
/// for a part (`--shard`, `--unit`) with `json_out`, prints what ran as JSON.
pub fn run_part(
    out: &Path,
    job: &Job,
    opts: &RunOptions,
    json_out: bool,
    run: impl Fn(&UnitSpec) -> Result<Value> + Sync,
) -> Result<ShardRun> {
    open_job(out, job)?;
    let what = match &opts.only {
        Some(id) => format!("unit {id}"),
        None => format!("shard {}", opts.shard),
    };
    if !opts.quiet {
        eprintln!(
            "{what} of {} units -> {} ({} at a time)",
            job.units.len(),
            out.display(),
            opts.threads
        );
    }
    let r = run_units(out, job, opts, run)?;
    if !r.kept.is_empty() && !opts.quiet {
        eprintln!(
            "{} units already have a result and were left as they are",
            r.kept.len()
        );
    }
    if json_out && (opts.only.is_some() || opts.shard != Shard::WHOLE) {
        println!(
            "{}",
            serde_json::to_string_pretty(&json!({
                "job": out, "part": what, "ran": r.ran, "failed": r.failed, "kept": r.kept,
                "taken": r.taken, "left": r.left,
            }))?
        );
    }
    Ok(r)
}

/// After a part: the next step (merge), or an error naming the units that failed.
pub fn finish_part(out: &Path, r: &ShardRun, json_out: bool) -> Result<()> {
    if !json_out {
        let mut also = String::new();
        if !r.kept.is_empty() {
            also.push_str(&format!(", kept {}", r.kept.len()));
        }
        if !r.taken.is_empty() || !r.left.is_empty() {
            also.push_str(&format!(
                ", {} from other parts, {} of its own left to other shards",
                r.taken.len(),
                r.left.len()
            ));
        }
        println!(
            "ran {} units ({} failed){also}; when every shard is done: cargo xtask merge {}",
            r.ran.len(),
            r.failed.len(),
            out.display()
        );
    }
    if !r.failed.is_empty() {
        bail!(
            "{} units failed ({}); their errors are in {}/units/<id>.json and merge names them",
            r.failed.len(),
            r.failed.join(", "),
            out.display()
        );
    }
    Ok(())
}

/// Prints the failed and missing units and fails when there are any (`rerun`: the command
/// that re-runs one unit, without `--unit ID`).
pub fn check_complete(dir: &Path, c: &Collected, rerun: &str) -> Result<()> {
    let problems = c.problems_text(rerun);
    if !problems.is_empty() {
        eprint!("{problems}");
    }
    if !c.complete() {
        bail!(
            "{} units failed and {} are missing in {}",
            c.failed.len(),
            c.missing.len(),
            dir.display()
        );
    }
    Ok(())
}

/// Writes a merge's files into the job folder, prints the result (or, with `json_out`, the
/// result, the units' state and the cost model as JSON) and the cost model, and fails naming
/// the failed and missing units.
pub fn finish_merge(
    dir: &Path,
    c: &Collected,
    m: &Merged,
    json_out: bool,
    rerun: &str,
) -> Result<()> {
    write_outputs(dir, &m.files)?;
    let cost = c.cost();
    if json_out {
        println!(
            "{}",
            serde_json::to_string_pretty(&json!({
                "result": m.json, "units": c.summary(), "cost": cost,
            }))?
        );
    } else {
        println!("{}", m.text);
        println!(
            "merged {} of {} units into {} ({})",
            c.done.len(),
            c.job.units.len(),
            dir.display(),
            m.files
                .iter()
                .map(|f| f.0.as_str())
                .collect::<Vec<_>>()
                .join(", ")
        );
        println!("{}", cost.text());
    }
    check_complete(dir, c, rerun)
}
