//! The comparison and diagnosis reports: a self-contained HTML page (figures inline) plus the
//! figures as SVG files.
//!
//! Figures: Bode overlays of the measured points and the model(s), the error against
//! frequency per channel and amplitude, the error by amplitude and by operating point, the
//! steady-state time overlay and the residual spectrum of the worst record, the third
//! harmonic against frequency, and (diagnosis) the error waterfall.

use crate::plot::{bars_svg, bode_svg, time_svg};
use anyhow::{Context, Result};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use zmp_campaign::Campaign;
use zmp_diagnose::cells::Cell;
use zmp_diagnose::measure::{aggregate, score, Prediction};
use zmp_diagnose::observe::Observation;
use zmp_diagnose::run::Diagnosis;
use zmp_diagnose::Verdict;

mod decide;
mod panels;
use panels::{bode_panels, error_panels, group_bars, harmonic_panel, record_panels, worst};

fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

/// What a comparison report shows: the campaign's observations against one or more models.
pub struct Overlay<'a> {
    pub label: &'a str,
    pub predictions: &'a [Prediction],
}

/// Writes the comparison figures of the last model of `models` into `dir` (time overlays of
/// `records`, campaign record numbers, or of the worst record); returns the HTML body.
fn comparison_section(
    campaign: &Campaign,
    obs: &[&Observation],
    models: &[Overlay],
    dir: &Path,
    force: bool,
    prefix: &str,
    records: &[usize],
) -> Result<(String, Vec<PathBuf>)> {
    let preds = models.last().expect("one model at least").predictions;
    let mut files = Vec::new();
    let mut h = String::new();
    let bode = dir.join(format!("{prefix}bode.svg"));
    bode_svg(&bode, &bode_panels(obs, models), 2, force)?;
    files.push(bode.clone());
    h.push_str("<h2>Frequency responses: measured points and model</h2>\n");
    let _ = writeln!(h, "<div>{}</div>", std::fs::read_to_string(&bode)?);

    let err = dir.join(format!("{prefix}error_vs_frequency.svg"));
    time_svg(&err, &error_panels(obs, preds), force)?;
    files.push(err.clone());
    h.push_str(
        "<h2>Error against frequency (per channel, RMS over operating points; 1 = noise \
         floor)</h2>\n",
    );
    let _ = writeln!(h, "<div>{}</div>", std::fs::read_to_string(&err)?);

    let amp = dir.join(format!("{prefix}error_by_amplitude.svg"));
    bars_svg(
        &amp,
        "Error / noise floor by amplitude",
        "error / floor",
        &group_bars(obs, preds, &|o| {
            format!("{:.1} mm", o.nominal_amplitude * 1e3)
        }),
        Some((1.0, "noise floor")),
        force,
    )?;
    let op = dir.join(format!("{prefix}error_by_operating_point.svg"));
    bars_svg(
        &op,
        "Error / noise floor by operating point",
        "error / floor",
        &group_bars(obs, preds, &|o| {
            format!("({:.3}, {:.3})", o.operating_point[0], o.operating_point[1])
        }),
        Some((1.0, "noise floor")),
        force,
    )?;
    files.push(amp.clone());
    files.push(op.clone());
    h.push_str("<h2>Error by amplitude and by operating point</h2>\n");
    let _ = writeln!(
        h,
        "<div>{}</div><div>{}</div>",
        std::fs::read_to_string(&amp)?,
        std::fs::read_to_string(&op)?
    );

    // The records asked for (by campaign record number), else the worst.
    let chosen: Vec<(usize, &str)> = if records.is_empty() {
        worst(obs, preds)
            .map(|k| (k, "Worst record"))
            .into_iter()
            .collect()
    } else {
        records
            .iter()
            .filter_map(|r| obs.iter().position(|o| o.index == *r))
            .map(|k| (k, "Record"))
            .collect()
    };
    for (k, what) in chosen {
        let Some((index, panels, spec)) = record_panels(campaign, obs, preds, k) else {
            continue;
        };
        let t = dir.join(format!("{prefix}record_{index}_time.svg"));
        time_svg(&t, &panels, force)?;
        let s = dir.join(format!("{prefix}record_{index}_residual_spectrum.svg"));
        time_svg(&s, std::slice::from_ref(&spec), force)?;
        files.push(t.clone());
        files.push(s.clone());
        let _ = writeln!(
            h,
            "<h2>{what} {index}: steady-state time overlay and residual spectrum</h2>\n\
             <p>The model's steady state is its first harmonic and trend on the measured mean; \
             what remains (residual) is noise, harmonics the model does not produce, or a \
             misfit of the fundamental.</p>\n<div>{}</div><div>{}</div>",
            std::fs::read_to_string(&t)?,
            std::fs::read_to_string(&s)?
        );
    }
    let hp = dir.join(format!("{prefix}harmonics.svg"));
    time_svg(&hp, &[harmonic_panel(obs)], force)?;
    files.push(hp.clone());
    h.push_str("<h2>Harmonics</h2>\n");
    let _ = writeln!(h, "<div>{}</div>", std::fs::read_to_string(&hp)?);
    Ok((h, files))
}

