//! The comparison and diagnosis reports: a self-contained HTML page (figures inline) plus the
//! figures as SVG files.
//!
//! Figures: Bode overlays of the measured points and the model(s), the error against
//! frequency per channel and amplitude, the error by amplitude and by operating point, the
//! steady-state time overlay and the residual spectrum of the worst record, the third
//! harmonic against frequency, and (diagnosis) the error waterfall.

use crate::html::{esc, STYLE};
use crate::plot::{bars_svg, bode_svg, frequency_svg, time_svg};
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

/// What a comparison report shows: the campaign's observations against one or more models.
pub struct Overlay<'a> {
    /// The model's name in legends and tables.
    pub label: &'a str,
    /// The model's prediction of every record of the campaign, in the campaign's order.
    pub predictions: &'a [Prediction],
}

/// Where a report's figures go: its folder, whether existing files are replaced, and the
/// prefix of their names.
struct Out<'a> {
    dir: &'a Path,
    force: bool,
    prefix: &'a str,
}

impl Out<'_> {
    fn path(&self, name: &str) -> PathBuf {
        self.dir.join(format!("{}{name}", self.prefix))
    }
}

/// The figure at `path`, inline.
fn inline(path: &Path) -> Result<String> {
    let svg =
        std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    Ok(format!("<div>{svg}</div>\n"))
}

/// The Bode overlay of the measured points and `models` under the heading `title`, with the
/// sentence `note` when it is not empty; returns the HTML.
fn bode_section(
    obs: &[&Observation],
    models: &[Overlay],
    out: &Out,
    title: &str,
    note: &str,
) -> Result<String> {
    let bode = out.path("bode.svg");
    bode_svg(&bode, &bode_panels(obs, models), 2, out.force)?;
    let mut h = format!("<h2>{}</h2>\n", esc(title));
    if !note.is_empty() {
        let _ = writeln!(h, "<p>{}</p>", esc(note));
    }
    h.push_str(&inline(&bode)?);
    Ok(h)
}

/// The figures of one model's `preds` (`model`, named in the headings when not empty): error
/// against frequency, by amplitude and operating point, time overlays of `records` (campaign
/// record numbers, else the worst record) and the harmonics; returns the HTML.
fn model_figures(
    campaign: &Campaign,
    obs: &[&Observation],
    preds: &[Prediction],
    model: &str,
    records: &[usize],
    out: &Out,
) -> Result<String> {
    let of = if model.is_empty() {
        String::new()
    } else {
        format!(", {}", esc(model))
    };
    let mut h = String::new();
    let err = out.path("error_vs_frequency.svg");
    frequency_svg(&err, &error_panels(obs, preds), out.force)?;
    let _ = writeln!(
        h,
        "<h2>Error against frequency{of}</h2>\n<p>Per channel, the RMS over operating points of \
         error / noise floor; 1 is the noise floor.</p>"
    );
    h.push_str(&inline(&err)?);

    let amp = out.path("error_by_amplitude.svg");
    bars_svg(
        &amp,
        "Error / noise floor by amplitude",
        "error / floor",
        &group_bars(obs, preds, &|o| {
            format!("{:.1} mm", o.nominal_amplitude * 1e3)
        }),
        Some((1.0, "noise floor")),
        out.force,
    )?;
    let op = out.path("error_by_operating_point.svg");
    bars_svg(
        &op,
        "Error / noise floor by operating point",
        "error / floor",
        &group_bars(obs, preds, &|o| {
            format!(
                "({:.3}, {:.3}) m",
                o.operating_point[0], o.operating_point[1]
            )
        }),
        Some((1.0, "noise floor")),
        out.force,
    )?;
    let _ = writeln!(h, "<h2>Error by amplitude and by operating point{of}</h2>");
    // Side by side where the page is wide enough.
    let _ = writeln!(
        h,
        "<div class=\"row\">{}{}</div>",
        inline(&amp)?,
        inline(&op)?
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
        let t = out.path(&format!("record_{index}_time.svg"));
        time_svg(&t, &panels, out.force)?;
        let s = out.path(&format!("record_{index}_residual_spectrum.svg"));
        time_svg(&s, std::slice::from_ref(&spec), out.force)?;
        let _ = writeln!(
            h,
            "<h2>{what} {index}: steady-state time overlay and residual spectrum{of}</h2>\n\
             <p>The model's steady state is its first harmonic and trend on the measured mean; \
             what remains (residual) is noise, harmonics the model does not produce, or a \
             misfit of the fundamental.</p>"
        );
        h.push_str(&inline(&t)?);
        h.push_str(&inline(&s)?);
    }
    let hp = out.path("harmonics.svg");
    frequency_svg(&hp, &[harmonic_panel(obs)], out.force)?;
    h.push_str("<h2>Harmonics</h2>\n");
    h.push_str(&inline(&hp)?);
    Ok(h)
}

