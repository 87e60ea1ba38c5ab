//! One error function over the measured travel with its ±2σ band, a cradle's compliance
//! term against A with its band, and the labelled empty panel that stands in for a term
//! the data cannot determine.

use super::key::{self, Key, Swatch};
use super::{
    Area, BAND, BAND_OPACITY, COLORS, DrawResult, PANEL, TEXT, TITLE, svg, tick, unit_label,
};
use mtcal_solver::cradle::ComplianceCurve;
use mtcal_solver::identification::TermReport;
use plotters::prelude::*;

/// The moving axis of an ISO 230-1 error name (`EXZ` → `Z`, `EC0Y` → `Y`).
fn moving_axis(name: &str) -> char {
    name.chars().last().unwrap_or('?')
}

/// An empty panel of the small-multiple size with a frame, `title` on top and `message`
/// in the middle: no axes, no curve.
pub fn empty_panel(title: &str, message: &str) -> String {
    svg(PANEL, title, |root| {
        let (w, h) = (PANEL.0 as i32, PANEL.1 as i32);
        root.draw(&Rectangle::new(
            [(1, 1), (w - 2, h - 2)],
            BLACK.mix(0.25).stroke_width(1),
        ))?;
        let style = |size| {
            ("sans-serif", size).into_font().color(&BLACK.mix(0.7)).pos(
                plotters::style::text_anchor::Pos::new(
                    plotters::style::text_anchor::HPos::Center,
                    plotters::style::text_anchor::VPos::Center,
                ),
            )
        };
        root.draw(&Text::new(title.to_string(), (w / 2, 24), style(TITLE)))?;
        // Wrap the message at about 40 characters a line.
        let mut lines: Vec<String> = vec![];
        for word in message.split_whitespace() {
            match lines.last_mut() {
                Some(l) if l.chars().count() + word.chars().count() < 40 => {
                    l.push(' ');
                    l.push_str(word);
                }
                _ => lines.push(word.to_string()),
            }
        }
        let top = h / 2 - 11 * lines.len() as i32;
        for (k, l) in lines.iter().enumerate() {
            root.draw(&Text::new(
                l.clone(),
                (w / 2, top + 22 * k as i32),
                style(TEXT),
            ))?;
        }
        Ok(())
    })
}

/// The function `name` (e.g. `EXX`) as reported: its values at the reported positions
/// joined by a line, and the band value ± 2·std, over `travel_mm` (the measured travel;
/// positions outside it are not drawn). A term that is not identifiable, or has no value
/// inside the travel, is an [`empty_panel`] saying so.
///
/// With a tolerance `limit` (the range limit the verdict applied, in the term's unit) the
/// panel draws the band the function must stay within to pass: two dashed lines a limit
/// apart, centred on the middle of the function's range (a range limit fixes the width,
/// not the place), named with its rounded value and unit under the panel ("range limit
/// 8.33 µm").
pub fn error_function(
    name: &str,
    term: &TermReport,
    travel_mm: Option<[f64; 2]>,
    limit: Option<f64>,
) -> String {
    let unit = unit_label(&term.unit);
    let title = format!("{name} ({unit})");
    if !term.identifiable {
        let with = if term.confounded_with.is_empty() {
            "no effect in this plan".to_string()
        } else {
            format!(
                "cannot be separated from {}",
                term.confounded_with.join(", ")
            )
        };
        return empty_panel(&title, &format!("not identifiable: {with}"));
    }
    let inside = |q: f64| travel_mm.is_none_or(|[lo, hi]| q >= lo && q <= hi);
    let pts: Vec<(f64, f64, f64)> = term
        .positions_mm
        .iter()
        .zip(&term.values)
        .zip(&term.std)
        .map(|((&q, &v), &s)| (q, v, s))
        .filter(|&(q, _, _)| inside(q))
        .collect();
    let limit = limit.filter(|l| l.is_finite() && *l > 0.0);
    if limit.is_none() || pts.len() < 2 {
        return function_band(name, &title, &pts);
    }
    let x_desc = format!("{} (mm)", moving_axis(name));
    svg(PANEL, &title, |root| {
        band(root, &x_desc, &title, &pts, None, limit.map(|l| (l, unit)))
    })
}

