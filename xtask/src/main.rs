//! `cargo xtask <verb>`: the command line for users and CI.

mod ci;
mod demo;
mod env;
mod setup;
mod simulate;

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Result;
use clap::{Parser, Subcommand};

#[derive(Parser)]
#[command(name = "cargo xtask", about = "ZMP biped identification toolkit tasks")]
struct Cli {
    #[command(subcommand)]
    command: Cmd,
}

#[derive(Subcommand)]
enum Cmd {
    /// Install the prerequisites (system packages, MuJoCo library, Python venv with FMPy).
    Setup {
        /// Only report steps that install something; hide apt/pip output unless they fail.
        #[arg(long)]
        quiet: bool,
    },
    /// What CI runs: setup, then cargo fmt --check, clippy -D warnings, test (release).
    Ci,
    /// The main job on built-in data: a virtual SILO2 campaign, the model's Bode diagrams and
    /// the seed's closed-loop experiment, written to OUT (default out/demo).
    Demo {
        /// Output folder; an earlier demo output there is replaced.
        #[arg(long, default_value = "out/demo")]
        out: PathBuf,
        /// Replace OUT even if it does not hold an earlier demo output.
        #[arg(long)]
        force: bool,
        /// Print a machine-readable summary on standard output.
        #[arg(long)]
        json: bool,
    },
    /// Simulate a stepped-sine campaign (zmp-campaign/1) on the virtual robot.
    ///
    /// Without --design, the reference design: 3 operating points x 2 amplitudes (3, 8 mm) x
    /// 14 frequencies (0.5-15 rad/s) x 2 excited channels at 200 Hz, 0.5 mm ZMP noise,
    /// 0.1 mm quantisation. A design file is TOML with the fields of that design
    /// (operating_points, amplitudes, omegas, excited, sample_rate_hz, transient_s, periods,
    /// min_steady_s, zmp_noise_std, quantisation, seed, internal_step, record_com).
    Simulate {
        /// Model file (zmp-model/1).
        #[arg(long, default_value = "models/params/silo2-paper.toml")]
        model: PathBuf,
        /// Experiment design (TOML).
        #[arg(long)]
        design: Option<PathBuf>,
        /// Override the design's noise seed.
        #[arg(long)]
        seed: Option<u64>,
        /// Campaign folder to write.
        #[arg(long)]
        out: PathBuf,
        /// Replace an existing campaign folder.
        #[arg(long)]
        force: bool,
        /// Print a machine-readable summary.
        #[arg(long)]
        json: bool,
    },
}

fn main() -> ExitCode {
    match run(Cli::parse()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            // The error chain only; no backtrace dump even with RUST_BACKTRACE set.
            eprintln!("error: {e}");
            for cause in e.chain().skip(1) {
                eprintln!("  caused by: {cause}");
            }
            ExitCode::FAILURE
        }
    }
}

fn run(cli: Cli) -> Result<()> {
    match cli.command {
        Cmd::Setup { quiet } => setup::setup(quiet).map(|_| ()),
        Cmd::Ci => ci::ci(),
        Cmd::Demo { out, force, json } => demo::demo(&out, force, json),
        Cmd::Simulate {
            model,
            design,
            seed,
            out,
            force,
            json,
        } => {
            let spec = simulate::load_model(&model)?;
            let mut d = simulate::load_design(design.as_deref())?;
            if let Some(s) = seed {
                d.seed = s;
            }
            let camp = simulate::simulate(&spec, &d, &out, force, json)?;
            let rows: usize = camp.records.iter().map(|r| r.len()).sum();
            if json {
                println!(
                    "{}",
                    serde_json::json!({"campaign": out, "records": camp.records.len(), "rows": rows, "seed": d.seed})
                );
            } else {
                println!(
                    "wrote {} records ({rows} rows) to {}",
                    camp.records.len(),
                    out.display()
                );
            }
            Ok(())
        }
    }
}
