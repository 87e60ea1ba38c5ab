//! Polar plots of radial deviations, drawn as on a ballbar plot: the angle θ (degrees,
//! counter-clockwise from +u toward +v of the plane) is the polar angle, and a deviation
//! d (µm) is drawn at radius r = 1 + d/s about a unit reference circle (d = 0, the
//! nominal radius, labelled `R 50 mm` on a circle test). The ring spacing `step` is the
//! smallest of 1, 2, 2.5, 5 × 10ᵏ µm with 2·step ≥ max|d|; s = 5·step, so the dotted
//! rings at ±step and ±2·step sit at r = 1 ± 0.2 and 1 ± 0.4 and bound every point. Each
//! The legend under the plot names the reference circle and the ring spacing, and the
//! outer ring carries its deviation just outside it, where no trace can be (every point
//! lies within the rings). The circle tests of one page share one step
//! ([`circle_step`]), so that their plots compare at a glance.
//!
//! A polar figure is [`CIRCLE`] px wide with text of at least [`MIN_FONT_PX`]
//! px: printed two to a row on A4 (about 330 px wide each) its text stays at least
//! 11 px high.

use super::key::{self, Key, Swatch};
use super::{Area, COLORS, DrawResult, finite_points, svg};
use mtcal_solver::diagnosis::{PlotData, PlotSeries};
use mtcal_solver::standards::iso230_4::CirclePlot;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

/// Size of a polar figure (a circle test's, a diagnosis's), px (module docs).
pub const CIRCLE: (u32, u32) = (400, 520);

/// The smallest text of a circle test's figure in the SVG, px (labels, legend; the
/// title is larger).
pub const MIN_FONT_PX: u32 = 14;

/// The font size asked of plotters for that text: plotters writes a font of size s as
/// `font-size` s/1.24 in SVG, so 18 gives 14.5 px.
const CIRCLE_FONT: u32 = 18;

/// Colours of a circle test's series: `measured ccw`, `model ccw`, `measured cw`,
/// `model cw` (one hue per direction: blue counter-clockwise, red clockwise; the
/// measured trace dark and drawn thick, the model's light and thin).
pub const CIRCLE_COLORS: [RGBColor; 4] = [
    RGBColor(8, 69, 148),
    RGBColor(107, 174, 214),
    RGBColor(165, 15, 21),
    RGBColor(252, 146, 114),
];

/// The smallest 1, 2, 2.5 or 5 × 10ᵏ not below `x` (> 0).
pub(crate) fn nice_ceil(x: f64) -> f64 {
    let e = x.log10().floor();
    let base = 10f64.powf(e);
    [1.0, 2.0, 2.5, 5.0, 10.0]
        .iter()
        .map(|m| m * base)
        .find(|v| *v >= x * (1.0 - 1e-12))
        .unwrap_or(10.0 * base)
}

/// A diagnosis figure of kind `polar` (module docs; angle labels 0°, 45°, …).
/// `step`: the page's ring step (µm; None: the plot's own, [`plot_step`]).
pub(crate) fn render(plot: &PlotData, step: Option<f64>) -> String {
    // The title names the quantity; its unit comes from the axis label ("radial
    // residual (µm)" → "µm").
    let unit = plot
        .y_label
        .rsplit_once('(')
        .map_or(plot.y_label.as_str(), |(_, u)| u.trim_end_matches(')'));
    let title = format!("{} ({unit})", plot.title);
    svg(CIRCLE, &plot.title, |root| {
        draw(
            root,
            &Style {
                title: &title,
                step,
                radius_mm: None,
                font: CIRCLE_FONT,
            },
            &plot.series,
            &|a| format!("{a}°"),
            &|k, _| COLORS[k % COLORS.len()],
        )
    })
}

/// The ring step (µm) of one diagnosis figure of kind `polar`: that of its largest
/// |deviation| (module docs).
pub(crate) fn plot_step(plot: &PlotData) -> f64 {
    step_of(plot.series.iter().flat_map(|s| s.y.iter()))
}