fn cells_table(cells: &[Cell], max: usize) -> String {
    let bad: Vec<&Cell> = cells.iter().filter(|c| c.significant).take(max).collect();
    if bad.is_empty() {
        return "<p>No cell is significantly above its noise floor.</p>\n".into();
    }
    let mut h = String::from(
        "<table><tr><th>channel</th><th>band (rad/s)</th><th>amplitude (mm)</th>\
         <th>operating point (m)</th><th>records</th><th>error</th><th>noise floor</th>\
         <th>error / floor</th></tr>\n",
    );
    for c in bad {
        let _ = writeln!(
            h,
            "<tr><td class=\"l\">{}</td><td>{:.2}-{:.2} ({})</td><td>{:.1}</td>\
             <td>({:.3}, {:.3})</td><td>{}</td><td>{:.4}</td><td>{:.4}</td><td>{:.1}</td></tr>",
            c.channel,
            c.band_rad_s[0],
            c.band_rad_s[1],
            c.band,
            c.amplitude_m * 1e3,
            c.operating_point_m[0],
            c.operating_point_m[1],
            c.records,
            c.error,
            c.noise_floor,
            c.ratio
        );
    }
    h.push_str("</table>\n");
    h
}

const STYLE: &str = "<style>body{font-family:sans-serif;max-width:1100px;margin:2em auto;}\
table{border-collapse:collapse;margin:1em 0;}td,th{border:1px solid #ccc;padding:3px 8px;\
text-align:right;}th{background:#eee;}td.l{text-align:left;}.v{font-size:1.3em;}\
.ok{color:#070;}.bad{color:#a40;}</style>";

const MEASURE: &str = "<p><b>Error measure</b> (the same everywhere): per record, the RMS over \
its steady state of the difference between the measured and the modelled response (first \
harmonic and linear trend of both ZMP outputs), divided by the RMS of the measured first \
harmonic; the campaign figure is the RMS over records. The <b>noise floor</b> is the same \
measure for the estimation noise of the measured components alone (from the residual of each \
record's harmonic fit): what a perfect model would score.</p>";

/// Comparison report of `campaign` against one model; returns the HTML file.
#[allow(clippy::too_many_arguments)] // the report's inputs, all distinct
pub fn write_compare_report(
    campaign: &Campaign,
    campaign_name: &str,
    model_name: &str,
    obs: &[&Observation],
    preds: &[Prediction],
    cells: &[Cell],
    records: &[usize],
    dir: &Path,
    force: bool,
) -> Result<PathBuf> {
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let scores: Vec<_> = obs.iter().zip(preds).map(|(o, p)| score(o, p)).collect();
    let (e, f) = aggregate(&scores);
    let mut h = String::new();
    let title = format!("Model against measurements: {model_name} on {campaign_name}");
    let _ = writeln!(
        h,
        "<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>{0}</title>{STYLE}</head>\
         <body>\n<h1>{0}</h1>\n<p class=\"v\">Error {e:.4}, noise floor {f:.4}: \
         <span class=\"{1}\">{2:.1}x the floor</span> over {3} records.</p>\n{MEASURE}",
        esc(&title),
        if e <= 1.5 * f { "ok" } else { "bad" },
        e / f,
        obs.len()
    );
    h.push_str("<h2>Where it fails</h2>\n<p>Cells (channel, frequency band, amplitude, operating point) whose error is significantly above their noise floor, worst first.</p>\n");
    h.push_str(&cells_table(cells, 20));
    let (body, _) = comparison_section(
        campaign,
        obs,
        &[Overlay {
            label: "model",
            predictions: preds,
        }],
        dir,
        force,
        "",
        records,
    )?;
    h.push_str(&body);
    h.push_str("<p>Next: <code>cargo xtask diagnose</code> names the physical effect that is missing.</p></body></html>\n");
    let html = dir.join("compare.html");
    zmp_files::atomic_write(&html, h.as_bytes(), force)?;
    Ok(html)
}

