//! Figures as self-contained SVG: Bode diagrams (magnitude and phase over log frequency,
//! [`bode_svg`]), time overlays ([`time_svg`]), curves against log frequency
//! ([`frequency_svg`]) and bar charts ([`bars_svg`]). Each plot's key is a row above it, never
//! over the data. Rendered in memory, written atomically.

use anyhow::{anyhow, Result};
use num_complex::Complex64;
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::Path;

mod bars;
mod legend;
mod time;

/// Font sizes as plotters takes them; its SVG backend writes `size / 1.24` px, so titles are
/// 16 px, tick labels, keys and values 12 px, axis descriptions 13 px on the page.
const TITLE: u32 = 20;
const LABEL: u32 = 15;
const DESC: u32 = 16;
pub use bars::bars_svg;
pub use time::{frequency_svg, time_svg, TimePanel, TimeSeries};

/// Line colours, in order of use.
pub const PALETTE: [RGBColor; 6] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(255, 127, 14),
    RGBColor(148, 103, 189),
    RGBColor(127, 127, 127),
];

/// How a series is drawn.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Style {
    /// A solid line (a model's prediction).
    Line,
    /// A dashed line (a reference or a second model).
    Dashed,
    /// Markers without a line (measurements).
    Points,
}

/// One curve or point set of a Bode diagram.
#[derive(Debug, Clone)]
pub struct BodeSeries {
    /// The legend's entry.
    pub label: String,
    /// Frequencies (rad/s).
    pub omega: Vec<f64>,
    /// The complex response at `omega`.
    pub value: Vec<Complex64>,
    /// Line, dashed or points.
    pub style: Style,
    /// Line or marker colour.
    pub color: RGBColor,
    /// Optional 1-sigma magnitude error (same unit as |value|), drawn as 2-sigma error bars on
    /// points.
    pub magnitude_error: Option<Vec<f64>>,
}

impl BodeSeries {
    /// A solid curve (a model's response).
    pub fn line(
        label: &str,
        omega: Vec<f64>,
        value: Vec<Complex64>,
        color: RGBColor,
    ) -> BodeSeries {
        BodeSeries {
            label: label.into(),
            omega,
            value,
            style: Style::Line,
            color,
            magnitude_error: None,
        }
    }
    /// A point set (measured responses).
    pub fn points(
        label: &str,
        omega: Vec<f64>,
        value: Vec<Complex64>,
        color: RGBColor,
    ) -> BodeSeries {
        BodeSeries {
            label: label.into(),
            omega,
            value,
            style: Style::Points,
            color,
            magnitude_error: None,
        }
    }
    /// The same series drawn dashed.
    pub fn dashed(self) -> BodeSeries {
        BodeSeries {
            style: Style::Dashed,
            ..self
        }
    }
}

/// A shaded magnitude band (e.g. the uncertainty set), in dB, drawn behind the series.
#[derive(Debug, Clone)]
pub struct Band {
    /// The legend's entry.
    pub label: String,
    /// Frequencies (rad/s).
    pub omega: Vec<f64>,
    /// Lower edge of the band at `omega` (dB).
    pub lower_db: Vec<f64>,
    /// Upper edge of the band at `omega` (dB).
    pub upper_db: Vec<f64>,
    /// Fill colour (drawn translucent).
    pub color: RGBColor,
}

/// One Bode diagram: a title, its series, an optional band.
#[derive(Debug, Clone, Default)]
pub struct BodePanel {
    /// Printed above the panel.
    pub title: String,
    /// The curves and point sets, drawn in order.
    pub series: Vec<BodeSeries>,
    /// Shaded magnitude bands, drawn behind the series.
    pub bands: Vec<Band>,
    /// Magnitude alone (the series' phase means nothing, e.g. error magnitudes).
    pub magnitude_only: bool,
}

/// The magnitude of `v` in decibels (`20 log10 |v|`, floored at -6000 dB for zero).
pub fn db(v: Complex64) -> f64 {
    20.0 * v.norm().max(1e-300).log10()
}

/// Phase in degrees, unwrapped along the series so curves do not jump by 360.
pub fn unwrapped_phase_deg(values: &[Complex64]) -> Vec<f64> {
    let mut out = Vec::with_capacity(values.len());
    let mut prev: Option<f64> = None;
    for v in values {
        let mut p = v.arg().to_degrees();
        if let Some(q) = prev {
            while p - q > 180.0 {
                p -= 360.0;
            }
            while p - q < -180.0 {
                p += 360.0;
            }
        }
        prev = Some(p);
        out.push(p);
    }
    out
}

