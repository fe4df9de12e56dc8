//! Figures as self-contained SVG: Bode diagrams (magnitude and phase over log frequency), time
//! overlays and bar charts. Rendered in memory, written atomically.

use anyhow::{anyhow, Result};
use num_complex::Complex64;
use plotters::prelude::*;
use std::path::Path;

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
    Line,
    Dashed,
    Points,
}

/// One curve or point set of a Bode diagram.
#[derive(Debug, Clone)]
pub struct BodeSeries {
    pub label: String,
    pub omega: Vec<f64>,
    pub value: Vec<Complex64>,
    pub style: Style,
    pub color: RGBColor,
    /// Optional 1-sigma magnitude error (same unit as |value|) drawn as error bars on points.
    pub magnitude_error: Option<Vec<f64>>,
}

impl BodeSeries {
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
    pub label: String,
    pub omega: Vec<f64>,
    pub lower_db: Vec<f64>,
    pub upper_db: Vec<f64>,
    pub color: RGBColor,
}

/// One Bode diagram: a title, its series, an optional band.
#[derive(Debug, Clone, Default)]
pub struct BodePanel {
    pub title: String,
    pub series: Vec<BodeSeries>,
    pub bands: Vec<Band>,
}

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

fn draw_bode<DB: DrawingBackend>(
    area: &DrawingArea<DB, plotters::coord::Shift>,
    panel: &BodePanel,
) -> Result<()>
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
    let (top, bottom) = area.split_vertically(area.dim_in_pixel().1 * 55 / 100);

    let mut mag = ChartBuilder::on(&top)
        .caption(&panel.title, ("sans-serif", 18))
        .margin(6)
        .x_label_area_size(22)
        .y_label_area_size(52)
        .build_cartesian_2d((wlo..whi).log_scale(), mlo..mhi)
        .map_err(e)?;
    mag.configure_mesh()
        .y_desc("magnitude (dB)")
        .x_labels(6)
        .y_labels(6)
        .draw()
        .map_err(e)?;
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
        .map_err(e)?
        .label(b.label.clone())
        .legend(move |(x, y)| {
            Rectangle::new([(x, y - 4), (x + 14, y + 4)], b.color.mix(0.3).filled())
        });
    }
    for s in &panel.series {
        let pts: Vec<(f64, f64)> = s
            .omega
            .iter()
            .copied()
            .zip(s.value.iter().map(|v| db(*v)))
            .collect();
        draw_series(&mut mag, s, &pts)?;
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
    mag.configure_series_labels()
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .label_font(("sans-serif", 12))
        .draw()
        .map_err(e)?;

    let mut ph = ChartBuilder::on(&bottom)
        .margin(6)
        .x_label_area_size(34)
        .y_label_area_size(52)
        .build_cartesian_2d((wlo..whi).log_scale(), plo..phi)
        .map_err(e)?;
    ph.configure_mesh()
        .x_desc("omega (rad/s)")
        .y_desc("phase (deg)")
        .x_labels(6)
        .y_labels(6)
        .draw()
        .map_err(e)?;
    for (s, p) in panel.series.iter().zip(&phases) {
        let pts: Vec<(f64, f64)> = s.omega.iter().copied().zip(p.iter().copied()).collect();
        draw_series(&mut ph, s, &pts)?;
    }
    Ok(())
}

