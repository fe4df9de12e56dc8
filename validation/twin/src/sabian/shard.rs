//! `calibrate-com --shard i/n` (docs/src/scale-out.md): the calibration's noise draws in
//! blocks and the walks one (model, run) each, as units of a `zmp_shard` job, and the merge
//! that assembles them with the one-process run's own functions (`assemble_calibration`,
//! `assemble_walks`), so its tables are that run's.

use super::calibrate::FOOT_SPACING;
use super::experiment::{
    assemble_calibration, assemble_walks, calibration_draws, calibration_setup, plan_facts,
    virtual_models, walk_jobs, walk_one, DrawSet, Options, PlanFacts,
};
use super::report::{markdown, write, Outcome};
use super::walk::{plan, Run};
use anyhow::{bail, Context, Result};
use serde_json::{json, Value};
use std::path::Path;
use zmp_models::walking::Gait;
use zmp_shard::{Collected, Job, JobKind, Merged, UnitSpec};

/// Noise draws per unit.
pub const DRAW_BLOCK: usize = 50;
/// Walking runs of one model per unit (each unit plans its model once: planning costs about
/// as much as a walk pair).
pub const RUN_BLOCK: usize = 5;
/// The virtual models, in `virtual_models`' order.
pub const MODELS: [&str; 5] = ["n", "r", "s", "v", "e"];

/// A unit of the job.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Unit {
    /// Noise draws `start..end` of every calibration.
    Draws {
        /// First draw.
        start: usize,
        /// One past the last draw.
        end: usize,
    },
    /// Runs `start..end` of model `model` (index in [`MODELS`]), open loop and with the
    /// control.
    Walk {
        /// Index of the model in [`MODELS`].
        model: usize,
        /// First run.
        start: usize,
        /// One past the last run.
        end: usize,
    },
}

impl Unit {
    /// The unit's id in the job folder (`draws-00000-00050`, `walk-r-000-005`).
    pub fn id(self) -> String {
        match self {
            Unit::Draws { start, end } => format!("draws-{start:05}-{end:05}"),
            Unit::Walk { model, start, end } => {
                format!("walk-{}-{start:03}-{end:03}", MODELS[model])
            }
        }
    }
}

/// The units of a run with `opt`: draw blocks first, then the walks.
pub fn units(opt: &Options) -> Vec<Unit> {
    let mut u: Vec<Unit> = (0..opt.draws)
        .step_by(DRAW_BLOCK)
        .map(|start| Unit::Draws {
            start,
            end: (start + DRAW_BLOCK).min(opt.draws),
        })
        .collect();
    for model in 0..MODELS.len() {
        u.extend((0..opt.runs).step_by(RUN_BLOCK).map(|start| Unit::Walk {
            model,
            start,
            end: (start + RUN_BLOCK).min(opt.runs),
        }));
    }
    u
}

/// The job of a run with `opt` (`quick`: the command's `--quick`, for its title). Expected
/// costs in seconds of one thread, the order of `calibrate-com --quick`'s measured units: the
/// setup (holding 14 postures) in every unit, a block of draws replaying the draws before it,
/// a walk unit planning its model and walking twice.
pub fn job(opt: &Options, quick: bool) -> Result<Job> {
    let specs = units(opt)
        .into_iter()
        .map(|u| {
            let cost = match u {
                Unit::Draws { end, .. } => 1.0 + 0.005 * end as f64,
                Unit::Walk { start, end, .. } => 3.0 + 3.0 * (end - start) as f64,
            };
            UnitSpec::new(u.id(), cost)
        })
        .collect();
    let params = json!({
        "quick": quick, "runs": opt.runs, "draws": opt.draws, "seed": opt.seed,
        "designed_postures": opt.designed_postures,
    });
    Job::new(JobKind::CalibrateCom, params, specs)
}

/// The options a job was made with.
pub fn job_options(job: &Job) -> Result<(Options, bool)> {
    let p = &job.params;
    let num = |k: &str| {
        p[k].as_u64()
            .with_context(|| format!("job.json: field `params.{k}` is missing"))
    };
    let opt = Options {
        runs: num("runs")? as usize,
        draws: num("draws")? as usize,
        designed_postures: num("designed_postures")? as usize,
        seed: num("seed")?,
        threads: 1,
    };
    Ok((opt, p["quick"].as_bool().unwrap_or(false)))
}

fn unit_of(opt: &Options, id: &str) -> Result<Unit> {
    units(opt)
        .into_iter()
        .find(|u| u.id() == id)
        .with_context(|| format!("no unit {id} in this job"))
}

