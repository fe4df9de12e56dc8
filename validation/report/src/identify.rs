//! The identification report: a self-contained HTML file (figures inline) plus the figures as
//! SVG files: per channel a Bode diagram with the measured points (2-sigma error bars), the
//! fitted model, the seed's model dashed and the uncertainty band (seed figures 11-14), the
//! uncertainty database with its weights (figures 15-16), the parameter table with confidence
//! intervals against the seed's SILO2 values, the excluded records and the warnings.

use crate::html::{esc, STYLE};
use crate::plot::{bode_svg, Band, BodePanel, BodeSeries, PALETTE};
use anyhow::{Context, Result};
use num_complex::Complex64;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use zmp_identify::{Identification, SEED_BANDWIDTH, SEED_PENDULUM};
use zmp_models::effects::tracking_lowpass::TrackingLowpass;
use zmp_models::effects::uncertainty::weight;
use zmp_models::logspace;
use zmp_models::Channel;

/// The Bode panel of one channel.
pub fn channel_panel(ident: &Identification, ch: Channel) -> BodePanel {
    let (i, j) = (ch.output.index(), ch.input.index());
    let recs: Vec<_> = ident
        .records
        .iter()
        .filter(|r| r.excited == ch.input && r.g[i].re.is_finite())
        .collect();
    let lo = recs.iter().map(|r| r.omega).fold(f64::INFINITY, f64::min);
    let hi = recs.iter().map(|r| r.omega).fold(0.0, f64::max);
    let (lo, hi) = if lo.is_finite() && hi > 0.0 {
        (lo / 3.0, hi * 3.0)
    } else {
        (0.1, 100.0)
    };
    let w = logspace(lo, hi, 300);
    let g: Vec<Complex64> = w.iter().map(|&x| ident.model_response(i, j, x)).collect();
    let seed = |x: f64| {
        let (a, b) = (SEED_PENDULUM.a[i][j], SEED_PENDULUM.b[i][j]);
        (a + b * x * x)
            * TrackingLowpass {
                omega_n: SEED_BANDWIDTH.0,
                zeta: SEED_BANDWIDTH.1,
            }
            .freq(x)
    };
    let gs: Vec<Complex64> = w.iter().map(|&x| seed(x)).collect();
    let mut series = Vec::new();
    let used: Vec<_> = recs.iter().filter(|r| r.excluded.is_none()).collect();
    let mut pts = BodeSeries::points(
        "measured (2 sigma)",
        used.iter().map(|r| r.omega).collect(),
        used.iter().map(|r| r.g[i]).collect(),
        PALETTE[1],
    );
    pts.magnitude_error = Some(used.iter().map(|r| r.sigma[i]).collect());
    series.push(pts);
    let sat: Vec<_> = recs.iter().filter(|r| r.excluded.is_some()).collect();
    if !sat.is_empty() {
        series.push(BodeSeries::points(
            "excluded (saturated, ...)",
            sat.iter().map(|r| r.omega).collect(),
            sat.iter().map(|r| r.g[i]).collect(),
            PALETTE[3],
        ));
    }
    series.push(BodeSeries::line(
        "identified model",
        w.clone(),
        g.clone(),
        PALETTE[0],
    ));
    series.push(BodeSeries::line("seed (SILO2 paper)", w.clone(), gs, PALETTE[5]).dashed());
    let (k, z, p) = ident.uncertainty[2 * i + j].weight;
    let (lower_db, upper_db): (Vec<f64>, Vec<f64>) = w
        .iter()
        .zip(&g)
        .map(|(&x, gk)| {
            let m = gk.norm();
            let r = weight(k, z, p).freq(x).norm();
            (
                20.0 * (m * (1.0 - r)).max(m * 1e-3).log10(),
                20.0 * (m * (1.0 + r)).log10(),
            )
        })
        .unzip();
    BodePanel {
        title: format!(
            "{}: zmp_{} from {}_cr",
            ch.name(),
            ch.output.name(),
            ch.input.name()
        ),
        series,
        bands: vec![Band {
            label: "|G|(1 +- |W|)".into(),
            omega: w,
            lower_db,
            upper_db,
            color: PALETTE[0],
        }],
        magnitude_only: false,
    }
}

