//! `cargo xtask simulate`: a virtual stepped-sine campaign from a model file.

use anyhow::{Context, Result};
use indicatif::{ProgressBar, ProgressStyle};
use std::path::Path;
use zmp_campaign::{check_destination, write_campaign, Campaign};
use zmp_models::ModelSpec;
use zmp_virtual_robot::{simulate_campaign_with_progress, ExperimentDesign};

pub fn load_model(path: &Path) -> Result<ModelSpec> {
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("reading model file {}", path.display()))?;
    Ok(ModelSpec::parse(&text, &path.display().to_string())?)
}

pub fn load_design(path: Option<&Path>) -> Result<ExperimentDesign> {
    match path {
        None => Ok(ExperimentDesign::reference()),
        Some(p) => {
            let text = std::fs::read_to_string(p)
                .with_context(|| format!("reading design file {}", p.display()))?;
            ExperimentDesign::from_toml(&text, &p.display().to_string()).map_err(anyhow::Error::msg)
        }
    }
}

pub fn progress_bar(len: u64, what: &str, quiet: bool) -> ProgressBar {
    if quiet {
        return ProgressBar::hidden();
    }
    let pb = ProgressBar::new(len);
    pb.set_style(
        ProgressStyle::with_template("{msg:>12} [{bar:40}] {pos}/{len} {elapsed_precise}")
            .expect("valid template")
            .progress_chars("=> "),
    );
    pb.set_message(what.to_string());
    pb
}

/// A spinner with a message and the time spent, for work whose length is not known up front.
pub fn spinner(what: &str, quiet: bool) -> ProgressBar {
    if quiet {
        return ProgressBar::hidden();
    }
    let pb = ProgressBar::new_spinner();
    pb.set_style(
        ProgressStyle::with_template("{spinner} {msg} {elapsed_precise}").expect("valid template"),
    );
    pb.set_message(what.to_string());
    pb.enable_steady_tick(std::time::Duration::from_millis(200));
    pb
}

/// Simulates `design` on `spec` and writes the campaign to `out`.
pub fn simulate(
    spec: &ModelSpec,
    design: &ExperimentDesign,
    out: &Path,
    force: bool,
    quiet: bool,
) -> Result<Campaign> {
    // The destination is checked before the simulation (and again when written).
    check_destination(out, force).with_context(|| format!("writing campaign {}", out.display()))?;
    design
        .check()
        .map_err(|e| anyhow::anyhow!("experiment design: {e}"))?;
    let n = design.records().len() as u64;
    let pb = progress_bar(n, "simulating", quiet);
    let camp = simulate_campaign_with_progress(spec, design, &|d| pb.set_position(d as u64))?;
    pb.finish_and_clear();
    write_campaign(out, &camp, force)
        .with_context(|| format!("writing campaign {}", out.display()))?;
    Ok(camp)
}
