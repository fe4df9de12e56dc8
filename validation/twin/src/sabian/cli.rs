//! The `zmp-twin sabian ...` subcommands.

use super::calibrate::FOOT_SPACING;
use super::experiment::{calibrate, virtual_models, walk_models, Options};
use super::report::{check_out, markdown, write, Outcome};
use anyhow::{bail, Result};
use clap::Subcommand;
use std::path::PathBuf;
use zmp_models::walking::Gait;

/// The commands on the SABIAN twin.
#[derive(Subcommand)]
pub enum SabianCommand {
    /// Calibrate the effective CoM on the twin (the seed's upright + 1 degree design, with and
    /// without its eq. 7 joint moments, and a D-optimal design, over noise draws), build the
    /// virtual models n, r, s, v (and e), walk the seed's gait with each open loop and with the
    /// seed's Torso Position Control, and write com-calibration.toml, report.html and SVG
    /// figures.
    CalibrateCom {
        /// Output folder.
        #[arg(long, default_value = "target/com-calibration")]
        out: PathBuf,
        /// The short version (1 walking run per model and control, 40 noise draws) used by the
        /// demo.
        #[arg(long)]
        quick: bool,
        /// Walking runs per model and control (default 5, the seed's; 1 with --quick).
        #[arg(long)]
        runs: Option<usize>,
        /// Noise draws of each calibration (default 200; 40 with --quick).
        #[arg(long)]
        draws: Option<usize>,
        /// Also write the SVG figures into this folder (e.g. docs/figures); figures of the same
        /// names there are replaced.
        #[arg(long)]
        figures: Option<PathBuf>,
        /// Print the tables as Markdown on standard output.
        #[arg(long)]
        markdown: bool,
        /// Print a machine-readable summary (JSON) on standard output.
        #[arg(long)]
        json: bool,
        /// Overwrite the files this command wrote before.
        #[arg(long)]
        force: bool,
        /// Run only part i of n of the units (blocks of noise draws, one walk pair per model
        /// and run) into the job folder OUT; `merge OUT` then writes what the one-process run
        /// writes (docs/src/scale-out.md).
        #[arg(long, value_name = "i/n", conflicts_with_all = ["unit", "figures", "markdown"])]
        shard: Option<zmp_shard::Shard>,
        /// Run one unit alone into the job folder OUT (one a merge named as failed or missing).
        #[arg(long, value_name = "ID", conflicts_with_all = ["figures", "markdown"])]
        unit: Option<String>,
        /// With --shard: when its part is done, take the units of the other parts that no shard
        /// has begun (each unit still runs once; the shards must share OUT, as on a cluster's
        /// shared file system: the Ray driver and the Slurm script pass it).
        #[arg(long, requires = "shard")]
        steal: bool,
    },
    /// Merge a `calibrate-com --shard` job folder: com-calibration.toml, report.html, the
    /// figures and tables.md (the --markdown tables), as the one-process run writes them.
    Merge {
        /// Job folder.
        dir: PathBuf,
        /// Print the merged outcome, the units' state and the cost model as JSON.
        #[arg(long)]
        json: bool,
    },
}

/// Runs a `sabian` command.
pub fn run(cmd: SabianCommand) -> Result<()> {
    match cmd {
        SabianCommand::CalibrateCom {
            out,
            quick,
            runs,
            draws,
            figures,
            markdown: md,
            json,
            force,
            shard,
            unit,
            steal,
        } => {
            let mut opt = if quick {
                Options::quick()
            } else {
                Options::full()
            };
            if let Some(r) = runs {
                if r == 0 {
                    bail!("--runs must be at least 1");
                }
                opt.runs = r;
            }
            if let Some(d) = draws {
                if d == 0 {
                    bail!("--draws must be at least 1");
                }
                opt.draws = d;
            }
            if shard.is_some() || unit.is_some() {
                return run_part(&out, &opt, quick, (shard, steal), unit, json);
            }
            check_out(&out, force)?;
            let started = std::time::Instant::now();
            eprintln!("calibrating the CoM ({} noise draws) ...", opt.draws);
            let cal = calibrate(&opt)?;
            let models = virtual_models(&cal);
            eprintln!(
                "walking {} models x {} runs, open loop and with Torso Position Control ({:.1} s \
                 so far) ...",
                models.len(),
                opt.runs,
                started.elapsed().as_secs_f64()
            );
            let gait = Gait::seed(FOOT_SPACING);
            let walking = walk_models(&models, &opt, &gait)?;
            let mut command = "cargo xtask calibrate-com".to_string();
            if quick {
                command += " --quick";
            }
            let outcome = Outcome {
                format: "zmp-com-calibration/1".into(),
                command,
                runs_per_model: opt.runs,
                calibration: cal,
                walking,
            };
            let files = write(&outcome, &out, force)?;
            if let Some(dir) = figures {
                super::report::figures(&outcome, &dir, true)?;
            }
            eprintln!(
                "wrote {} files into {} in {:.1} s",
                files.len(),
                out.display(),
                started.elapsed().as_secs_f64()
            );
            if md {
                println!("{}", markdown(&outcome));
            }
            if json {
                println!("{}", serde_json::to_string_pretty(&outcome)?);
            }
            Ok(())
        }
        SabianCommand::Merge { dir, json } => super::shard::merge(&dir, json),
    }
}

/// `calibrate-com --shard i/n` or `--unit ID`: the units into the job folder `out`.
fn run_part(
    out: &std::path::Path,
    opt: &Options,
    quick: bool,
    (shard, steal): (Option<zmp_shard::Shard>, bool),
    unit: Option<String>,
    json: bool,
) -> Result<()> {
    let job = super::shard::job(opt, quick)?;
    let ropts = zmp_shard::RunOptions {
        shard: shard.unwrap_or(zmp_shard::Shard::WHOLE),
        only: unit,
        keep_done: false,
        steal,
        threads: opt.threads,
        quiet: false,
    };
    let r = zmp_shard::cli::run_part(out, &job, &ropts, json, |u| {
        super::shard::run_unit(opt, &u.id)
    })?;
    zmp_shard::cli::finish_part(out, &r, json)
}