fn cells_table(cells: &[Cell], max: usize) -> String {
    let bad: Vec<&Cell> = cells.iter().filter(|c| c.significant).take(max).collect();
    if bad.is_empty() {
        return "<p>No cell is significantly above its noise floor.</p>\n".into();
    }
    let mut h = String::from(
        "<table><tr><th class=\"l\">channel</th><th>band (rad/s)</th><th>amplitude (mm)</th>\
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

/// The findings, one row each (parameters one per line), and the candidates tried.
fn findings_table(d: &Diagnosis) -> String {
    let f = d.noise_floor;
    let mut h = String::from("<h2>Findings</h2>\n");
    if d.findings.is_empty() {
        h.push_str("<p>No catalogued effect was fitted.</p>\n");
    } else {
        h.push_str(
            "<table><tr><th>#</th><th class=\"l\">effect</th><th class=\"l\">channels</th>\
             <th class=\"l\">parameters</th>\
             <th>error before</th><th>error after (held-out)</th><th class=\"l\">evidence</th>\
             </tr>\n",
        );
    }
    for (k, fd) in d.findings.iter().enumerate() {
        // Each parameter escaped, then one per line.
        let params: Vec<String> = fd
            .parameters
            .iter()
            .map(|(n, v)| esc(&format!("{n} = {}", zmp_diagnose::words::sig(*v))))
            .collect();
        let _ = writeln!(
            h,
            "<tr><td>{}</td><td class=\"l\">{}{}</td><td class=\"l\">{}</td>\
             <td class=\"l nw\">{}</td><td>{:.4}</td><td>{:.4}</td><td class=\"l\">{}</td></tr>",
            k + 1,
            esc(&fd.effect.to_string()),
            if fd.significant {
                ""
            } else {
                " (not significant)"
            },
            fd.channels.join(", "),
            params.join("<br>"),
            fd.error_before,
            fd.error_after,
            esc(&fd.evidence)
        );
    }
    if !d.findings.is_empty() {
        h.push_str("</table>\n");
    }
    if !d.tried.is_empty() {
        let _ = writeln!(
            h,
            "<p>Every single effect fitted (held-out error / noise floor): {}.</p>",
            d.tried
                .iter()
                .map(|t| esc(&format!("{} {:.2}", t.structure, t.held_out_error / f)))
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
    h
}

const MEASURE: &str = "<p><b>Error measure</b> (the same everywhere): per record, the RMS over \
its steady state of the difference between the measured and the modelled response (first \
harmonic and linear trend of both ZMP outputs), divided by the RMS of the measured first \
harmonic; the campaign figure is the RMS over records. The <b>noise floor</b> is the same \
measure for the estimation noise of the measured components alone (from how each component \
varies from period to period of the record's steady state): what a perfect model would \
score.</p>";

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
    zmp_files::claim_dir(dir, zmp_files::Kind::Report, true)?;
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
    let out = Out {
        dir,
        force,
        prefix: "",
    };
    let overlay = [Overlay {
        label: "model",
        predictions: preds,
    }];
    h.push_str(&bode_section(
        obs,
        &overlay,
        &out,
        "Frequency responses: measured points and model",
        "",
    )?);
    h.push_str(&model_figures(campaign, obs, preds, "", records, &out)?);
    h.push_str("<p>Next: <code>cargo xtask diagnose</code> names the physical effect that is missing.</p></body></html>\n");
    let html = dir.join("compare.html");
    zmp_files::write_file(&html, zmp_files::Kind::Html, h.as_bytes(), force)?;
    Ok(html)
}

/// Diagnosis report of `d` (made on `campaign`) into `dir`; returns the HTML file.
pub fn write_diagnosis_report(
    campaign: &Campaign,
    d: &Diagnosis,
    dir: &Path,
    force: bool,
) -> Result<PathBuf> {
    zmp_files::claim_dir(dir, zmp_files::Kind::Report, true)?;
    let obs: Vec<&Observation> = d.observations.iter().collect();
    let mut h = diagnosis_header(d);
    h.push_str(&findings_table(d));
    h.push_str(&decide::section(d));
    h.push_str(&waterfall_section(d, dir, force)?);
    let out = Out {
        dir,
        force,
        prefix: "diagnosis_",
    };
    h.push_str(&responses_section(d, &obs, &out)?);
    h.push_str("<h2>Where the model as given fails</h2>\n");
    h.push_str(&cells_table(&d.cells, 12));
    let (preds, model) = if d.selected.is_empty() {
        (&d.base_predictions, "")
    } else {
        h.push_str("<h2>Where it still fails with the effects found</h2>\n");
        h.push_str(&cells_table(
            &zmp_diagnose::cells::cells(&obs, &d.final_predictions),
            12,
        ));
        (&d.final_predictions, FOUND)
    };
    h.push_str(&model_figures(campaign, &obs, preds, model, &[], &out)?);
    h.push_str("</body></html>\n");
    let html = dir.join("diagnosis.html");
    zmp_files::write_file(&html, zmp_files::Kind::Html, h.as_bytes(), force)?;
    Ok(html)
}

/// The label of the model with the effects the diagnosis found.
const FOUND: &str = "with the effects found";

/// The verdict in words (HTML, names escaped).
fn verdict_words(verdict: &Verdict) -> String {
    match verdict {
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
    }
}

/// The page's head, title, verdict and how the diagnosis decided (the criterion and its
/// threshold), then the error measure.
fn diagnosis_header(d: &Diagnosis) -> String {
    let f = d.noise_floor;
    let mut h = String::new();
    let title = format!("Diagnosis: {} on {}", d.model, d.campaign);
    let verdict = verdict_words(&d.verdict);
    let _ = writeln!(
        h,
        "<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>{0}</title>{STYLE}</head>\
         <body>\n<h1>{0}</h1>\n<p class=\"v\">Verdict: {verdict}.</p>\n\
         <p>The model as given scores {1:.4} ({2:.1}x the noise floor {f:.4}) on {3} records; \
         every structure of the catalogue's effects (up to four, each under its law) was fitted \
         with every parameter and scored on records it was not fitted on (two folds by alternate \
         frequencies); an effect counts when the structure with it predicts those records \
         significantly better than without it (z, the held-out chi-square difference over twice \
         the distance between the two predictions in noise standard deviations, above the 1 % \
         normal quantile shared over the {4} structures compared: z &gt; {5:.2}).</p>\n{MEASURE}",
        esc(&title),
        d.baseline_error,
        d.baseline_error / f,
        d.records,
        d.compared,
        d.z_crit
    );
    h
}

/// The error waterfall (held-out error of the model as given, refitted, and as each effect
/// is added, against the noise floor), written as `waterfall.svg` in `dir` and inlined.
fn waterfall_section(d: &Diagnosis, dir: &Path, force: bool) -> Result<String> {
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
        Some((d.noise_floor, "noise floor")),
        force,
    )?;
    Ok(format!("<h2>Error waterfall</h2>\n{}", inline(&wf)?))
}

/// The frequency responses: measured points and the model, and with the effects found
/// beside the model as given when the diagnosis found any ("Before and after").
fn responses_section(d: &Diagnosis, obs: &[&Observation], out: &Out) -> Result<String> {
    if d.selected.is_empty() {
        let overlay = [Overlay {
            label: "model",
            predictions: &d.base_predictions,
        }];
        bode_section(
            obs,
            &overlay,
            out,
            "Frequency responses: measured points and model",
            "",
        )
    } else {
        let overlays = [
            Overlay {
                label: "model as given",
                predictions: &d.base_predictions,
            },
            Overlay {
                label: FOUND,
                predictions: &d.final_predictions,
            },
        ];
        bode_section(
            obs,
            &overlays,
            out,
            "Before and after",
            "Frequency responses. Points: measured; dashed: the model as given; solid: with \
             the effects found (fitted on every record).",
        )
    }
}
