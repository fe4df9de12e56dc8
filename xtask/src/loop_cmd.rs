//! `cargo xtask loop CAMPAIGN`: the user's whole loop in one command. Identify the seed's
//! model (with the acceleration limit when the data show one), diagnose it once, write each
//! step of the best structure as a model version (every version recorded in the ledger; when
//! the records cannot decide, every structure of the set and the designed records that will),
//! then the error waterfall (`zmp_diagnose::iterate`).

use crate::diagnose::{augmented_path, history_cmd, history_plot, read};
use crate::simulate::{load_model, progress_bar};
use anyhow::Result;
use std::path::{Path, PathBuf};
use zmp_campaign::ledger;
use zmp_campaign::Campaign;
use zmp_diagnose::iterate::{LoopResult, Outcome};
use zmp_diagnose::observe::Observation;
use zmp_diagnose::DiagnoseOptions;
use zmp_identify::IdentifyOptions;
use zmp_report::diagnose::write_diagnosis_report;

mod design;
mod own_files;

use own_files::{file_name, OwnFiles};

/// What `cargo xtask loop` was asked.
pub struct LoopArgs<'a> {
    pub campaign: &'a Path,
    /// A model whose structure is identified instead of the seed's.
    pub model: Option<&'a Path>,
    /// Folder of the model versions, reports and waterfall.
    pub out: &'a Path,
    pub force: bool,
    pub json: bool,
    /// Wall-clock limit of the whole loop (`DiagnoseOptions::time_limit`); `None`: none.
    pub time_limit: Option<std::time::Duration>,
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
    /// `explained` when the last model explains the data, `ambiguous` when the records do not
    /// decide between several structures (`set`), else `unexplained`.
    pub outcome: Outcome,
    /// When ambiguous: each structure of the set (its effects), best first; the first is the
    /// last version, the others are `alternatives`.
    pub set: Vec<Vec<String>>,
    /// When ambiguous: the set's other structures, each a version of the identified model.
    pub alternatives: Vec<Version>,
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
    /// Whether the time limit (`--time-limit`) passed before the loop ended: the last model
    /// is the best it reached in time.
    pub time_limit_reached: bool,
    /// The seed's cascade controller on the last model against its uncertainty weights.
    pub robust: zmp_report::robust::RobustSummary,
    /// When ambiguous: the experiment that decides, as `cargo xtask design-next --json`
    /// prints it (the design file in the loop's folder, its records, the predicted separation
    /// of every pair, the total recording time), with `predicted_sigma`, the least separated
    /// pair's (noise standard deviations); `error` when none could be designed.
    pub design_next: Option<serde_json::Value>,
}

fn options(
    campaign: &Path,
    model: &Path,
    time_limit: Option<std::time::Duration>,
) -> DiagnoseOptions {
    DiagnoseOptions {
        campaign_path: campaign.display().to_string(),
        model_path: model.display().to_string(),
        threads: zmp_campaign::par::budget(),
        time_limit,
        ..DiagnoseOptions::default()
    }
}

/// The longest `--time-limit`: a week (a loop that runs longer is stuck, not slow; and the
/// deadline, now + limit, must be a time the clock can hold).
pub const MAX_TIME_LIMIT: std::time::Duration = std::time::Duration::from_secs(7 * 24 * 3600);

/// Parses `--time-limit`: seconds (`900`), or a number with the unit `s`, `min` or `h`
/// (`90s`, `15min`, `2h`); `0` is no limit (`None`). More than [`MAX_TIME_LIMIT`] is an error
/// that says so, never a panic.
pub fn parse_time_limit(s: &str) -> std::result::Result<TimeLimit, String> {
    let bound = format!(
        "a duration of at most {} s (7 days) is expected; 0 means no limit",
        MAX_TIME_LIMIT.as_secs()
    );
    let t = s.trim();
    let (number, unit) = match t.find(|c: char| !c.is_ascii_digit() && c != '.') {
        Some(k) => (&t[..k], t[k..].trim()),
        None => (t, "s"),
    };
    let scale = match unit {
        "s" => 1.0,
        "min" | "m" => 60.0,
        "h" => 3600.0,
        _ => {
            return Err(format!(
                "{s:?}: not seconds (900) nor a number with the unit s, min or h (15min): {bound}"
            ))
        }
    };
    let v: f64 = number.parse().map_err(|_| {
        format!("{s:?}: not a number of seconds (900) or a duration (15min): {bound}")
    })?;
    let secs = v * scale;
    if !(secs.is_finite() && secs >= 0.0) {
        return Err(format!("{s:?}: not a duration: {bound}"));
    }
    if secs > MAX_TIME_LIMIT.as_secs_f64() {
        return Err(format!("{s}: longer than the longest limit: {bound}"));
    }
    Ok(TimeLimit(
        (secs > 0.0).then(|| std::time::Duration::from_secs_f64(secs)),
    ))
}

