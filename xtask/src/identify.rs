//! `cargo xtask identify`: a campaign folder in, the identified model file and a report out.

use crate::simulate::load_model;
use crate::simulate::progress_bar;
use anyhow::{bail, Context, Result};
use std::path::{Path, PathBuf};
use zmp_campaign::{read_campaign, read_manifest, Campaign, Manifest};
use zmp_files::{check_file, claim_dir, Kind};
use zmp_identify::{
    analyse_folder, analyse_records, identify_analysed, identify_with_progress, summary_json,
    write_model, Identification, IdentifyOptions, RecordFit,
};
use zmp_models::robust::RobustAnalysis;
use zmp_models::EffectKind;
use zmp_report::identify::{write_report, ReportFiles};

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
    /// Write the model without its ledger entry (else a failed entry is a failed run).
    pub no_ledger: bool,
}

/// Runs the identification; writes the model (and the report if asked).
pub fn identify(a: &IdentifyArgs) -> Result<Identification> {
    let (campaign, out, report, force, json) = (a.campaign, a.out, a.report, a.force, a.json);
    let out = out
        .map(Path::to_path_buf)
        .unwrap_or_else(|| default_out(campaign));
    // Where the results go is checked before the work starts (and again when written).
    check_file(&out, Kind::Model, force)?;
    if let Some(dir) = report {
        claim_dir(dir, Kind::Report, force)?;
    }
    let start_model = a.model.map(load_model).transpose()?;
    let quiet = json;
    let manifest = read_manifest(campaign).with_context(|| reading(campaign))?;
    let opts = IdentifyOptions {
        given_bandwidth: a.bandwidth,
        campaign_path: Some(campaign.to_path_buf()),
        start_model,
        include_saturation: a.include_saturation,
        ..IdentifyOptions::default()
    };
    let (fits, camp) = analyse(a, &manifest, &opts, quiet)?;
    let mut ident = identify_analysed(fits, manifest.name.clone(), &opts)?;
    // A model that names effects beyond the core: those are refitted with it.
    let dopts = zmp_diagnose::DiagnoseOptions {
        campaign_path: campaign.display().to_string(),
        model_path: a
            .model
            .map_or_else(|| out.display().to_string(), |m| m.display().to_string()),
        ..Default::default()
    };
    let mut change = "identified".to_string();
    if let Some(camp) = &camp {
        if refit_named_structure(camp, &mut ident, &dopts, quiet)? {
            change = "refit".into();
        }
    }
    let written = write_model(&ident, &out, force)?;
    // The ledger's error reuses the identification's own record analyses.
    if written.special && !a.no_ledger && !quiet {
        eprintln!(
            "note: {} is not a regular file (the model was written into it): no ledger entry",
            out.display()
        );
    }
    if !written.special && !a.no_ledger {
        let (obs, _) = zmp_diagnose::run::observations_of(&ident.records);
        record_in_ledger(&obs, &ident.model, &out, a.model, &change, &dopts)
            .map_err(|e| ledger_failed(e, &out))?;
    }
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
        print_summary(&ident, &robust, &out, files.as_ref());
    }
    Ok(ident)
}

/// The context of an error reading the campaign.
fn reading(campaign: &Path) -> String {
    format!("reading campaign {}", campaign.display())
}

/// Steps 1-3 on every record, with progress: each record is analysed as it is read and its
/// columns dropped (the campaign's data is never all in memory), unless a starting model's
/// refit needs the data: then the campaign is read once and kept (and returned).
fn analyse(
    a: &IdentifyArgs,
    manifest: &Manifest,
    opts: &IdentifyOptions,
    quiet: bool,
) -> Result<(Vec<RecordFit>, Option<Campaign>)> {
    let campaign = a.campaign;
    let pb = progress_bar(manifest.records.len() as u64, "reading and fitting", quiet);
    let progress = |d: usize| pb.set_position(d as u64);
    let (fits, camp) = if a.model.is_some() {
        let camp = read_campaign(campaign).with_context(|| reading(campaign))?;
        (analyse_records(&camp, opts, &progress), Some(camp))
    } else {
        let fits = analyse_folder(campaign, manifest, opts, &progress)
            .with_context(|| reading(campaign))?;
        (fits, None)
    };
    pb.finish_and_clear();
    Ok((fits, camp))
}

/// Refits the effects the identified model names beyond the core on `camp` (and says so
/// unless `quiet`); whether there were any.
fn refit_named_structure(
    camp: &Campaign,
    ident: &mut Identification,
    dopts: &zmp_diagnose::DiagnoseOptions,
    quiet: bool,
) -> Result<bool> {
    let pb = progress_bar(1, "refitting", quiet);
    let refit = zmp_diagnose::augment::refit_structure(camp, &ident.model, dopts)?;
    pb.finish_and_clear();
    let Some(r) = refit else {
        return Ok(false);
    };
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
    Ok(true)
}

/// The identification for a reader: records used, parameters with standard errors,
/// warnings, a detected acceleration limit, the robust stability, where the files went.
fn print_summary(
    ident: &Identification,
    robust: &RobustAnalysis,
    out: &Path,
    files: Option<&ReportFiles>,
) {
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
    if let Some(f) = files {
        println!("report -> {}", f.html.display());
    }
}

/// A failed ledger entry as the run's error: the model stays written, and the message names
/// it and says how to write models without a ledger.
pub fn ledger_failed(e: anyhow::Error, model: &Path) -> anyhow::Error {
    e.context(format!(
        "the model was written to {} and is kept, but its ledger entry was not written (so \
         `history` cannot follow it); fix the ledger, or pass --no-ledger to write models \
         without one",
        model.display()
    ))
}

/// Records the written model in the ledger beside it, with its error on the campaign.
pub fn record_in_ledger(
    obs: &[zmp_diagnose::observe::Observation],
    spec: &zmp_models::ModelSpec,
    out: &Path,
    parent: Option<&Path>,
    change: &str,
    opts: &zmp_diagnose::DiagnoseOptions,
) -> Result<()> {
    let evaluate = |spec: &zmp_models::ModelSpec, refs: &[&zmp_diagnose::observe::Observation]| {
        zmp_diagnose::measure::predict(spec, refs)
            .map(|p| zmp_diagnose::run::error_and_floor(refs, &p))
    };
    let refs: Vec<_> = obs.iter().collect();
    let (e, f) = evaluate(spec, &refs)?;
    // A starting model in the same folder joins the chain (recorded first if these contents
    // have no entry yet).
    let parent = parent.filter(|p| p.parent() == out.parent() && p != &out);
    if let Some(p) = parent {
        let name = p.file_name().and_then(|n| n.to_str());
        let bytes = zmp_files::read_limited(p, zmp_files::limits::MODEL_BYTES, "a model file")?;
        let known = zmp_campaign::ledger::read(out)?.entries.iter().any(|e| {
            Some(e.model.as_str()) == name
                && zmp_campaign::ledger::hash_matches(&e.hash, &bytes) == Some(true)
        });
        if !known {
            let start = crate::simulate::load_model(p)?;
            let (e0, f0) = evaluate(&start, &refs)?;
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
