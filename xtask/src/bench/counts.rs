//! Instruction counts of the hot paths: the count binaries of `bench/src/bin/*_count.rs` built
//! in release and run under callgrind, each collecting only inside its `count_loop_*` function
//! (`--toggle-collect`), pinned to one CPU so that every pool of the library runs one thread.
//!
//! Callgrind rather than gungraun (iai-callgrind's successor): gungraun 0.20 needs valgrind
//! 3.20 or later and Debian 12, this project's machine, ships 3.19; callgrind itself is all
//! the gate needs, and the count binaries stay plain programs that a person can run by hand.

use anyhow::{anyhow, bail, Context, Result};
use std::collections::{BTreeSet, HashMap};
use std::ffi::OsString;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

use super::gate::Measured;
use crate::env::repo_root;

/// What one repetition of a bench is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Per {
    /// A real-time step, repeated this many times in the counted function.
    Step(u64),
    /// One whole run of a command's work.
    Run,
}

impl Per {
    pub fn repetitions(self) -> u64 {
        match self {
            Per::Step(n) => n,
            Per::Run => 1,
        }
    }
    pub fn unit(self) -> &'static str {
        match self {
            Per::Step(_) => "instructions / step",
            Per::Run => "instructions / run",
        }
    }
}

/// Which count binary runs a bench, and with what.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Runner {
    /// `realtime_count <loop> <steps>`.
    Realtime(&'static str),
    /// `fmu_count <plant.fmu> <model.toml> <steps>`.
    Fmu,
    /// `pipeline_count <mode> <dir>`.
    Pipeline(&'static str),
    /// `twin_count <steps>` (the MuJoCo twin crate; run with MuJoCo's library path).
    Twin,
}

/// One hot path of the gate.
#[derive(Debug, Clone, Copy)]
pub struct CountBench {
    pub name: &'static str,
    pub what: &'static str,
    pub per: Per,
    /// Relative tolerance of the gate: 2 % for real-time loops, 5 % otherwise.
    pub tolerance: f64,
    pub runner: Runner,
}

impl CountBench {
    pub fn binary(&self) -> Option<&'static str> {
        match self.runner {
            Runner::Realtime(_) => Some("realtime_count"),
            Runner::Fmu => Some("fmu_count"),
            Runner::Pipeline(_) => Some("pipeline_count"),
            Runner::Twin => Some("twin_count"),
        }
    }
}

/// Steps counted per real-time loop.
pub const STEPS: u64 = 100_000;
/// Steps counted of the MuJoCo twin (a physics step is about 60 times a plant step; 10,000
/// take about 20 s under callgrind).
pub const TWIN_STEPS: u64 = 10_000;
/// Tolerance of the real-time loops.
pub const REALTIME_TOLERANCE: f64 = 0.02;
/// Tolerance of the other benches.
pub const PIPELINE_TOLERANCE: f64 = 0.05;

/// The gate's benches, in table order.
pub const REGISTRY: &[CountBench] = &[
    CountBench {
        name: "plant_step/all_effects",
        what: "`Plant::step`, every effect of the registry on (bench/src/lib.rs)",
        per: Per::Step(STEPS),
        tolerance: REALTIME_TOLERANCE,
        runner: Runner::Realtime("plant_all_effects"),
    },
    CountBench {
        name: "plant_step/paper_nominal",
        what: "`Plant::step`, the paper's SILO2 model",
        per: Per::Step(STEPS),
        tolerance: REALTIME_TOLERANCE,
        runner: Runner::Realtime("plant_paper_nominal"),
    },
    CountBench {
        name: "controller_step",
        what: "`CascadeController::step`, both axes",
        per: Per::Step(STEPS),
        tolerance: REALTIME_TOLERANCE,
        runner: Runner::Realtime("controller"),
    },
    CountBench {
        name: "fmu_do_step/plant_fmi2",
        what:
            "plant FMU, set 2 inputs + `fmi2DoStep` (1 ms) + get 4 outputs through the `fmi` crate",
        per: Per::Step(STEPS),
        tolerance: REALTIME_TOLERANCE,
        runner: Runner::Fmu,
    },
    CountBench {
        name: "identify/small_campaign",
        what: "read + identify the 16-record campaign of `bench/src/pipeline.rs`, 1 thread",
        per: Per::Run,
        tolerance: PIPELINE_TOLERANCE,
        runner: Runner::Pipeline("identify"),
    },
    CountBench {
        name: "diagnose/small_campaign",
        what: "diagnose that campaign against the model identified from it, 1 thread",
        per: Per::Run,
        tolerance: PIPELINE_TOLERANCE,
        runner: Runner::Pipeline("diagnose"),
    },
    CountBench {
        name: "twin_step",
        what: "one SILO2 twin step: trunk servo references, `mj_step` (MuJoCo 3.17.0's \
               instructions included) and the 8 load cells' ZMP (`zmp-twin`'s `twin_count`)",
        per: Per::Step(TWIN_STEPS),
        tolerance: REALTIME_TOLERANCE,
        runner: Runner::Twin,
    },
];

