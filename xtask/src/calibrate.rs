//! `cargo xtask calibrate-com`: the second seed's effective-CoM calibration and walking
//! comparison on the SABIAN twin (runs `zmp-twin sabian calibrate-com`).

use crate::env::prereqs;
use crate::twin::run_twin;
use anyhow::Result;
use std::path::{Path, PathBuf};

/// The command's options, as the user gave them.
pub struct CalibrateArgs {
    pub out: PathBuf,
    pub quick: bool,
    pub runs: Option<usize>,
    pub draws: Option<usize>,
    pub figures: Option<PathBuf>,
    pub markdown: bool,
    pub json: bool,
    pub force: bool,
    /// `--shard i/n` / `--unit ID`: part of the units into the job folder `out`.
    pub shard: Option<zmp_shard::Shard>,
    pub unit: Option<String>,
    /// `--steal`: after its part, take other parts' units no shard has begun.
    pub steal: bool,
}

fn abs(p: &Path) -> PathBuf {
    std::path::absolute(p).unwrap_or_else(|_| p.to_path_buf())
}

pub fn calibrate_com(a: &CalibrateArgs) -> Result<()> {
    crate::setup::setup(true)?;
    // The twin runs from the repository root: paths are made absolute first.
    let mut args: Vec<String> = vec![
        "sabian".into(),
        "calibrate-com".into(),
        "--out".into(),
        abs(&a.out).display().to_string(),
    ];
    if a.quick {
        args.push("--quick".into());
    }
    if let Some(r) = a.runs {
        args.extend(["--runs".into(), r.to_string()]);
    }
    if let Some(d) = a.draws {
        args.extend(["--draws".into(), d.to_string()]);
    }
    if let Some(s) = a.shard {
        args.extend(["--shard".into(), s.to_string()]);
    }
    if a.steal {
        args.push("--steal".into());
    }
    if let Some(u) = &a.unit {
        args.extend(["--unit".into(), u.clone()]);
    }
    if let Some(f) = &a.figures {
        args.extend(["--figures".into(), abs(f).display().to_string()]);
    }
    for (on, flag) in [
        (a.markdown, "--markdown"),
        (a.json, "--json"),
        (a.force, "--force"),
    ] {
        if on {
            args.push(flag.into());
        }
    }
    run_twin(&args, &prereqs())
}

/// `cargo xtask merge DIR` of a `calibrate-com --shard` job (runs `zmp-twin sabian merge`).
pub fn merge(dir: &Path, json: bool) -> Result<()> {
    crate::setup::setup(true)?;
    let mut args: Vec<String> = vec![
        "sabian".into(),
        "merge".into(),
        abs(dir).display().to_string(),
    ];
    if json {
        args.push("--json".into());
    }
    run_twin(&args, &prereqs())
}
