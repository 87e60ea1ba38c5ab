//! SVG plots, drawn with plotters' SVG backend. Every function returns a whole `<svg>`
//! document (with a `viewBox`, so a page can scale it) and draws only what the data give:
//! nothing is extrapolated, and a quantity the data cannot determine is drawn as a
//! labelled empty panel ([`empty_panel`]), never as a curve.
//!
//! No system fonts are needed: without plotters' `ttf`/`ab_glyph` features text is
//! written as SVG `<text>` elements and laid out with a fixed-width estimate, so labels
//! may sit slightly off where a viewer's font is wider or narrower.
//!
//! * [`render_svg`]: the diagnosis figures ([`PlotData`]): `cartesian` (every series a
//!   line; series whose name starts with `measured` also get a marker per point when
//!   they have at most 120 points; a series whose name contains `split` is drawn dashed,
//!   the train/test boundary of a drift log) and `polar` ([`polar`]).
//! * [`error_function`]: one of the 18 error functions over the measured travel with its
//!   ±2σ band.
//! * [`circle_polar`]: a circle test, measured and modelled radial deviation, both
//!   directions.
//! * [`trend`], [`error_bar_chart`]: values over time (or any x) with ±2σ error bars;
//!   [`rotation_vectors`]: a cradle's rotation vector per A pose.
//! * [`compliance_curve`]: a cradle's compliance term against A with its ±2σ band.
//! * [`sparkline`]: a tiny line without axes.
//! * [`finding_bars`]: a diagnosis finding's RMS before/after, fit and held out.
//! * [`ranking_bars`]: a sensitivity ranking.
//!
//! Tick labels are plain numbers (or dates, `YYYY-MM-DD`), so a reader — and the tests,
//! through [`inspect`] (feature `inspect`) — can recover the data coordinates of every
//! mark from the SVG alone.

use mtcal_solver::diagnosis::{PlotData, PlotKind, PlotSeries};
use plotters::prelude::*;

mod band;
mod bars;
mod errorbars;
#[cfg(any(test, feature = "inspect"))]
pub mod inspect;
mod key;
mod polar;
mod spark;

pub use band::{compliance_curve, empty_panel, error_function, function_band, function_band_on};
pub use bars::{finding_bars, ranking_bars};
pub use errorbars::{
    BarPoint, ErrorBarChart, MISFIT_KEY, PointSeries, TrendPoint, TrendSeries, XScale,
    error_bar_chart, rotation_vectors, trend, unix_seconds,
};
pub use polar::{CIRCLE_COLORS, MIN_FONT_PX, circle_polar, circle_step, nominal_mm};
pub use spark::sparkline;

/// Series colours, in order. Tests find series by these (`#rrggbb` in the SVG).
pub const COLORS: [RGBColor; 8] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(255, 127, 14),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(127, 127, 127),
];

/// Fill of a ±2σ band (drawn with opacity [`BAND_OPACITY`]).
pub const BAND: RGBColor = RGBColor(31, 119, 180);
pub const BAND_OPACITY: f64 = 0.2;

/// The text size asked of plotters for ticks, axis names and legends: plotters writes a
/// font of size s as `font-size` s/1.24 in SVG, so 18 gives 14.5 px, and text stays at
/// least 12 px on screen where a figure is drawn at 83 % of its size or more.
pub(crate) const TEXT: u32 = 18;
/// The text size asked of plotters for a figure's title (16.1 px).
pub(crate) const TITLE: u32 = 20;

/// Size of a full-width figure, px.
pub const SIZE: (u32, u32) = (900, 560);
/// Size of a small-multiple figure (one error function), px.
pub const PANEL: (u32, u32) = (440, 300);

pub(crate) type Area<'a> = DrawingArea<SVGBackend<'a>, plotters::coord::Shift>;
pub(crate) type DrawResult = Result<(), Box<dyn std::error::Error + 'static>>;

/// Runs `draw` on a white SVG canvas of `size`; when it fails (nothing to draw) the
/// canvas says so under `title` instead.
pub(crate) fn svg(size: (u32, u32), title: &str, draw: impl FnOnce(&Area) -> DrawResult) -> String {
    let mut out = String::new();
    {
        let root = SVGBackend::with_string(&mut out, size).into_drawing_area();
        let _ = root.fill(&WHITE);
        if draw(&root).is_err() {
            let _ = root.fill(&WHITE);
            let _ = root.draw(&Text::new(
                format!("{title}: nothing to draw"),
                (20, 20),
                ("sans-serif", 16).into_font(),
            ));
        }
        let _ = root.present();
    }
    out
}

