//! Bar charts: one labelled bar per entry (its name under it, its value over it) and an
//! optional reference line labelled at its end.

use super::legend::{self, text_width, Item, Mark};
use super::{e, DESC, LABEL, PALETTE, TITLE};
use anyhow::Result;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use std::path::Path;
use zmp_files::atomic_write;

/// Width of the y label area, px (the key starts there too).
const LEFT: i32 = 92;

fn text(h: HPos, v: VPos) -> TextStyle<'static> {
    TextStyle::from(("sans-serif", LABEL).into_font())
        .pos(Pos::new(h, v))
        .color(&BLACK)
}

/// `s` on a white box, its bottom at `y` px, centred on `x`.
fn label<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    s: &str,
    (x, y): (i32, i32),
) -> Result<()>
where
    DB::ErrorType: 'static,
{
    let w = text_width(s, LABEL);
    root.draw(&Rectangle::new(
        [(x - w / 2 - 3, y - 17), (x + w / 2 + 3, y + 1)],
        WHITE.mix(0.85).filled(),
    ))
    .map_err(e)?;
    root.draw(&Text::new(
        s.to_string(),
        (x, y),
        text(HPos::Center, VPos::Bottom),
    ))
    .map_err(e)
}

/// A bar's value: four decimals (errors of 0.0036 and ratios of 1.3456 alike), a whole
/// number without them.
fn value(v: f64) -> String {
    if v.fract() == 0.0 && v.abs() < 1e9 {
        format!("{v:.0}")
    } else {
        format!("{v:.4}")
    }
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
    let n = bars.len().max(1);
    // Each bar's slot is wide enough for its name.
    let slot = bars
        .iter()
        .map(|b| text_width(&b.0, LABEL) + 24)
        .max()
        .unwrap_or(0)
        .max(130) as u32;
    // Wide enough for the bars and for the title.
    let w = (slot * n.max(3) as u32 + 140).max(text_width(title, TITLE) as u32 + 40);
    let h = 440u32;
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
            * 1.2;
        let top = if top > 0.0 { top } else { 1.0 };
        // The reference line's key above the plot: a label on the line itself would meet the
        // bar that ends on it (the last model at the noise floor).
        let area = root.titled(title, ("sans-serif", TITLE)).map_err(e)?;
        let items: Vec<Item> = reference
            .iter()
            .map(|(v, name)| Item {
                label: format!("{name} {}", value(*v)),
                mark: Mark::Dashed,
                color: BLACK,
            })
            .collect();
        let (keys, area) = area.split_vertically(legend::height(&items, LEFT, w));
        legend::draw(&keys, &items, LEFT)?;
        let mut chart = ChartBuilder::on(&area)
            .margin(12)
            .x_label_area_size(34)
            .y_label_area_size(LEFT as u32 - 12)
            .build_cartesian_2d(0f64..n as f64, 0f64..top)
            .map_err(e)?;
        chart
            .configure_mesh()
            .disable_x_mesh()
            .x_labels(0)
            .y_desc(y_label)
            .label_style(("sans-serif", LABEL))
            .axis_desc_style(("sans-serif", DESC))
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
        if let Some((v, _)) = reference {
            chart
                .draw_series(DashedLineSeries::new(
                    vec![(0.0, v), (n as f64, v)],
                    6,
                    4,
                    BLACK.stroke_width(1),
                ))
                .map_err(e)?;
        }
        // Values over the bars (after the reference line: a value stays readable on it).
        for (i, b) in bars.iter().enumerate() {
            let (x, y) = chart.backend_coord(&(i as f64 + 0.5, b.1.max(0.0)));
            label(&root, &value(b.1), (x, y - 4))?;
        }
        // Names under the bars, in the x label area.
        for (i, b) in bars.iter().enumerate() {
            let (x, y) = chart.backend_coord(&(i as f64 + 0.5, 0.0));
            root.draw(&Text::new(
                b.0.clone(),
                (x, y + 8),
                text(HPos::Center, VPos::Top),
            ))
            .map_err(e)?;
        }
        root.present().map_err(e)?;
    }
    atomic_write(path, svg.as_bytes(), overwrite)
}
