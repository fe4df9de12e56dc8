//! `cargo xtask loop CAMPAIGN`: the user's whole loop in one command. Identify the seed's
//! model (with the acceleration limit when the data show one), diagnose it, add what the
//! diagnosis finds one effect at a time (every version written and recorded in the ledger),
//! diagnose again, until the model explains the data or nothing significant is left; then
//! the error waterfall.

use crate::diagnose::{augmented_path, history_cmd, history_plot, read};
use crate::simulate::{load_model, progress_bar};
use anyhow::{Context, Result};
use std::path::{Path, PathBuf};
use zmp_validation::campaign::Campaign;
use zmp_validation::diagnose::augment::augmented_from_diagnosis;
use zmp_validation::diagnose::observe::Observation;
use zmp_validation::diagnose::report::write_diagnosis_report;
use zmp_validation::diagnose::run::{diagnose_observations, observations_of};
use zmp_validation::diagnose::select::MAX_EFFECTS;
use zmp_validation::diagnose::{DiagnoseOptions, Diagnosis};
use zmp_validation::identify::{identify_with_progress, write_model, IdentifyOptions};
use zmp_validation::ledger;

/// Diagnosis rounds at most (each may add several effects).
const MAX_ROUNDS: usize = 3;

/// What `cargo xtask loop` was asked.
pub struct LoopArgs<'a> {
    pub campaign: &'a Path,
    /// A model whose structure is identified instead of the seed's.
    pub model: Option<&'a Path>,
    /// Folder of the model versions, reports and waterfall.
    pub out: &'a Path,
    pub force: bool,
    pub json: bool,
}

/// One model version the loop wrote.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Version {
    pub model: PathBuf,
    pub change: String,
    pub error: f64,
    pub noise_floor: f64,
}

/// What the loop did.
#[derive(Debug, Clone, serde::Serialize)]
pub struct LoopSummary {
    pub campaign: PathBuf,
    /// Effects added, in order.
    pub found: Vec<String>,
    /// `explained` when the last model explains the data, else `unexplained`.
    pub outcome: String,
    /// The first diagnosis's verdict.
    pub verdict: String,
    pub versions: Vec<Version>,
    pub noise_floor: f64,
    /// The first diagnosis's report and the last one's (when it differs).
    pub reports: Vec<PathBuf>,
    pub history: PathBuf,
    pub final_model: PathBuf,
    /// Where the last model still fails, when it does (one line per cell).
    pub still_failing: Vec<String>,
}

fn options(campaign: &Path, model: &Path) -> DiagnoseOptions {
    DiagnoseOptions {
        campaign_path: campaign.display().to_string(),
        model_path: model.display().to_string(),
        threads: std::thread::available_parallelism().map_or(1, |n| n.get()),
        ..DiagnoseOptions::default()
    }
}

fn error_of(spec: &zmp_models::ModelSpec, obs: &[&Observation]) -> Result<(f64, f64)> {
    let s = zmp_validation::diagnose::engine::evaluate(spec, obs)?;
    Ok(zmp_validation::diagnose::measure::aggregate(&s))
}

/// `cargo xtask loop`.
pub fn loop_cmd(a: &LoopArgs) -> Result<LoopSummary> {
    let camp = read(a.campaign, a.json)?;
    let summary = run_loop(&camp, a, a.json)?;
    if a.json {
        println!("{}", serde_json::to_string_pretty(&summary)?);
    }
    Ok(summary)
}

