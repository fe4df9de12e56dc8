//! The demo's step for the second seed: the short calibration and walking comparison on the
//! SABIAN twin, into `<out>/com`.

use crate::env::prereqs;
use crate::twin::run_twin;
use anyhow::Result;
use std::path::Path;

pub fn demo_step(out: &Path, quiet: bool) -> Result<()> {
    if !quiet {
        println!(
            "7. Effective centre of mass (second seed) on the SABIAN twin: calibration, virtual \
             models n, r, s, v, e, one walk each open loop and one with the Torso Position \
             Control"
        );
    }
    // The twin runs from the repository root: an absolute path.
    let dir = std::path::absolute(out.join("com"))?;
    let mut args = vec![
        "sabian".to_string(),
        "calibrate-com".into(),
        "--quick".into(),
        "--force".into(),
        "--out".into(),
        dir.display().to_string(),
    ];
    if !quiet {
        args.push("--markdown".into());
    }
    run_twin(&args, &prereqs())?;
    if !quiet {
        println!("   -> {}", dir.join("report.html").display());
    }
    Ok(())
}
