//! `cargo xtask compare | diagnose | augment | history`: the model against measurements, the
//! missing effect, adding it, and the error's history.

use crate::simulate::{load_model, progress_bar};
use anyhow::{Context, Result};
use std::path::{Path, PathBuf};
use zmp_campaign::ledger;
use zmp_campaign::{read_campaign, Campaign};
use zmp_diagnose::augment::{augment, Augmented};
use zmp_diagnose::cells::{cells, channel_scores, channel_summary};
use zmp_diagnose::measure::{aggregate, score};
use zmp_diagnose::observe::Observation;
use zmp_diagnose::run::{check_inputs, observe_campaign};
use zmp_diagnose::{diagnose, DiagnoseOptions, Diagnosis};
use zmp_files::{check_file, claim_dir, write_file, Kind};
use zmp_report::diagnose::{write_compare_report, write_diagnosis_report};
use zmp_report::plot::bars_svg;

/// The thread budget (`--threads`, else every core).
fn threads() -> usize {
    zmp_campaign::par::budget()
}

pub fn read(campaign: &Path, quiet: bool) -> Result<Campaign> {
    let spinner = progress_bar(1, "reading", quiet);
    let camp = read_campaign(campaign)
        .with_context(|| format!("reading campaign {}", campaign.display()))?;
    spinner.finish_and_clear();
    Ok(camp)
}

fn options(campaign: &Path, model: &Path) -> DiagnoseOptions {
    DiagnoseOptions {
        campaign_path: campaign.display().to_string(),
        model_path: model.display().to_string(),
        threads: threads(),
        ..DiagnoseOptions::default()
    }
}

/// `cargo xtask compare`.
pub fn compare(
    campaign: &Path,
    model: &Path,
    report: &Path,
    records: &[usize],
    force: bool,
    json: bool,
) -> Result<()> {
    claim_dir(report, Kind::Report, force)?;
    let spec = load_model(model)?;
    let camp = read(campaign, json)?;
    let opts = options(campaign, model);
    let (obs, skipped) = observe_campaign(&camp, opts.threads);
    let refs: Vec<&Observation> = obs.iter().collect();
    let preds = check_inputs(&refs, &spec, &opts)?;
    for r in records {
        if let Some((_, why)) = skipped.iter().find(|(k, _)| k == r) {
            anyhow::bail!("{}: record {r} was left out: {why}", campaign.display());
        }
        if !refs.iter().any(|o| o.index == *r) {
            anyhow::bail!(
                "{}: there is no record {r} (records are numbered from 0 in campaign.toml order; the campaign has {})",
                campaign.display(),
                camp.records.len()
            );
        }
    }
    let scores: Vec<_> = refs.iter().zip(&preds).map(|(o, p)| score(o, p)).collect();
    let (e, f) = aggregate(&scores);
    let cl = cells(&refs, &preds);
    let ch = channel_summary(&refs, &preds);
    let html = write_compare_report(
        &camp,
        &campaign.display().to_string(),
        &model.display().to_string(),
        &refs,
        &preds,
        &cl,
        records,
        report,
        force,
    )?;
    if json {
        let records: Vec<_> = refs
            .iter()
            .zip(&scores)
            .zip(&preds)
            .map(|((o, s), p)| {
                // Per channel: this record's measure split by output (they add in squares).
                let per: serde_json::Map<String, serde_json::Value> = channel_scores(o, p)
                    .iter()
                    .enumerate()
                    .map(|(i, c)| {
                        let ch = zmp_models::Channel::new(
                            zmp_models::Axis::from_index(i).expect("0 or 1"),
                            o.excited,
                        );
                        (
                            ch.name().to_string(),
                            serde_json::json!({"error": c.error2.sqrt(), "noise_floor": c.floor2.sqrt()}),
                        )
                    })
                    .collect();
                serde_json::json!({
                    "record": o.index, "excited": o.excited.name(), "omega": o.omega,
                    "amplitude_m": o.nominal_amplitude, "operating_point_m": o.operating_point,
                    "error": s.error(), "noise_floor": s.floor(), "channels": per,
                })
            })
            .collect();
        let v = serde_json::json!({
            "campaign": campaign, "model": model, "error": e, "noise_floor": f,
            "explained": e <= 1.5 * f && !cl.iter().any(|c| c.significant),
            "channels": ch.iter().map(|c| serde_json::json!({"channel": c.0, "error": c.1, "noise_floor": c.2})).collect::<Vec<_>>(),
            "where_it_fails": cl.iter().filter(|c| c.significant).collect::<Vec<_>>(),
            "records": records,
            "skipped": skipped.iter().map(|(k, r)| serde_json::json!({"record": k, "reason": r})).collect::<Vec<_>>(),
            "report": html,
        });
        println!("{}", serde_json::to_string_pretty(&v)?);
        return Ok(());
    }
    println!(
        "{} records: error {e:.4}, noise floor {f:.4} ({:.1}x)",
        refs.len(),
        e / f
    );
    for c in &ch {
        println!(
            "  {}: error {:.4}, floor {:.4} ({:.1}x)",
            c.0,
            c.1,
            c.2,
            c.1 / c.2
        );
    }
    let bad: Vec<_> = cl.iter().filter(|c| c.significant).take(10).collect();
    if bad.is_empty() {
        println!("no cell is significantly above its noise floor");
    } else {
        println!("where it fails (error / noise floor):");
        for c in bad {
            println!("  {}", c.line());
        }
    }
    for (k, r) in &skipped {
        println!("record {k} left out: {r}");
    }
    println!("report -> {}", html.display());
    Ok(())
}

