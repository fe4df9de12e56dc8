//! Many-unit commands past one machine (docs/src/scale-out.md): `cargo xtask suite` (one unit
//! per draw of the out-of-sample suite), `cargo xtask merge` (every job kind), and what `fleet`
//! and `calibrate-com --shard` share with them. The contract (units, `--shard i/n`, unit files,
//! the cost model) is `zmp_shard`'s; this module only parses and prints.

use anyhow::{bail, Result};
use serde_json::{json, Value};
use std::path::{Path, PathBuf};
use zmp_shard::{Collected, Job, JobKind, Merged, RunOptions, Shard, ShardRun, UnitSpec};
use zmp_suites::sharded::{self, Range};

/// `cargo xtask suite`.
#[derive(clap::Args)]
pub struct SuiteArgs {
    /// Which draws: `development` (seeds 1-60, where the diagnosis is tuned), `held-out` (60
    /// draws from the next range never run; run once) or `ci` (a few quick development draws).
    #[arg(long)]
    pub range: Range,
    /// First seed of a development or held-out range (held-out default: the next unspent
    /// range after validation/suites/held-out-ranges.csv). A held-out range already recorded
    /// there is refused.
    #[arg(long, value_name = "N")]
    pub first_seed: Option<u64>,
    /// Run only part i of n of the draws (a deterministic partition balanced by expected
    /// cost: every shard of the same job and n gets the same draws). Without it, every draw
    /// is run and the results are merged at the end.
    #[arg(long, value_name = "i/n", conflicts_with = "unit")]
    pub shard: Option<Shard>,
    /// Re-run one unit alone (e.g. `draw-17`, named by merge as failed or missing).
    #[arg(long, value_name = "ID")]
    pub unit: Option<String>,
    /// Job folder: job.json, units/<id>.json (one per draw) and, after a merge, table.md,
    /// report.md and result.json. Shards of one job share it. A folder of another job is
    /// refused; for the held-out range, a folder of the same range is resumed (draws with a
    /// result are never run twice).
    #[arg(long)]
    pub out: PathBuf,
    /// Print the merged result (or, for a shard, what it ran) as JSON.
    #[arg(long)]
    pub json: bool,
}

/// `cargo xtask merge`.
#[derive(clap::Args)]
pub struct MergeArgs {
    /// Job folder (the --out of `suite`, `fleet` or `calibrate-com --shard`).
    pub dir: PathBuf,
    /// Print the merged result, the units' state and the cost model as JSON.
    #[arg(long)]
    pub json: bool,
}

/// Runs the units `opts` picks of `job` in `out` and says what ran (as JSON with `json`).
pub fn run_job(
    out: &Path,
    job: &Job,
    opts: &RunOptions,
    json_out: bool,
    run: impl Fn(&UnitSpec) -> Result<Value> + Sync,
) -> Result<ShardRun> {
    zmp_shard::open_job(out, job)?;
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
    let r = zmp_shard::run_units(out, job, opts, run)?;
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
            }))?
        );
    }
    Ok(r)
}

/// After a shard or a single unit: the next step, or the failures.
pub fn after_part(out: &Path, r: &ShardRun, json_out: bool) -> Result<()> {
    if !json_out {
        println!(
            "ran {} units ({} failed){}; when every shard is done: cargo xtask merge {}",
            r.ran.len(),
            r.failed.len(),
            if r.kept.is_empty() {
                String::new()
            } else {
                format!(", kept {}", r.kept.len())
            },
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

/// Options of a run with `--shard` / `--unit` (`keep_done`: never run a unit with a result
/// again); units run `--threads` at a time (default: every core).
pub fn run_options(shard: Option<Shard>, unit: Option<String>, keep_done: bool) -> RunOptions {
    RunOptions {
        shard: shard.unwrap_or(Shard::WHOLE),
        only: unit,
        keep_done,
        threads: zmp_campaign::par::budget(),
        quiet: false,
    }
}

/// `cargo xtask suite`.
pub fn suite(a: SuiteArgs) -> Result<()> {
    let (job, cases) = sharded::job(a.range, a.first_seed)?;
    let whole = a.shard.is_none() && a.unit.is_none();
    let opts = run_options(a.shard, a.unit, a.range == Range::HeldOut);
    let r = run_job(&a.out, &job, &opts, a.json, |spec| {
        let case = cases
            .iter()
            .find(|c| sharded::unit_id(c) == spec.id)
            .ok_or_else(|| anyhow::anyhow!("no draw for unit {}", spec.id))?;
        sharded::run_unit(case)
    })?;
    if whole {
        merge(&a.out, a.json)
    } else {
        after_part(&a.out, &r, a.json)
    }
}

/// How to re-run one unit of `job` in `dir`.
fn rerun_hint(c: &Collected, dir: &Path) -> String {
    let d = dir.display();
    match c.job.kind {
        JobKind::Suite => format!(
            "cargo xtask suite --range {} --out {d}{}",
            c.job.params["range"].as_str().unwrap_or("?"),
            match c.job.params["range"].as_str() {
                Some("ci") | None => String::new(),
                Some(_) => format!(" --first-seed {}", c.job.params["first_seed"]),
            }
        ),
        JobKind::Fleet => format!(
            "cargo xtask fleet {} --out {d}",
            c.job.params["campaigns"].as_str().unwrap_or("DIR")
        ),
        JobKind::CalibrateCom => format!("cargo xtask calibrate-com --out {d} --shard 1/1"),
    }
}

/// Writes a merge's files, prints the result and the cost model, and fails naming the failed
/// and missing units.
pub fn emit(dir: &Path, c: &Collected, m: &Merged, json_out: bool) -> Result<()> {
    let files = &m.files;
    zmp_shard::collect::write_outputs(dir, files)?;
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
            files
                .iter()
                .map(|f| f.0.as_str())
                .collect::<Vec<_>>()
                .join(", ")
        );
        println!("{}", cost.text());
    }
    let problems = c.problems_text(&rerun_hint(c, dir));
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

/// `cargo xtask merge DIR`: the table, report and JSON of a job folder's units (what the
/// one-process run writes), and the cost model.
pub fn merge(dir: &Path, json_out: bool) -> Result<()> {
    let c = zmp_shard::collect(dir)?;
    match c.job.kind {
        JobKind::Suite => emit(dir, &c, &sharded::render(&c)?, json_out),
        JobKind::Fleet => emit(dir, &c, &crate::fleet::render(&c)?, json_out),
        JobKind::CalibrateCom => crate::calibrate::merge(dir, json_out),
    }
}
