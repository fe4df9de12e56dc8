//! The arguments of the project's own tasks that take more than a flag or two.

use std::path::PathBuf;

use anyhow::Result;
use clap::Args;

use crate::bench;

#[derive(Args)]
pub struct BenchCmd {
    /// Only the instruction counts and the gate (what `cargo xtask ci` runs; about half a
    /// minute after `cargo test --workspace --release`): no criterion, no history.
    #[arg(long)]
    counts_only: bool,
    /// Write this run's counts, with this machine's fingerprint, as the new baseline
    /// instead of gating (after a deliberate change of speed, toolchain or dependencies;
    /// implies --counts-only).
    #[arg(long)]
    save_baseline: bool,
    /// Only this bench (repeatable): plant_step/all_effects, plant_step/paper_nominal,
    /// controller_step, fmu_do_step/plant_fmi2, identify/small_campaign,
    /// diagnose/small_campaign.
    #[arg(long = "only", value_name = "BENCH")]
    only: Vec<String>,
    /// Baseline file (default bench/baseline.toml).
    #[arg(long)]
    baseline: Option<PathBuf>,
    /// Test of the gate itself: build the real-time count binary with the test-only
    /// feature that adds about 6 % instructions to the plant step (the gate must fail).
    #[arg(long)]
    planted_regression: bool,
    /// Print the counts, the gate's verdicts and the wall-clock results as JSON.
    #[arg(long)]
    json: bool,
}

impl BenchCmd {
    /// Counts, gates and (unless `--counts-only`) benchmarks.
    pub fn run(self) -> Result<()> {
        let BenchCmd {
            counts_only,
            save_baseline,
            only,
            baseline,
            planted_regression,
            json,
        } = self;
        bench::bench(&bench::BenchArgs {
            counts_only: counts_only || save_baseline,
            save_baseline,
            only,
            baseline,
            planted_regression,
            json,
        })
    }
}