/// A tick label: the value rounded to 6 decimals in its shortest form (`-40`, `2.5`).
pub(crate) fn tick(v: &f64) -> String {
    let r = (v * 1e6).round() / 1e6;
    if r == 0.0 { "0".into() } else { format!("{r}") }
}

/// A position or value as the axes label it (`-40`, `2.5`).
pub fn tick_label(v: f64) -> String {
    tick(&v)
}

pub use mtcal_solver::text::unit_label;

/// Renders one diagnosis figure to an SVG document (module docs); its title and axis
/// labels with units as a person writes them (`µm`, not `um`).
pub fn render_svg(plot: &PlotData) -> String {
    render_one(plot, None)
}

/// Renders the diagnosis figures of one page, the `polar` ones on one radial scale (the
/// ring step of the largest deviation of them all), in order.
pub fn render_svgs(plots: &[PlotData]) -> Vec<String> {
    let step = plots
        .iter()
        .filter(|p| p.kind == PlotKind::Polar)
        .map(polar::plot_step)
        .reduce(f64::max);
    plots.iter().map(|p| render_one(p, step)).collect()
}

/// One diagnosis figure; a `polar` one with rings every `polar_step` µm (None: its own).
fn render_one(plot: &PlotData, polar_step: Option<f64>) -> String {
    let plot = PlotData {
        title: mtcal_solver::text::person_units(&plot.title),
        x_label: mtcal_solver::text::person_units(&plot.x_label),
        y_label: mtcal_solver::text::person_units(&plot.y_label),
        ..plot.clone()
    };
    if plot.kind == PlotKind::Polar {
        polar::render(&plot, polar_step)
    } else {
        svg(SIZE, &plot.title, |root| cartesian(root, &plot))
    }
}

/// The file stem of a plot: its id with every character other than ASCII letters,
/// digits, `_` and `-` replaced by `_` (so an id can never leave the output folder).
pub fn file_stem(plot: &PlotData) -> String {
    plot.id
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '_' || c == '-' {
                c
            } else {
                '_'
            }
        })
        .collect()
}

pub(crate) fn finite_points(s: &PlotSeries) -> Vec<(f64, f64)> {
    s.x.iter()
        .zip(&s.y)
        .map(|(&x, &y)| (x, y))
        .filter(|(x, y)| x.is_finite() && y.is_finite())
        .collect()
}

/// The range of `v` padded by 5 % on each side (a single value gets ±5 % of itself, at
/// least ±0.05); `None` when there is no finite value.
pub(crate) fn range(v: impl Iterator<Item = f64>) -> Option<(f64, f64)> {
    let (lo, hi) = v
        .filter(|x| x.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| {
            (a.min(x), b.max(x))
        });
    if !lo.is_finite() {
        return None;
    }
    let pad = if hi > lo {
        0.05 * (hi - lo)
    } else {
        lo.abs().max(1.0) * 0.05
    };
    Some((lo - pad, hi + pad))
}

