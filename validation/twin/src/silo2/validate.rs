//! `validate silo2`: everything about the SILO2 twin into one folder, in this order:
//!
//! 1. the twin's mass properties and what they predict (seed eqs. 6-15, multibody, servo);
//! 2. the ZMP measurement: eq. 10 at every operating point (load cells against MuJoCo's
//!    centre of pressure and the CoM), a dynamic cross-check (momentum and cart-table ZMP), and
//!    the contact-softness budget;
//! 3. the stepped-sine campaign (`campaign/`, `zmp-campaign/1`), its identification
//!    (`identified.toml`, `identify/`), and the identified `a`, `b` against the predictions;
//! 4. the closed loop (seed section 6.6) on the twin against the identified model's prediction
//!    (`closed_loop.svg`);
//! 5. the compare / diagnose loop on the campaign (`diagnosis/`, and the model with the effects
//!    it found), and the stance resonance swept on the model file against the mode the loop
//!    names ([`super::stance`]: the physical resonance or an in-band surrogate);
//! 6. frames of the robot during the disturbance experiment (`frames/`, when rendering works);
//! 7. `report.html` and `summary.json`.
//!
//! The folder is built aside and renamed into place: it is either complete or absent. An
//! existing folder is replaced only with `force` and only if an earlier run of this command
//! wrote it (it holds [`MARKER`]).

use super::campaign::{run_campaign, TwinDesign};
use super::closed_loop::{compare, experiment, run_model, run_twin, LoopComparison, TwinRun};
use super::crosscheck::{
    budget, dynamic_check, static_check, BudgetRow, DynamicCheck, StaticCheck,
};
use super::props::{mass_properties, predict, MassProperties, OperatingPoint};
use super::report;
use super::summary::{parameter_rows, summarise_diagnosis};
pub use super::summary::{
    CampaignSummary, ClosedLoopSummary, DiagnosisSummary, Experiment, ParameterRow, Summary,
};
use super::Silo2;
use anyhow::{bail, Context, Result};
use indicatif::{ProgressBar, ProgressStyle};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use std::time::Instant;
use zmp_campaign::{write_campaign, Campaign};
use zmp_diagnose::{diagnose, DiagnoseOptions, Diagnosis};
use zmp_identify::{identify_with_progress, Identification, IdentifyOptions};
use zmp_models::closed_loop::StepExperiment;
use zmp_models::Axis;

/// `format` of `summary.json`.
pub const FORMAT: &str = "zmp-twin-silo2/1";
/// File that marks a folder as this command's output.
pub const MARKER: &str = zmp_files::TWIN_SILO2_MARKER;

/// When the frames of the disturbance experiment are taken, s.
pub const FRAME_TIMES: [f64; 6] = [0.0, 20.0, 79.0, 82.0, 100.0, 160.0];

/// How frames are made.
#[derive(Debug, Clone)]
pub enum Frames {
    /// By a child process of this program (`<exe> silo2 render-frames`), so that a failing
    /// OpenGL stack cannot take the validation down with it.
    Render {
        /// This program's executable.
        exe: PathBuf,
    },
    /// Not at all, for this reason.
    Skip(String),
}

/// What `validate silo2` runs and where it writes.
#[derive(Debug, Clone)]
pub struct ValidateOptions {
    /// The model file checked against the twin.
    pub model: PathBuf,
    /// Output folder.
    pub out: PathBuf,
    /// The short campaign (the demo's).
    pub short: bool,
    /// The campaign extended to 50 rad/s ([`TwinDesign::extended`]).
    pub extended: bool,
    /// Overwrite the files a previous run wrote.
    pub force: bool,
    /// Worker threads.
    pub threads: usize,
    /// No progress bars (and no text).
    pub quiet: bool,
    /// How the frames of the disturbance experiment are made.
    pub frames: Frames,
    /// Delay of the ZMP measurement, s (campaign and closed loop; stated in `campaign.toml`).
    pub zmp_delay: f64,
}

/// The robot's posture at one frame.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct FrameState {
    /// Time of the frame, s.
    pub t: f64,
    /// MuJoCo's qpos at that time.
    pub qpos: Vec<f64>,
    /// The 4 kg load is on.
    pub loaded: bool,
}

