//! `cargo xtask simulate`: a virtual stepped-sine campaign from a model file.

use anyhow::{Context, Result};
use indicatif::{ProgressBar, ProgressStyle};
use std::path::Path;
use zmp_campaign::{append_campaign, check_destination, write_campaign, Campaign};
use zmp_models::ModelSpec;
use zmp_virtual_robot::{simulate_records_after, ExperimentDesign};

pub fn load_model(path: &Path) -> Result<ModelSpec> {
    let text = zmp_files::read_limited_text(path, zmp_files::limits::MODEL_BYTES, "a model file")
        .with_context(|| format!("reading model file {}", path.display()))?;
    Ok(ModelSpec::parse(&text, &path.display().to_string())?)
}

pub fn load_design(path: Option<&Path>) -> Result<ExperimentDesign> {
    match path {
        None => Ok(ExperimentDesign::reference()),
        Some(p) => {
            let text = zmp_files::read_limited_text(p, zmp_files::limits::MODEL_BYTES, "a design")
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

/// `cargo xtask simulate`: the design (or the reference) on the model, written to `out`, or
/// with `append` that campaign with the design's records after its own.
pub fn simulate_cmd(
    model: &Path,
    design: Option<&Path>,
    seed: Option<u64>,
    out: &Path,
    append: Option<&Path>,
    force: bool,
    json: bool,
) -> Result<()> {
    let spec = load_model(model)?;
    let mut d = load_design(design)?;
    if let Some(s) = seed {
        d.seed = s;
    }
    let base = append
        .map(|dir| crate::diagnose::read(dir, json).map(|c| (dir, c)))
        .transpose()?;
    let camp = simulate_into(
        &spec,
        &d,
        out,
        base.as_ref().map(|(p, c)| (*p, c)),
        force,
        json,
    )?;
    let rows: usize = camp.records.iter().map(|r| r.len()).sum();
    let added = d.records().len();
    if json {
        println!(
            "{}",
            serde_json::json!({"campaign": out, "records": camp.records.len(), "simulated": added, "rows": rows, "seed": d.seed, "appended_to": append})
        );
    } else {
        println!(
            "wrote {} records ({rows} rows{}) to {}",
            camp.records.len(),
            append.map_or(String::new(), |a| format!(
                "; {added} simulated after the {} of {}",
                camp.records.len() - added,
                a.display()
            )),
            out.display()
        );
    }
    Ok(())
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
    simulate_into(spec, design, out, None, force, quiet)
}

/// [`simulate`]; with `base` (its folder and campaign), that campaign with the design's
/// records after its own, their noise drawn after its records' (the design's seed, record
/// numbers continuing).
pub fn simulate_into(
    spec: &ModelSpec,
    design: &ExperimentDesign,
    out: &Path,
    base: Option<(&Path, &Campaign)>,
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
    let first = base.map_or(0, |(_, c)| c.records.len());
    let camp = simulate_records_after(spec, design, first, &|d| pb.set_position(d as u64))?;
    pb.finish_and_clear();
    let camp = match base {
        Some((dir, b)) => append_campaign(b, dir, &camp, out)?,
        None => camp,
    };
    write_campaign(out, &camp, force)
        .with_context(|| format!("writing campaign {}", out.display()))?;
    Ok(camp)
}
