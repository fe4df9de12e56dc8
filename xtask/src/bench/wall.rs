//! The wall-clock part of `cargo xtask bench`: the criterion benches of `bench/` (the real-time
//! steps, the FMU steps, the identification pipeline, the commands as a user runs them, the
//! diagnosis) and the peers they run in the same process, collected from criterion's estimates
//! and from the results file the benches append to (`ZMP_BENCH_RESULTS`).

use anyhow::{bail, Context, Result};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::Path;
use std::process::{Command, Stdio};

use super::counts::target_dir;
use crate::env::{apply_env, prereqs, repo_root};

/// The criterion benches `cargo xtask bench` runs, in order.
pub const BENCHES: &[&str] = &[
    "realtime",
    "fmu",
    "identify",
    "commands",
    "diagnose",
    "design_next",
];

/// Criterion ids whose medians go into the history and the table, with what they measure.
pub const MEDIANS: &[(&str, &str)] = &[
    ("plant_step/all_effects", "one plant step, every effect on"),
    ("plant_step/paper_nominal", "one plant step, paper model"),
    ("controller_step", "one cascade-controller step"),
    (
        "fmu_step_rust_importer/plant_fmi2",
        "one plant FMU step through the `fmi` crate",
    ),
    (
        "identify/read_and_fit_168",
        "read + identify the 168-record campaign (library)",
    ),
    (
        "command/identify_168",
        "`xtask identify` on the 168-record campaign (process)",
    ),
    (
        "command/compare_168",
        "`xtask compare` on the 168-record campaign (process)",
    ),
    (
        "command/diagnose_168",
        "`xtask diagnose` on the 168-record campaign (process)",
    ),
    (
        "command/loop_168",
        "`xtask loop` (identify, diagnose, augment) on a 168-record campaign of the \
         independent simulator: saturation + delay + drift (process; target <= 20 s)",
    ),
    (
        "diagnose/delay_and_drift_168",
        "diagnosis, delay + drift robot (library)",
    ),
    (
        "diagnose/friction_168",
        "diagnosis, friction robot (library)",
    ),
    (
        "design_next/play_and_delay_168",
        "design-next, a play and a delay's two rivals, 168-record campaign (library; target \
         <= 30 s)",
    ),
    (
        "design_next/budget_24_168",
        "design-next, the same with the whole budget of 24 records designed (library)",
    ),
    (
        "design_next/play_in_servo_168",
        "design-next, the play inside the servo (describing functions simulated), 168-record \
         campaign (library; target <= 30 s)",
    ),
];

/// One peer comparison of the run, as a bench reported it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Peer {
    /// What is compared, e.g. `identify_168/numpy`.
    pub name: String,
    /// Our side, s (per run or per step, as `unit` says).
    pub ours_s: f64,
    /// The peer's side, s.
    pub peer_s: f64,
    /// `peer_s / ours_s`: how many times faster we are.
    pub ratio: f64,
    /// `run` or `step`.
    pub unit: String,
    /// How it was measured.
    pub note: String,
}

/// Wall-clock results of one run.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct WallResults {
    /// Criterion medians, s, by id.
    pub medians: BTreeMap<String, f64>,
    pub peers: Vec<Peer>,
}

/// Runs the criterion benches and collects their medians and peers.
pub fn run() -> Result<WallResults> {
    let work = target_dir().join("bench-wall");
    std::fs::create_dir_all(&work).with_context(|| format!("creating {}", work.display()))?;
    let results = work.join("peers.jsonl");
    zmp_files::write_file(&results, zmp_files::Kind::BenchHistory, b"", true)
        .with_context(|| format!("clearing {}", results.display()))?;
    let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
    let mut cmd = Command::new(cargo);
    cmd.current_dir(repo_root())
        .args(["bench", "-p", "zmp-bench"])
        .stdin(Stdio::null());
    for b in BENCHES {
        cmd.args(["--bench", b]);
    }
    crate::ci::strip_cargo_run_env(&mut cmd);
    apply_env(&mut cmd, &prereqs());
    cmd.env("ZMP_BENCH_RESULTS", &results);
    // The commands bench runs this very binary (`cargo xtask` builds it in release).
    // When the count binaries' build replaced this binary on disk (another feature set of a
    // shared dependency), `current_exe` names a deleted file; the rebuilt one is in its place.
    let exe = std::env::current_exe()?;
    let exe = if exe.is_file() {
        exe
    } else {
        target_dir().join("release").join("xtask")
    };
    cmd.env("ZMP_XTASK_BIN", exe);
    eprintln!(
        "bench: cargo bench -p zmp-bench --bench {} (several minutes)",
        BENCHES.join(" --bench ")
    );
    let started = std::time::SystemTime::now();
    let status = cmd.status().context("running cargo bench")?;
    if !status.success() {
        bail!("cargo bench failed ({status})");
    }
    // The MuJoCo twin's step against MuJoCo's Python bindings (its own crate: the only one
    // linking MuJoCo).
    let mut twin = Command::new(std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into()));
    twin.current_dir(repo_root())
        .args(["bench", "-p", "zmp-twin", "--bench", "step"])
        .stdin(Stdio::null());
    crate::ci::strip_cargo_run_env(&mut twin);
    apply_env(&mut twin, &prereqs());
    twin.env("ZMP_BENCH_RESULTS", &results);
    eprintln!("bench: cargo bench -p zmp-twin --bench step (about a minute)");
    let status = twin.status().context("running cargo bench -p zmp-twin")?;
    if !status.success() {
        bail!("cargo bench -p zmp-twin --bench step failed ({status})");
    }
    let mut out = WallResults::default();
    let criterion = target_dir().join("criterion");
    for (id, _) in MEDIANS {
        let path = criterion.join(id).join("new/estimates.json");
        out.medians
            .insert((*id).to_string(), read_median(&path, started)?);
    }
    let text = std::fs::read_to_string(&results)
        .with_context(|| format!("reading {}", results.display()))?;
    for (n, line) in text.lines().enumerate() {
        if line.trim().is_empty() {
            continue;
        }
        let p: Peer = serde_json::from_str(line)
            .with_context(|| format!("{}:{}: a peer result", results.display(), n + 1))?;
        out.peers.push(p);
    }
    Ok(out)
}

/// Criterion's median estimate in `estimates.json`, s; an estimate older than `since` (left
/// from an earlier run) is an error.
fn read_median(path: &Path, since: std::time::SystemTime) -> Result<f64> {
    let modified = std::fs::metadata(path)
        .and_then(|m| m.modified())
        .with_context(|| format!("{} (did the bench run?)", path.display()))?;
    if modified < since {
        bail!(
            "{} is from an earlier run: the bench did not run",
            path.display()
        );
    }
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("reading {} (did the bench run?)", path.display()))?;
    let v: serde_json::Value =
        serde_json::from_str(&text).with_context(|| format!("parsing {}", path.display()))?;
    let ns = v["median"]["point_estimate"]
        .as_f64()
        .with_context(|| format!("{}: no median.point_estimate", path.display()))?;
    Ok(ns * 1e-9)
}