fn bar(quiet: bool, len: u64, what: &str) -> ProgressBar {
    if quiet {
        return ProgressBar::hidden();
    }
    let pb = ProgressBar::new(len);
    pb.set_style(
        ProgressStyle::with_template("{prefix:>12} [{bar:40}] {pos}/{len} {elapsed}")
            .unwrap_or_else(|_| ProgressStyle::default_bar())
            .progress_chars("=> "),
    );
    pb.set_prefix(what.to_string());
    pb
}

/// Decides what to do with an existing output folder (the one output path's rule for a
/// `validate silo2` folder: missing or empty, or an earlier validation with `force`; any other
/// folder is refused, `force` or not); errors name the folder.
pub fn check_destination(out: &Path, force: bool) -> Result<()> {
    zmp_files::check_dir(out, zmp_files::Kind::TwinSilo2, force)?;
    Ok(())
}

/// Runs the whole validation (see the module docs).
///
/// The folder is built aside and swapped into place whole by the one output path
/// (`zmp_files::write_dir`): it is either complete or absent, an earlier validation is
/// replaced only with `force`, and a killed run's half-built folder is removed by the next.
pub fn validate(opts: &ValidateOptions) -> Result<Summary> {
    let started = Instant::now();
    check_destination(&opts.out, opts.force)?;
    let (summary, _) = zmp_files::write_dir(
        &opts.out,
        zmp_files::Kind::TwinSilo2,
        opts.force,
        |staging| build(opts, staging.path(), started),
    )?;
    if !opts.quiet {
        eprintln!("report -> {}", opts.out.join("report.html").display());
    }
    Ok(summary)
}

/// Everything of the validation, written into `dir` (the folder being built).
fn build(opts: &ValidateOptions, dir: &Path, started: Instant) -> Result<Summary> {
    let dir = dir.to_path_buf();
    let say = |s: &str| {
        if !opts.quiet {
            eprintln!("{s}");
        }
    };

    // 1. The twin and its predictions.
    let twin = Silo2::load(&opts.model)?;
    let props = mass_properties(&twin)?;
    let design = design_of(opts);
    let (predictions, upright) = predictions(&twin, &props, &design, &say)?;

    // 2. The ZMP measurement.
    let checks = zmp_checks(opts, &twin, &props, &say)?;

    // 3. Campaign and identification.
    let (camp, campaign, ident) =
        campaign_and_identification(opts, &dir, &twin, &props, &design, &say)?;

    // 4. Closed loop, twin and model, beside the diagnosis.
    let run = closed_loop_and_diagnosis(opts, &twin, &props, &upright, &design, &camp, &ident)?;
    let (exp, diag) = (run.exp, run.diag);
    let comparison = closed_loop_comparison(&dir, &ident, &props, &exp, &run.twin_run, &say)?;

    // 5. Diagnosis.
    let final_model = write_diagnosis(&dir, &camp, &diag)?;
    let diagnosis = summarise_diagnosis(&diag, final_model);
    say(&format!(
        "diagnosis: {} (error {:.2}x the noise floor -> {:.2}x)",
        diagnosis.verdict,
        diag.baseline_error / diag.noise_floor,
        diag.final_error / diag.noise_floor
    ));
    let parameters = parameter_rows(&predictions, &ident, &diag);
    // The stance resonance swept on the model file, against the mode the diagnosis named.
    let pb = bar(opts.quiet, 1, "stance");
    let stance = super::stance::stance(
        &twin,
        &props,
        upright.servo.b[1][1],
        &diagnosis,
        (!diag.selected.is_empty()).then_some(&diag.final_model),
        opts.threads,
    )?;
    pb.finish_and_clear();
    for s in &stance {
        say(&format!("stance {}: {} ({})", s.axis, s.verdict, s.why));
    }

    // 6. Frames.
    let (frames, frames_note) = make_frames(opts, &dir, &run.states);

    // 7. Report.
    let summary = Summary {
        format: FORMAT,
        model_file: opts.model.display().to_string(),
        short: opts.short,
        extended: opts.extended,
        output: opts.out.clone(),
        mass: props,
        predictions,
        eq10: checks.eq10,
        dynamic: checks.dynamic,
        budget: checks.budget,
        campaign,
        parameters,
        reduced_chi2: ident.reduced_chi2,
        excluded_records: ident
            .records
            .iter()
            .filter_map(|r| r.excluded.clone().map(|w| (r.index, w)))
            .collect(),
        identify_warnings: ident.warnings.clone(),
        closed_loop: ClosedLoopSummary {
            experiment: (&exp).into(),
            comparison,
            wall_s: run.loop_wall,
        },
        diagnosis,
        stance,
        frames,
        frames_note,
        wall_s: started.elapsed().as_secs_f64(),
    };
    report::write_html(&dir.join("report.html"), &summary, &ident, &upright)?;
    zmp_files::write_file(
        &dir.join("summary.json"),
        zmp_files::Kind::Json,
        serde_json::to_string_pretty(&summary)?.as_bytes(),
        false,
    )?;
    Ok(summary)
}