/// The ring step of the largest finite |d| of `ds` (1 µm when there is none).
fn step_of<'a>(ds: impl Iterator<Item = &'a f64>) -> f64 {
    let m = ds
        .filter(|d| d.is_finite())
        .fold(0.0f64, |a, d| a.max(d.abs()));
    if m > 0.0 { nice_ceil(m / 2.0) } else { 1.0 }
}

/// The ring step (µm) that every circle of `all` fits in: the step of the largest
/// |deviation|, measured or modelled, of them all (module docs).
pub fn circle_step(all: &[CirclePlot]) -> f64 {
    step_of(
        all.iter()
            .flat_map(|c| c.measured_um.iter().chain(&c.model_um)),
    )
}

/// A nominal radius as a person writes it: rounded to 1 µm, shortest form (`50`,
/// `12.5`).
pub fn nominal_mm(r: f64) -> String {
    super::tick(&((r * 1e3).round() / 1e3))
}

/// Measured and modelled radial deviation of one circle, both directions when given
/// (series `measured ccw`, `model ccw`, `measured cw`, `model cw`; measured traces drawn
/// thicker), with a legend; rings every `step_um` (the page's [`circle_step`]), the
/// reference circle labelled with the nominal radius. The circles should be of one
/// plane and radius; the title names the first.
pub fn circle_polar(circles: &[CirclePlot], step_um: f64) -> String {
    let Some(first) = circles.first() else {
        return svg(CIRCLE, "circle", |_| Err("no circle".into()));
    };
    let mut series = vec![];
    for c in circles {
        for (what, y) in [("measured", &c.measured_um), ("model", &c.model_um)] {
            series.push(PlotSeries {
                name: format!("{what} {}", c.direction),
                x: c.angle_deg.clone(),
                y: y.clone(),
            });
        }
    }
    let (u, v) = first.plane.axes();
    let title = format!(
        "{} {}, R {} mm, radial deviation",
        first.file,
        first.plane,
        nominal_mm(first.radius_mm)
    );
    let angle = move |a: i32| match a {
        0 => format!("+{u}"),
        90 => format!("+{v}"),
        180 => format!("−{u}"),
        270 => format!("−{v}"),
        _ => String::new(),
    };
    let color = |_: usize, s: &PlotSeries| {
        let model = usize::from(s.name.starts_with("model"));
        let cw = if s.name.ends_with(" cw") { 2 } else { 0 };
        CIRCLE_COLORS[cw + model]
    };
    svg(CIRCLE, &title, |root| {
        draw(
            root,
            &Style {
                title: &title,
                step: Some(step_um),
                radius_mm: Some(first.radius_mm),
                font: CIRCLE_FONT,
            },
            &series,
            &angle,
            &color,
        )
    })
}

/// How a polar plot is drawn: its title, ring step (None: its own data's), the nominal
/// radius that labels the reference circle (None: `0 µm`) and its text size, px.
struct Style<'a> {
    title: &'a str,
    step: Option<f64>,
    radius_mm: Option<f64>,
    font: u32,
}