/// The uncertainty panel of one channel: multiplicative error points and `|W|` (as a gain).
fn uncertainty_panel(ident: &Identification, c: usize) -> BodePanel {
    let u = &ident.uncertainty[c];
    let om: Vec<f64> = u.points.iter().map(|p| p.omega).collect();
    let (lo, hi) = (
        om.iter().cloned().fold(f64::INFINITY, f64::min).max(1e-3) / 3.0,
        om.iter().cloned().fold(0.0, f64::max).max(1e-2) * 3.0,
    );
    let w = logspace(lo, hi, 200);
    let (k, z, p) = u.weight;
    let wt = zmp_models::effects::uncertainty::weight(k, z, p);
    BodePanel {
        title: format!(
            "{}: multiplicative uncertainty, W = {:.3}(s+{:.3})/(s+{:.3})",
            u.channel, k, z, p
        ),
        series: vec![
            BodeSeries::points(
                "additive |G_meas - G_model|",
                om.clone(),
                u.points
                    .iter()
                    .map(|p| Complex64::new(p.additive, 0.0))
                    .collect(),
                PALETTE[2],
            ),
            BodeSeries::points(
                "multiplicative l(w)",
                om,
                u.points
                    .iter()
                    .map(|p| Complex64::new(p.multiplicative, 0.0))
                    .collect(),
                PALETTE[1],
            ),
            BodeSeries::line(
                "weight W(jw)",
                w.clone(),
                w.iter().map(|&x| wt.freq(x)).collect(),
                PALETTE[0],
            ),
        ],
        bands: vec![],
        // The points are magnitudes; the seed's figures 15-16 show magnitudes alone.
        magnitude_only: true,
    }
}

/// Paths of what [`write_report`] wrote.
#[derive(Debug, Clone)]
pub struct ReportFiles {
    pub html: PathBuf,
    /// `bode_G11.svg` .. `bode_G22.svg`.
    pub bode: Vec<PathBuf>,
    /// All four channels in one figure.
    pub bode_all: PathBuf,
    pub uncertainty: PathBuf,
}

fn fmt_v(v: f64) -> String {
    if v == 0.0 {
        "0".into()
    } else if v.abs() >= 1e-3 && v.abs() < 1e4 {
        format!("{v:.5}")
    } else {
        format!("{v:.4e}")
    }
}

/// The parameters (with 95 % intervals and the seed's values) and the uncertainty weights.
fn parameter_tables(ident: &Identification) -> String {
    let mut h = String::new();
    h.push_str(
        "<h2>Parameters</h2>\n<table><tr><th class=\"l\">parameter</th><th>value</th>\
         <th>std. error</th><th>95 % CI</th><th>seed (SILO2)</th><th class=\"l\">source</th></tr>\n",
    );
    for p in ident.parameters() {
        let short = p.name.rsplit('.').next().unwrap_or(&p.name);
        let seed = SEED_PENDULUM
            .named()
            .into_iter()
            .find(|(n, _)| *n == short && p.name.starts_with("pendulum"))
            .map(|(_, v)| v)
            .or(match p.name.as_str() {
                "tracking_lowpass.omega_n" => Some(SEED_BANDWIDTH.0),
                "tracking_lowpass.zeta" => Some(SEED_BANDWIDTH.1),
                _ => None,
            });
        let (lo, hi) = p.ci95();
        let _ = writeln!(
            h,
            "<tr><td class=\"l\">{}</td><td>{}</td><td>{}</td><td>[{}, {}]</td><td>{}</td>\
             <td class=\"l\">{}</td></tr>",
            esc(&p.name),
            fmt_v(p.value),
            fmt_v(p.stderr),
            fmt_v(lo),
            fmt_v(hi),
            seed.map(fmt_v).unwrap_or_else(|| "-".into()),
            if p.estimated { "estimated" } else { "given" }
        );
    }
    h.push_str("</table>\n");
    let _ = writeln!(h, "<p>{}</p>", esc(&ident.bandwidth.note));
    h.push_str(
        "<h2>Uncertainty weights</h2>\n<table><tr><th class=\"l\">channel</th><th>k</th><th>z (rad/s)</th>\
         <th>p (rad/s)</th></tr>\n",
    );
    for u in &ident.uncertainty {
        let (k, z, p) = u.weight;
        let _ = writeln!(
            h,
            "<tr><td class=\"l\">{}</td><td>{}</td><td>{}</td><td>{}</td></tr>",
            u.channel,
            fmt_v(k),
            fmt_v(z),
            fmt_v(p)
        );
    }
    h.push_str("</table>\n");
    h
}