/// A parsed `--time-limit` (`None`: no limit).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TimeLimit(pub Option<std::time::Duration>);

/// `cargo xtask loop`.
pub fn loop_cmd(a: &LoopArgs) -> Result<LoopSummary> {
    // The time limit covers the whole command: reading the campaign and identifying it too
    // (an inner limit set later does not extend this one).
    let deadline = a.time_limit.map(|d| std::time::Instant::now() + d);
    let summary = zmp_campaign::par::with_deadline(deadline, || {
        let camp = read(a.campaign, a.json)?;
        run_loop(&camp, a, a.json)
    })?;
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
    // The output folder is claimed before any work: only a folder the loop wrote is replaced,
    // and the earlier run's own versions are removed first, so two runs never mix in it.
    let out = &zmp_files::claim_dir(a.out, zmp_files::Kind::LoopOutput, a.force)?;
    for p in OwnFiles::remove_earlier(out)? {
        say(&format!("   removed the earlier run's {}", p.display()));
    }
    let mut own = OwnFiles::new(out);
    own.note("(the files this run wrote, and their hashes)".into())?;
    let identified = out.join("identified.toml");
    let start = a.model.map(load_model).transpose()?;
    let dopts = options(a.campaign, &identified, a.time_limit);
    let iopts = IdentifyOptions {
        campaign_path: Some(a.campaign.to_path_buf()),
        ..IdentifyOptions::default()
    };
    let pb = progress_bar(3, "identifying", quiet);
    let r = zmp_diagnose::iterate::run_loop(camp, start, &iopts, &dopts, &|what| {
        pb.set_message(what.to_string());
        if what == "diagnosing" || what == "identifying" {
            pb.inc(1);
        }
    })?;
    pb.finish_and_clear();
    for w in &r.identification.warnings {
        say(&format!("   identify: {w}"));
    }
    let mut versions = vec![write_identified(
        &r,
        a.campaign,
        &identified,
        &mut own,
        &say,
    )?];
    let reports = write_reports(camp, &r, out, &mut own, &say)?;
    let (chain, final_model) = write_chain(&r, a.campaign, &identified, &mut own, &say)?;
    versions.extend(chain);
    let alternatives = write_alternatives(&r, a.campaign, &identified, &mut own, &say)?;
    let still_failing = still_failing(&r)?;
    let history = write_history(out, &final_model, &mut own, quiet)?;
    let outcome = r.outcome;
    say(&format!(
        "outcome: {}{}",
        serde_json::to_value(outcome)?.as_str().unwrap_or_default(),
        if r.found.is_empty() {
            String::new()
        } else {
            format!(" after adding {}", r.found.join(", "))
        }
    ));
    for c in &still_failing {
        say(&format!("   still failing: {c}"));
    }
    let robust = crate::robust::seed_controller_check(&r.final_model)?;
    say(&format!(
        "robust stability of the last model with the seed's controller ({}): {}",
        robust.controller,
        robust.summary()
    ));
    let design_next = if outcome == Outcome::Ambiguous {
        say(&format!(
            "   the records do not decide between {}",
            r.set
                .iter()
                .map(|s| s.join("+"))
                .collect::<Vec<_>>()
                .join(" / ")
        ));
        let models: Vec<PathBuf> = std::iter::once(final_model.clone())
            .chain(alternatives.iter().map(|v| v.model.clone()))
            .collect();
        let v = design::design_for_set(camp, a, &r, &models, out, &mut own, quiet)?;
        if let Some(last) = reports.last() {
            design::add_to_report(last, &design::report_line(&v))?;
        }
        Some(v)
    } else {
        None
    };
    if r.time_limit_reached {
        say(&format!(
            "   the time limit ({} s, --time-limit) passed before the loop ended: the last \
             model is the best it reached in time",
            a.time_limit.map_or(0, |d| d.as_secs())
        ));
    }
    Ok(LoopSummary {
        campaign: a.campaign.to_path_buf(),
        found: r.found.clone(),
        outcome,
        set: r.set.clone(),
        alternatives,
        verdict: r
            .diagnoses
            .first()
            .map_or(String::new(), |d| d.verdict.to_string()),
        versions,
        noise_floor: r.noise_floor,
        reports,
        history,
        final_model,
        still_failing,
        time_limit_reached: r.time_limit_reached,
        robust: zmp_report::robust::summary(&robust),
        design_next,
    })
}

