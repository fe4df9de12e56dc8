//! `cargo xtask identify`: a campaign folder in, the identified model file and a report out.

use crate::simulate::load_model;
use crate::simulate::progress_bar;
use anyhow::{bail, Context, Result};
use std::path::{Path, PathBuf};
use zmp_campaign::{read_campaign, read_manifest};
use zmp_files::{check_output_file, claim_dir, REPORT_MARKER};
use zmp_identify::{
    analyse_folder, analyse_records, identify_analysed, identify_with_progress, summary_json,
    write_model, Identification, IdentifyOptions,
};
use zmp_models::EffectKind;
use zmp_report::identify::write_report;

/// The default model path: `<campaign>/../<campaign-folder-name>-identified.toml`.
pub fn default_out(campaign: &Path) -> PathBuf {
    let name = campaign
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "campaign".into());
    let parent = campaign.parent().unwrap_or(Path::new("."));
    parent.join(format!("{name}-identified.toml"))
}

/// Parses `WN,ZETA`.
pub fn parse_bandwidth(s: &str) -> Result<(f64, f64)> {
    let parts: Vec<&str> = s.split(',').map(str::trim).collect();
    if parts.len() != 2 {
        bail!("--bandwidth expects WN,ZETA (e.g. 30,1), got {s:?}");
    }
    let wn: f64 = parts[0]
        .parse()
        .with_context(|| format!("omega_n {:?}", parts[0]))?;
    let z: f64 = parts[1]
        .parse()
        .with_context(|| format!("zeta {:?}", parts[1]))?;
    if !(wn > 0.0 && z > 0.0 && wn.is_finite() && z.is_finite()) {
        bail!("--bandwidth: omega_n and zeta must be positive, got {wn}, {z}");
    }
    Ok((wn, z))
}

/// What `cargo xtask identify` was asked.
pub struct IdentifyArgs<'a> {
    pub campaign: &'a Path,
    pub out: Option<&'a Path>,
    pub report: Option<&'a Path>,
    pub model: Option<&'a Path>,
    pub bandwidth: Option<(f64, f64)>,
    pub include_saturation: bool,
    pub force: bool,
    pub json: bool,
}

/// Runs the identification; writes the model (and the report if asked).
pub fn identify(a: &IdentifyArgs) -> Result<Identification> {
    let (campaign, out, report, force, json) = (a.campaign, a.out, a.report, a.force, a.json);
    let out = out
        .map(Path::to_path_buf)
        .unwrap_or_else(|| default_out(campaign));
    // Where the results go is checked before the work starts (and again when written).
    check_output_file(&out, force)?;
    if let Some(dir) = report {
        claim_dir(dir, REPORT_MARKER, force, "report")?;
    }
    let start_model = a.model.map(load_model).transpose()?;
    let quiet = json;
    let reading = || format!("reading campaign {}", campaign.display());
    let manifest = read_manifest(campaign).with_context(reading)?;
    let opts = IdentifyOptions {
        given_bandwidth: a.bandwidth,
        campaign_path: Some(campaign.to_path_buf()),
        start_model,
        include_saturation: a.include_saturation,
        ..IdentifyOptions::default()
    };
    // Each record is analysed as it is read and its columns dropped (the campaign's data is
    // never all in memory), unless a starting model's refit below needs the data: then the
    // campaign is read once and kept.
    let pb = progress_bar(manifest.records.len() as u64, "reading and fitting", quiet);
    let progress = |d: usize| pb.set_position(d as u64);
    let (fits, camp) = if a.model.is_some() {
        let camp = read_campaign(campaign).with_context(reading)?;
        (analyse_records(&camp, &opts, &progress), Some(camp))
    } else {
        let fits = analyse_folder(campaign, &manifest, &opts, &progress).with_context(reading)?;
        (fits, None)
    };
    pb.finish_and_clear();
    let ident = identify_analysed(fits, manifest.name.clone(), &opts)?;
    // A model that names effects beyond the core: those are refitted with it.
    let dopts = zmp_diagnose::DiagnoseOptions {
        campaign_path: campaign.display().to_string(),
        model_path: a
            .model
            .map_or_else(|| out.display().to_string(), |m| m.display().to_string()),
        ..Default::default()
    };
    let mut ident = ident;
    let mut change = "identified".to_string();
    if let Some(camp) = &camp {
        let pb = progress_bar(1, "refitting", quiet);
        let refit = zmp_diagnose::augment::refit_structure(camp, &ident.model, &dopts)?;
        pb.finish_and_clear();
        if let Some(r) = refit {
            if !quiet {
                println!(
                    "refitted the structure the model names: error {:.4} -> {:.4} (noise floor {:.4})",
                    r.error_before, r.error_after, r.noise_floor
                );
                for (k, (v, se)) in &r.parameters {
                    println!("  {k:<40} {v:>12.6} +- {se:.3e}");
                }
            }
            ident.model = r.spec;
            change = "refit".into();
        }
    }
    write_model(&ident, &out, force)?;
    // The ledger's error reuses the identification's own record analyses.
    let (obs, _) = zmp_diagnose::run::observations_of(&ident.records);
    record_in_ledger(&obs, &ident.model, &out, a.model, &change, &dopts, quiet);
    let files = match report {
        Some(dir) => Some(write_report(&ident, dir, force)?),
        None => None,
    };
    let robust = crate::robust::seed_controller_check(&ident.model)?;
    if json {
        let mut s = summary_json(&ident);
        s["model"] = serde_json::json!(out);
        s["robust"] = serde_json::to_value(zmp_report::robust::summary(&robust))?;
        if let Some(f) = &files {
            s["report"] = serde_json::json!(f.html);
        }
        println!("{}", serde_json::to_string_pretty(&s)?);
    } else {
        println!(
            "{} records, {} used; reduced chi-square {:.2}",
            ident.records.len(),
            ident.used().count(),
            ident.reduced_chi2
        );
        for p in ident.parameters() {
            println!(
                "  {:<32} {:>12.6} +- {:<10.3e}{}",
                p.name,
                p.value,
                p.stderr,
                if p.estimated { "" } else { " (given)" }
            );
        }
        for w in &ident.warnings {
            println!("warning: {w}");
        }
        if let Some(l) = ident.saturation.limit {
            if !ident.model.has(EffectKind::AccelerationSaturation) {
                println!(
                    "acceleration saturation detected (limit about {l:.3} m/s2); the model file stays linear: \
                     `cargo xtask diagnose` scores it, or pass --include-saturation"
                );
            }
        }
        println!(
            "robust stability with the seed's controller ({}): {}",
            robust.controller,
            robust.summary()
        );
        println!("model -> {}", out.display());
        if let Some(f) = &files {
            println!("report -> {}", f.html.display());
        }
    }
    Ok(ident)
}

