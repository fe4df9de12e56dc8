//! `cargo xtask demo`: the main job on built-in data.

use crate::simulate::{load_model, simulate};
use anyhow::{bail, Context, Result};
use serde::Serialize;
use std::path::{Path, PathBuf};
use zmp_files::atomic_write;
use zmp_models::closed_loop::{run, StepExperiment, StepMetrics};
use zmp_models::controller::{CascadeController, CascadeParams};
use zmp_models::effects::uncertainty::weight;
use zmp_models::logspace;
use zmp_models::EffectKind;
use zmp_models::{Binding, Channel, Complex64, ModelSpec, Plant};
use zmp_report::plot::{
    bode_svg, time_svg, Band, BodePanel, BodeSeries, Style, TimePanel, TimeSeries, PALETTE,
};
use zmp_virtual_robot::ExperimentDesign;

const MARKER: &str = ".zmp-demo-output";

#[derive(Serialize)]
struct Summary {
    output: PathBuf,
    campaign: PathBuf,
    records: usize,
    rows: usize,
    bode: PathBuf,
    closed_loop: PathBuf,
    closed_loop_x: Metrics,
    diagnosis_loop: crate::loop_cmd::DemoLoop,
}

#[derive(Serialize)]
struct Metrics {
    reach_time_s: f64,
    settling_time_2pct_s: f64,
    overshoot_pct: f64,
    load_peak_error_m: f64,
    load_recovery_time_s: f64,
}

impl From<StepMetrics> for Metrics {
    fn from(m: StepMetrics) -> Metrics {
        Metrics {
            reach_time_s: m.reach_time,
            settling_time_2pct_s: m.settling_time_2pct,
            overshoot_pct: 100.0 * m.overshoot,
            load_peak_error_m: m.load_peak_error,
            load_recovery_time_s: m.load_recovery_time,
        }
    }
}

/// Why the demo may not write into `out`, if it may not: a folder that is neither missing,
/// empty, nor an earlier demo output (it holds the marker file) may be the user's, and is
/// refused whatever `--force` says.
fn refusal(out: &Path) -> Result<Option<String>> {
    let m = match std::fs::symlink_metadata(out) {
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(e) => return Err(e).with_context(|| format!("inspecting {}", out.display())),
        Ok(m) => m,
    };
    if m.file_type().is_symlink() {
        return Ok(Some(format!(
            "{} is a symbolic link; pass its target as --out if it is a demo output folder",
            out.display()
        )));
    }
    if !m.is_dir() {
        return Ok(Some(format!(
            "{} exists and is not a folder",
            out.display()
        )));
    }
    let ours = out.join(MARKER).is_file();
    let empty = out
        .read_dir()
        .with_context(|| format!("reading {}", out.display()))?
        .next()
        .is_none();
    Ok((!(ours || empty)).then(|| {
        format!(
            "{} exists and is not a demo output folder (it has no {MARKER} marker); the demo \
             replaces only its own earlier output, even with --force: choose another --out",
            out.display()
        )
    }))
}

/// Prepares the demo's output folder: created if missing, replaced if it is empty or holds an
/// earlier demo's output, refused otherwise (see [`refusal`]).
pub fn prepare_out(out: &Path) -> Result<()> {
    if let Some(why) = refusal(out)? {
        bail!(why);
    }
    if out.exists() {
        std::fs::remove_dir_all(out).with_context(|| format!("removing {}", out.display()))?;
    }
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    atomic_write(
        &out.join(MARKER),
        b"written by cargo xtask demo; replaced on the next run\n",
        true,
    )
}