fn draw(
    root: &Area,
    style: &Style,
    series: &[PlotSeries],
    angle_label: &dyn Fn(i32) -> String,
    color: &dyn Fn(usize, &PlotSeries) -> RGBColor,
) -> DrawResult {
    let pts: Vec<Vec<(f64, f64)>> = series.iter().map(finite_points).collect();
    if pts.iter().all(Vec::is_empty) {
        return Err("no points".into());
    }
    let m = pts.iter().flatten().fold(0.0f64, |a, p| a.max(p.1.abs()));
    let own = if m > 0.0 { nice_ceil(m / 2.0) } else { 1.0 };
    // A shared step smaller than this plot's own would put points outside the rings.
    let step = style.step.map_or(own, |s| s.max(own));
    let scale = 5.0 * step;
    let to_xy = |ang_deg: f64, dev: f64| {
        let r = 1.0 + dev / scale;
        let a = ang_deg.to_radians();
        (r * a.cos(), r * a.sin())
    };
    let font = f64::from(style.font);
    let reference = match style.radius_mm {
        Some(r) => format!("R {} mm", nominal_mm(r)),
        None => "0 µm".to_string(),
    };
    let mut keys = vec![
        Key::new(reference, Swatch::Line, BLACK.mix(0.6)),
        Key::new(
            format!("rings every {} µm", super::tick(&step)),
            Swatch::Dashed,
            BLACK.mix(0.5),
        ),
    ];
    for (k, s) in series.iter().enumerate() {
        let width = if s.name.starts_with("model") { 1 } else { 2 };
        keys.push(Key::new(
            s.name.as_str(),
            Swatch::Line,
            color(k, s).stroke_width(width),
        ));
    }
    // A square plotting area, so that circles stay round.
    let area = root.titled(style.title, ("sans-serif", font + 2.0))?;
    let area = key::below(&area, &keys)?;
    let (w, h) = area.dim_in_pixel();
    let side = w.min(h);
    let area = area.shrink(((w - side) / 2, (h - side) / 2), (side, side));
    // Room outside the rings (r ≤ 1.4) for the angle labels at r = 1.5.
    let mut chart = ChartBuilder::on(&area)
        .margin(4)
        .build_cartesian_2d(-1.9f64..1.9f64, -1.9f64..1.9f64)?;
    let circle = |dev: f64| (0..=360).map(move |a| to_xy(f64::from(a), dev));
    chart.draw_series(LineSeries::new(circle(0.0), BLACK.mix(0.6).stroke_width(1)))?;
    for k in [-2.0, -1.0, 1.0, 2.0] {
        chart.draw_series(DashedLineSeries::new(
            circle(k * step),
            2,
            4,
            BLACK.mix(0.3).stroke_width(1),
        ))?;
    }
    // The outer ring's deviation just outside it along the 67.5° ray (no angle label
    // there), above the ring, where no point of a trace can be.
    let (x, y) = to_xy(67.5, 2.15 * step);
    chart.draw_series(std::iter::once(Text::new(
        format!("+{} µm", super::tick(&(2.0 * step))),
        (x, y),
        ("sans-serif", font)
            .into_font()
            .color(&BLACK.mix(0.75))
            .pos(Pos::new(HPos::Left, VPos::Bottom)),
    )))?;
    for a in (0..360).step_by(45) {
        let (x, y) = to_xy(f64::from(a), 2.1 * step);
        chart.draw_series(LineSeries::new([(0.0, 0.0), (x, y)], BLACK.mix(0.15)))?;
        // Labels outward of the ray's end: left-aligned on the right half, right-aligned
        // on the left half.
        let c = f64::from(a).to_radians().cos();
        let h = if c > 0.1 {
            HPos::Left
        } else if c < -0.1 {
            HPos::Right
        } else {
            HPos::Center
        };
        let text = angle_label(a);
        if text.is_empty() {
            continue;
        }
        let r = 1.5 / (x * x + y * y).sqrt();
        let style =
            TextStyle::from(("sans-serif", font).into_font()).pos(Pos::new(h, VPos::Center));
        chart.draw_series(std::iter::once(Text::new(text, (x * r, y * r), style)))?;
    }
    for (k, (s, p)) in series.iter().zip(&pts).enumerate() {
        let width = if s.name.starts_with("model") { 1 } else { 2 };
        chart.draw_series(LineSeries::new(
            p.iter().map(|&(a, d)| to_xy(a, d)),
            color(k, s).stroke_width(width),
        ))?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plots::inspect::{self, hex};
    use crate::plots::render_svg;

    fn circle(direction: &str, sign: f64) -> CirclePlot {
        let angle_deg: Vec<f64> = (0..360).step_by(5).map(f64::from).collect();
        // An oval: +3 µm along ±u, −3 µm along ±v (a squareness-free scale mismatch).
        let measured_um = angle_deg
            .iter()
            .map(|a| 3.0 * (2.0 * a.to_radians()).cos() + 0.2 * sign)
            .collect();
        let model_um = angle_deg
            .iter()
            .map(|a| 2.8 * (2.0 * a.to_radians()).cos())
            .collect();
        CirclePlot {
            file: "xy.csv".into(),
            run: 3,
            plane: mtcal_solver::Plane::XY,
            direction: direction.into(),
            radius_mm: 50.0,
            centre_mm: [0.0, 0.0],
            feed_mm_min: 500.0,
            start_angle_deg: 0.0,
            angle_deg,
            measured_um,
            model_um,
        }
    }

    #[test]
    fn nice_steps() {
        assert_eq!(nice_ceil(1.6), 2.0);
        assert_eq!(nice_ceil(2.1), 2.5);
        assert_eq!(nice_ceil(0.03), 0.05);
        assert_eq!(nice_ceil(5.0), 5.0);
        assert_eq!(nice_ceil(7.0), 10.0);
    }

    /// Centre and radius (px) of the reference circle: the solid grey polyline of 361
    /// points.
    fn reference(plot: &inspect::Plot) -> ((f64, f64), f64) {
        let r = plot
            .marks
            .iter()
            .find(|m| {
                m.tag == "polyline"
                    && m.points.len() == 361
                    && m.stroke.as_deref() == Some("#000000")
            })
            .expect("reference circle");
        let n = r.points.len() as f64;
        let cx = r.points.iter().map(|p| p.0).sum::<f64>() / n;
        let cy = r.points.iter().map(|p| p.1).sum::<f64>() / n;
        let rad = r
            .points
            .iter()
            .map(|p| ((p.0 - cx).powi(2) + (p.1 - cy).powi(2)).sqrt())
            .sum::<f64>()
            / n;
        ((cx, cy), rad)
    }

    #[test]
    fn both_directions_measured_and_model_at_their_radii() {
        let both = [circle("ccw", 1.0), circle("cw", -1.0)];
        // max|d| = 3.2 µm → step 2 µm, s = 10 µm: 1 µm is r0/10 px.
        assert_eq!(circle_step(&both), 2.0);
        let svg = circle_polar(&both, circle_step(&both));
        let plot = inspect::parse(&svg).unwrap();
        let ((cx, cy), r0) = reference(&plot);
        assert!(plot.has_text("+4 µm") && plot.has_text("rings every 2 µm"));
        // The reference circle is the nominal radius.
        assert!(plot.has_text("R 50 mm") && !plot.has_text("0 µm"));
        assert!(plot.has_text("+X") && plot.has_text("+Y") && plot.has_text("−X"));
        let c = circle("ccw", 1.0);
        for (k, name) in ["measured ccw", "model ccw", "measured cw", "model cw"]
            .iter()
            .enumerate()
        {
            assert!(plot.has_text(name));
            let line = plot.marks("polyline", &hex(CIRCLE_COLORS[k]));
            let line = line.iter().find(|m| m.points.len() == 72).expect(name);
            let sign = if k < 2 { 1.0 } else { -1.0 };
            for (i, p) in line.points.iter().enumerate() {
                let a = c.angle_deg[i];
                let d = if k % 2 == 0 {
                    3.0 * (2.0 * a.to_radians()).cos() + 0.2 * sign
                } else {
                    2.8 * (2.0 * a.to_radians()).cos()
                };
                let (dx, dy) = (p.0 - cx, cy - p.1);
                let r = (dx * dx + dy * dy).sqrt();
                assert!(
                    (r - r0 * (1.0 + d / 10.0)).abs() <= 1.5,
                    "{name} at {a}°: {r} px"
                );
                let ang = dy.atan2(dx).to_degrees().rem_euclid(360.0);
                let diff = (ang - a + 180.0).rem_euclid(360.0) - 180.0;
                assert!(diff.abs() < 1.0, "{name}: angle {ang} vs {a}");
            }
        }
        // Counter-clockwise on screen: 90° (+Y) is above the centre.
        let ccw = plot.marks("polyline", &hex(CIRCLE_COLORS[0]));
        let p90 = ccw.iter().find(|m| m.points.len() == 72).unwrap().points[18];
        assert!(p90.1 < cy - 0.5 * r0);
    }

    /// Every `font-size` of an SVG, px.
    fn font_sizes(svg: &str) -> Vec<f64> {
        svg.split("font-size=\"")
            .skip(1)
            .map(|s| {
                s[..s.find('"').unwrap()]
                    .trim_end_matches("px")
                    .parse()
                    .unwrap()
            })
            .collect()
    }

    /// Readable when printed: every text of a circle plot is at least 14 px in a 400 px
    /// wide figure, so at least 11 px at the narrowest it is drawn (two to a row on A4,
    /// about 330 px); the legend names both directions, measured and model.
    #[test]
    fn circle_plot_text_is_readable_at_print_size() {
        let both = [circle("ccw", 1.0), circle("cw", -1.0)];
        let svg = circle_polar(&both, 2.0);
        let sizes = font_sizes(&svg);
        assert!(sizes.len() >= 10, "{sizes:?}");
        let smallest = sizes.iter().copied().fold(f64::INFINITY, f64::min);
        assert!(smallest >= f64::from(MIN_FONT_PX), "{sizes:?}");
        let printed_px = 330.0;
        assert!(smallest * printed_px / f64::from(CIRCLE.0) >= 11.0);
        assert!(
            svg.contains("viewBox=\"0 0 400 520\""),
            "scales with its figure"
        );
        let plot = inspect::parse(&svg).unwrap();
        for name in ["measured ccw", "model ccw", "measured cw", "model cw"] {
            assert!(plot.has_text(name), "legend lacks {name}");
        }
    }

    /// One radial scale for the circles of a page: a circle of ±0.3 µm drawn with the
    /// page's step of a ±3.2 µm circle gets the same rings (±2, ±4 µm), not its own
    /// (±0.2, ±0.4 µm); a step smaller than a plot's own widens to it (no point leaves
    /// the rings). A radius of 49.999999 mm is the nominal R 50 mm.
    #[test]
    fn circles_of_a_page_share_one_scale() {
        let big = circle("ccw", 1.0);
        let mut small = circle("cw", 1.0);
        small.measured_um.iter_mut().for_each(|d| *d *= 0.1);
        small.model_um.iter_mut().for_each(|d| *d *= 0.1);
        small.radius_mm = 49.999_999;
        let step = circle_step(&[big.clone(), small.clone()]);
        assert_eq!(step, 2.0);
        let alone = inspect::parse(&circle_polar(
            std::slice::from_ref(&small),
            circle_step(std::slice::from_ref(&small)),
        ))
        .unwrap();
        assert!(alone.has_text("+0.4 µm"));
        let shared = inspect::parse(&circle_polar(std::slice::from_ref(&small), step)).unwrap();
        assert!(shared.has_text("+4 µm") && !shared.has_text("+0.4 µm"));
        assert!(shared.has_text("R 50 mm"));
        let widened = inspect::parse(&circle_polar(std::slice::from_ref(&big), 0.2)).unwrap();
        assert!(widened.has_text("+4 µm"));
        assert_eq!(nominal_mm(49.999_999), "50");
        assert_eq!(nominal_mm(12.5), "12.5");
    }

    /// The polar figures of one diagnosis page share one scale: a ±0.3 µm figure drawn
    /// beside a ±3 µm one gets its rings (±2, ±4 µm), not its own (±0.2, ±0.4 µm); a
    /// cartesian figure beside them is untouched.
    #[test]
    fn diagnosis_polar_figures_of_a_page_share_one_scale() {
        use mtcal_solver::diagnosis::PlotKind;
        let big = crate::plots::tests::plot(PlotKind::Polar);
        let mut small = big.clone();
        small
            .series
            .iter_mut()
            .for_each(|s| s.y.iter_mut().for_each(|d| *d *= 0.1));
        assert!(render_svg(&small).contains("+0.4 µm"));
        let line = crate::plots::tests::plot(PlotKind::Cartesian);
        let drawn = crate::plots::render_svgs(&[small, line.clone(), big]);
        assert!(drawn[0].contains("+4 µm") && !drawn[0].contains("+0.4 µm"));
        assert!(drawn[2].contains("+4 µm"));
        assert_eq!(drawn[1], render_svg(&line));
    }

    #[test]
    fn diagnosis_polar_keeps_its_rings() {
        let svg = render_svg(&crate::plots::tests::plot(
            mtcal_solver::diagnosis::PlotKind::Polar,
        ));
        assert!(svg.starts_with("<svg"));
        // max|d| = 3 → step 2 µm.
        assert!(svg.contains("90°") && svg.contains("rings every 2 µm") && svg.contains("+4 µm"));
    }

    #[test]
    fn no_circle_says_so() {
        assert!(circle_polar(&[], 1.0).contains("nothing to draw"));
    }
}