fn cartesian(root: &Area, plot: &PlotData) -> DrawResult {
    use key::{Key, Swatch};
    let pts: Vec<Vec<(f64, f64)>> = plot.series.iter().map(finite_points).collect();
    let (x0, x1) = range(pts.iter().flatten().map(|p| p.0)).ok_or("no points")?;
    let (y0, y1) = range(pts.iter().flatten().map(|p| p.1)).ok_or("no points")?;
    let points = plot.kind == PlotKind::Points;
    let width = |s: &PlotSeries| if s.name.starts_with("measured") { 1 } else { 2 };
    let keys: Vec<Key> = plot
        .series
        .iter()
        .enumerate()
        .map(|(k, s)| {
            let style = COLORS[k % COLORS.len()].stroke_width(width(s));
            let swatch = match (points, s.name.contains("split")) {
                (true, _) => Swatch::Dot,
                (false, true) => Swatch::Dashed,
                (false, false) => Swatch::Line,
            };
            Key::new(mtcal_solver::text::person_units(&s.name), swatch, style)
        })
        .collect();
    let area = key::below(root, &keys)?;
    let mut chart = ChartBuilder::on(&area)
        .caption(&plot.title, ("sans-serif", TITLE))
        .margin(12)
        .x_label_area_size(48)
        .y_label_area_size(76)
        .build_cartesian_2d(x0..x1, y0..y1)?;
    chart
        .configure_mesh()
        .x_desc(plot.x_label.as_str())
        .y_desc(plot.y_label.as_str())
        .x_label_formatter(&tick)
        .y_label_formatter(&tick)
        .label_style(("sans-serif", TEXT))
        .axis_desc_style(("sans-serif", TEXT))
        .x_labels(8)
        .light_line_style(WHITE.mix(0.0))
        .draw()?;
    for (k, (s, p)) in plot.series.iter().zip(&pts).enumerate() {
        let color = COLORS[k % COLORS.len()];
        if points {
            // One value per run: marks, not a line through separate runs.
            chart.draw_series(
                p.iter()
                    .map(|&(x, y)| Circle::new((x, y), 4, color.filled())),
            )?;
            continue;
        }
        let style = ShapeStyle::from(&color).stroke_width(width(s));
        if s.name.contains("split") {
            chart.draw_series(DashedLineSeries::new(p.iter().copied(), 6, 4, style))?;
        } else {
            chart.draw_series(LineSeries::new(p.iter().copied(), style))?;
        }
        if s.name.starts_with("measured") && p.len() <= 120 {
            chart.draw_series(
                p.iter()
                    .map(|&(x, y)| Circle::new((x, y), 3, color.filled())),
            )?;
        }
    }
    Ok(())
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    pub(crate) fn plot(kind: PlotKind) -> PlotData {
        let x: Vec<f64> = (0..=72).map(|i| f64::from(i) * 5.0).collect();
        PlotData {
            id: "t".into(),
            title: "title <&>".into(),
            x_label: "angle (deg)".into(),
            y_label: "deviation (µm)".into(),
            kind,
            series: vec![
                PlotSeries {
                    name: "measured".into(),
                    y: x.iter()
                        .map(|a| 3.0 * (2.0 * a.to_radians()).cos())
                        .collect(),
                    x: x.clone(),
                },
                PlotSeries {
                    name: "train | test split".into(),
                    x: vec![100.0, 100.0],
                    y: vec![-3.0, 3.0],
                },
            ],
        }
    }

    #[test]
    fn cartesian_svg_has_series_and_labels() {
        let svg = render_svg(&plot(PlotKind::Cartesian));
        assert!(svg.starts_with("<svg"), "{}", &svg[..80.min(svg.len())]);
        assert!(svg.contains("viewBox=\"0 0 900 560\""));
        assert!(svg.contains("polyline") || svg.contains("<path"));
        assert!(svg.contains("deviation (µm)"));
        assert!(svg.contains("title &lt;&amp;&gt;"), "text must be escaped");
        assert!(
            svg.matches("<circle").count() >= 73,
            "one marker per measured point"
        );
        assert!(
            svg.contains("stroke-dasharray")
                || svg.matches("<line").count() > 2
                || svg.contains("polyline")
        );
    }

    /// One value per run is drawn as separate marks, never a line joining runs; units in
    /// the labels as a person writes them.
    #[test]
    fn points_of_separate_runs_are_not_joined() {
        let mut p = plot(PlotKind::Points);
        p.y_label = "RMS (um)".into();
        p.series = vec![PlotSeries {
            name: "before".into(),
            x: vec![10.0, 200.0, 30.0, 400.0],
            y: vec![1.0, 2.0, 1.5, 0.5],
        }];
        let svg = render_svg(&p);
        assert!(svg.contains("RMS (µm)") && !svg.contains("(um)"), "{svg}");
        let plot = crate::plots::inspect::parse(&svg).unwrap();
        let color = crate::plots::inspect::hex(COLORS[0]);
        assert!(
            plot.marks("polyline", &color).is_empty(),
            "no line through the runs"
        );
        assert!(svg.matches("<circle").count() >= 4, "{svg}");
    }

    #[test]
    fn file_stem_keeps_ids_inside_the_folder() {
        let mut p = plot(PlotKind::Cartesian);
        p.id = "../x y/ch5".into();
        assert_eq!(file_stem(&p), "___x_y_ch5");
    }

    #[test]
    fn empty_plot_still_renders() {
        let mut p = plot(PlotKind::Cartesian);
        p.series.clear();
        let svg = render_svg(&p);
        assert!(svg.contains("nothing to draw"));
    }

    #[test]
    fn tick_labels_are_short_numbers() {
        assert_eq!(tick(&-40.0), "-40");
        assert_eq!(tick(&(0.1 + 0.2)), "0.3");
        assert_eq!(tick(&-0.0), "0");
        assert_eq!(tick(&2.5e-7), "0");
    }
}
