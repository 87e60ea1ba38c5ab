//! Legends drawn outside the data: a strip under the chart holds one entry per series
//! (a swatch and its name), laid out in rows as wide as the figure; the chart is drawn
//! in what is left above it, so that no legend covers a point.

use super::{Area, DrawResult, TEXT};
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

/// How a legend entry shows its series.
#[derive(Debug, Clone, Copy)]
pub(crate) enum Swatch {
    /// A line of the series' style.
    Line,
    /// A dashed line.
    Dashed,
    /// A filled box (bars, a band).
    Box,
    /// A filled dot (markers).
    Dot,
    /// A hollow ring (a point that is not decided).
    Ring,
    /// Text only (a note such as a limit beyond the scale).
    None,
}

/// One legend entry: its name, swatch and the style the swatch is drawn in.
#[derive(Debug, Clone)]
pub(crate) struct Key {
    pub name: String,
    pub swatch: Swatch,
    pub style: ShapeStyle,
}

impl Key {
    pub(crate) fn new(
        name: impl Into<String>,
        swatch: Swatch,
        style: impl Into<ShapeStyle>,
    ) -> Self {
        Key {
            name: name.into(),
            swatch,
            style: style.into(),
        }
    }
}

/// Height of one row of the strip, px.
const ROW: i32 = 24;
/// Width of a swatch and the gap after it and after an entry, px.
const SWATCH: i32 = 22;
const GAP: i32 = 6;
const SPACING: i32 = 18;

/// The width `text` takes at the legend's size, px: an upper estimate (0.62 em a
/// character), since without fonts the figure cannot measure it.
pub(crate) fn text_width(text: &str) -> i32 {
    let em = f64::from(TEXT) / 1.24;
    (text.chars().count() as f64 * 0.62 * em).ceil() as i32
}

/// The entries of each row in a strip `width` px wide.
fn rows(keys: &[Key], width: i32) -> Vec<Vec<&Key>> {
    let mut rows: Vec<Vec<&Key>> = vec![];
    let mut used = width;
    for k in keys {
        let w = entry_width(k);
        if used + w > width && !rows.last().is_some_and(Vec::is_empty) {
            rows.push(vec![]);
            used = 0;
        }
        rows.last_mut().expect("a row").push(k);
        used += w + SPACING;
    }
    rows
}

fn entry_width(k: &Key) -> i32 {
    let swatch = if matches!(k.swatch, Swatch::None) {
        0
    } else {
        SWATCH + GAP
    };
    swatch + text_width(&k.name)
}

/// Draws `keys` in a strip at the bottom of `root` and returns the area above it (all
/// of `root` when there are no keys).
pub(crate) fn below<'a>(
    root: &Area<'a>,
    keys: &[Key],
) -> Result<Area<'a>, Box<dyn std::error::Error>> {
    if keys.is_empty() {
        return Ok(root.clone());
    }
    let (w, h) = root.dim_in_pixel();
    let margin = 10;
    let rows = rows(keys, w as i32 - 2 * margin);
    let strip = ROW * rows.len() as i32 + 6;
    let (chart, legend) = root.split_vertically(h as i32 - strip);
    draw_rows(&legend, &rows, margin)?;
    Ok(chart)
}

fn draw_rows(area: &Area, rows: &[Vec<&Key>], margin: i32) -> DrawResult {
    let font =
        TextStyle::from(("sans-serif", TEXT).into_font()).pos(Pos::new(HPos::Left, VPos::Center));
    for (r, row) in rows.iter().enumerate() {
        let y = ROW * r as i32 + ROW / 2;
        let mut x = margin;
        for k in row {
            let s = k.style;
            match k.swatch {
                Swatch::Line => area.draw(&PathElement::new(vec![(x, y), (x + SWATCH, y)], s))?,
                Swatch::Dashed => {
                    for d in [0, 8, 16] {
                        area.draw(&PathElement::new(vec![(x + d, y), (x + d + 5, y)], s))?;
                    }
                }
                Swatch::Box => area.draw(&Rectangle::new(
                    [(x + 5, y - 6), (x + 17, y + 6)],
                    s.filled(),
                ))?,
                Swatch::Dot => area.draw(&Circle::new((x + SWATCH / 2, y), 5, s.filled()))?,
                Swatch::Ring => area.draw(&Circle::new((x + SWATCH / 2, y), 5, s))?,
                Swatch::None => {}
            }
            let tx = if matches!(k.swatch, Swatch::None) {
                x
            } else {
                x + SWATCH + GAP
            };
            area.draw(&Text::new(k.name.clone(), (tx, y), font.clone()))?;
            x += entry_width(k) + SPACING;
        }
    }
    Ok(())
}
