//! Points with ±2σ error bars: trends over time ([`trend`]), a cradle's rotation vector
//! per A pose ([`rotation_vectors`]), or any series ([`error_bar_chart`]).

use super::key::{self, Key, Swatch};
use super::{Area, COLORS, DrawResult, SIZE, TEXT, TITLE, svg, tick};
use mtcal_solver::cradle::PoseRow;
use plotters::prelude::*;

/// One point; `std` is the standard uncertainty (1σ), drawn as a ±2σ bar. A `misfit`
/// point (its model does not explain its recording: not decided) is drawn as a hollow
/// ring without a bar and outside the series' line.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct BarPoint {
    pub x: f64,
    pub y: f64,
    pub std: Option<f64>,
    pub misfit: bool,
}

#[derive(Debug, Clone, PartialEq)]
pub struct PointSeries {
    pub name: String,
    pub points: Vec<BarPoint>,
}

impl PointSeries {
    /// The series `name` of the points `point` makes of `items`, in their order; an item
    /// it makes none of (`None`) is left out.
    pub fn of<T>(name: &str, items: &[T], point: impl Fn(&T) -> Option<BarPoint>) -> Self {
        PointSeries {
            name: name.to_string(),
            points: items.iter().filter_map(point).collect(),
        }
    }
}

/// How x is labelled: numbers, or Unix seconds labelled as dates `YYYY-MM-DD` (with
/// `HH:MM` when a tick falls within a day).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum XScale {
    Linear,
    Time,
}

#[derive(Debug, Clone, PartialEq)]
pub struct ErrorBarChart<'a> {
    pub title: &'a str,
    pub x_label: &'a str,
    pub y_label: &'a str,
    pub x_scale: XScale,
    pub series: &'a [PointSeries],
}

/// The legend entry of misfit points.
pub const MISFIT_KEY: &str = "ring: model misfit, not decided";

/// Size of a trend, px: drawn half a page wide (about 620 px on a 1400 px window), so
/// its text stays at least 12 px.
pub const TREND: (u32, u32) = (640, 440);

const DAY: f64 = 86_400.0;

/// The label of a time axis in days since 1970-01-01: `YYYY-MM-DD` on a whole day,
/// `YYYY-MM-DD HH:MM` otherwise (UTC).
pub(crate) fn date_label(days: &f64) -> String {
    let Ok(t) = time::OffsetDateTime::from_unix_timestamp((days * DAY).round() as i64) else {
        return String::new();
    };
    if (days - days.round()).abs() < 1e-9 {
        t.date().to_string()
    } else {
        format!("{} {:02}:{:02}", t.date(), t.hour(), t.minute())
    }
}

/// Every series as a marker per point joined by a thin line, each point with a vertical
/// bar from y − 2σ to y + 2σ (none where σ is unknown). Points that are not finite are
/// left out.
pub fn error_bar_chart(c: &ErrorBarChart) -> String {
    svg(SIZE, c.title, |root| draw(root, c))
}

/// [`error_bar_chart`] on a canvas of `size` px.
fn error_bar_chart_sized(c: &ErrorBarChart, size: (u32, u32)) -> String {
    svg(size, c.title, |root| draw(root, c))
}

fn finite(p: &BarPoint) -> bool {
    p.x.is_finite() && p.y.is_finite() && p.std.is_none_or(f64::is_finite)
}

