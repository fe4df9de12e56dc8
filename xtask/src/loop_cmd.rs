//! `cargo xtask loop CAMPAIGN`: the user's whole loop in one command. Identify the seed's
//! model (with the acceleration limit when the data show one), diagnose it, add what the
//! diagnosis finds one effect at a time (every version written and recorded in the ledger),
//! diagnose again, until the model explains the data or nothing significant is left; then
//! the error waterfall.

use crate::diagnose::{augmented_path, history_cmd, history_plot, read};
use crate::simulate::{load_model, progress_bar};
use anyhow::Result;
use std::path::{Path, PathBuf};
use zmp_campaign::ledger;
use zmp_campaign::Campaign;
use zmp_diagnose::iterate::MAX_ROUNDS;
use zmp_diagnose::observe::Observation;
use zmp_diagnose::DiagnoseOptions;
use zmp_identify::{write_model, IdentifyOptions};
use zmp_report::diagnose::write_diagnosis_report;

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
    /// Whether the time limit (`--time-limit`) passed before the loop ended: the last model
    /// is the best it reached in time.
    pub time_limit_reached: bool,
    /// The seed's cascade controller on the last model against its uncertainty weights.
    pub robust: zmp_report::robust::RobustSummary,
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

/// `cargo xtask loop`.
pub fn loop_cmd(a: &LoopArgs) -> Result<LoopSummary> {
    let camp = read(a.campaign, a.json)?;
    let summary = run_loop(&camp, a, a.json)?;
    if a.json {
        println!("{}", serde_json::to_string_pretty(&summary)?);
    }
    Ok(summary)
}

/// Marker of a loop output folder.
pub const LOOP_MARKER: &str = ".zmp-loop-output";

/// The loop on a campaign already read; `quiet` hides the narration (not the waterfall
/// table unless `a.json`).
pub fn run_loop(camp: &Campaign, a: &LoopArgs, quiet: bool) -> Result<LoopSummary> {
    let say = |s: &str| {
        if !quiet {
            println!("{s}");
        }
    };
    let out = a.out;
    // The output folder is claimed before any work: only a folder the loop wrote is replaced.
    zmp_files::claim_dir(out, LOOP_MARKER, a.force, "loop output")?;
    let identified = out.join("identified.toml");
    let start = a.model.map(load_model).transpose()?;
    let dopts = options(a.campaign, &identified, a.time_limit);
    let iopts = IdentifyOptions {
        campaign_path: Some(a.campaign.to_path_buf()),
        ..IdentifyOptions::default()
    };
    let pb = progress_bar(1 + 2 * MAX_ROUNDS as u64, "identifying", quiet);
    let r = zmp_diagnose::iterate::run_loop(camp, start, &iopts, &dopts, &|what| {
        pb.set_message(what.to_string());
        if what == "diagnosing" || what.starts_with("adding") {
            pb.inc(1);
        }
    })?;
    pb.finish_and_clear();
    for w in &r.identification.warnings {
        say(&format!("   identify: {w}"));
    }
    // The files: the identified model, each version, the ledger, the reports.
    write_model(&r.identification, &identified, true)?;
    let cname = a.campaign.display().to_string();
    ledger::append(
        &identified,
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
    let mut versions = vec![Version {
        model: identified.clone(),
        change: "identified".into(),
        error: r.identified_error,
        noise_floor: r.noise_floor,
    }];
    let mut reports = Vec::new();
    for (k, d) in r.diagnoses.iter().enumerate() {
        let dir = if k == 0 {
            out.join("diagnosis")
        } else {
            out.join(format!("diagnosis-{}", k + 1))
        };
        zmp_files::claim_dir(&dir, zmp_files::REPORT_MARKER, true, "report")?;
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
    }
    let mut current_path = identified.clone();
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
        zmp_files::atomic_write(&next, aug.spec.to_toml().as_bytes(), true)?;
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
    let obs: Vec<&Observation> = r.observations.iter().collect();
    let final_preds = zmp_diagnose::measure::predict(&r.final_model, &obs)?;
    let still_failing: Vec<String> = zmp_diagnose::cells::cells(&obs, &final_preds)
        .iter()
        .filter(|c| c.significant)
        .take(8)
        .map(|c| c.line())
        .collect();
    let history = out.join("history.svg");
    if quiet {
        history_plot(&current_path, Some(&history), true)?;
    } else {
        history_cmd(&current_path, Some(&history), true, false)?;
    }
    let outcome = if r.explained {
        "explained"
    } else {
        "unexplained"
    };
    say(&format!(
        "outcome: {outcome}{}",
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
        outcome: outcome.into(),
        verdict: r
            .diagnoses
            .first()
            .map_or(String::new(), |d| d.verdict.clone()),
        versions,
        noise_floor: r.noise_floor,
        reports,
        history,
        final_model: current_path,
        still_failing,
        time_limit_reached: r.time_limit_reached,
        robust: zmp_report::robust::summary(&robust),
    })
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
    std::fs::create_dir_all(dir)?;
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
    zmp_files::atomic_write(&truth, robot.to_json().as_bytes(), true)?;
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