/// Diagnosis report; `waterfall` is the error of each model version (label, error) if known.
pub fn write_diagnosis_report(
    campaign: &Campaign,
    d: &Diagnosis,
    dir: &Path,
    force: bool,
) -> Result<PathBuf> {
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let obs: Vec<&Observation> = d.observations.iter().collect();
    let f = d.noise_floor;
    let mut h = String::new();
    let title = format!("Diagnosis: {} on {}", d.model, d.campaign);
    let verdict = match &d.verdict {
        Verdict::None => "none: the model explains the measurements to the noise floor".to_string(),
        Verdict::Unexplained => {
            "unexplained: a significant error remains that no structure of the catalogue removes"
                .to_string()
        }
        Verdict::Refit => {
            "the structure is right but the parameters are off: identify again".to_string()
        }
        Verdict::Ambiguous(set) => format!(
            "ambiguous: the records do not decide between {}",
            set.iter()
                .map(|s| format!("<b>{}</b>", esc(&s.label())))
                .collect::<Vec<_>>()
                .join(", ")
        ),
        Verdict::Effect(c) => format!("the model is missing <b>{}</b>", esc(&c.label())),
    };
    let _ = writeln!(
        h,
        "<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>{0}</title>{STYLE}</head>\
         <body>\n<h1>{0}</h1>\n<p class=\"v\">Verdict: {verdict}.</p>\n\
         <p>The model as given scores {1:.4} ({2:.1}x the noise floor {f:.4}) on {3} records; \
         every structure of the catalogue's effects (up to four, each under its law) was fitted \
         with every parameter and scored on records it was not fitted on (two folds by alternate \
         frequencies); an effect counts when the structure with it predicts those records \
         significantly better than without it (a paired test over the records at 1 %, shared \
         over the {4} structures compared: z &gt; {5:.2}).</p>\n{MEASURE}",
        esc(&title),
        d.baseline_error,
        d.baseline_error / f,
        d.records,
        d.compared,
        d.z_crit
    );
    h.push_str("<h2>Findings</h2>\n<table><tr><th>#</th><th>effect</th><th>channels</th><th>parameters</th><th>error before</th><th>error after (held-out)</th><th class=\"l\">evidence</th></tr>\n");
    for (k, fd) in d.findings.iter().enumerate() {
        let params: Vec<String> = fd
            .parameters
            .iter()
            .map(|(n, v)| format!("{n} = {}", zmp_diagnose::words::sig(*v)))
            .collect();
        let _ = writeln!(
            h,
            "<tr><td>{}</td><td class=\"l\">{}{}</td><td class=\"l\">{}</td><td class=\"l\">{}</td>\
             <td>{:.4}</td><td>{:.4}</td><td class=\"l\">{}</td></tr>",
            k + 1,
            esc(&fd.effect.to_string()),
            if fd.significant { "" } else { " (not significant)" },
            fd.channels.join(", "),
            esc(&params.join("<br>")),
            fd.error_before,
            fd.error_after,
            esc(&fd.evidence)
        );
    }
    h.push_str("</table>\n");
    h.push_str(&decide::section(d));
    let _ = writeln!(
        h,
        "<p>Every single effect fitted (held-out error / noise floor): {}.</p>",
        d.tried
            .iter()
            .map(|t| format!("{} {:.2}", esc(&t.structure), t.held_out_error / f))
            .collect::<Vec<_>>()
            .join(", ")
    );
    // Waterfall.
    let mut bars = vec![("model as given".to_string(), d.baseline_error)];
    if d.refit_error.is_finite() {
        bars.push(("refitted".into(), d.refit_error));
    }
    for (c, x) in &d.selected {
        bars.push((format!("+ {c}"), *x));
    }
    let wf = dir.join("waterfall.svg");
    bars_svg(
        &wf,
        "Error as effects are added (held-out)",
        "error",
        &bars,
        Some((f, "noise floor")),
        force,
    )?;
    h.push_str("<h2>Error waterfall</h2>\n");
    let _ = writeln!(h, "<div>{}</div>", std::fs::read_to_string(&wf)?);
    if !d.selected.is_empty() {
        h.push_str("<h2>Before and after</h2>\n<p>Dashed: the model as given; solid: with the effects found (fitted on every record).</p>\n");
    }
    let overlays: Vec<Overlay> = if d.selected.is_empty() {
        vec![Overlay {
            label: "model",
            predictions: &d.base_predictions,
        }]
    } else {
        vec![
            Overlay {
                label: "model as given",
                predictions: &d.base_predictions,
            },
            Overlay {
                label: "with the effects found",
                predictions: &d.final_predictions,
            },
        ]
    };
    let (body, _) = comparison_section(campaign, &obs, &overlays, dir, force, "diagnosis_", &[])?;
    h.push_str("<h2>Where the model as given fails</h2>\n");
    h.push_str(&cells_table(&d.cells, 12));
    if !d.selected.is_empty() {
        h.push_str("<h2>Where it still fails with the effects found</h2>\n");
        h.push_str(&cells_table(
            &zmp_diagnose::cells::cells(&obs, &d.final_predictions),
            12,
        ));
    }
    h.push_str(&body);
    h.push_str("</body></html>\n");
    let html = dir.join("diagnosis.html");
    zmp_files::atomic_write(&html, h.as_bytes(), force)?;
    Ok(html)
}