/// The excluded records (why each) and every record's analysis.
fn record_tables(ident: &Identification) -> String {
    let mut h = String::new();
    h.push_str("<h2>Excluded records</h2>\n");
    let ex: Vec<_> = ident
        .records
        .iter()
        .filter(|r| r.excluded.is_some())
        .collect();
    if ex.is_empty() {
        h.push_str("<p>None.</p>\n");
    } else {
        h.push_str(
            "<table><tr><th>record</th><th>excited</th><th>omega (rad/s)</th>\
             <th>amplitude (mm)</th><th>operating point (m)</th><th class=\"l\">reason</th></tr>\n",
        );
        for r in ex {
            let _ = writeln!(
                h,
                "<tr><td>{}</td><td>{}</td><td>{:.3}</td><td>{:.2}</td><td>({}, {})</td>\
                 <td class=\"l\">{}</td></tr>",
                r.index,
                r.excited,
                r.omega,
                1000.0 * r.amplitude,
                r.operating_point[0],
                r.operating_point[1],
                esc(r.excluded.as_deref().unwrap_or(""))
            );
        }
        h.push_str("</table>\n");
    }
    h.push_str(
        "<h2>Records</h2>\n<table><tr><th>record</th><th>excited</th><th>omega</th>\
         <th>amp. (mm)</th><th>steady from (s)</th><th>periods</th><th>|G_x|</th><th>|G_y|</th>\
         <th>distortion x</th><th>distortion y</th><th>noise x (mm)</th><th>noise y (mm)</th></tr>\n",
    );
    for r in &ident.records {
        let _ = writeln!(
            h,
            "<tr><td>{}</td><td>{}</td><td>{:.3}</td><td>{:.2}</td><td>{:.2}</td><td>{}</td>\
             <td>{:.4}</td><td>{:.4}</td><td>{:.2e}</td><td>{:.2e}</td><td>{:.3}</td><td>{:.3}</td></tr>",
            r.index,
            r.excited,
            r.omega,
            1000.0 * r.amplitude,
            r.steady_start_s,
            r.periods,
            r.g[0].norm(),
            r.g[1].norm(),
            r.distortion[0],
            r.distortion[1],
            1000.0 * r.noise_std[0],
            1000.0 * r.noise_std[1]
        );
    }
    h.push_str("</table>\n");
    h
}

/// Writes the report into `dir` (created if needed; existing files need `force`).
pub fn write_report(ident: &Identification, dir: &Path, force: bool) -> Result<ReportFiles> {
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let mut bode = Vec::new();
    let mut panels = Vec::new();
    for ch in Channel::ALL {
        let panel = channel_panel(ident, ch);
        let path = dir.join(format!("bode_{}.svg", ch.name()));
        bode_svg(&path, std::slice::from_ref(&panel), 1, force)?;
        bode.push(path);
        panels.push(panel);
    }
    let bode_all = dir.join("bode_all.svg");
    bode_svg(&bode_all, &panels, 2, force)?;
    let unc: Vec<BodePanel> = (0..4).map(|c| uncertainty_panel(ident, c)).collect();
    let uncertainty = dir.join("uncertainty.svg");
    bode_svg(&uncertainty, &unc, 2, force)?;

    let mut h = String::new();
    let title = format!(
        "ZMP model identification: {}",
        ident.campaign_name.as_deref().unwrap_or("campaign")
    );
    let _ = writeln!(
        h,
        "<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>{0}</title>{STYLE}</head>\
         <body>\n<h1>{0}</h1>",
        esc(&title)
    );
    let used = ident.used().count();
    let _ = writeln!(
        h,
        "<p>{} records, {} used in the linear fit; reduced chi-square {:.3}; harmonic \
         regression per record, joint weighted Levenberg-Marquardt fit of \
         G<sub>ij</sub> = (a<sub>ij</sub> + b<sub>ij</sub> w<sup>2</sup>) H(jw) (first seed, \
         section 5). Tool: zmp-toolkit {}.</p>",
        ident.records.len(),
        used,
        ident.reduced_chi2,
        env!("CARGO_PKG_VERSION")
    );
    if !ident.warnings.is_empty() {
        h.push_str("<h2>Warnings</h2><ul>\n");
        for w in &ident.warnings {
            let _ = writeln!(h, "<li class=\"warn\">{}</li>", esc(w));
        }
        h.push_str("</ul>\n");
    }
    h.push_str(&parameter_tables(ident));
    // The four channels side by side (the single diagrams are written beside the report).
    h.push_str("<h2>Bode diagrams (seed figures 11-14)</h2>\n");
    let _ = writeln!(h, "<div>{}</div>", std::fs::read_to_string(&bode_all)?);
    h.push_str("<h2>Uncertainty database (seed figures 15-16)</h2>\n");
    let _ = writeln!(h, "<div>{}</div>", std::fs::read_to_string(&uncertainty)?);
    h.push_str(&record_tables(ident));
    h.push_str("</body></html>\n");
    let html = dir.join("report.html");
    zmp_files::atomic_write(&html, h.as_bytes(), force)?;
    Ok(ReportFiles {
        html,
        bode,
        bode_all,
        uncertainty,
    })
}