/// Runs the diagnosis with a progress bar.
pub fn run_diagnosis(
    camp: &Campaign,
    spec: &zmp_models::ModelSpec,
    opts: &DiagnoseOptions,
    quiet: bool,
) -> Result<Diagnosis> {
    // A structure scored at a time (each message names it and counts).
    let pb = crate::simulate::spinner("diagnosing", quiet);
    let d = diagnose(camp, spec, opts, &|what| {
        pb.set_message(what.to_string());
        pb.inc(1);
    })?;
    pb.finish_and_clear();
    Ok(d)
}

/// `cargo xtask diagnose`.
pub fn diagnose_cmd(
    campaign: &Path,
    model: &Path,
    report: Option<&Path>,
    force: bool,
    json: bool,
) -> Result<Diagnosis> {
    if let Some(dir) = report {
        claim_dir(dir, Kind::Report, force)?;
    }
    let spec = load_model(model)?;
    let camp = read(campaign, json)?;
    let opts = options(campaign, model);
    let d = run_diagnosis(&camp, &spec, &opts, json)?;
    let html = match report {
        Some(dir) => Some(write_diagnosis_report(&camp, &d, dir, force)?),
        None => None,
    };
    if json {
        let mut v = d.to_json();
        if let Some(h) = &html {
            v["report"] = serde_json::json!(h);
        }
        println!("{}", serde_json::to_string_pretty(&v)?);
    } else {
        print!("{}", d.to_text());
        if let Some(e) = d.selected.first() {
            println!(
                "next: cargo xtask augment {} --add {} --campaign {}",
                model.display(),
                e.0,
                campaign.display()
            );
        }
        if let Some(h) = &html {
            println!("report -> {}", h.display());
        }
    }
    Ok(d)
}

/// Default name of an augmented model: `<stem>+<effect>.toml` beside it.
pub fn augmented_path(model: &Path, effect: &str) -> PathBuf {
    let stem = model
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "model".into());
    model.with_file_name(format!("{stem}+{effect}.toml"))
}

/// Makes sure the parent model has a ledger entry (measured on `campaign`) before a child
/// is recorded (checked and written under the ledger's lock).
fn ensure_root(model: &Path, campaign: &str, error: f64, floor: f64) -> Result<()> {
    ledger::append_unless_recorded(model, "starting model", campaign, error, floor)?;
    Ok(())
}

/// What `cargo xtask augment` was asked.
pub struct AugmentArgs<'a> {
    pub model: &'a Path,
    pub effect: &'a str,
    pub campaign: &'a Path,
    pub out: Option<&'a Path>,
    pub force: bool,
    pub json: bool,
    /// Write the model without its ledger entries (else a failed entry is a failed run).
    pub no_ledger: bool,
}