/// The registered bench called `name`.
pub fn lookup(name: &str) -> Result<&'static CountBench> {
    REGISTRY.iter().find(|b| b.name == name).ok_or_else(|| {
        let names: Vec<_> = REGISTRY.iter().map(|b| b.name).collect();
        anyhow!("no bench {name:?}; the benches are {}", names.join(", "))
    })
}

/// The cargo target directory the count binaries are built in.
pub fn target_dir() -> PathBuf {
    match std::env::var_os("CARGO_TARGET_DIR").filter(|d| !d.is_empty()) {
        Some(d) => {
            let p = PathBuf::from(d);
            if p.is_absolute() {
                p
            } else {
                repo_root().join(p)
            }
        }
        None => repo_root().join("target"),
    }
}

fn cargo() -> OsString {
    std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into())
}

/// Builds the count binaries `bins` (release) and returns their paths by name.
///
/// Normally through `cargo test --workspace --release --no-run`: the count binaries are built
/// as the binaries of zmp-bench's integration test, with the features the test step resolves,
/// so after `cargo test --workspace --release` (CI's step before the gate) this rebuilds
/// nothing (a `cargo build -p zmp-bench` would resolve other features of the shared
/// dependencies and recompile zmp-models and the validation crates). With `planted`, builds them with
/// the planted regression of `Plant::step` and without the pipeline and FMU features, so that
/// only `zmp-models` and `zmp-bench` are recompiled.
pub fn build(bins: &BTreeSet<&str>, planted: bool) -> Result<HashMap<String, PathBuf>> {
    let mut cmd = Command::new(cargo());
    cmd.current_dir(repo_root()).stderr(Stdio::inherit());
    if planted {
        cmd.args(["build", "--release", "-p", "zmp-bench"]);
        cmd.args(["--no-default-features", "--features", "planted-regression"]);
        for b in bins {
            cmd.args(["--bin", b]);
        }
    } else {
        cmd.args(["test", "--workspace", "--release", "--no-run"]);
    }
    cmd.arg("--message-format=json-render-diagnostics");
    crate::ci::strip_cargo_run_env(&mut cmd);
    // The workspace's test build includes the MuJoCo twin crate.
    crate::env::apply_env(&mut cmd, &crate::env::prereqs());
    let out = cmd
        .output()
        .context("running cargo to build the count binaries")?;
    if !out.status.success() {
        bail!("cargo build of the count binaries failed ({})", out.status);
    }
    let mut found = HashMap::new();
    for line in String::from_utf8_lossy(&out.stdout).lines() {
        let Ok(msg) = serde_json::from_str::<serde_json::Value>(line) else {
            continue;
        };
        if msg["reason"] != "compiler-artifact"
            || msg["profile"]["test"] == true
            || msg["target"]["kind"] != serde_json::json!(["bin"])
        {
            continue;
        }
        if let (Some(name), Some(exe)) =
            (msg["target"]["name"].as_str(), msg["executable"].as_str())
        {
            if bins.contains(name) {
                found.insert(name.to_string(), PathBuf::from(exe));
            }
        }
    }
    for b in bins {
        if !found.contains_key(*b) {
            bail!("cargo build reported no executable for the count binary {b}");
        }
    }
    Ok(found)
}