/// Records the written model in the ledger beside it, with its error on the campaign (a
/// failure here is a warning: the model file is written).
pub fn record_in_ledger(
    obs: &[zmp_diagnose::observe::Observation],
    spec: &zmp_models::ModelSpec,
    out: &Path,
    parent: Option<&Path>,
    change: &str,
    opts: &zmp_diagnose::DiagnoseOptions,
    quiet: bool,
) {
    use zmp_diagnose::{engine::evaluate, measure::aggregate};
    let run = || -> Result<()> {
        let refs: Vec<_> = obs.iter().collect();
        let (e, f) = aggregate(&evaluate(spec, &refs)?);
        // A starting model in the same folder joins the chain (recorded first if new).
        let parent = parent.filter(|p| p.parent() == out.parent() && p != &out);
        if let Some(p) = parent {
            let name = p.file_name().and_then(|n| n.to_str());
            let known = zmp_campaign::ledger::read(out)?
                .entries
                .iter()
                .any(|e| Some(e.model.as_str()) == name);
            if !known {
                let start = crate::simulate::load_model(p)?;
                let (e0, f0) = aggregate(&evaluate(&start, &refs)?);
                zmp_campaign::ledger::append_unless_recorded(
                    p,
                    "starting model",
                    &opts.campaign_path,
                    e0,
                    f0,
                )?;
            }
        }
        zmp_campaign::ledger::append(out, parent, change, &opts.campaign_path, e, f)?;
        Ok(())
    };
    if let Err(e) = run() {
        if !quiet {
            eprintln!("warning: the model's ledger entry was not written: {e:#}");
        }
    }
}

/// The demo's identification step: identifies the in-memory virtual campaign, writes
/// `out/identified.toml` and the report into `out/identify/`. Returns the identification and
/// the report's files.
pub fn demo_step(
    camp: &zmp_campaign::Campaign,
    campaign_dir: &Path,
    out: &Path,
    quiet: bool,
) -> Result<(Identification, zmp_report::identify::ReportFiles)> {
    let opts = IdentifyOptions {
        campaign_path: Some(campaign_dir.to_path_buf()),
        ..IdentifyOptions::default()
    };
    let pb = progress_bar(camp.records.len() as u64, "fitting", quiet);
    let ident = identify_with_progress(camp, &opts, &|d| pb.set_position(d as u64))?;
    pb.finish_and_clear();
    write_model(&ident, &out.join("identified.toml"), true)?;
    let files = write_report(&ident, &out.join("identify"), true)?;
    Ok((ident, files))
}