/// The campaign the options ask for (short, extended or full), with their ZMP delay.
fn design_of(opts: &ValidateOptions) -> TwinDesign {
    let mut design = if opts.short {
        TwinDesign::short()
    } else if opts.extended {
        TwinDesign::extended()
    } else {
        TwinDesign::full()
    };
    design.sensor.delay = opts.zmp_delay;
    design
}

/// What the twin's mass properties predict at the design's operating points and upright
/// (said in one line).
fn predictions(
    twin: &Silo2,
    props: &MassProperties,
    design: &TwinDesign,
    say: &dyn Fn(&str),
) -> Result<(Vec<OperatingPoint>, OperatingPoint)> {
    let predictions = design
        .operating_points
        .iter()
        .map(|&op| predict(twin, props, op))
        .collect::<Result<Vec<_>, _>>()?;
    let upright = predict(twin, props, [props.com_upright[0], props.com_upright[1]])?;
    say(&format!(
        "SILO2 twin: {:.2} kg, trunk {:.2} kg ({:.1} %), l_t = {:.3} m; predicted a11 = {:.4}, \
         b11 = {:.4} s2 (seed eq. 15: b = {:.4} s2)",
        props.total_mass,
        props.trunk_mass,
        100.0 * props.trunk_mass_ratio,
        props.trunk_lever,
        upright.servo.a[0][0],
        upright.servo.b[0][0],
        upright.seed.b[0][0]
    ));
    Ok((predictions, upright))
}

/// The checks of the ZMP measurement (step 2).
struct ZmpChecks {
    /// Eq. 10 at the full design's operating points.
    eq10: Vec<StaticCheck>,
    /// The dynamic cross-check per axis.
    dynamic: Vec<DynamicCheck>,
    /// The contact-softness budget.
    budget: Vec<BudgetRow>,
}

/// The ZMP measurement: eq. 10 at the operating points (3 even in the short run), a dynamic
/// cross-check per axis, the contact-softness budget.
fn zmp_checks(
    opts: &ValidateOptions,
    twin: &Silo2,
    props: &MassProperties,
    say: &dyn Fn(&str),
) -> Result<ZmpChecks> {
    let eq10_points: Vec<[f64; 2]> = TwinDesign::full().operating_points;
    let pb = bar(opts.quiet, eq10_points.len() as u64 + 2, "ZMP checks");
    let eq10 = zmp_campaign::par::try_parallel_map(eq10_points.len(), opts.threads, |k| {
        let r = static_check(twin, props, eq10_points[k], 2.5, 0.5);
        pb.inc(1);
        r
    })?;
    let dynamic = zmp_campaign::par::try_parallel_map(2, opts.threads, |k| {
        let axis = if k == 0 { Axis::X } else { Axis::Y };
        let r = dynamic_check(twin, props, axis, 6.0, 0.0035, 3);
        pb.inc(1);
        r
    })?;
    pb.finish_and_clear();
    let (timeconsts, probes): (Vec<f64>, Vec<(Axis, f64)>) = if opts.short {
        (
            vec![0.002, 0.005, 0.01],
            vec![(Axis::X, 6.0), (Axis::Y, 6.0)],
        )
    } else {
        (
            vec![0.002, 0.005, 0.01, 0.02],
            vec![
                (Axis::X, 3.0),
                (Axis::X, 10.0),
                (Axis::Y, 3.0),
                (Axis::Y, 10.0),
            ],
        )
    };
    let pb = bar(opts.quiet, 1, "softness");
    let budget_rows = budget(
        twin,
        props,
        &timeconsts,
        TwinDesign::full().operating_points[1],
        &probes,
        0.0015,
        opts.threads,
    )?;
    pb.finish_and_clear();
    let worst_static = eq10
        .iter()
        .map(|s| s.max_cells_minus_cop)
        .fold(0.0, f64::max);
    say(&format!(
        "ZMP: load cells within {:.3} mm of MuJoCo's centre of pressure at rest (3 operating points)",
        worst_static * 1e3
    ));
    Ok(ZmpChecks {
        eq10,
        dynamic,
        budget: budget_rows,
    })
}