fn draw(root: &Area, c: &ErrorBarChart) -> DrawResult {
    // A time axis is drawn in days, so that round ticks fall on midnights.
    let unit = if c.x_scale == XScale::Time { DAY } else { 1.0 };
    let scaled: Vec<PointSeries> = c
        .series
        .iter()
        .map(|s| {
            PointSeries::of(&s.name, &s.points, |p| {
                finite(p).then_some(BarPoint {
                    x: p.x / unit,
                    ..*p
                })
            })
        })
        .collect();
    let pts = || scaled.iter().flat_map(|s| s.points.iter());
    let two = |p: &BarPoint| 2.0 * p.std.unwrap_or(0.0);
    let (mut x0, mut x1) = super::range(pts().map(|p| p.x)).ok_or("no points")?;
    if c.x_scale == XScale::Time && x1 - x0 < 4.0 {
        // Dates label the axis: give it at least a few days.
        let mid = 0.5 * (x0 + x1);
        (x0, x1) = (mid - 2.0, mid + 2.0);
    }
    let (y0, y1) =
        super::range(pts().flat_map(|p| [p.y - two(p), p.y + two(p)])).ok_or("no points")?;
    let mut keys: Vec<Key> = scaled
        .iter()
        .enumerate()
        .map(|(k, s)| Key::new(s.name.as_str(), Swatch::Dot, COLORS[k % COLORS.len()]))
        .collect();
    if pts().any(|p| p.misfit) {
        keys.push(Key::new(MISFIT_KEY, Swatch::Ring, BLACK.stroke_width(2)));
    }
    let area = key::below(root, &keys)?;
    let mut chart = ChartBuilder::on(&area)
        .caption(c.title, ("sans-serif", TITLE))
        .margin(14)
        // Room for half a date label right of the axis's end.
        .margin_right(56)
        .x_label_area_size(48)
        .y_label_area_size(80)
        .build_cartesian_2d(x0..x1, y0..y1)?;
    let dates = date_label;
    let x_fmt: &dyn Fn(&f64) -> String = match c.x_scale {
        XScale::Linear => &tick,
        XScale::Time => &dates,
    };
    chart
        .configure_mesh()
        .x_desc(c.x_label)
        .y_desc(c.y_label)
        .x_label_formatter(x_fmt)
        .y_label_formatter(&tick)
        .label_style(("sans-serif", TEXT))
        .axis_desc_style(("sans-serif", TEXT))
        .x_labels(if c.x_scale == XScale::Time { 5 } else { 8 })
        .light_line_style(WHITE.mix(0.0))
        .draw()?;
    for (k, s) in scaled.iter().enumerate() {
        let color = COLORS[k % COLORS.len()];
        let (misfit, p): (Vec<&BarPoint>, Vec<&BarPoint>) = s.points.iter().partition(|p| p.misfit);
        chart.draw_series(
            misfit
                .iter()
                .map(|p| Circle::new((p.x, p.y), 5, color.stroke_width(2))),
        )?;
        chart.draw_series(LineSeries::new(
            p.iter().map(|p| (p.x, p.y)),
            color.mix(0.5).stroke_width(1),
        ))?;
        chart.draw_series(p.iter().filter(|p| p.std.is_some()).map(|p| {
            ErrorBar::new_vertical(
                p.x,
                p.y - two(p),
                p.y,
                p.y + two(p),
                color.stroke_width(1),
                7,
            )
        }))?;
        chart.draw_series(p.iter().map(|p| Circle::new((p.x, p.y), 4, color.filled())))?;
    }
    Ok(())
}

/// One point of a trend: a result's time (RFC 3339) and a value with its standard
/// uncertainty; `value: None` where the result does not determine it (not drawn);
/// `misfit` when the check's model does not explain its recording (a hollow ring, not
/// decided).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct TrendPoint {
    pub measured_at: String,
    pub value: Option<f64>,
    pub std: Option<f64>,
    pub misfit: bool,
}

#[derive(Debug, Clone, PartialEq)]
pub struct TrendSeries {
    pub name: String,
    pub points: Vec<TrendPoint>,
}

/// Unix seconds of an RFC 3339 time.
pub fn unix_seconds(rfc3339: &str) -> Option<f64> {
    time::OffsetDateTime::parse(rfc3339, &time::format_description::well_known::Rfc3339)
        .ok()
        .map(|t| t.unix_timestamp() as f64)
}

/// Values over time with ±2σ bars, x labelled with dates.
pub fn trend(title: &str, y_label: &str, series: &[TrendSeries]) -> String {
    let series: Vec<PointSeries> = series
        .iter()
        .map(|s| {
            PointSeries::of(&s.name, &s.points, |p| {
                Some(BarPoint {
                    x: unix_seconds(&p.measured_at)?,
                    y: p.value?,
                    std: p.std,
                    misfit: p.misfit,
                })
            })
        })
        .collect();
    error_bar_chart_sized(
        &ErrorBarChart {
            title,
            x_label: "measured at (UTC)",
            y_label,
            x_scale: XScale::Time,
            series: &series,
        },
        TREND,
    )
}

