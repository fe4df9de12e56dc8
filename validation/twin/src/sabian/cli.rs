//! The `zmp-twin sabian ...` subcommands.

use super::calibrate::FOOT_SPACING;
use super::experiment::{calibrate, virtual_models, walk_models, Options};
use super::report::{check_out, markdown, write, Outcome};
use anyhow::{bail, Result};
use clap::Subcommand;
use std::path::PathBuf;
use zmp_models::walking::Gait;

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
    },
}

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
    }
}