/// Where the last model still fails (one line per significant cell, at most eight).
fn still_failing(r: &LoopResult) -> Result<Vec<String>> {
    let obs: Vec<&Observation> = r.observations.iter().collect();
    let final_preds = zmp_diagnose::measure::predict(&r.final_model, &obs)?;
    Ok(zmp_diagnose::cells::cells(&obs, &final_preds)
        .iter()
        .filter(|c| c.significant)
        .take(8)
        .map(|c| c.line())
        .collect())
}

/// Writes the waterfall of the ledger up to `final_model` (`history.svg`; its table printed
/// unless `quiet`).
fn write_history(
    out: &Path,
    final_model: &Path,
    own: &mut OwnFiles,
    quiet: bool,
) -> Result<PathBuf> {
    let history = out.join("history.svg");
    own.note("file svg history.svg".into())?;
    if quiet {
        history_plot(final_model, Some(&history), true)?;
    } else {
        history_cmd(final_model, Some(&history), true, false)?;
    }
    Ok(history)
}

/// Writes the identified model and its ledger line.
fn write_identified(
    r: &LoopResult,
    campaign: &Path,
    identified: &Path,
    own: &mut OwnFiles,
    say: &dyn Fn(&str),
) -> Result<Version> {
    own.write_model(identified, &r.identification.model.to_toml())?;
    let cname = campaign.display().to_string();
    ledger::append(
        identified,
        None,
        "identified",
        &cname,
        r.identified_error,
        r.noise_floor,
    )?;
    say(&format!(
        "identified {} ({} records): error {:.4} = {:.1}x the noise floor",
        identified.display(),
        r.observations.len(),
        r.identified_error,
        r.identified_error / r.noise_floor
    ));
    Ok(Version {
        model: identified.to_path_buf(),
        change: "identified".into(),
        error: r.identified_error,
        noise_floor: r.noise_floor,
    })
}

/// Writes each diagnosis's report (`diagnosis/`, `diagnosis-2/`, ...) and says its verdict.
fn write_reports(
    camp: &Campaign,
    r: &LoopResult,
    out: &Path,
    own: &mut OwnFiles,
    say: &dyn Fn(&str),
) -> Result<Vec<PathBuf>> {
    let mut reports = Vec::new();
    for (k, d) in r.diagnoses.iter().enumerate() {
        let dir = if k == 0 {
            out.join("diagnosis")
        } else {
            out.join(format!("diagnosis-{}", k + 1))
        };
        own.note(format!("file report {}", file_name(&dir)))?;
        zmp_files::claim_dir(&dir, zmp_files::Kind::Report, true)?;
        reports.push(write_diagnosis_report(camp, d, &dir, true)?);
        say(&format!(
            "diagnosis {}: verdict {}{}",
            k + 1,
            d.verdict,
            if d.explained { " (explained)" } else { "" }
        ));
        for f in d.findings.iter().filter(|f| f.significant) {
            say(&format!("   - {}: {}", f.effect, f.evidence));
        }
        for a in d.alternatives.iter().filter(|_| d.alternatives.len() > 1) {
            let words = a.distinguished.as_ref().map_or("", |s| s.words.as_str());
            say(&format!("   ? {}: {words}", a.structure));
        }
        for p in &d.parted {
            say(&format!("   ! {}", p.words));
        }
    }
    Ok(reports)
}