/// The rotation vector of the C-on-A connection per A pose (the pooled variant, which
/// the rigid/compliant choice uses), its three components in µrad with ±2σ bars (the
/// per-component standard uncertainty `std_urad`). A rigid connection gives flat lines.
pub fn rotation_vectors(poses: &[PoseRow]) -> String {
    let series: Vec<PointSeries> = ["x", "y", "z"]
        .iter()
        .enumerate()
        .map(|(i, c)| {
            PointSeries::of(&format!("r{c}"), poses, |p| {
                Some(BarPoint {
                    x: p.a_deg,
                    y: p.rotation_pooled.vector_urad[i],
                    std: Some(p.rotation_pooled.std_urad),
                    misfit: false,
                })
            })
        })
        .collect();
    error_bar_chart(&ErrorBarChart {
        title: "rotation vector of the C-on-A connection per A pose (±2σ)",
        x_label: "A (deg)",
        y_label: "rotation vector (µrad)",
        x_scale: XScale::Linear,
        series: &series,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plots::inspect::{self, hex};

    fn series() -> Vec<TrendSeries> {
        // Quarterly checks: EXX at +50 mm drifting 1.5 µm a quarter; one check where
        // the term was not determined.
        let dates = ["2026-01-05", "2026-04-06", "2026-07-06", "2026-10-05"];
        vec![
            TrendSeries {
                name: "EXX at 50 mm".into(),
                points: dates
                    .iter()
                    .enumerate()
                    .map(|(i, d)| TrendPoint {
                        measured_at: format!("{d}T08:00:00Z"),
                        value: (i != 2).then_some(3.0 + 1.5 * i as f64),
                        std: Some(0.1 + 0.05 * i as f64),
                        misfit: false,
                    })
                    .collect(),
            },
            TrendSeries {
                name: "EXX at -50 mm".into(),
                points: dates
                    .iter()
                    .enumerate()
                    .map(|(i, d)| TrendPoint {
                        measured_at: format!("{d}T08:00:00Z"),
                        value: Some(-2.0 - 0.5 * i as f64),
                        std: None,
                        misfit: false,
                    })
                    .collect(),
            },
        ]
    }

    #[test]
    fn trend_points_and_bars_sit_where_the_values_say() {
        let s = series();
        let svg = trend("EXX", "EXX (µm)", &s);
        let plot = inspect::parse(&svg).unwrap();
        let axes = plot.axes().unwrap();
        let c0 = hex(COLORS[0]);
        // Markers (r = 4) of the first series: 3 (the undetermined check is not drawn).
        let marks: Vec<_> = plot
            .marks("circle", &c0)
            .into_iter()
            .filter(|m| m.r == 4.0 && m.fill.as_deref() == Some(c0.as_str()))
            .collect();
        let expect: Vec<(f64, f64, f64)> = s[0]
            .points
            .iter()
            .filter_map(|p| Some((unix_seconds(&p.measured_at)?, p.value?, p.std?)))
            .collect();
        assert_eq!(marks.len(), 3, "{marks:?}");
        for (m, (t, v, _)) in marks.iter().zip(&expect) {
            let (x, y) = axes.data(m.points[0]);
            // One pixel in x is about a day here; in y about 0.03 µm.
            assert!(
                (x - t).abs() < 1.5 * axes.x.scale.recip().abs(),
                "{x} vs {t}"
            );
            assert!(
                (y - v).abs() < 1.5 * axes.y.scale.recip().abs(),
                "{y} vs {v}"
            );
        }
        // The bars: vertical lines of the series colour from v − 2σ to v + 2σ.
        let bars: Vec<_> = plot
            .marks("line", &c0)
            .into_iter()
            .filter(|m| m.points[0].0 == m.points[1].0 && m.points[0].1 != m.points[1].1)
            .collect();
        assert_eq!(bars.len(), 3);
        for (b, (_, v, s)) in bars.iter().zip(&expect) {
            let lo = axes.y.value(b.points[0].1.max(b.points[1].1));
            let hi = axes.y.value(b.points[0].1.min(b.points[1].1));
            let px = axes.y.scale.recip().abs();
            assert!(
                (lo - (v - 2.0 * s)).abs() < 1.5 * px,
                "{lo} vs {}",
                v - 2.0 * s
            );
            assert!(
                (hi - (v + 2.0 * s)).abs() < 1.5 * px,
                "{hi} vs {}",
                v + 2.0 * s
            );
        }
        // The second series has no uncertainty: markers, no bars.
        let c1 = hex(COLORS[1]);
        assert_eq!(
            plot.marks("circle", &c1)
                .iter()
                .filter(|m| m.r == 4.0)
                .count(),
            4
        );
        assert!(
            plot.marks("line", &c1)
                .iter()
                .all(|m| m.points[0].1 == m.points[1].1),
            "no vertical bar without an uncertainty"
        );
        assert!(plot.has_text("2026-"), "dates on the x axis");
    }

    /// A misfit check's point is a hollow ring at its value, without a ±2σ bar and off
    /// the series' line, and the legend says what a ring means.
    #[test]
    fn a_misfit_point_is_a_ring_without_a_bar() {
        let mut s = series();
        s.truncate(1);
        s[0].points[1].misfit = true;
        let svg = trend("EXX", "EXX (µm)", &s);
        let plot = inspect::parse(&svg).unwrap();
        let axes = plot.axes().unwrap();
        let c0 = hex(COLORS[0]);
        let circles = plot.marks("circle", &c0);
        let rings: Vec<_> = circles
            .iter()
            .filter(|m| m.r == 5.0 && m.fill.as_deref() != Some(c0.as_str()))
            .collect();
        assert_eq!(rings.len(), 1, "{circles:?}");
        let (x, y) = axes.data(rings[0].points[0]);
        let t = unix_seconds(&s[0].points[1].measured_at).unwrap();
        assert!(
            (x - t).abs() < 1.5 * axes.x.scale.recip().abs(),
            "{x} vs {t}"
        );
        assert!((y - 4.5).abs() < 1.5 * axes.y.scale.recip().abs(), "{y}");
        // Two decided points (one check did not determine the term): two bars, none at
        // the ring's x.
        let bars: Vec<_> = plot
            .marks("line", &c0)
            .into_iter()
            .filter(|m| m.points[0].0 == m.points[1].0 && m.points[0].1 != m.points[1].1)
            .collect();
        assert_eq!(bars.len(), 2, "{bars:?}");
        assert!(
            bars.iter()
                .all(|b| (b.points[0].0 - rings[0].points[0].0).abs() > 2.0)
        );
        assert!(plot.has_text(MISFIT_KEY), "the legend names the ring");
        // Without a misfit point, no such legend entry.
        assert!(
            !inspect::parse(&trend("EXX", "EXX (µm)", &series()))
                .unwrap()
                .has_text(MISFIT_KEY)
        );
    }

    #[test]
    fn empty_trend_says_so() {
        let svg = trend("EXX", "EXX (µm)", &[]);
        assert!(svg.contains("nothing to draw"));
    }

    #[test]
    fn a_single_check_still_gets_a_dated_axis() {
        let mut s = series();
        s.truncate(1);
        s[0].points.truncate(1);
        let plot = inspect::parse(&trend("EXX", "EXX (µm)", &s)).unwrap();
        let axes = plot.axes().unwrap();
        // The marker (r = 4), not the legend's swatch (r = 5).
        let m = plot
            .marks("circle", &hex(COLORS[0]))
            .into_iter()
            .find(|m| m.r == 4.0)
            .expect("a marker")
            .points[0];
        let t = unix_seconds("2026-01-05T08:00:00Z").unwrap();
        assert!((axes.x.value(m.0) - t).abs() < 1.5 * axes.x.scale.recip().abs());
    }
}
