//! Runs the MuJoCo twins' binary (`zmp-twin`, outside the default members) with the MuJoCo
//! environment that `cargo xtask setup` prepared.

use crate::env::{apply_env, repo_root, Prereqs};
use anyhow::{bail, Context, Result};
use std::process::Command;

/// `cargo run --release -q -p zmp-twin --bin zmp-twin -- <args>` from the repository root, with
/// MUJOCO_DYNAMIC_LINK_DIR and the rest of the prerequisites' environment set.
pub fn run_twin(args: &[String], prereqs: &Prereqs) -> Result<()> {
    let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
    let mut cmd = Command::new(cargo);
    cmd.current_dir(repo_root()).args([
        "run",
        "--release",
        "-q",
        "-p",
        "zmp-twin",
        "--bin",
        "zmp-twin",
        "--",
    ]);
    cmd.args(args);
    apply_env(&mut cmd, prereqs);
    let status = cmd
        .status()
        .context("starting cargo run -p zmp-twin (the MuJoCo twin binary)")?;
    if !status.success() {
        bail!("zmp-twin {} failed ({status})", args.join(" "));
    }
    Ok(())
}