/// Writes each version of the best structure's chain after the identified model, each with
/// its ledger line; returns them and the last model's file.
fn write_chain(
    r: &LoopResult,
    campaign: &Path,
    identified: &Path,
    own: &mut OwnFiles,
    say: &dyn Fn(&str),
) -> Result<(Vec<Version>, PathBuf)> {
    let cname = campaign.display().to_string();
    let mut versions = Vec::new();
    let mut current_path = identified.to_path_buf();
    for (added, aug) in &r.versions {
        // A version without an added effect is the structure refitted (`refit`) or its
        // modes (`trunk-in-servo`) or its play (`play-in-servo`) moved inside the servo's loop;
        // one that puts an effect in another's place is named by its change
        // (`time_delay-for-structural_mode`), one that takes out an effect that did nothing
        // too (`without-time_delay`).
        let label = if added.is_empty() || !aug.change.starts_with('+') {
            aug.change.clone()
        } else {
            added.join("+")
        };
        let next = augmented_path(&current_path, &label);
        own.write_model(&next, &aug.spec.to_toml())?;
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
        current_path = next;
    }
    Ok((versions, current_path))
}

/// Writes the ambiguous set's other structures, each a version of the identified model.
fn write_alternatives(
    r: &LoopResult,
    campaign: &Path,
    identified: &Path,
    own: &mut OwnFiles,
    say: &dyn Fn(&str),
) -> Result<Vec<Version>> {
    let cname = campaign.display().to_string();
    let mut alternatives = Vec::new();
    for (added, aug) in &r.alternatives {
        let next = augmented_path(identified, &added.join("+"));
        own.write_model(&next, &aug.spec.to_toml())?;
        ledger::append(
            &next,
            Some(identified),
            &aug.change,
            &cname,
            aug.error_after,
            aug.noise_floor,
        )?;
        say(&format!(
            "   ? {}: error {:.4} ({:.1}x the floor) -> {}",
            added.join("+"),
            aug.error_after,
            aug.error_after / aug.noise_floor,
            next.display()
        ));
        alternatives.push(Version {
            model: next,
            change: aug.change.clone(),
            error: aug.error_after,
            noise_floor: aug.noise_floor,
        });
    }
    Ok(alternatives)
}

/// What the demo's loop did.
#[derive(Debug, Clone, serde::Serialize)]
pub struct DemoLoop {
    /// The hidden effects (catalogue names), the simulator's seed and where its truth is.
    pub hidden: Vec<String>,
    pub seed: u64,
    pub truth: PathBuf,
    pub summary: LoopSummary,
}

/// Seed of the demo's independently simulated robot.
pub const DEMO_SEED: u64 = 7;

/// The demo's loop: a robot drawn by `zmp-indep-sim` (a simulator that shares no code with
/// the project's models: its own mechanics, stick-slip, saturation) with a servo latency and
/// a drifting ZMP sensor hidden, always saturating like the seed's robot; its campaign is
/// written by that simulator and the loop sees only the folder.
pub fn demo_loop(dir: &Path, quiet: bool) -> Result<DemoLoop> {
    use zmp_indep_sim::{draw_with, write_campaign, Design, DrawOptions, Scenario};
    let design = Design::default();
    let scenario: Scenario = "pair:time_delay,sensor_drift"
        .parse()
        .map_err(|e| anyhow::anyhow!("{e}"))?;
    let robot = draw_with(DEMO_SEED, &scenario, &design, &DrawOptions::default());
    let camp_dir = dir.join("campaign");
    let pb = progress_bar(1, "simulating (zmp-indep-sim)", quiet);
    write_campaign(&robot, &design, &camp_dir, true)?;
    pb.finish_and_clear();
    // The truth stays outside the campaign folder.
    let truth = dir.join("truth.json");
    zmp_files::write_file(
        &truth,
        zmp_files::Kind::Json,
        robot.to_json().as_bytes(),
        true,
    )?;
    let hidden: Vec<String> = robot.hidden.iter().map(|h| h.name.to_string()).collect();
    if !quiet {
        println!(
            "   a robot from an independent simulator (zmp-indep-sim seed {DEMO_SEED}): {} hidden \
             besides its acceleration limit; {} records -> {}",
            hidden.join(" and "),
            design.records().len(),
            camp_dir.display()
        );
    }
    let camp = read(&camp_dir, quiet)?;
    let summary = run_loop(
        &camp,
        &LoopArgs {
            campaign: &camp_dir,
            model: None,
            out: &dir.join("loop"),
            force: true,
            json: quiet,
            time_limit: None,
        },
        quiet,
    )?;
    Ok(DemoLoop {
        hidden,
        seed: DEMO_SEED,
        truth,
        summary,
    })
}
