//! `cargo xtask bench`: the speed of the hot paths and of the commands, tracked.
//!
//! 1. **Instruction counts** (`counts`) of the real-time steps, the FMU step through the Rust
//!    importer, and the identification and diagnosis of a small campaign, under callgrind, and
//!    the **gate** (`gate`) against the committed `bench/baseline.toml`. `cargo xtask ci` runs
//!    this part (`--counts-only`).
//! 2. **Wall clock** (`wall`): the criterion benches of `bench/`, among them the commands as a
//!    user runs them (`identify`, `compare`, `diagnose` on the 168-record campaign), and the
//!    peers in the same run (numpy identification, FMPy per-step cost, MuJoCo's Python stepping
//!    once the twin's bench exists), as ratios.
//! 3. **History** (`history`): each full run appends to `bench/history.jsonl` with the commit,
//!    draws a trend per hot path (`bench/trends/*.svg`) and regenerates the latest table of
//!    `bench/README.md`.

pub mod counts;
pub mod fingerprint;
pub mod gate;
pub mod history;
pub mod wall;

use anyhow::{bail, Context, Result};
use std::collections::BTreeSet;
use std::path::PathBuf;

use crate::env::repo_root;
use counts::{CountBench, Runner, REGISTRY};
use gate::{Baseline, BaselineBench, Measured};

/// Options of `cargo xtask bench`.
#[derive(Debug, Clone, Default)]
pub struct BenchArgs {
    /// Instruction counts and the gate only (what CI runs): no criterion, no history.
    pub counts_only: bool,
    /// Rewrite the baseline from this run's counts instead of gating.
    pub save_baseline: bool,
    /// Only these benches (names of the registry); default all that can be measured.
    pub only: Vec<String>,
    /// Baseline file (default `bench/baseline.toml`).
    pub baseline: Option<PathBuf>,
    /// Test of the gate: build the real-time count binary with the planted regression.
    pub planted_regression: bool,
    /// Machine-readable result on standard output.
    pub json: bool,
}

pub fn default_baseline() -> PathBuf {
    repo_root().join("bench/baseline.toml")
}

/// The benches a run measures: `only`, else every registered bench.
fn selected(args: &BenchArgs) -> Result<Vec<&'static CountBench>> {
    let benches: Vec<&'static CountBench> = if args.only.is_empty() {
        REGISTRY.iter().collect()
    } else {
        args.only
            .iter()
            .map(|n| counts::lookup(n))
            .collect::<Result<_>>()?
    };
    if args.planted_regression {
        if let Some(b) = benches
            .iter()
            .find(|b| !matches!(b.runner, Runner::Realtime(_)))
        {
            bail!(
                "--planted-regression builds only the real-time count binary; {} is not a \
                 real-time loop (use --only plant_step/all_effects)",
                b.name
            );
        }
    }
    Ok(benches)
}

/// Measures the instruction counts of `benches`.
pub fn measure_counts(benches: &[&'static CountBench], planted: bool) -> Result<Vec<Measured>> {
    let bins: BTreeSet<&str> = benches.iter().filter_map(|b| b.binary()).collect();
    eprintln!(
        "bench: building {} (release{})",
        bins.iter().copied().collect::<Vec<_>>().join(", "),
        if planted {
            ", with the planted regression"
        } else {
            ""
        }
    );
    let exes = counts::build(&bins, planted)?;
    let inputs = counts::prepare(benches, &exes)?;
    counts::run(benches, &exes, &inputs)
}

/// The outcome of the count part of a run.
pub struct CountOutcome {
    pub measured: Vec<Measured>,
    pub report: Option<gate::Report>,
}

/// Counts and gate (or baseline refresh). Errors when the gate fails.
pub fn counts_and_gate(args: &BenchArgs) -> Result<CountOutcome> {
    let benches = selected(args)?;
    let baseline_path = args.baseline.clone().unwrap_or_else(default_baseline);
    let fingerprint = fingerprint::fingerprint()?;
    let measured = measure_counts(&benches, args.planted_regression)?;
    if args.save_baseline {
        if args.planted_regression {
            bail!("--save-baseline with --planted-regression would store the planted regression");
        }
        if let Some(z) = measured.iter().find(|m| m.instructions == 0) {
            bail!(
                "{}: measured 0 instructions; the baseline is not written",
                z.name
            );
        }
        // A selected run keeps the other benches of an existing baseline (same fingerprint).
        let mut kept: Vec<BaselineBench> = Vec::new();
        if !args.only.is_empty() && baseline_path.exists() {
            let old = Baseline::read(&baseline_path)?;
            if old.fingerprint == fingerprint {
                kept = old
                    .benches
                    .into_iter()
                    .filter(|b| !measured.iter().any(|m| m.name == b.name))
                    .collect();
            }
        }
        kept.extend(measured.iter().map(|m| BaselineBench {
            name: m.name.clone(),
            instructions: m.instructions,
            repetitions: m.repetitions,
        }));
        kept.sort_by_key(|b| REGISTRY.iter().position(|r| r.name == b.name));
        let baseline = Baseline {
            format: gate::FORMAT.into(),
            commit: history::commit_id(),
            fingerprint,
            benches: kept,
        };
        zmp_files::write_file(
            &baseline_path,
            zmp_files::Kind::Baseline,
            baseline.to_toml()?.as_bytes(),
            true,
        )?;
        eprintln!("bench: wrote {}", baseline_path.display());
        return Ok(CountOutcome {
            measured,
            report: None,
        });
    }
    let baseline = Baseline::read(&baseline_path)?;
    let expected: Vec<(&str, f64)> = benches.iter().map(|b| (b.name, b.tolerance)).collect();
    let report = gate::compare(&baseline, &fingerprint, &expected, &measured);
    eprintln!(
        "bench: instruction-count gate against {} (measured on {}):\n{}",
        baseline_path.display(),
        baseline.commit,
        report.to_text()
    );
    Ok(CountOutcome {
        measured,
        report: Some(report),
    })
}

pub fn bench(args: &BenchArgs) -> Result<()> {
    let outcome = counts_and_gate(args)?;
    let gate_ok = outcome.report.as_ref().is_none_or(gate::Report::ok);
    let mut wall_results = None;
    if !args.counts_only {
        let w = wall::run().context("the wall-clock benches")?;
        history::record(&outcome.measured, &w)?;
        wall_results = Some(w);
    }
    if args.json {
        println!(
            "{}",
            serde_json::json!({
                "ok": gate_ok,
                "counts": outcome.measured.iter().map(|m| serde_json::json!({
                    "name": m.name,
                    "instructions": m.instructions,
                    "repetitions": m.repetitions,
                    "per_repetition": m.per_repetition(),
                })).collect::<Vec<_>>(),
                "gate": outcome.report,
                "wall": wall_results,
            })
        );
    }
    if !gate_ok {
        let report = outcome.report.expect("a gate ran");
        let failing: Vec<String> = report
            .rows
            .iter()
            .filter(|r| !r.ok())
            .map(|r| r.describe())
            .chain(
                (!report.fingerprint_differences.is_empty())
                    .then(|| format!("fingerprint: {}", report.fingerprint_differences.join("; "))),
            )
            .collect();
        bail!(
            "the instruction-count gate failed:\n  {}",
            failing.join("\n  ")
        );
    }
    Ok(())
}