pub fn bode_panels(spec: &ModelSpec, title_prefix: &str) -> Result<Vec<BodePanel>> {
    let plant = Plant::new(spec, zmp_models::DEFAULT_STEP)?;
    let w = logspace(0.01, 100.0, 400);
    let mut panels = Vec::new();
    for ch in Channel::ALL {
        let (i, j) = (ch.output.index(), ch.input.index());
        let g: Vec<Complex64> = w
            .iter()
            .map(|&wk| plant.frequency_response(wk)[i][j])
            .collect();
        let mut bands = Vec::new();
        if let Some(u) = spec.get(EffectKind::Uncertainty, Binding::Channel(ch)) {
            let wt = weight(u.values[0], u.values[1], u.values[2]);
            let (lo, hi): (Vec<f64>, Vec<f64>) = w
                .iter()
                .zip(&g)
                .map(|(&wk, gk)| {
                    let m = gk.norm();
                    let r = wt.freq(wk).norm();
                    (
                        20.0 * (m * (1.0 - r)).max(m * 1e-3).log10(),
                        20.0 * (m * (1.0 + r)).log10(),
                    )
                })
                .unzip();
            bands.push(Band {
                label: "|G|(1 +- |W|)".into(),
                omega: w.clone(),
                lower_db: lo,
                upper_db: hi,
                color: PALETTE[0],
            });
        }
        panels.push(BodePanel {
            title: format!(
                "{title_prefix}{}: zmp_{} from {}_cr",
                ch.name(),
                ch.output,
                ch.input
            ),
            series: vec![BodeSeries::line("nominal model", w.clone(), g, PALETTE[0])],
            bands,
            magnitude_only: false,
        });
    }
    Ok(panels)
}

pub fn closed_loop_plot(spec: &ModelSpec, path: &Path) -> Result<StepMetrics> {
    let mut plant = Plant::new(spec, zmp_models::DEFAULT_STEP)?;
    let exp = StepExperiment::silo2();
    let mut ctrl = CascadeController::new(CascadeParams::silo2(), exp.controller_period);
    let tr = run(&mut plant, &mut ctrl, &exp);
    // Every 5th controller sample (20 Hz) is plenty for a figure of a 160 s run.
    let idx: Vec<usize> = (0..tr.t.len()).step_by(5).collect();
    let col = |f: &dyn Fn(usize) -> f64| -> Vec<f64> { idx.iter().map(|&k| f(k)).collect() };
    let t = col(&|k| tr.t[k]);
    let panels = [
        TimePanel {
            title: "ZMP regulation (seed fig. 18): reference step 0.12 -> 0.17 m, 4 kg load at t = 80 s".into(),
            y_label: "zmp_x (m)".into(),
            series: vec![
                TimeSeries { label: "reference".into(), t: t.clone(), y: col(&|k| tr.zmp_ref[k][0]), color: PALETTE[5], style: Style::Dashed },
                TimeSeries { label: "measured ZMP".into(), t: t.clone(), y: col(&|k| tr.zmp[k][0]), color: PALETTE[0], style: Style::Line },
            ],
            markers: vec![(exp.load_time, "4 kg load".into())],
            x_label: None,
        },
        TimePanel {
            title: "ZMP error (seed fig. 19)".into(),
            y_label: "error (m)".into(),
            series: vec![TimeSeries { label: "zmp_ref - zmp".into(), t: t.clone(), y: col(&|k| tr.zmp_ref[k][0] - tr.zmp[k][0]), color: PALETTE[1], style: Style::Line }],
            markers: vec![],
            x_label: None,
        },
        TimePanel {
            title: "Trunk motion (seed fig. 20)".into(),
            y_label: "theta (rad)".into(),
            series: vec![TimeSeries { label: "trunk angle, lateral".into(), t: t.clone(), y: col(&|k| tr.theta[k][0]), color: PALETTE[2], style: Style::Line }],
            markers: vec![],
            x_label: None,
        },
    ];
    time_svg(path, &panels, true)?;
    Ok(tr.metrics(0, &exp))
}