fn finite_range(values: impl Iterator<Item = f64>) -> Option<(f64, f64)> {
    let mut lo = f64::INFINITY;
    let mut hi = f64::NEG_INFINITY;
    for v in values.filter(|v| v.is_finite()) {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    (lo <= hi).then_some((lo, hi))
}

fn pad((lo, hi): (f64, f64), min_span: f64) -> (f64, f64) {
    let span = (hi - lo).max(min_span);
    let mid = 0.5 * (lo + hi);
    (mid - 0.55 * span, mid + 0.55 * span)
}

fn e<T: std::fmt::Debug>(x: T) -> anyhow::Error {
    anyhow!("plotting: {x:?}")
}

/// Width of a Bode diagram's y label area, px (the legend's keys start there too).
const BODE_LEFT: i32 = 68;

fn draw_bode<DB: DrawingBackend>(area: &DrawingArea<DB, Shift>, panel: &BodePanel) -> Result<()>
where
    DB::ErrorType: 'static,
{
    let omegas = panel
        .series
        .iter()
        .flat_map(|s| s.omega.iter().copied())
        .chain(panel.bands.iter().flat_map(|b| b.omega.iter().copied()));
    let (wlo, whi) = finite_range(omegas.filter(|w| *w > 0.0)).unwrap_or((0.1, 10.0));
    let (wlo, whi) = (wlo / 1.2, whi * 1.2);
    let mags = panel
        .series
        .iter()
        .flat_map(|s| s.value.iter().map(|v| db(*v)));
    let (mlo, mhi) = pad(finite_range(mags).unwrap_or((-1.0, 1.0)), 6.0);
    let phases: Vec<Vec<f64>> = panel
        .series
        .iter()
        .map(|s| unwrapped_phase_deg(&s.value))
        .collect();
    let (plo, phi) = pad(
        finite_range(phases.iter().flatten().copied()).unwrap_or((-10.0, 10.0)),
        20.0,
    );
    let area = area
        .titled(&panel.title, ("sans-serif", TITLE))
        .map_err(e)?;
    let items = legend::bode_items(&panel.bands, &panel.series);
    let width = area.dim_in_pixel().0;
    let (keys, area) = area.split_vertically(legend::height(&items, BODE_LEFT, width));
    legend::draw(&keys, &items, BODE_LEFT)?;
    let (top, bottom) = if panel.magnitude_only {
        (area, None)
    } else {
        let (t, b) = area.split_vertically(area.dim_in_pixel().1 * 52 / 100);
        (t, Some(b))
    };
    let mut mag = ChartBuilder::on(&top)
        .margin(6)
        // The last x label is centred on the axis' end: room for its right half.
        .margin_right(16)
        .x_label_area_size(if bottom.is_some() { 22 } else { 38 })
        .y_label_area_size(BODE_LEFT as u32 - 6)
        .build_cartesian_2d((wlo..whi).log_scale(), mlo..mhi)
        .map_err(e)?;
    let mut mesh = mag.configure_mesh();
    mesh.y_desc("magnitude (dB)")
        .x_labels(6)
        .y_labels(6)
        .label_style(("sans-serif", LABEL))
        .axis_desc_style(("sans-serif", DESC));
    if bottom.is_none() {
        mesh.x_desc("omega (rad/s)");
    }
    mesh.draw().map_err(e)?;
    draw_magnitudes(&mut mag, panel, (mlo, mhi))?;
    let Some(bottom) = bottom else {
        return Ok(());
    };
    draw_phases(&bottom, panel, &phases, (wlo, whi), (plo, phi))
}

/// The uncertainty bands (clamped to the magnitude axis `mlo..mhi`, dB) and each series'
/// magnitude (dB), measured points with bars of two standard errors.
fn draw_magnitudes<DB: DrawingBackend, X: Ranged<ValueType = f64>, Y: Ranged<ValueType = f64>>(
    mag: &mut ChartContext<'_, DB, Cartesian2d<X, Y>>,
    panel: &BodePanel,
    (mlo, mhi): (f64, f64),
) -> Result<()>
where
    DB::ErrorType: 'static,
{
    for b in &panel.bands {
        let mut poly: Vec<(f64, f64)> = b
            .omega
            .iter()
            .copied()
            .zip(b.upper_db.iter().map(|v| v.clamp(mlo, mhi)))
            .collect();
        poly.extend(
            b.omega
                .iter()
                .copied()
                .zip(b.lower_db.iter().map(|v| v.clamp(mlo, mhi)))
                .rev(),
        );
        mag.draw_series(std::iter::once(Polygon::new(
            poly,
            b.color.mix(0.18).filled(),
        )))
        .map_err(e)?;
    }
    for s in &panel.series {
        let pts: Vec<(f64, f64)> = s
            .omega
            .iter()
            .copied()
            .zip(s.value.iter().map(|v| db(*v)))
            .collect();
        draw_curve(mag, s.style, s.color, &pts)?;
        if let (Some(err), Style::Points) = (&s.magnitude_error, s.style) {
            let c = s.color;
            mag.draw_series(s.omega.iter().zip(s.value.iter()).zip(err.iter()).map(
                move |((w, v), sd)| {
                    let m = v.norm();
                    let lo = 20.0 * (m - 2.0 * sd).max(m * 1e-3).log10();
                    let hi = 20.0 * (m + 2.0 * sd).log10();
                    PathElement::new(vec![(*w, lo), (*w, hi)], c.stroke_width(1))
                },
            ))
            .map_err(e)?;
        }
    }
    Ok(())
}

/// The phase chart (deg, unwrapped: `phases` per series) under the magnitude, on the same
/// frequency axis `wlo..whi` (rad/s).
fn draw_phases<DB: DrawingBackend>(
    bottom: &DrawingArea<DB, Shift>,
    panel: &BodePanel,
    phases: &[Vec<f64>],
    (wlo, whi): (f64, f64),
    (plo, phi): (f64, f64),
) -> Result<()>
where
    DB::ErrorType: 'static,
{
    let mut ph = ChartBuilder::on(bottom)
        .margin(6)
        // The last x label is centred on the axis' end: room for its right half.
        .margin_right(16)
        .x_label_area_size(38)
        .y_label_area_size(BODE_LEFT as u32 - 6)
        .build_cartesian_2d((wlo..whi).log_scale(), plo..phi)
        .map_err(e)?;
    ph.configure_mesh()
        .x_desc("omega (rad/s)")
        .y_desc("phase (deg)")
        .x_labels(6)
        .y_labels(6)
        .label_style(("sans-serif", LABEL))
        .axis_desc_style(("sans-serif", DESC))
        .draw()
        .map_err(e)?;
    for (s, p) in panel.series.iter().zip(phases) {
        let pts: Vec<(f64, f64)> = s.omega.iter().copied().zip(p.iter().copied()).collect();
        draw_curve(&mut ph, s.style, s.color, &pts)?;
    }
    Ok(())
}

/// Draws one curve (or point set) in `style` and `color`; points that are not finite are
/// left out.
fn draw_curve<DB: DrawingBackend, X: Ranged<ValueType = f64>, Y: Ranged<ValueType = f64>>(
    chart: &mut ChartContext<'_, DB, Cartesian2d<X, Y>>,
    style: Style,
    c: RGBColor,
    pts: &[(f64, f64)],
) -> Result<()>
where
    DB::ErrorType: 'static,
{
    let pts: Vec<(f64, f64)> = pts
        .iter()
        .copied()
        .filter(|(x, y)| x.is_finite() && y.is_finite())
        .collect();
    match style {
        Style::Line => {
            chart
                .draw_series(LineSeries::new(pts, c.stroke_width(2)))
                .map_err(e)?;
        }
        Style::Dashed => {
            chart
                .draw_series(DashedLineSeries::new(pts, 6, 4, c.stroke_width(2)))
                .map_err(e)?;
        }
        Style::Points => {
            chart
                .draw_series(pts.into_iter().map(move |p| Circle::new(p, 3, c.filled())))
                .map_err(e)?;
        }
    }
    Ok(())
}

/// Renders Bode panels on a grid of `cols` columns into one SVG file.
pub fn bode_svg(path: &Path, panels: &[BodePanel], cols: usize, overwrite: bool) -> Result<()> {
    let cols = cols.max(1);
    let rows = panels.len().div_ceil(cols).max(1);
    let h_panel = if panels.iter().all(|p| p.magnitude_only) {
        300
    } else {
        490
    };
    let (w, h) = (520 * cols as u32, h_panel * rows as u32);
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (w, h)).into_drawing_area();
        root.fill(&WHITE).map_err(e)?;
        let cells = root.split_evenly((rows, cols));
        for (cell, panel) in cells.iter().zip(panels) {
            draw_bode(cell, panel)?;
        }
        root.present().map_err(e)?;
    }
    write_svg(path, &svg, overwrite)
}

