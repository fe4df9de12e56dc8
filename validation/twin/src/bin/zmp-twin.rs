//! `zmp-twin`: the MuJoCo twins' command line (run through `cargo xtask`, which sets the MuJoCo
//! environment).

use anyhow::Result;
use clap::{Parser, Subcommand};

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

fn main() -> Result<()> {
    match Cli::parse().robot {
        Robot::Sabian { command } => zmp_twin::sabian::cli::run(command),
    }
}