/// Runs one unit on one thread; its outcome as JSON.
pub fn run_unit(opt: &Options, id: &str) -> Result<Value> {
    let opt = Options { threads: 1, ..*opt };
    let setup = calibration_setup(&opt)?;
    match unit_of(&opt, id)? {
        Unit::Draws { start, end } => {
            let draws = calibration_draws(&setup, &opt, end)?;
            Ok(json!({"start": start, "draws": draws[start..].to_vec()}))
        }
        Unit::Walk { model, start, end } => {
            let cal = assemble_calibration(&setup, &calibration_draws(&setup, &opt, 1)?)?;
            let models = virtual_models(&cal);
            let names: Vec<&str> = models.iter().map(|m| m.name.as_str()).collect();
            if names != MODELS {
                bail!("the virtual models are {names:?}, this job's units expect {MODELS:?}");
            }
            let gait = Gait::seed(FOOT_SPACING);
            let p = plan(&models[model], &gait)?;
            let mut runs = Vec::new();
            for run in start..end {
                runs.push(json!({
                    "open_loop": walk_one(&p, &gait, &opt, run, false)?,
                    "with_tpc": walk_one(&p, &gait, &opt, run, true)?,
                }));
            }
            Ok(json!({"facts": plan_facts(&p)?, "runs": runs}))
        }
    }
}

fn field<T: serde::de::DeserializeOwned>(v: &Value, k: &str, id: &str) -> Result<T> {
    serde_json::from_value(v[k].clone()).with_context(|| format!("unit {id}: field `{k}`"))
}

/// The one-process run's outcome from a complete job's units (the setup is held again here:
/// a few seconds, deterministic).
pub fn assemble(c: &Collected) -> Result<Outcome> {
    let (opt, quick) = job_options(&c.job)?;
    let mut draws: Vec<DrawSet> = Vec::with_capacity(opt.draws);
    let mut facts: Vec<Option<PlanFacts>> = vec![None; MODELS.len()];
    let jobs = walk_jobs(MODELS.len(), opt.runs);
    let mut runs: Vec<Option<Run>> = vec![None; jobs.len()];
    for d in &c.done {
        match unit_of(&opt, &d.spec.id)? {
            Unit::Draws { start, end } => {
                if draws.len() != start {
                    bail!("unit {}: draws out of order", d.spec.id);
                }
                let block: Vec<DrawSet> = field(&d.outcome, "draws", &d.spec.id)?;
                if block.len() != end - start {
                    bail!(
                        "unit {}: {} draws, expected {}",
                        d.spec.id,
                        block.len(),
                        end - start
                    );
                }
                draws.extend(block);
            }
            Unit::Walk { model, start, end } => {
                facts[model].get_or_insert(field(&d.outcome, "facts", &d.spec.id)?);
                let pairs = d.outcome["runs"].as_array().cloned().unwrap_or_default();
                if pairs.len() != end - start {
                    bail!(
                        "unit {}: {} runs, expected {}",
                        d.spec.id,
                        pairs.len(),
                        end - start
                    );
                }
                for (run, pair) in (start..end).zip(&pairs) {
                    for (tpc, k) in [(false, "open_loop"), (true, "with_tpc")] {
                        let j = jobs.iter().position(|&x| x == (model, run, tpc));
                        runs[j.context("walk job")?] = Some(field(pair, k, &d.spec.id)?);
                    }
                }
            }
        }
    }
    let setup = calibration_setup(&opt)?;
    let calibration = assemble_calibration(&setup, &draws)?;
    let models = virtual_models(&calibration);
    let facts: Vec<PlanFacts> = facts
        .into_iter()
        .collect::<Option<_>>()
        .context("a model has no walk")?;
    let runs: Vec<Run> = runs
        .into_iter()
        .collect::<Option<_>>()
        .context("a walk is missing")?;
    let gait = Gait::seed(FOOT_SPACING);
    let walking = assemble_walks(&models, &facts, None, &jobs, &runs, &gait);
    let mut command = "cargo xtask calibrate-com".to_string();
    if quick {
        command += " --quick";
    }
    Ok(Outcome {
        format: "zmp-com-calibration/1".into(),
        command,
        runs_per_model: opt.runs,
        calibration,
        walking,
    })
}

/// `zmp-twin sabian merge DIR`: com-calibration.toml, report.html and the figures as the
/// one-process run writes them, and tables.md (its `--markdown`), into the job folder.
pub fn merge(dir: &Path, json_out: bool) -> Result<()> {
    let c = zmp_shard::collect(dir)?;
    if c.job.kind != JobKind::CalibrateCom {
        bail!(
            "{} holds a job of another command: use cargo xtask merge",
            dir.display()
        );
    }
    let (opt, quick) = job_options(&c.job)?;
    let rerun = format!(
        "cargo xtask calibrate-com --out {} {}",
        dir.display(),
        if quick {
            "--quick".to_string()
        } else {
            format!("--runs {} --draws {}", opt.runs, opt.draws)
        }
    );
    zmp_shard::cli::check_complete(dir, &c, &rerun)?;
    let o = assemble(&c)?;
    let files = write(&o, dir, true)?;
    let md = markdown(&o);
    let mut text = md.clone();
    text.push_str(&format!(
        "\nwrote {} files into {}",
        files.len(),
        dir.display()
    ));
    let m = Merged {
        // As `--markdown` prints it (with its line end).
        files: vec![("tables.md".into(), format!("{md}\n").into_bytes())],
        json: serde_json::to_value(&o)?,
        text,
    };
    zmp_shard::cli::finish_merge(dir, &c, &m, json_out, &rerun)
}