/// Writes a plot through the one output path (`zmp_files`): an existing file needs
/// `overwrite`, and only an SVG is ever replaced.
fn write_svg(path: &Path, svg: &str, overwrite: bool) -> Result<()> {
    zmp_files::write_file(path, zmp_files::Kind::Svg, svg.as_bytes(), overwrite)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn phase_unwraps() {
        let v: Vec<Complex64> = (0..10)
            .map(|k| Complex64::from_polar(1.0, -0.8 * k as f64))
            .collect();
        let p = unwrapped_phase_deg(&v);
        for w in p.windows(2) {
            assert!((w[1] - w[0] + 0.8f64.to_degrees()).abs() < 1e-9);
        }
    }

    #[test]
    fn writes_svgs() {
        let d = tempfile::tempdir().unwrap();
        let w: Vec<f64> = (0..50).map(|k| 0.1 * 1.1f64.powi(k)).collect();
        let g: Vec<Complex64> = w
            .iter()
            .map(|w| Complex64::new(1.0, 0.0) / Complex64::new(1.0, *w))
            .collect();
        let panel = BodePanel {
            title: "G11".into(),
            series: vec![BodeSeries::line("model", w.clone(), g.clone(), PALETTE[0])],
            bands: vec![],
            magnitude_only: false,
        };
        let p = d.path().join("bode.svg");
        bode_svg(&p, &[panel.clone(), panel], 2, false).unwrap();
        let s = std::fs::read_to_string(&p).unwrap();
        assert!(s.starts_with("<svg") && s.contains("G11") && s.contains("magnitude (dB)"));
        let tp = TimePanel {
            title: "zmp".into(),
            y_label: "m".into(),
            series: vec![TimeSeries {
                label: "a".into(),
                t: w.clone(),
                y: w.clone(),
                color: PALETTE[1],
                style: Style::Line,
            }],
            markers: vec![(1.0, "load".into())],
            x_label: None,
        };
        time_svg(&d.path().join("t.svg"), &[tp], false).unwrap();
        bars_svg(
            &d.path().join("b.svg"),
            "errors",
            "err",
            &[("v1".into(), 0.2), ("v2".into(), 0.01)],
            Some((0.005, "noise")),
            false,
        )
        .unwrap();
        let b = texts(&std::fs::read_to_string(d.path().join("b.svg")).unwrap());
        // Names under the bars, values over them, the reference in the key.
        for text in ["v1", "v2", "0.2000", "0.0100", "noise 0.0050"] {
            assert!(
                b.iter().any(|t| t == text),
                "no {text} in the bar chart: {b:?}"
            );
        }
    }

    #[test]
    fn a_tick_at_zero_reads_zero() {
        // A symmetric range whose ticks come out of floating-point steps: the one at zero
        // must not print as "-0.0" (it did on the SABIAN walking figures).
        let d = tempfile::tempdir().unwrap();
        let t: Vec<f64> = (0..50).map(|k| k as f64 * 0.1).collect();
        let panel = TimePanel {
            title: "ZMP y".into(),
            y_label: "m".into(),
            series: vec![TimeSeries {
                label: "y".into(),
                y: t.iter().map(|x| 0.11 * x.sin()).collect(),
                t,
                color: PALETTE[0],
                style: Style::Line,
            }],
            ..Default::default()
        };
        let p = d.path().join("t.svg");
        time_svg(&p, &[panel], false).unwrap();
        let s = texts(&std::fs::read_to_string(p).unwrap());
        // "0.0" twice: t = 0 and the y tick at zero.
        assert_eq!(s.iter().filter(|t| *t == "0.0").count(), 2, "{s:?}");
        assert!(
            !s.iter().any(|t| t == "-0.0"),
            "a tick at zero reads -0.0: {s:?}"
        );
    }

    /// The texts of an SVG's `<text>` elements.
    fn texts(svg: &str) -> Vec<String> {
        svg.split("<text")
            .skip(1)
            .filter_map(|t| {
                let body = &t[t.find('>')? + 1..];
                Some(body[..body.find("</text>")?].trim().to_string())
            })
            .collect()
    }
}