/// A function of position `name` (its last letter names the axis) from points
/// (position mm, value, standard uncertainty): the values joined by a line and the band
/// value ± 2·std, over the points' span only. Points whose position or value is not
/// finite are left out; the band is drawn only when every uncertainty is known (finite);
/// fewer than two points make an [`empty_panel`].
pub fn function_band(name: &str, title: &str, points: &[(f64, f64, f64)]) -> String {
    function_band_on(name, title, points, None)
}

/// [`function_band`] with the value axis spanning at least `y_range` (a scale shared by
/// several panels, so that a small change is drawn small); points beyond it widen it.
pub fn function_band_on(
    name: &str,
    title: &str,
    points: &[(f64, f64, f64)],
    y_range: Option<(f64, f64)>,
) -> String {
    let pts: Vec<(f64, f64, f64)> = points
        .iter()
        .copied()
        .filter(|&(q, v, _)| q.is_finite() && v.is_finite())
        .collect();
    if pts.len() < 2 {
        return empty_panel(title, "no values inside the measured travel");
    }
    let x_desc = format!("{} (mm)", moving_axis(name));
    svg(PANEL, title, |root| {
        band(root, &x_desc, title, &pts, y_range, None)
    })
}

/// A cradle's compliance term against A (the chosen model's, over the measured A range
/// only) with the band value ± 2·std; fewer than two finite values make an
/// [`empty_panel`].
pub fn compliance_curve(c: &ComplianceCurve) -> String {
    let title = format!("{} ({})", c.name, unit_label(&c.unit));
    let pts: Vec<(f64, f64, f64)> = c
        .a_deg
        .iter()
        .zip(&c.value)
        .zip(&c.std)
        .map(|((&a, &v), &s)| (a, v, s))
        .filter(|&(a, v, _)| a.is_finite() && v.is_finite())
        .collect();
    if pts.len() < 2 {
        return empty_panel(&title, "no values over the measured A range");
    }
    svg(PANEL, &title, |root| {
        band(root, "A (°)", &title, &pts, None, None)
    })
}

fn band(
    root: &Area,
    x_desc: &str,
    title: &str,
    pts: &[(f64, f64, f64)],
    y_range: Option<(f64, f64)>,
    limit: Option<(f64, &str)>,
) -> DrawResult {
    let unit = limit.map_or("", |l| l.1);
    let limit = limit.map(|l| l.0);
    let x0 = pts[0].0;
    // The tolerance band: a range limit's width about the middle of the values' range.
    let (vmin, vmax) = pts
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
            (a.min(p.1), b.max(p.1))
        });
    // A limit far wider than the data (more than FAR_LIMIT times their span with the
    // band) is named, not drawn: drawn, it would flatten the function to a line.
    let span = pts
        .iter()
        .map(|p| p.1 + 2.0 * p.2.max(0.0))
        .fold(f64::NEG_INFINITY, f64::max)
        - pts
            .iter()
            .map(|p| p.1 - 2.0 * p.2.max(0.0))
            .fold(f64::INFINITY, f64::min);
    let far = limit.filter(|l| !(span > 0.0 && *l <= FAR_LIMIT * span));
    let limits = limit
        .filter(|_| far.is_none())
        .map(|l| ((vmin + vmax) / 2.0 - l / 2.0, (vmin + vmax) / 2.0 + l / 2.0));
    let y_range = match (y_range, limits) {
        (Some((a, b)), Some((l, h))) => Some((a.min(l), b.max(h))),
        (None, Some(lh)) => Some(lh),
        (r, None) => r,
    };
    let x1 = pts[pts.len() - 1].0;
    let with_band = pts.iter().all(|p| p.2.is_finite());
    let u = |p: &(f64, f64, f64)| if with_band { 2.0 * p.2 } else { 0.0 };
    let lo = pts.iter().map(|p| p.1 - u(p));
    let hi = pts.iter().map(|p| p.1 + u(p));
    // With a shared scale the panel's own extremes widen the shared range before the one
    // padding, so that panels within it get exactly the same axis.
    let (y0, y1) = match y_range {
        Some((a, b)) => {
            let (raw_lo, raw_hi) = lo
                .chain(hi)
                .filter(|v| v.is_finite())
                .fold((a, b), |(l, h), v| (l.min(v), h.max(v)));
            super::range([raw_lo, raw_hi].into_iter())
        }
        None => super::range(lo.chain(hi)),
    }
    .ok_or("no points")?;
    let keys: Vec<Key> = match (far, limits) {
        (Some(l), _) => vec![Key::new(
            format!("range limit {} {unit} (beyond this scale)", rounded(l)),
            Swatch::None,
            LIMIT,
        )],
        (None, Some(_)) => vec![Key::new(
            format!("range limit {} {unit}", rounded(limit.unwrap_or(f64::NAN))),
            Swatch::Dashed,
            LIMIT,
        )],
        (None, None) => vec![],
    };
    let area = key::below(root, &keys)?;
    let mut chart = ChartBuilder::on(&area)
        .caption(title, ("sans-serif", TITLE))
        .margin(8)
        .x_label_area_size(44)
        .y_label_area_size(64)
        .build_cartesian_2d(x0..x1, y0..y1)?;
    chart
        .configure_mesh()
        .x_desc(x_desc)
        .x_label_formatter(&tick)
        .y_label_formatter(&tick)
        .label_style(("sans-serif", TEXT))
        .axis_desc_style(("sans-serif", TEXT))
        .x_labels(5)
        .y_labels(6)
        .light_line_style(WHITE.mix(0.0))
        .draw()?;
    if with_band {
        let upper = pts.iter().map(|p| (p.0, p.1 + 2.0 * p.2));
        let lower = pts.iter().rev().map(|p| (p.0, p.1 - 2.0 * p.2));
        chart.draw_series(std::iter::once(Polygon::new(
            upper.chain(lower).collect::<Vec<_>>(),
            BAND.mix(BAND_OPACITY).filled(),
        )))?;
    }
    chart.draw_series(LineSeries::new(
        pts.iter().map(|p| (p.0, p.1)),
        COLORS[0].stroke_width(2),
    ))?;
    if let Some((l, h)) = limits {
        for y in [l, h] {
            chart.draw_series(DashedLineSeries::new(
                [(x0, y), (x1, y)],
                6,
                4,
                LIMIT.stroke_width(1),
            ))?;
        }
    }
    Ok(())
}