/// The loop on a campaign already read; `quiet` hides the narration (not the waterfall
/// table unless `a.json`).
pub fn run_loop(camp: &Campaign, a: &LoopArgs, quiet: bool) -> Result<LoopSummary> {
    let say = |s: &str| {
        if !quiet {
            println!("{s}");
        }
    };
    let out = a.out;
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    let identified = out.join("identified.toml");
    // Output paths are checked before any work.
    if !a.force && identified.exists() {
        anyhow::bail!(
            "{} exists; pass --force to replace the loop's earlier output there",
            identified.display()
        );
    }
    // 1. Identify: the seed's structure (or the given model's), the acceleration limit in
    //    the model when the data show one.
    let start = a.model.map(load_model).transpose()?;
    let iopts = IdentifyOptions {
        campaign_path: Some(a.campaign.to_path_buf()),
        include_saturation: true,
        start_model: start,
        ..IdentifyOptions::default()
    };
    let pb = progress_bar(camp.records.len() as u64, "identifying", quiet);
    let ident = identify_with_progress(camp, &iopts, &|d| pb.set_position(d as u64))?;
    pb.finish_and_clear();
    write_model(&ident, &identified, a.force)?;
    for w in &ident.warnings {
        say(&format!("   identify: {w}"));
    }
    // The identification's own record analyses are the diagnosis's observations.
    let (observations, skipped) = observations_of(&ident.records);
    let obs: Vec<&Observation> = observations.iter().collect();
    let cname = a.campaign.display().to_string();
    let (e0, floor) = error_of(&ident.model, &obs)?;
    ledger::append(&identified, None, "identified", &cname, e0, floor)?;
    say(&format!(
        "identified {} ({} records): error {e0:.4} = {:.1}x the noise floor",
        identified.display(),
        obs.len(),
        e0 / floor
    ));
    let mut versions = vec![Version {
        model: identified.clone(),
        change: "identified".into(),
        error: e0,
        noise_floor: floor,
    }];
    let mut current_path = identified.clone();
    let mut current = ident.model.clone();
    let mut found: Vec<String> = Vec::new();
    let mut reports = Vec::new();
    let mut verdict = String::new();
    let mut last: Option<Diagnosis> = None;
    for round in 0..MAX_ROUNDS {
        let dopts = options(a.campaign, &current_path);
        let pb = progress_bar(
            (2 + zmp_validation::diagnose::candidates::CATALOGUE.len()) as u64,
            &format!("diagnosing {}", file_name(&current_path)),
            quiet,
        );
        let d = diagnose_observations(
            observations.clone(),
            skipped.clone(),
            &current,
            &dopts,
            &|what| {
                pb.set_message(what.to_string());
                pb.inc(1);
            },
        )?;
        pb.finish_and_clear();
        if round == 0 {
            verdict = d.verdict.clone();
            let dir = out.join("diagnosis");
            reports.push(write_diagnosis_report(camp, &d, &dir, a.force)?);
        }
        say(&format!(
            "diagnosis of {}: verdict {}{}",
            file_name(&current_path),
            d.verdict,
            if d.explained { " (explained)" } else { "" }
        ));
        for f in d.findings.iter().filter(|f| f.significant) {
            say(&format!("   - {}: {}", f.effect, f.evidence));
        }
        // The diagnosis's path: each step's model, fitted on every record, becomes a version
        // (a pair found together is one version with both).
        let pairs: Vec<(Vec<String>, zmp_validation::diagnose::engine::Fitted)> = d
            .path
            .iter()
            .filter(|(added, _)| added.iter().all(|e| !found.contains(e)))
            .cloned()
            .collect();
        let stop = pairs.is_empty() || found.len() >= MAX_EFFECTS;
        last = Some(d);
        if stop {
            break;
        }
        for (added, fitted) in pairs {
            if found.len() + added.len() > MAX_EFFECTS {
                break;
            }
            let dopts = options(a.campaign, &current_path);
            let label = added.join("+");
            let pb = progress_bar(1, &format!("fitting +{label}"), quiet);
            let aug = augmented_from_diagnosis(&obs, &current, &fitted, &label, &dopts)?;
            pb.finish_and_clear();
            let next = augmented_path(&current_path, &label);
            zmp_validation::io::atomic_write(&next, aug.spec.to_toml().as_bytes(), a.force)?;
            ledger::append(
                &next,
                Some(&current_path),
                &aug.change,
                &cname,
                aug.error_after,
                aug.noise_floor,
            )?;
            say(&format!(
                "   + {label}: error {:.4} -> {:.4} ({:.1}x the floor) -> {}",
                aug.error_before,
                aug.error_after,
                aug.error_after / aug.noise_floor,
                next.display()
            ));
            versions.push(Version {
                model: next.clone(),
                change: aug.change.clone(),
                error: aug.error_after,
                noise_floor: aug.noise_floor,
            });
            found.extend(added);
            current = aug.spec;
            current_path = next;
        }
    }
    let last = last.expect("at least one diagnosis round");
    // The last model's own standing (the last diagnosis may have been of an earlier one).
    let final_preds = zmp_validation::diagnose::measure::predict(&current, &obs)?;
    let explained = zmp_validation::diagnose::run::explains(&obs, &final_preds);
    let still_failing: Vec<String> = zmp_validation::diagnose::cells::cells(&obs, &final_preds)
        .iter()
        .filter(|c| c.significant)
        .take(8)
        .map(|c| c.line())
        .collect();
    if !last.explained && last.model != versions[0].model.display().to_string() {
        let dir = out.join("diagnosis-final");
        reports.push(write_diagnosis_report(camp, &last, &dir, a.force)?);
    }
    let history = out.join("history.svg");
    if quiet {
        history_plot(&current_path, Some(&history), true)?;
    } else {
        history_cmd(&current_path, Some(&history), true, false)?;
    }
    let outcome = if explained {
        "explained"
    } else {
        "unexplained"
    };
    say(&format!(
        "outcome: {outcome}{}",
        if found.is_empty() {
            String::new()
        } else {
            format!(" after adding {}", found.join(", "))
        }
    ));
    for c in &still_failing {
        say(&format!("   still failing: {c}"));
    }
    Ok(LoopSummary {
        campaign: a.campaign.to_path_buf(),
        found,
        outcome: outcome.into(),
        verdict,
        versions,
        noise_floor: floor,
        reports,
        history,
        final_model: current_path,
        still_failing,
    })
}

fn file_name(p: &Path) -> String {
    p.file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default()
}
