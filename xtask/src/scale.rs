//! Many-unit commands past one machine (docs/src/scale-out.md): `cargo xtask suite` (one unit
//! per draw of the out-of-sample suite), `cargo xtask merge` (every job kind), and what `fleet`
//! and `calibrate-com --shard` share with them. The contract (units, `--shard i/n`, unit files,
//! the cost model) is `zmp_shard`'s; this module only parses and prints.

use anyhow::Result;
use std::path::{Path, PathBuf};
use zmp_shard::cli::{finish_merge, finish_part, run_part};
use zmp_shard::{Collected, JobKind, RunOptions, Shard};
use zmp_suites::sharded::{self, Range};

/// `cargo xtask suite`.
#[derive(clap::Args)]
pub struct SuiteArgs {
    /// Which draws: `development` (seeds 1-300, where the diagnosis is tuned), `held-out` (300
    /// draws from the next range never run; run once), `ci` (12 development draws derived
    /// from the composition: the first of each kind) or `smoke` (5 quick development draws,
    /// for testing the shard machinery).
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
    /// With --shard: when its part is done, take the units of the other parts that no shard
    /// has begun (each unit still runs once; the shards must share OUT, as on a cluster's
    /// shared file system: the Ray driver and the Slurm script pass it).
    #[arg(long, requires = "shard")]
    pub steal: bool,
    /// Job folder: job.json, units/<id>.json (one per draw) and, after a merge, table.md,
    /// report.md and result.json. Shards of one job share it. A folder of another job is
    /// refused; for the held-out range, a folder of the same range is resumed (draws with a
    /// result are never run twice).
    #[arg(long)]
    pub out: PathBuf,
    /// Print the merged result (or, for a shard, what it ran) as JSON.
    #[arg(long)]
    pub json: bool,
    /// Leave the draws that already have a result: a run stopped part-way goes on where it
    /// stopped (the held-out range always does). It must be the build that began the job
    /// (the same binary): results of another build are refused, as a merge refuses units of
    /// two builds.
    #[arg(long)]
    pub resume: bool,
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

/// Options of a run with `--shard` / `--unit` (`keep_done`: never run a unit with a result
/// again; `steal`: take other parts' units after this one's); units run `--threads` at a time
/// (default: every core).
pub fn run_options(
    shard: Option<Shard>,
    unit: Option<String>,
    keep_done: bool,
    steal: bool,
) -> RunOptions {
    RunOptions {
        shard: shard.unwrap_or(Shard::WHOLE),
        only: unit,
        keep_done,
        steal,
        threads: zmp_campaign::par::budget(),
        quiet: false,
    }
}

/// `cargo xtask suite`.
pub fn suite(a: SuiteArgs) -> Result<()> {
    let (job, cases) = sharded::job(a.range, a.first_seed)?;
    let whole = a.shard.is_none() && a.unit.is_none();
    let opts = run_options(
        a.shard,
        a.unit,
        a.resume || a.range == Range::HeldOut,
        a.steal,
    );
    let r = run_part(&a.out, &job, &opts, a.json, |spec| {
        let case = cases
            .iter()
            .find(|c| sharded::unit_id(c) == spec.id)
            .ok_or_else(|| anyhow::anyhow!("no draw for unit {}", spec.id))?;
        sharded::run_unit(case)
    })?;
    if whole {
        merge(&a.out, a.json)
    } else {
        finish_part(&a.out, &r, a.json)
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
                Some("ci" | "smoke") | None => String::new(),
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

/// `cargo xtask merge DIR`: the table, report and JSON of a job folder's units (what the
/// one-process run writes), and the cost model.
pub fn merge(dir: &Path, json_out: bool) -> Result<()> {
    let c = zmp_shard::collect(dir)?;
    match c.job.kind {
        JobKind::Suite => finish_merge(
            dir,
            &c,
            &sharded::render(&c)?,
            json_out,
            &rerun_hint(&c, dir),
        ),
        JobKind::Fleet => finish_merge(
            dir,
            &c,
            &crate::fleet::render(&c)?,
            json_out,
            &rerun_hint(&c, dir),
        ),
        JobKind::CalibrateCom => crate::calibrate::merge(dir, json_out),
    }
}