/// A range limit wider than this many times the data's span (with their band) is named
/// on the panel instead of drawn.
const FAR_LIMIT: f64 = 5.0;

/// A limit as its label gives it: three significant digits, shortest form (8.333333 →
/// `8.33`, 1000 → `1000`, 0.0125 → `0.0125`).
pub(crate) fn rounded(v: f64) -> String {
    if v == 0.0 || !v.is_finite() {
        return tick(&v);
    }
    let digits = 2 - v.abs().log10().floor() as i32;
    let f = 10f64.powi(digits);
    tick(&((v * f).round() / f))
}

/// The colour of a tolerance's lines.
pub const LIMIT: RGBColor = RGBColor(0xb0, 0x30, 0x30);

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plots::inspect::{self, hex};

    fn term(identifiable: bool) -> TermReport {
        // EXX = 2 µm/100 mm · q + 1e-4 µm/mm² · q², std growing away from 0.
        let positions_mm: Vec<f64> = (-10..=10).map(|k| f64::from(k) * 5.0).collect();
        TermReport {
            unit: "um".into(),
            values: positions_mm
                .iter()
                .map(|q| 0.02 * q + 1e-4 * q * q)
                .collect(),
            std: positions_mm
                .iter()
                .map(|q| 0.05 + 0.002 * q.abs())
                .collect(),
            positions_mm,
            identifiable,
            confounded_with: if identifiable {
                vec![]
            } else {
                vec!["EYX".into(), "ECX".into()]
            },
            coefficients: vec![0.02, 1e-4, 0.0],
            coefficient_covariance: vec![],
        }
    }

    #[test]
    fn line_and_band_sit_where_the_values_say() {
        let t = term(true);
        let svg = error_function("EXX", &t, Some([-50.0, 50.0]), None);
        let plot = inspect::parse(&svg).unwrap();
        let axes = plot.axes().unwrap();
        let line = plot.marks("polyline", &hex(COLORS[0]));
        assert_eq!(line.len(), 1, "one curve");
        assert_eq!(line[0].points.len(), 21, "one vertex per reported position");
        // Each vertex at (q, value) within a pixel, read through the tick labels.
        for (p, (q, v)) in line[0]
            .points
            .iter()
            .zip(t.positions_mm.iter().zip(&t.values))
        {
            assert!((axes.x.px(*q) - p.0).abs() <= 1.0, "x of {q}");
            assert!((axes.y.px(*v) - p.1).abs() <= 1.0, "y of {q}");
        }
        // The band: upper edge value + 2σ forward, lower edge value − 2σ backward.
        let band = plot.marks("polygon", &hex(BAND));
        assert_eq!(band.len(), 1);
        let b = &band[0].points;
        assert_eq!(b.len(), 42);
        for (i, q) in t.positions_mm.iter().enumerate() {
            let up = t.values[i] + 2.0 * t.std[i];
            let down = t.values[i] - 2.0 * t.std[i];
            assert!((axes.y.px(up) - b[i].1).abs() <= 1.0, "upper edge at {q}");
            assert!(
                (axes.y.px(down) - b[41 - i].1).abs() <= 1.0,
                "lower edge at {q}"
            );
        }
        // At q = 50 the band is 4σ = 4·0.15 µm wide: in pixels, 0.6 µm on the y scale.
        let width = (b[20].1 - b[21].1).abs();
        assert!((width - 0.6 * axes.y.scale.abs()).abs() <= 1.5, "{width}");
        assert!((band[0].opacity - BAND_OPACITY).abs() < 1e-9);
    }

    #[test]
    fn nothing_is_drawn_outside_the_measured_travel() {
        let t = term(true);
        let svg = error_function("EXX", &t, Some([-20.0, 30.0]), None);
        let plot = inspect::parse(&svg).unwrap();
        let axes = plot.axes().unwrap();
        let line = &plot.marks("polyline", &hex(COLORS[0]))[0];
        assert_eq!(line.points.len(), 11, "-20, -15, …, 30");
        let xs: Vec<f64> = line.points.iter().map(|p| axes.x.value(p.0)).collect();
        assert!(
            (xs[0] + 20.0).abs() < 0.5 && (xs[10] - 30.0).abs() < 0.5,
            "{xs:?}"
        );
        // The x axis spans the travel, not beyond: no tick label outside it.
        for t in plot.texts.iter().filter(|t| t.anchor == "middle") {
            if let Some(v) = inspect::label_value(&t.content) {
                assert!((-20.0..=30.0).contains(&v), "tick {v}");
            }
        }
    }

    #[test]
    fn a_term_that_is_not_identifiable_is_an_empty_labelled_panel() {
        let svg = error_function("EAX", &term(false), Some([-50.0, 50.0]), None);
        let plot = inspect::parse(&svg).unwrap();
        assert!(plot.has_text("EAX (µm)"));
        assert!(plot.has_text("not identifiable"));
        assert!(plot.has_text("EYX") && plot.has_text("ECX"));
        assert!(
            plot.marks
                .iter()
                .all(|m| m.tag != "polyline" && m.tag != "polygon" && m.tag != "circle"),
            "no curve, band or marker: {:?}",
            plot.marks
        );
        assert!(plot.axes().is_err(), "no axes");
    }

    #[test]
    fn without_uncertainties_the_line_has_no_band() {
        let pts = [(0.0, 0.0, f64::NAN), (10.0, 1.0, 0.1), (20.0, 3.0, 0.1)];
        let plot = inspect::parse(&function_band("EXX", "EXX b − a", &pts)).unwrap();
        assert_eq!(plot.marks("polyline", &hex(COLORS[0]))[0].points.len(), 3);
        assert!(plot.marks("polygon", &hex(BAND)).is_empty());
    }

    #[test]
    fn a_term_without_values_in_the_travel_is_an_empty_panel() {
        let svg = error_function("EXX", &term(true), Some([200.0, 300.0]), None);
        assert!(svg.contains("no values inside the measured travel"));
        assert!(!svg.contains("<polyline"));
    }

    /// A compliance curve against A: the line through the values, the band ± 2σ, the x
    /// axis in degrees over the curve's A range only.
    #[test]
    fn compliance_curve_is_drawn_against_a_with_its_band() {
        let a_deg: Vec<f64> = (0..=12).map(|k| -90.0 + 15.0 * f64::from(k)).collect();
        let c = ComplianceCurve {
            term: mtcal_solver::cradle::Term::MountX,
            name: "tilt about the mount, X: τ_X(A)".into(),
            unit: "urad".into(),
            value: a_deg.iter().map(|a| 60.0 * a.to_radians().sin()).collect(),
            std: a_deg
                .iter()
                .map(|a| 2.0 * a.to_radians().sin().abs())
                .collect(),
            a_deg: a_deg.clone(),
        };
        let plot = inspect::parse(&compliance_curve(&c)).unwrap();
        assert!(plot.has_text("tilt about the mount, X: τ_X(A) (µrad)"));
        assert!(plot.has_text("A (°)"));
        let axes = plot.axes().unwrap();
        let line = &plot.marks("polyline", &hex(COLORS[0]))[0];
        assert_eq!(line.points.len(), 13);
        for (p, (a, v)) in line.points.iter().zip(a_deg.iter().zip(&c.value)) {
            assert!((axes.x.px(*a) - p.0).abs() <= 1.0 && (axes.y.px(*v) - p.1).abs() <= 1.0);
        }
        let band = &plot.marks("polygon", &hex(BAND))[0].points;
        assert_eq!(band.len(), 26);
        let up = c.value[12] + 2.0 * c.std[12];
        assert!(
            (axes.y.px(up) - band[12].1).abs() <= 1.0,
            "upper edge at A = 90"
        );
        for t in plot.texts.iter().filter(|t| t.anchor == "middle") {
            if let Some(v) = inspect::label_value(&t.content) {
                assert!((-90.0..=90.0).contains(&v), "tick {v}");
            }
        }
        let empty = ComplianceCurve {
            a_deg: vec![0.0],
            value: vec![1.0],
            std: vec![0.1],
            ..c
        };
        assert!(compliance_curve(&empty).contains("no values over the measured A range"));
    }

    #[test]
    fn a_range_limit_is_drawn_as_a_band_a_limit_wide_about_the_middle_of_the_range() {
        // EXX rises linearly from -1 to +1 µm over ±50 mm: range 2 µm, middle 0.
        let mut t = term(true);
        t.positions_mm = vec![-50.0, 0.0, 50.0];
        t.values = vec![-1.0, 0.0, 1.0];
        t.std = vec![0.01; 3];
        let svg = error_function("EXX", &t, Some([-50.0, 50.0]), Some(5.0));
        let plot = inspect::parse(&svg).unwrap();
        let axes = plot.axes().unwrap();
        // The dashes in the chart, right of the legend's swatch (at x < 40 px).
        let dashes: Vec<_> = plot
            .marks("polyline", &hex(LIMIT))
            .into_iter()
            .filter(|m| m.points[0].0 > 40.0)
            .collect();
        assert!(!dashes.is_empty(), "{svg}");
        let mut ys: Vec<f64> = dashes.iter().map(|m| axes.y.value(m.points[0].1)).collect();
        ys.sort_by(f64::total_cmp);
        let px = 1.5 / axes.y.scale.abs();
        assert!(
            (ys[0] + 2.5).abs() <= px && (ys[ys.len() - 1] - 2.5).abs() <= px,
            "{ys:?}"
        );
        assert!(plot.has_text("range limit 5 µm"), "the limit with its unit");
        let without = error_function("EXX", &t, Some([-50.0, 50.0]), None);
        assert!(!without.contains("range limit"));
        // A limit of 1 mm is named, not drawn: the function keeps its scale.
        let far = inspect::parse(&error_function(
            "EXX",
            &t,
            Some([-50.0, 50.0]),
            Some(1000.0),
        ))
        .unwrap();
        assert!(
            far.marks("polyline", &hex(LIMIT)).is_empty(),
            "no line, no swatch"
        );
        assert!(far.has_text("range limit 1000 µm (beyond this scale)"));
        let axes = far.axes().unwrap();
        assert!(axes.y.value(0.0) < 5.0, "the scale stays the data's");
        // A limit scaled to the travel is labelled as rounded, with its unit.
        let scaled = inspect::parse(&error_function(
            "EXX",
            &t,
            Some([-50.0, 50.0]),
            Some(25.0 / 3.0),
        ))
        .unwrap();
        assert!(scaled.has_text("range limit 8.33 µm"), "{:?}", scaled.texts);
        assert_eq!(rounded(0.012_54), "0.0125");
        assert_eq!(rounded(1234.5), "1230");
    }
}
