//! `zmp-twin`: the MuJoCo twins' command line (run through `cargo xtask`, which sets the MuJoCo
//! environment).

use clap::{Parser, Subcommand};
use std::process::ExitCode;

#[derive(Parser)]
#[command(name = "zmp-twin", about = "MuJoCo twins of the seeds' robots")]
struct Cli {
    #[command(subcommand)]
    robot: Robot,
}

#[derive(Subcommand)]
enum Robot {
    /// The SABIAN twin (second seed).
    Sabian {
        #[command(subcommand)]
        command: zmp_twin::sabian::cli::SabianCommand,
    },
}

fn main() -> ExitCode {
    let result = match Cli::parse().robot {
        Robot::Sabian { command } => zmp_twin::sabian::cli::run(command),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            // The error chain only, no backtrace.
            eprintln!("error: {e}");
            for cause in e.chain().skip(1) {
                eprintln!("  caused by: {cause}");
            }
            ExitCode::FAILURE
        }
    }
}