/// The stepped-sine campaign on the twin, written to `dir/campaign`, and its identification
/// (`identified.toml`, `identify/`).
fn campaign_and_identification(
    opts: &ValidateOptions,
    dir: &Path,
    twin: &Silo2,
    props: &MassProperties,
    design: &TwinDesign,
    say: &dyn Fn(&str),
) -> Result<(Campaign, CampaignSummary, Identification)> {
    let t_camp = Instant::now();
    let metas = design.records().len();
    let pb = bar(opts.quiet, metas as u64, "campaign");
    let camp = run_campaign(twin, props, design, opts.threads, &|d| {
        pb.set_position(d as u64)
    })?;
    pb.finish_and_clear();
    let campaign_wall = t_camp.elapsed().as_secs_f64();
    let camp_dir = dir.join("campaign");
    write_campaign(&camp_dir, &camp, false)?;
    let rows: usize = camp.records.iter().map(|r| r.len()).sum();
    say(&format!(
        "campaign: {} records, {rows} rows, {:.0} s simulated in {campaign_wall:.1} s",
        camp.records.len(),
        design.simulated_seconds()
    ));
    let shown_campaign = opts.out.join("campaign");
    let iopts = IdentifyOptions {
        campaign_path: Some(shown_campaign.clone()),
        threads: Some(opts.threads),
        ..IdentifyOptions::default()
    };
    let pb = bar(opts.quiet, camp.records.len() as u64, "identify");
    let ident = identify_with_progress(&camp, &iopts, &|d| pb.set_position(d as u64))?;
    pb.finish_and_clear();
    zmp_identify::write_model(&ident, &dir.join("identified.toml"), false)?;
    zmp_report::identify::write_report(&ident, &dir.join("identify"), false)?;
    let campaign = CampaignSummary {
        records: camp.records.len(),
        rows,
        simulated_s: design.simulated_seconds(),
        wall_s: campaign_wall,
        sensor: design.sensor.describe(),
    };
    Ok((camp, campaign, ident))
}

/// The closed loop on the twin and the diagnosis, run side by side (they are independent).
struct LoopAndDiagnosis {
    /// The disturbance experiment.
    exp: StepExperiment,
    /// The twin's run of it.
    twin_run: TwinRun,
    /// Wall time of the twin's run, s.
    loop_wall: f64,
    /// The diagnosis of the identified model on the campaign.
    diag: Diagnosis,
    /// The robot's posture at the frame times.
    states: Vec<FrameState>,
}

/// Step 4: the twin's closed-loop run (its frames' states captured) beside the diagnosis.
fn closed_loop_and_diagnosis(
    opts: &ValidateOptions,
    twin: &Silo2,
    props: &MassProperties,
    upright: &OperatingPoint,
    design: &TwinDesign,
    camp: &Campaign,
    ident: &Identification,
) -> Result<LoopAndDiagnosis> {
    let shown_campaign = opts.out.join("campaign");
    let exp = experiment(twin, props, upright)?;
    let dopts = DiagnoseOptions {
        campaign_path: shown_campaign.display().to_string(),
        model_path: opts.out.join("identified.toml").display().to_string(),
        threads: opts.threads.saturating_sub(1).max(1),
        ..DiagnoseOptions::default()
    };
    let pb = bar(opts.quiet, 2, "loop+diag");
    let mut states: Vec<FrameState> = Vec::new();
    let (twin_run, diag) = std::thread::scope(|s| {
        let h = s.spawn(|| {
            let t0 = Instant::now();
            let r = run_twin(
                twin,
                props,
                &exp,
                design.sensor,
                &FRAME_TIMES,
                &mut |t, d| {
                    states.push(FrameState {
                        t,
                        qpos: d.qpos().to_vec(),
                        loaded: t >= exp.load_time,
                    });
                    Ok(())
                },
            );
            pb.inc(1);
            r.map(|r| (r, t0.elapsed().as_secs_f64()))
        });
        let diag = diagnose(camp, &ident.model, &dopts, &|_| {});
        pb.inc(1);
        let twin_run = h.join().unwrap_or_else(|p| std::panic::resume_unwind(p));
        (twin_run, diag)
    });
    pb.finish_and_clear();
    let (twin_run, loop_wall): (TwinRun, f64) = twin_run?;
    let diag = diag?;
    Ok(LoopAndDiagnosis {
        exp,
        twin_run,
        loop_wall,
        diag,
        states,
    })
}

