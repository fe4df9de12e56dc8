//! Stacked panels sharing an x axis: time traces ([`time_svg`]) or quantities against
//! frequency on a logarithmic axis ([`frequency_svg`]).

use super::legend;
use super::{draw_curve, e, finite_range, pad, Style, DESC, LABEL, TITLE};
use anyhow::Result;
use plotters::coord::ranged1d::ValueFormatter;
use plotters::coord::types::RangedCoordf64;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use std::path::Path;
use zmp_files::atomic_write;

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
    /// Label of the x axis (default `t (s)`, or `omega (rad/s)` in [`frequency_svg`]).
    pub x_label: Option<String>,
}

/// Width of the y label area, px (the legend's keys start there too).
const LEFT: i32 = 70;

/// Stacked time panels in one SVG file.
pub fn time_svg(path: &Path, panels: &[TimePanel], overwrite: bool) -> Result<()> {
    panels_svg(path, panels, false, overwrite)
}

/// As [`time_svg`], with a logarithmic x axis: the panels' `t` are frequencies (rad/s).
pub fn frequency_svg(path: &Path, panels: &[TimePanel], overwrite: bool) -> Result<()> {
    panels_svg(path, panels, true, overwrite)
}

fn panels_svg(path: &Path, panels: &[TimePanel], log_x: bool, overwrite: bool) -> Result<()> {
    let (w, h) = (900u32, 330 * panels.len().max(1) as u32);
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (w, h)).into_drawing_area();
        root.fill(&WHITE).map_err(e)?;
        let cells = root.split_evenly((panels.len().max(1), 1));
        for (cell, p) in cells.iter().zip(panels) {
            let xs = p.series.iter().flat_map(|s| s.t.iter().copied());
            let (mut tlo, mut thi) = if log_x {
                finite_range(xs.filter(|t| *t > 0.0)).unwrap_or((0.1, 10.0))
            } else {
                finite_range(xs).unwrap_or((0.0, 1.0))
            };
            // Points at the ends of the axis are drawn whole.
            if p.series.iter().any(|s| s.style == Style::Points) {
                if log_x {
                    (tlo, thi) = (tlo / 1.12, thi * 1.12);
                } else {
                    let m = 0.03 * (thi - tlo).max(1e-12);
                    (tlo, thi) = (tlo - m, thi + m);
                }
            }
            if thi <= tlo {
                (tlo, thi) = if log_x {
                    (tlo / 2.0, thi * 2.0)
                } else {
                    (tlo - 0.5, thi + 0.5)
                };
            }
            let (ylo, yhi) = pad(
                finite_range(p.series.iter().flat_map(|s| s.y.iter().copied()))
                    .unwrap_or((-1.0, 1.0)),
                1e-9,
            );
            let cell = cell.titled(&p.title, ("sans-serif", TITLE)).map_err(e)?;
            let items = legend::time_items(&p.series);
            let (keys, area) = cell.split_vertically(legend::height(&items, LEFT, w));
            legend::draw(&keys, &items, LEFT)?;
            let mut builder = ChartBuilder::on(&area);
            builder
                .margin(8)
                // The last x label is centred on the axis' end: room for its right half.
                .margin_right(24)
                // Room for the markers' labels above the plot, where no curve runs.
                .margin_top(if p.markers.is_empty() { 8 } else { 24 })
                .x_label_area_size(38)
                .y_label_area_size(LEFT as u32 - 8);
            if log_x {
                let x_desc = p.x_label.as_deref().unwrap_or("omega (rad/s)");
                let mut chart = builder
                    .build_cartesian_2d((tlo..thi).log_scale(), ylo..yhi)
                    .map_err(e)?;
                fill(&mut chart, p, x_desc, (ylo, yhi))?;
                marker_labels(&area, &chart, p, yhi)?;
            } else {
                let x_desc = p.x_label.as_deref().unwrap_or("t (s)");
                let mut chart = builder.build_cartesian_2d(tlo..thi, ylo..yhi).map_err(e)?;
                fill(&mut chart, p, x_desc, (ylo, yhi))?;
                marker_labels(&area, &chart, p, yhi)?;
            }
        }
        root.present().map_err(e)?;
    }
    atomic_write(path, svg.as_bytes(), overwrite)
}

/// The mesh, markers and curves of one panel.
fn fill<DB, X>(
    chart: &mut ChartContext<'_, DB, Cartesian2d<X, RangedCoordf64>>,
    p: &TimePanel,
    x_desc: &str,
    (ylo, yhi): (f64, f64),
) -> Result<()>
where
    DB: DrawingBackend,
    DB::ErrorType: 'static,
    X: Ranged<ValueType = f64> + ValueFormatter<f64>,
{
    // A tick a rounding error away from zero reads "0.0", not "-0.0".
    let zero = 1e-9 * (yhi - ylo);
    let y_tick = |v: &f64| {
        let v = if v.abs() < zero { 0.0 } else { *v };
        RangedCoordf64::format(&v)
    };
    chart
        .configure_mesh()
        .x_desc(x_desc)
        .y_desc(p.y_label.as_str())
        .y_label_formatter(&y_tick)
        .x_max_light_lines(2)
        .y_max_light_lines(2)
        .label_style(("sans-serif", LABEL))
        .axis_desc_style(("sans-serif", DESC))
        .draw()
        .map_err(e)?;
    for (t, _) in &p.markers {
        chart
            .draw_series(std::iter::once(PathElement::new(
                vec![(*t, ylo), (*t, yhi)],
                BLACK.mix(0.4).stroke_width(1),
            )))
            .map_err(e)?;
    }
    for s in &p.series {
        let pts: Vec<(f64, f64)> = s.t.iter().copied().zip(s.y.iter().copied()).collect();
        draw_curve(chart, s.style, s.color, &pts)?;
    }
    Ok(())
}

/// The markers' labels, centred over their lines above the plot.
fn marker_labels<DB, X>(
    area: &DrawingArea<DB, Shift>,
    chart: &ChartContext<'_, DB, Cartesian2d<X, RangedCoordf64>>,
    p: &TimePanel,
    yhi: f64,
) -> Result<()>
where
    DB: DrawingBackend,
    DB::ErrorType: 'static,
    X: Ranged<ValueType = f64>,
{
    let (x0, y0) = area.get_base_pixel();
    let style = TextStyle::from(("sans-serif", LABEL).into_font())
        .pos(Pos::new(HPos::Center, VPos::Bottom))
        .color(&BLACK);
    for (t, label) in &p.markers {
        let (x, y) = chart.backend_coord(&(*t, yhi));
        area.draw(&Text::new(
            label.clone(),
            (x - x0, y - y0 - 3),
            style.clone(),
        ))
        .map_err(e)?;
    }
    Ok(())
}
