//! SVG rendering of the diagnosis plots ([`PlotData`]) with plotters' SVG backend.
//!
//! No system fonts are needed: without plotters' `ttf`/`ab_glyph` features text is
//! written as SVG `<text>` elements and laid out with a fixed-width estimate, so labels
//! may sit slightly off where a viewer's font is wider or narrower.
//!
//! * `cartesian`: every series a line; series whose name starts with `measured` also get
//!   a marker per point when they have at most 120 points; a series whose name contains
//!   `split` is drawn dashed (the train/test boundary of a drift log).
//! * `polar`: x is an angle in degrees, y a radial deviation (µm). Drawn as on a ballbar
//!   plot: r = 1 + y/s on a unit reference circle (dev = 0), s = max|y|/0.4, so the largest
//!   deviation sits 0.4 of the radius off the circle; dotted rings at ±s/2 and ±s, with
//!   the scale written in the caption.

use mtcal_solver::diagnosis::{PlotData, PlotSeries};
use plotters::prelude::*;

const COLORS: [RGBColor; 8] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(255, 127, 14),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(127, 127, 127),
];

const SIZE: (u32, u32) = (900, 560);

/// Renders one plot to an SVG document (module docs).
pub fn render_svg(plot: &PlotData) -> String {
    let mut out = String::new();
    {
        let size = if plot.kind == "polar" {
            (640, 680)
        } else {
            SIZE
        };
        let root = SVGBackend::with_string(&mut out, size).into_drawing_area();
        let _ = root.fill(&WHITE);
        let drawn = if plot.kind == "polar" {
            polar(&root, plot)
        } else {
            cartesian(&root, plot)
        };
        if drawn.is_err() {
            let _ = root.draw(&Text::new(
                format!("{}: nothing to draw", plot.title),
                (20, 20),
                ("sans-serif", 16).into_font(),
            ));
        }
        let _ = root.present();
    }
    out
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

type Area<'a> = DrawingArea<SVGBackend<'a>, plotters::coord::Shift>;
type DrawResult = Result<(), Box<dyn std::error::Error + 'static>>;

fn finite_points(s: &PlotSeries) -> Vec<(f64, f64)> {
    s.x.iter()
        .zip(&s.y)
        .map(|(&x, &y)| (x, y))
        .filter(|(x, y)| x.is_finite() && y.is_finite())
        .collect()
}

fn range(v: impl Iterator<Item = f64>) -> Option<(f64, f64)> {
    let (lo, hi) = v.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| {
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
    let pts: Vec<Vec<(f64, f64)>> = plot.series.iter().map(finite_points).collect();
    let (x0, x1) = range(pts.iter().flatten().map(|p| p.0)).ok_or("no points")?;
    let (y0, y1) = range(pts.iter().flatten().map(|p| p.1)).ok_or("no points")?;
    let mut chart = ChartBuilder::on(root)
        .caption(&plot.title, ("sans-serif", 18))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d(x0..x1, y0..y1)?;
    chart
        .configure_mesh()
        .x_desc(plot.x_label.as_str())
        .y_desc(plot.y_label.as_str())
        .light_line_style(WHITE.mix(0.0))
        .draw()?;
    for (k, (s, p)) in plot.series.iter().zip(&pts).enumerate() {
        let color = COLORS[k % COLORS.len()];
        let style = ShapeStyle::from(&color).stroke_width(if s.name.starts_with("measured") {
            1
        } else {
            2
        });
        if s.name.contains("split") {
            chart
                .draw_series(DashedLineSeries::new(p.iter().copied(), 6, 4, style))?
                .label(s.name.as_str())
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], color));
        } else {
            chart
                .draw_series(LineSeries::new(p.iter().copied(), style))?
                .label(s.name.as_str())
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], color));
        }
        if s.name.starts_with("measured") && p.len() <= 120 {
            chart.draw_series(
                p.iter()
                    .map(|&(x, y)| Circle::new((x, y), 3, color.filled())),
            )?;
        }
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK.mix(0.3))
        .position(SeriesLabelPosition::UpperRight)
        .draw()?;
    Ok(())
}

fn polar(root: &Area, plot: &PlotData) -> DrawResult {
    let pts: Vec<Vec<(f64, f64)>> = plot.series.iter().map(finite_points).collect();
    let m = pts.iter().flatten().fold(0.0f64, |a, p| a.max(p.1.abs()));
    if pts.iter().all(Vec::is_empty) {
        return Err("no points".into());
    }
    let scale = if m > 0.0 { m / 0.4 } else { 1.0 };
    let to_xy = |ang_deg: f64, dev: f64| {
        let r = 1.0 + dev / scale;
        let a = ang_deg.to_radians();
        (r * a.cos(), r * a.sin())
    };
    let mut chart = ChartBuilder::on(root)
        .caption(
            format!(
                "{} (ring spacing {:.3} µm; {})",
                plot.title,
                scale / 2.0,
                plot.y_label
            ),
            ("sans-serif", 16),
        )
        .margin(12)
        .build_cartesian_2d(-1.5f64..1.5f64, -1.5f64..1.5f64)?;
    let circle = |dev: f64| (0..=360).map(move |a| to_xy(f64::from(a), dev));
    chart.draw_series(LineSeries::new(circle(0.0), BLACK.mix(0.6).stroke_width(1)))?;
    for dev in [-scale, -0.5 * scale, 0.5 * scale, scale] {
        chart.draw_series(DashedLineSeries::new(
            circle(dev),
            2,
            4,
            BLACK.mix(0.3).stroke_width(1),
        ))?;
    }
    for a in (0..360).step_by(45) {
        let (x, y) = to_xy(f64::from(a), scale * 1.05);
        chart.draw_series(LineSeries::new([(0.0, 0.0), (x, y)], BLACK.mix(0.15)))?;
        chart.draw_series(std::iter::once(Text::new(
            format!("{a}°"),
            (x * 1.04, y * 1.04),
            ("sans-serif", 12),
        )))?;
    }
    for (k, (s, p)) in plot.series.iter().zip(&pts).enumerate() {
        let color = COLORS[k % COLORS.len()];
        chart
            .draw_series(LineSeries::new(
                p.iter().map(|&(a, d)| to_xy(a, d)),
                color.stroke_width(2),
            ))?
            .label(s.name.as_str())
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], color));
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK.mix(0.3))
        .position(SeriesLabelPosition::LowerRight)
        .draw()?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn plot(kind: &str) -> PlotData {
        let x: Vec<f64> = (0..=72).map(|i| f64::from(i) * 5.0).collect();
        PlotData {
            id: "t".into(),
            title: "title <&>".into(),
            x_label: "angle (deg)".into(),
            y_label: "deviation (µm)".into(),
            kind: kind.into(),
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
        let svg = render_svg(&plot("cartesian"));
        assert!(svg.starts_with("<svg"), "{}", &svg[..80.min(svg.len())]);
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

    #[test]
    fn polar_svg_draws_rings_and_series() {
        let svg = render_svg(&plot("polar"));
        assert!(svg.starts_with("<svg"));
        assert!(
            svg.contains("90°") && svg.contains("ring spacing 3.750 µm"),
            "scale = 3/0.4, rings at half"
        );
    }

    #[test]
    fn file_stem_keeps_ids_inside_the_folder() {
        let mut p = plot("cartesian");
        p.id = "../x y/ch5".into();
        assert_eq!(file_stem(&p), "___x_y_ch5");
    }

    #[test]
    fn empty_plot_still_renders() {
        let mut p = plot("cartesian");
        p.series.clear();
        let svg = render_svg(&p);
        assert!(svg.contains("nothing to draw"));
    }
}