fn draw_series<DB: DrawingBackend, X: Ranged<ValueType = f64>, Y: Ranged<ValueType = f64>>(
    chart: &mut ChartContext<'_, DB, Cartesian2d<X, Y>>,
    s: &BodeSeries,
    pts: &[(f64, f64)],
) -> Result<()>
where
    DB::ErrorType: 'static,
{
    let c = s.color;
    let pts: Vec<(f64, f64)> = pts
        .iter()
        .copied()
        .filter(|(x, y)| x.is_finite() && y.is_finite())
        .collect();
    match s.style {
        Style::Line => {
            chart
                .draw_series(LineSeries::new(pts, c.stroke_width(2)))
                .map_err(e)?
                .label(s.label.clone())
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 14, y)], c.stroke_width(2))
                });
        }
        Style::Dashed => {
            chart
                .draw_series(DashedLineSeries::new(pts, 6, 4, c.stroke_width(2)))
                .map_err(e)?
                .label(s.label.clone())
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 14, y)], c.stroke_width(1))
                });
        }
        Style::Points => {
            chart
                .draw_series(pts.into_iter().map(move |p| Circle::new(p, 3, c.filled())))
                .map_err(e)?
                .label(s.label.clone())
                .legend(move |(x, y)| Circle::new((x + 7, y), 3, c.filled()));
        }
    }
    Ok(())
}

/// Writes a plot through the one output path (`zmp_files`): an existing file needs
/// `overwrite`, and only an SVG is ever replaced.
fn write_svg(path: &Path, svg: &str, overwrite: bool) -> Result<()> {
    zmp_files::write_file(path, zmp_files::Kind::Svg, svg.as_bytes(), overwrite)?;
    Ok(())
}

/// Renders Bode panels on a grid of `cols` columns into one SVG file.
pub fn bode_svg(path: &Path, panels: &[BodePanel], cols: usize, overwrite: bool) -> Result<()> {
    let cols = cols.max(1);
    let rows = panels.len().div_ceil(cols).max(1);
    let (w, h) = (520 * cols as u32, 460 * rows as u32);
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

/// One curve of a time plot.
#[derive(Debug, Clone)]
pub struct TimeSeries {
    pub label: String,
    pub t: Vec<f64>,
    pub y: Vec<f64>,
    pub color: RGBColor,
    pub style: Style,
}

/// One panel of a time plot: shared x axis, its own y axis.
#[derive(Debug, Clone, Default)]
pub struct TimePanel {
    pub title: String,
    pub y_label: String,
    pub series: Vec<TimeSeries>,
    /// Vertical markers: (time, label).
    pub markers: Vec<(f64, String)>,
    /// Label of the x axis (default `t (s)`).
    pub x_label: Option<String>,
}

/// Stacked time panels in one SVG file.
pub fn time_svg(path: &Path, panels: &[TimePanel], overwrite: bool) -> Result<()> {
    let (w, h) = (900u32, 300 * panels.len().max(1) as u32);
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (w, h)).into_drawing_area();
        root.fill(&WHITE).map_err(e)?;
        let cells = root.split_evenly((panels.len().max(1), 1));
        for (cell, p) in cells.iter().zip(panels) {
            let (tlo, thi) = finite_range(p.series.iter().flat_map(|s| s.t.iter().copied()))
                .unwrap_or((0.0, 1.0));
            let (ylo, yhi) = pad(
                finite_range(p.series.iter().flat_map(|s| s.y.iter().copied()))
                    .unwrap_or((-1.0, 1.0)),
                1e-9,
            );
            let mut chart = ChartBuilder::on(cell)
                .caption(&p.title, ("sans-serif", 17))
                .margin(8)
                .x_label_area_size(34)
                .y_label_area_size(64)
                .build_cartesian_2d(tlo..thi, ylo..yhi)
                .map_err(e)?;
            chart
                .configure_mesh()
                .x_desc(p.x_label.as_deref().unwrap_or("t (s)"))
                .y_desc(p.y_label.as_str())
                .draw()
                .map_err(e)?;
            for (t, label) in &p.markers {
                chart
                    .draw_series(std::iter::once(PathElement::new(
                        vec![(*t, ylo), (*t, yhi)],
                        BLACK.mix(0.4).stroke_width(1),
                    )))
                    .map_err(e)?;
                chart
                    .draw_series(std::iter::once(Text::new(
                        label.clone(),
                        (*t, yhi - 0.06 * (yhi - ylo)),
                        ("sans-serif", 12),
                    )))
                    .map_err(e)?;
            }
            for s in &p.series {
                let b = BodeSeries {
                    label: s.label.clone(),
                    omega: vec![],
                    value: vec![],
                    style: s.style,
                    color: s.color,
                    magnitude_error: None,
                };
                let pts: Vec<(f64, f64)> = s.t.iter().copied().zip(s.y.iter().copied()).collect();
                draw_series(&mut chart, &b, &pts)?;
            }
            chart
                .configure_series_labels()
                .position(SeriesLabelPosition::LowerRight)
                .background_style(WHITE.mix(0.85))
                .border_style(BLACK)
                .label_font(("sans-serif", 12))
                .draw()
                .map_err(e)?;
        }
        root.present().map_err(e)?;
    }
    write_svg(path, &svg, overwrite)
}