/// The identified model's run of the experiment against the twin's, drawn into
/// `closed_loop.svg` and said in one line.
fn closed_loop_comparison(
    dir: &Path,
    ident: &Identification,
    props: &MassProperties,
    exp: &StepExperiment,
    twin_run: &TwinRun,
    say: &dyn Fn(&str),
) -> Result<LoopComparison> {
    let model_trace = run_model(&ident.model, props, exp)?;
    let comparison = compare(twin_run, &model_trace, exp);
    report::closed_loop_svg(&dir.join("closed_loop.svg"), twin_run, &model_trace, exp)?;
    say(&format!(
        "closed loop: twin reaches the new reference at {:.1} s (model {:.1} s), 4 kg load: \
         peak error {:.1} mm, final error {:.2} mm; twin against model NRMSE {:.4} (noise floor {:.4})",
        comparison.twin.reach_time_s,
        comparison.model.reach_time_s,
        comparison.twin.load_peak_error_m * 1e3,
        comparison.twin.final_error_m * 1e3,
        comparison.nrmse_x,
        comparison.noise_floor_x
    ));
    Ok(comparison)
}

/// The diagnosis report (`diagnosis/`) and, when effects were found, the model with them
/// (`identified+<effects>.toml`, its name returned).
fn write_diagnosis(dir: &Path, camp: &Campaign, diag: &Diagnosis) -> Result<Option<PathBuf>> {
    zmp_report::diagnose::write_diagnosis_report(camp, diag, &dir.join("diagnosis"), false)?;
    let final_model = if diag.selected.is_empty() {
        None
    } else {
        let names: Vec<&str> = diag.selected.iter().map(|(c, _)| c.name()).collect();
        let file = PathBuf::from(format!("identified+{}.toml", names.join("+")));
        zmp_files::write_file(
            &dir.join(&file),
            zmp_files::Kind::Model,
            diag.final_model.to_toml().as_bytes(),
            false,
        )?;
        Some(file)
    };
    Ok(final_model)
}

/// Renders the frames in a child process; returns the files (relative) or why there are none.
fn make_frames(
    opts: &ValidateOptions,
    dir: &Path,
    states: &[FrameState],
) -> (Vec<PathBuf>, Option<String>) {
    let exe = match &opts.frames {
        Frames::Skip(why) => return (Vec::new(), Some(why.clone())),
        Frames::Render { exe } => exe,
    };
    let run = || -> Result<Vec<PathBuf>> {
        let states_file = dir.join("frames").join("states.json");
        zmp_files::write_file(
            &states_file,
            zmp_files::Kind::Json,
            serde_json::to_string(states)?.as_bytes(),
            false,
        )?;
        let out = std::process::Command::new(exe)
            .args(["silo2", "render-frames", "--model"])
            .arg(&opts.model)
            .arg("--states")
            .arg(&states_file)
            .arg("--out")
            .arg(dir.join("frames"))
            .stdin(std::process::Stdio::null())
            .output()
            .with_context(|| format!("starting {}", exe.display()))?;
        if !out.status.success() {
            let err = String::from_utf8_lossy(&out.stderr);
            let last = err
                .lines()
                .rev()
                .find(|l| !l.trim().is_empty())
                .unwrap_or("");
            bail!("the renderer exited with {}: {last}", out.status);
        }
        let files: Vec<PathBuf> =
            serde_json::from_slice(&out.stdout).context("reading the renderer's list of frames")?;
        Ok(files
            .into_iter()
            .map(|f| Path::new("frames").join(f.file_name().unwrap_or_default()))
            .collect())
    };
    match run() {
        Ok(f) => (f, None),
        Err(e) => (Vec::new(), Some(format!("frames not rendered: {e:#}"))),
    }
}