/// What the benches need besides their binaries: the plant FMU and the small campaign.
pub struct Inputs {
    pub model: PathBuf,
    pub plant_fmu: Option<PathBuf>,
    pub pipeline_dir: Option<PathBuf>,
}

/// Prepares the inputs of `benches` under `<target>/bench-counts`: builds the FMUs of the
/// paper model (release) and simulates, writes and identifies the small campaign (natively,
/// not counted).
pub fn prepare(benches: &[&CountBench], bins: &HashMap<String, PathBuf>) -> Result<Inputs> {
    let work = target_dir().join("bench-counts");
    let model = repo_root().join("models/params/silo2-paper.toml");
    let mut inputs = Inputs {
        model: model.clone(),
        plant_fmu: None,
        pipeline_dir: None,
    };
    if benches.iter().any(|b| b.runner == Runner::Fmu) {
        let dir = work.join("fmu");
        let opts = zmp_fmu_core::package::BuildOptions {
            release: true,
            fmi3: false,
            passthrough: false,
            force: true,
            target_dir: Some(target_dir()),
        };
        let files = zmp_fmu_core::package::build_fmus(&model, &dir, &opts)
            .map_err(|e| anyhow!("building the FMUs of {}: {e}", model.display()))?;
        let plant = files
            .into_iter()
            .find(|f| f.file_name().is_some_and(|n| n == "zmp_plant.fmu"))
            .ok_or_else(|| anyhow!("building the FMUs gave no zmp_plant.fmu"))?;
        inputs.plant_fmu = Some(plant);
    }
    if benches
        .iter()
        .any(|b| matches!(b.runner, Runner::Pipeline(_)))
    {
        let dir = work.join("pipeline");
        std::fs::create_dir_all(&dir).with_context(|| format!("creating {}", dir.display()))?;
        let out = Command::new(&bins["pipeline_count"])
            .arg("write")
            .arg(&dir)
            .stdin(Stdio::null())
            .output()
            .context("running pipeline_count write")?;
        if !out.status.success() {
            bail!(
                "pipeline_count write {} failed: {}",
                dir.display(),
                String::from_utf8_lossy(&out.stderr)
            );
        }
        inputs.pipeline_dir = Some(dir);
    }
    Ok(inputs)
}

fn args_of(b: &CountBench, inputs: &Inputs) -> Result<Vec<OsString>> {
    let steps = b.per.repetitions().to_string();
    Ok(match b.runner {
        Runner::Realtime(which) => vec![which.into(), steps.into()],
        Runner::Twin => vec![steps.into()],
        Runner::Fmu => vec![
            inputs
                .plant_fmu
                .clone()
                .ok_or_else(|| anyhow!("no plant FMU prepared"))?
                .into(),
            inputs.model.clone().into(),
            steps.into(),
        ],
        Runner::Pipeline(mode) => vec![
            mode.into(),
            inputs
                .pipeline_dir
                .clone()
                .ok_or_else(|| anyhow!("no small campaign prepared"))?
                .into(),
        ],
    })
}