/// `force` is accepted for scripts: an earlier demo output is always replaced, and no flag
/// replaces anything else.
pub fn demo(out: &Path, _force: bool, json: bool) -> Result<()> {
    // A refused folder is refused before the minute of setup.
    if let Some(why) = refusal(out)? {
        bail!(why);
    }
    crate::setup::setup(true)?;
    prepare_out(out)?;
    let root = crate::env::repo_root();
    let model_path = root.join("models/params/silo2-paper.toml");
    let spec = load_model(&model_path)?;
    let quiet = json;
    let say = |s: &str| {
        if !quiet {
            println!("{s}");
        }
    };

    say("1. Virtual SILO2 stepped-sine campaign (paper model, 3 operating points x 2 amplitudes x 14 frequencies x 2 channels)");
    let design = ExperimentDesign::reference();
    let camp_dir = out.join("campaign");
    let camp = simulate(&spec, &design, &camp_dir, true, quiet)?;
    let rows: usize = camp.records.iter().map(|r| r.len()).sum();
    say(&format!(
        "   {} records, {rows} rows -> {}",
        camp.records.len(),
        camp_dir.display()
    ));

    say("2. Bode diagrams of the four channels with the uncertainty band");
    let bode = out.join("bode_silo2_paper.svg");
    bode_svg(&bode, &bode_panels(&spec, "")?, 2, true)?;
    say(&format!("   -> {}", bode.display()));

    say("3. Cascade ZMP controller, seed section 6.6 (K1 = 0.014, K2 = 0.2)");
    let cl = out.join("closed_loop_step.svg");
    let m = closed_loop_plot(&spec, &cl)?;
    say(&format!(
        "   reaches 0.17 m at {:.1} s, settles (2 %) at {:.1} s, overshoot {:.1} %; 4 kg load: peak error {:.1} mm, recovered in {:.1} s",
        m.reach_time,
        m.settling_time_2pct,
        100.0 * m.overshoot,
        1000.0 * m.load_peak_error,
        m.load_recovery_time
    ));
    say(&format!("   -> {}", cl.display()));

    say("4. Identification of the virtual campaign (seed section 5)");
    let (id, files) = crate::identify::demo_step(&camp, &camp_dir, out, quiet)?;
    say(&format!(
        "   {} of {} records used, reduced chi-square {:.2} -> {}, report {}",
        id.used().count(),
        id.records.len(),
        id.reduced_chi2,
        out.join("identified.toml").display(),
        files.html.display()
    ));
    for p in id.parameters() {
        say(&format!(
            "   {:<28} {:>11.6} +- {:.2e}",
            p.name, p.value, p.stderr
        ));
    }

    say("5. The promise: compare, diagnose the missing effect, add it, watch the error fall");
    let lp = crate::loop_cmd::demo_loop(&out.join("loop"), quiet)?;
    crate::twin::demo_step(out, quiet)?;
    crate::demo_com::demo_step(out, quiet)?;

    if json {
        let s = Summary {
            output: out.to_path_buf(),
            campaign: camp_dir,
            records: camp.records.len(),
            rows,
            bode,
            closed_loop: cl,
            closed_loop_x: m.into(),
            diagnosis_loop: lp,
        };
        println!("{}", serde_json::to_string_pretty(&s)?);
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `demo --out DIR --force` on a folder without the marker: refused, folder intact; an
    /// earlier demo output (marker) is replaced.
    #[test]
    fn only_demo_output_is_replaced() {
        let d = tempfile::tempdir().unwrap();
        let users = d.path().join("results");
        std::fs::create_dir(&users).unwrap();
        std::fs::write(users.join("data.csv"), "1,2,3\n").unwrap();
        for force in [false, true] {
            let e = demo(&users, force, true).unwrap_err();
            assert!(
                e.to_string().contains("not a demo output folder"),
                "force {force}: {e}"
            );
        }
        assert_eq!(
            std::fs::read_to_string(users.join("data.csv")).unwrap(),
            "1,2,3\n"
        );
        assert_eq!(std::fs::read_dir(&users).unwrap().count(), 1);

        let earlier = d.path().join("demo");
        prepare_out(&earlier).unwrap();
        std::fs::write(earlier.join("old.svg"), "<svg/>").unwrap();
        prepare_out(&earlier).unwrap();
        assert!(earlier.join(MARKER).is_file());
        assert!(!earlier.join("old.svg").exists(), "earlier output replaced");
        let file = d.path().join("file");
        std::fs::write(&file, "x").unwrap();
        assert!(prepare_out(&file).is_err());
        assert_eq!(std::fs::read_to_string(&file).unwrap(), "x");
    }
}
