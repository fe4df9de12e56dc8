//! Legends as a row of keys above the plot, wrapped to the panel's width: a legend never
//! covers a curve or a point, whatever the data.

use super::{Band, BodeSeries, Style, TimeSeries, LABEL as FONT};
use anyhow::Result;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

/// Height of one row of keys, px.
const ROW: i32 = 20;
/// Length of a key's line, px.
const KEY: i32 = 24;
/// Space after a key's label, px.
const GAP: i32 = 20;

/// How a key is drawn.
#[derive(Debug, Clone, Copy)]
pub(super) enum Mark {
    Line,
    Dashed,
    Points,
    Band,
}

/// One key: a mark in a colour and its label.
#[derive(Debug, Clone)]
pub(super) struct Item {
    pub label: String,
    pub mark: Mark,
    pub color: RGBColor,
}

impl Item {
    fn of(label: &str, style: Style, color: RGBColor) -> Item {
        Item {
            label: label.to_string(),
            mark: match style {
                Style::Line => Mark::Line,
                Style::Dashed => Mark::Dashed,
                Style::Points => Mark::Points,
            },
            color,
        }
    }
}

/// The keys of a Bode diagram: its bands, then its series.
pub(super) fn bode_items(bands: &[Band], series: &[BodeSeries]) -> Vec<Item> {
    bands
        .iter()
        .map(|b| Item {
            label: b.label.clone(),
            mark: Mark::Band,
            color: b.color,
        })
        .chain(series.iter().map(|s| Item::of(&s.label, s.style, s.color)))
        .collect()
}

/// The keys of a time panel's series.
pub(super) fn time_items(series: &[TimeSeries]) -> Vec<Item> {
    series
        .iter()
        .map(|s| Item::of(&s.label, s.style, s.color))
        .collect()
}

/// Width of `text` at plotters' font size `size` (`size / 1.24` px on the page), px: 0.55 em
/// a character, a little above the mean advance of a sans-serif font on lower-case text
/// (0.5 em), so that estimates err towards space.
pub(super) fn text_width(text: &str, size: u32) -> i32 {
    (0.55 * size as f64 / 1.24 * text.chars().count() as f64).ceil() as i32
}

/// Where each key goes (x, row), keys left to right from `left`, wrapped at `width`.
fn layout(items: &[Item], left: i32, width: i32) -> Vec<(i32, i32)> {
    let mut out = Vec::with_capacity(items.len());
    let (mut x, mut row) = (left, 0);
    for it in items {
        let w = KEY + 6 + text_width(&it.label, FONT);
        if x > left && x + w > width {
            x = left;
            row += 1;
        }
        out.push((x, row));
        x += w + GAP;
    }
    out
}

/// Height the keys need in an area `width` px wide, px (0 without keys).
pub(super) fn height(items: &[Item], left: i32, width: u32) -> u32 {
    layout(items, left, width as i32)
        .last()
        .map_or(0, |&(_, row)| ((row + 1) * ROW + 4) as u32)
}

fn e<T: std::fmt::Debug>(x: T) -> anyhow::Error {
    anyhow::anyhow!("plotting the legend: {x:?}")
}

/// Draws the keys into `area` (laid out as [`height`] measured them).
pub(super) fn draw<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    items: &[Item],
    left: i32,
) -> Result<()>
where
    DB::ErrorType: 'static,
{
    let width = area.dim_in_pixel().0 as i32;
    let style = TextStyle::from(("sans-serif", FONT).into_font())
        .pos(Pos::new(HPos::Left, VPos::Center))
        .color(&BLACK);
    for (it, (x, row)) in items.iter().zip(layout(items, left, width)) {
        let y = row * ROW + ROW / 2 + 2;
        let c = it.color;
        match it.mark {
            Mark::Line => area
                .draw(&PathElement::new(
                    vec![(x, y), (x + KEY, y)],
                    c.stroke_width(2),
                ))
                .map_err(e)?,
            Mark::Dashed => {
                for (a, b) in [(0, 7), (10, 16), (19, KEY)] {
                    area.draw(&PathElement::new(
                        vec![(x + a, y), (x + b, y)],
                        c.stroke_width(2),
                    ))
                    .map_err(e)?;
                }
            }
            Mark::Points => area
                .draw(&Circle::new((x + KEY / 2, y), 4, c.filled()))
                .map_err(e)?,
            Mark::Band => area
                .draw(&Rectangle::new(
                    [(x, y - 6), (x + KEY, y + 6)],
                    c.mix(0.3).filled(),
                ))
                .map_err(e)?,
        }
        area.draw(&Text::new(
            it.label.clone(),
            (x + KEY + 6, y),
            style.clone(),
        ))
        .map_err(e)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn item(label: &str) -> Item {
        Item {
            label: label.into(),
            mark: Mark::Line,
            color: BLACK,
        }
    }

    #[test]
    fn keys_wrap_at_the_width_and_never_overlap() {
        let items: Vec<Item> = [
            "measured (2 sigma)",
            "identified model",
            "seed (SILO2 paper)",
        ]
        .iter()
        .map(|l| item(l))
        .collect();
        // Wide enough for all three: one row; narrow: the third wraps to a second row.
        let one = layout(&items, 50, 2000);
        assert!(one.iter().all(|&(_, r)| r == 0));
        let w = |k: usize| KEY + 6 + text_width(&items[k].label, FONT);
        let narrow = 50 + w(0) + GAP + w(1) + 10;
        let two = layout(&items, 50, narrow);
        assert_eq!(two.iter().map(|p| p.1).collect::<Vec<_>>(), [0, 0, 1]);
        assert_eq!(two[2].0, 50);
        for k in 0..2 {
            assert!(two[k].0 + w(k) < two[k + 1].0 || two[k + 1].1 > two[k].1);
        }
        assert_eq!(height(&items, 50, narrow as u32), (2 * ROW + 4) as u32);
        assert_eq!(height(&[], 50, 100), 0);
    }
}