/// A horizontal list of labelled bars (e.g. an error waterfall), with an optional reference
/// line (e.g. the noise floor).
pub fn bars_svg(
    path: &Path,
    title: &str,
    y_label: &str,
    bars: &[(String, f64)],
    reference: Option<(f64, &str)>,
    overwrite: bool,
) -> Result<()> {
    let (w, h) = ((160 * bars.len().max(3)) as u32 + 120, 420u32);
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (w, h)).into_drawing_area();
        root.fill(&WHITE).map_err(e)?;
        let top = bars
            .iter()
            .map(|b| b.1)
            .chain(reference.map(|r| r.0))
            .filter(|v| v.is_finite())
            .fold(0.0, f64::max)
            * 1.15;
        let top = if top > 0.0 { top } else { 1.0 };
        let n = bars.len();
        let mut chart = ChartBuilder::on(&root)
            .caption(title, ("sans-serif", 18))
            .margin(10)
            .x_label_area_size(40)
            .y_label_area_size(70)
            .build_cartesian_2d(0f64..n.max(1) as f64, 0f64..top)
            .map_err(e)?;
        let labels: Vec<String> = bars.iter().map(|b| b.0.clone()).collect();
        chart
            .configure_mesh()
            .disable_x_mesh()
            .x_labels(n.max(1))
            .x_label_formatter(&|x| {
                let i = (*x - 0.5).round();
                if (x - 0.5 - i).abs() < 1e-6 && i >= 0.0 {
                    labels.get(i as usize).cloned().unwrap_or_default()
                } else {
                    String::new()
                }
            })
            .y_desc(y_label)
            .draw()
            .map_err(e)?;
        chart
            .draw_series(bars.iter().enumerate().map(|(i, b)| {
                Rectangle::new(
                    [(i as f64 + 0.15, 0.0), (i as f64 + 0.85, b.1.max(0.0))],
                    PALETTE[i % PALETTE.len()].filled(),
                )
            }))
            .map_err(e)?;
        chart
            .draw_series(bars.iter().enumerate().map(|(i, b)| {
                Text::new(
                    format!("{}: {:.4}", b.0, b.1),
                    (i as f64 + 0.17, b.1 + 0.03 * top),
                    ("sans-serif", 12),
                )
            }))
            .map_err(e)?;
        if let Some((v, label)) = reference {
            let label = label.to_string();
            chart
                .draw_series(DashedLineSeries::new(
                    vec![(0.0, v), (n as f64, v)],
                    6,
                    4,
                    BLACK.stroke_width(1),
                ))
                .map_err(e)?
                .label(label)
                .legend(|(x, y)| {
                    PathElement::new(vec![(x, y), (x + 14, y)], BLACK.stroke_width(1))
                });
            chart
                .configure_series_labels()
                .background_style(WHITE.mix(0.85))
                .border_style(BLACK)
                .draw()
                .map_err(e)?;
        }
        root.present().map_err(e)?;
    }
    write_svg(path, &svg, overwrite)
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
    }
}