/// Runs one bench under callgrind pinned to `cpu`; returns its count.
fn run_one(
    b: &CountBench,
    exe: &Path,
    inputs: &Inputs,
    cpu: usize,
    scratch: &Path,
) -> Result<Measured> {
    let stem = b.name.replace('/', "-");
    let log = scratch.join(format!("{stem}.log"));
    let out_file = scratch.join(format!("{stem}.callgrind"));
    let mut cmd = Command::new("taskset");
    cmd.arg("-c")
        .arg(cpu.to_string())
        .arg("valgrind")
        .arg("--tool=callgrind")
        .arg(format!("--callgrind-out-file={}", out_file.display()))
        .arg(format!("--log-file={}", log.display()))
        .arg("--toggle-collect=*count_loop*")
        .arg(exe)
        .args(args_of(b, inputs)?)
        .stdin(Stdio::null());
    if b.runner == Runner::Twin {
        // libmujoco.so has no rpath in the binary: its directory goes on the library path.
        crate::env::apply_env(&mut cmd, &crate::env::prereqs());
    }
    let out = cmd.output().with_context(|| {
        format!(
            "running {} under `taskset -c {cpu} valgrind` (are valgrind and taskset installed? \
             `cargo xtask setup` installs valgrind)",
            b.name
        )
    })?;
    let log_text = std::fs::read_to_string(&log).unwrap_or_default();
    if !out.status.success() {
        bail!(
            "{} under callgrind failed ({}):\n{}{}",
            b.name,
            out.status,
            String::from_utf8_lossy(&out.stderr),
            log_text
        );
    }
    let collected = log_text
        .lines()
        .find_map(|l| {
            l.split_once("Collected :")
                .map(|(_, n)| n.trim().to_string())
        })
        .ok_or_else(|| anyhow!("{}: no `Collected :` line in {}", b.name, log.display()))?;
    let instructions: u64 = collected
        .parse()
        .with_context(|| format!("{}: callgrind's count {collected:?}", b.name))?;
    Ok(Measured {
        name: b.name.to_string(),
        instructions,
        repetitions: b.per.repetitions(),
    })
}

/// Runs `benches` under callgrind, two at a time on CPUs 0 and 1 (one when the machine has
/// one), the longest first; results in the order of `benches`.
pub fn run(
    benches: &[&'static CountBench],
    bins: &HashMap<String, PathBuf>,
    inputs: &Inputs,
) -> Result<Vec<Measured>> {
    let scratch = target_dir().join("bench-counts").join("callgrind");
    std::fs::create_dir_all(&scratch).with_context(|| format!("creating {}", scratch.display()))?;
    let cpus = std::thread::available_parallelism()
        .map_or(1, |n| n.get())
        .min(2);
    // Longest first: the pipeline benches take tens of seconds under callgrind.
    let mut order: Vec<usize> = (0..benches.len()).collect();
    order.sort_by_key(|&k| match benches[k].runner {
        Runner::Pipeline("diagnose") => 0,
        Runner::Pipeline(_) => 1,
        _ => 2,
    });
    let next = std::sync::atomic::AtomicUsize::new(0);
    let results: Vec<(usize, Result<Measured>)> = std::thread::scope(|s| {
        let handles: Vec<_> = (0..cpus)
            .map(|cpu| {
                let (order, next, scratch) = (&order, &next, &scratch);
                s.spawn(move || {
                    let mut mine = Vec::new();
                    loop {
                        let i = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                        let Some(&k) = order.get(i) else { break };
                        let b = benches[k];
                        let r = b
                            .binary()
                            .ok_or_else(|| anyhow!("{} has no count binary", b.name))
                            .and_then(|bin| {
                                bins.get(bin)
                                    .ok_or_else(|| anyhow!("count binary {bin} not built"))
                            })
                            .and_then(|exe| run_one(b, exe, inputs, cpu, scratch));
                        if let Ok(m) = &r {
                            eprintln!(
                                "bench: {:<26} {:>14} instructions ({:.1} per {})",
                                m.name,
                                m.instructions,
                                m.per_repetition(),
                                if b.per == Per::Run { "run" } else { "step" }
                            );
                        }
                        mine.push((k, r));
                    }
                    mine
                })
            })
            .collect();
        handles
            .into_iter()
            .flat_map(|h| h.join().expect("a count worker panicked"))
            .collect()
    });
    let mut by_index: Vec<Option<Result<Measured>>> = (0..benches.len()).map(|_| None).collect();
    for (k, r) in results {
        by_index[k] = Some(r);
    }
    by_index
        .into_iter()
        .map(|r| r.expect("every bench ran"))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn registry_names_are_unique_and_tolerances_follow_the_rule() {
        let names: BTreeSet<_> = REGISTRY.iter().map(|b| b.name).collect();
        assert_eq!(names.len(), REGISTRY.len());
        for b in REGISTRY {
            let expected = match b.per {
                Per::Step(_) => REALTIME_TOLERANCE,
                Per::Run => PIPELINE_TOLERANCE,
            };
            assert_eq!(b.tolerance, expected, "{}", b.name);
        }
    }
}