/// `cargo xtask augment`.
pub fn augment_cmd(args: &AugmentArgs) -> Result<(PathBuf, Augmented)> {
    let AugmentArgs {
        model,
        effect,
        campaign,
        out,
        force,
        json,
        no_ledger,
    } = *args;
    let out = out
        .map(Path::to_path_buf)
        .unwrap_or_else(|| augmented_path(model, effect));
    check_file(&out, Kind::Model, force)?;
    let spec = load_model(model)?;
    let camp = read(campaign, json)?;
    let opts = options(campaign, model);
    let pb = progress_bar(1, "fitting", json);
    let a = augment(&camp, &spec, effect, &opts)?;
    pb.finish_and_clear();
    let written = write_file(&out, Kind::Model, a.spec.to_toml().as_bytes(), force)?;
    if !no_ledger && !written.special {
        let cname = campaign.display().to_string();
        ensure_root(model, &cname, a.error_before, a.noise_floor)
            .and_then(|()| {
                ledger::append(
                    &out,
                    Some(model),
                    &a.change,
                    &cname,
                    a.error_after,
                    a.noise_floor,
                )
            })
            .map_err(|e| crate::identify::ledger_failed(e, &out))?;
    }
    if json {
        let v = serde_json::json!({
            "model": out, "parent": model, "effect": effect,
            "error_before": a.error_before, "error_after": a.error_after,
            "noise_floor": a.noise_floor,
            "parameters": a.parameters.iter().map(|(k, v)| (k.clone(), serde_json::json!({"value": v.0, "stderr": v.1}))).collect::<serde_json::Map<_, _>>(),
        });
        println!("{}", serde_json::to_string_pretty(&v)?);
    } else {
        println!(
            "added {effect}: error {:.4} -> {:.4} (noise floor {:.4}; {:.1}x -> {:.1}x)",
            a.error_before,
            a.error_after,
            a.noise_floor,
            a.error_before / a.noise_floor,
            a.error_after / a.noise_floor
        );
        for (k, (v, se)) in &a.parameters {
            println!("  {k:<40} {v:>12.6} +- {se:.3e}");
        }
        println!("model -> {}", out.display());
        println!("history: cargo xtask history {}", out.display());
    }
    Ok((out, a))
}

/// What [`history_plot`] found and drew.
pub struct HistoryPlot {
    pub history: ledger::History,
    pub plot: PathBuf,
}

/// The versions leading to `model` and the waterfall plot (written through the one output
/// path: an existing plot needs `force`, and only an SVG is ever replaced).
pub fn history_plot(model: &Path, plot: Option<&Path>, force: bool) -> Result<HistoryPlot> {
    let history = ledger::history(model)?;
    // Damaged ledger lines are skipped, never fatal; say so on standard error.
    for w in &history.warnings {
        eprintln!("warning: {w}");
    }
    let plot = plot.map(Path::to_path_buf).unwrap_or_else(|| {
        let stem = model
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        model.with_file_name(format!("{stem}.history.svg"))
    });
    let chain = &history.chain;
    let bars: Vec<(String, f64)> = chain.iter().map(|e| (e.change.clone(), e.error)).collect();
    let floor = chain.last().map_or(f64::NAN, |e| e.noise_floor);
    bars_svg(
        &plot,
        &format!(
            "Error of {} and the models before it",
            chain.last().map_or("", |e| e.model.as_str())
        ),
        "error",
        &bars,
        Some((floor, "noise floor")),
        force,
    )?;
    Ok(HistoryPlot { history, plot })
}

/// `cargo xtask history`.
pub fn history_cmd(model: &Path, plot: Option<&Path>, force: bool, json: bool) -> Result<()> {
    let HistoryPlot { history, plot } = history_plot(model, plot, force)?;
    let ledger::History {
        chain,
        edited,
        warnings,
        notes,
    } = history;
    if json {
        let v = serde_json::json!({"versions": chain, "edited_since": edited, "plot": plot,
            "warnings": warnings, "notes": notes});
        println!("{}", serde_json::to_string_pretty(&v)?);
        return Ok(());
    }
    println!(
        "{:<3} {:<44} {:<20} {:>9} {:>8} {:>9}  campaign",
        "#", "model", "change", "error", "x floor", "change"
    );
    let mut prev: Option<f64> = None;
    for (k, e) in chain.iter().enumerate() {
        println!(
            "{:<3} {:<44} {:<20} {:>9.4} {:>8.1} {:>9}  {}",
            k + 1,
            e.model,
            e.change,
            e.error,
            e.error / e.noise_floor,
            prev.map_or("".into(), |p| format!(
                "{:+.1} %",
                100.0 * (e.error - p) / p
            )),
            e.campaign
        );
        prev = Some(e.error);
    }
    for n in &notes {
        println!("note: {n}");
    }
    if edited {
        println!(
            "note: {} was edited after its ledger entry; `cargo xtask identify CAMPAIGN --model {}` refits and records it",
            model.display(),
            model.display()
        );
    }
    println!("waterfall -> {}", plot.display());
    Ok(())
}
