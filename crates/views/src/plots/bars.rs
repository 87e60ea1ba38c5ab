//! Bar charts: a diagnosis finding's RMS before and after ([`finding_bars`]) and a
//! sensitivity ranking ([`ranking_bars`]).

use super::key::{self, Key, Swatch};
use super::{Area, COLORS, DrawResult, PANEL, TEXT, TITLE, svg, tick};
use mtcal_solver::diagnosis::Finding;
use mtcal_solver::sensitivity::local::ComponentRanking;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

/// Colour of the "before" bars and of the key errors of a ranking.
pub const BEFORE: RGBColor = COLORS[1];
/// Colour of the "after" bars.
pub const AFTER: RGBColor = COLORS[2];
/// Colour of the errors outside the key set.
pub const OTHER: RGBColor = COLORS[7];

fn anchored(size: u32, h: HPos, v: VPos) -> TextStyle<'static> {
    TextStyle::from(("sans-serif", size).into_font()).pos(Pos::new(h, v))
}

/// Residual RMS (on the data fitted) and held-out RMS (on data not fitted), before the
/// finding (the rigid model) and after it, as two pairs of bars; the noise floor (µm)
/// as a dashed line when it is finite and positive.
pub fn finding_bars(f: &Finding, noise_um: f64) -> String {
    let title = match &f.axis {
        Some(a) => format!("{} ({a}): RMS before / after", f.effect),
        None => format!("{}: RMS before / after", f.effect),
    };
    svg(PANEL, &title, |root| finding(root, &title, f, noise_um))
}

fn finding(root: &Area, title: &str, f: &Finding, noise: f64) -> DrawResult {
    let groups = [("fit", f.residual_rms_um), ("held out", f.heldout_rms_um)];
    let top = groups
        .iter()
        .flat_map(|(_, b)| [b.before, b.after])
        .chain(std::iter::once(noise))
        .filter(|v| v.is_finite())
        .fold(0.0f64, f64::max);
    if top <= 0.0 {
        return Err("no RMS".into());
    }
    let mut keys = vec![
        Key::new("before", Swatch::Box, BEFORE),
        Key::new("after", Swatch::Box, AFTER),
    ];
    if noise.is_finite() && noise > 0.0 {
        keys.push(Key::new("noise floor", Swatch::Dashed, BLACK.mix(0.6)));
    }
    let area = key::below(root, &keys)?;
    let mut chart = ChartBuilder::on(&area)
        .caption(title, ("sans-serif", TITLE))
        .margin(8)
        .x_label_area_size(30)
        .y_label_area_size(64)
        .build_cartesian_2d(-0.5f64..1.5f64, 0.0..top * 1.15)?;
    chart
        .configure_mesh()
        .disable_x_mesh()
        .x_labels(0)
        .y_desc("RMS (µm)")
        .y_label_formatter(&tick)
        .label_style(("sans-serif", TEXT))
        .axis_desc_style(("sans-serif", TEXT))
        .light_line_style(WHITE.mix(0.0))
        .draw()?;
    for (i, (name, b)) in groups.iter().enumerate() {
        let x = i as f64;
        for (v, x0, x1, c) in [
            (b.before, x - 0.38, x - 0.02, BEFORE),
            (b.after, x + 0.02, x + 0.38, AFTER),
        ] {
            if v.is_finite() {
                chart.draw_series(std::iter::once(Rectangle::new(
                    [(x0, 0.0), (x1, v)],
                    c.filled(),
                )))?;
            }
        }
        // Under the axis, clear of the bars.
        chart.draw_series(std::iter::once(
            EmptyElement::at((x, 0.0))
                + Text::new(
                    name.to_string(),
                    (0, 6),
                    anchored(TEXT, HPos::Center, VPos::Top),
                ),
        ))?;
    }
    if noise.is_finite() && noise > 0.0 {
        chart.draw_series(DashedLineSeries::new(
            [(-0.5, noise), (1.5, noise)],
            6,
            4,
            BLACK.mix(0.6).stroke_width(1),
        ))?;
    }
    Ok(())
}

/// The first `top` rows of a sensitivity ranking as horizontal bars of the normalised
/// coefficient (%), rank 1 on top; the key errors (the fewest covering the share) in
/// [`BEFORE`]'s colour, the rest grey; each bar labelled with its share.
pub fn ranking_bars(component: &str, r: &ComponentRanking, top: usize) -> String {
    let title = format!("{component}: normalised sensitivity");
    let x_desc = format!(
        "coefficient (%); key errors cover {:.1} %",
        100.0 * r.covered
    );
    svg(RANKING, &title, |root| {
        ranking(root, &title, &x_desc, r, top)
    })
}

/// Size of a ranking, px: drawn in a grid of figures about 430 px wide.
const RANKING: (u32, u32) = (440, 480);

fn ranking(root: &Area, title: &str, x_desc: &str, r: &ComponentRanking, top: usize) -> DrawResult {
    let rows: Vec<_> = r
        .ranking
        .iter()
        .filter(|e| e.coefficient.is_finite())
        .take(top.max(1))
        .collect();
    let xmax = rows
        .iter()
        .map(|e| 100.0 * e.coefficient)
        .fold(0.0f64, f64::max);
    if rows.is_empty() || xmax <= 0.0 {
        return Err("no ranking".into());
    }
    let n = rows.len() as f64;
    let mut chart = ChartBuilder::on(root)
        .caption(title, ("sans-serif", TITLE))
        .margin(12)
        .x_label_area_size(48)
        .y_label_area_size(80)
        .build_cartesian_2d(0.0..xmax * 1.4, -0.5..n - 0.5)?;
    chart
        .configure_mesh()
        .disable_y_mesh()
        .y_labels(0)
        .x_desc(x_desc)
        .x_labels(5)
        .x_label_formatter(&tick)
        .label_style(("sans-serif", TEXT))
        .axis_desc_style(("sans-serif", TEXT))
        .light_line_style(WHITE.mix(0.0))
        .draw()?;
    for (i, e) in rows.iter().enumerate() {
        let y = n - 1.0 - i as f64;
        let v = 100.0 * e.coefficient;
        let c = if r.key_errors.contains(&e.error) {
            BEFORE
        } else {
            OTHER
        };
        chart.draw_series(std::iter::once(Rectangle::new(
            [(0.0, y - 0.35), (v, y + 0.35)],
            c.filled(),
        )))?;
        chart.draw_series([
            Text::new(
                format!("{} ", e.error),
                (0.0, y),
                anchored(TEXT, HPos::Right, VPos::Center),
            ),
            Text::new(
                format!(" {v:.1} %"),
                (v, y),
                anchored(TEXT, HPos::Left, VPos::Center),
            ),
        ])?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plots::inspect::{self, hex};
    use mtcal_solver::diagnosis::BeforeAfter;
    use mtcal_solver::sensitivity::local::RankEntry;

    fn finding() -> Finding {
        Finding {
            effect: "backlash".into(),
            axis: Some("X".into()),
            depends_on: None,
            parameters: Default::default(),
            physics: "lost motion at reversal".into(),
            residual_rms_um: BeforeAfter {
                before: 2.4,
                after: 0.3,
            },
            heldout_rms_um: BeforeAfter {
                before: 2.6,
                after: 0.35,
            },
            evidence: String::new(),
            signature: None,
            undetermined: vec![],
            rivals: Vec::new(),
        }
    }

    #[test]
    fn finding_bars_have_the_heights_of_the_rms() {
        let plot = inspect::parse(&finding_bars(&finding(), 0.25)).unwrap();
        let y = plot.y_axis().unwrap();
        let heights = |c: RGBColor| -> Vec<f64> {
            plot.marks("rect", &hex(c))
                .iter()
                .filter(|m| m.points[1].0 - m.points[0].0 > 14.0) // not the legend swatch
                .map(|m| y.value(m.points[0].1) - y.value(m.points[1].1))
                .map(f64::abs)
                .collect()
        };
        let px = y.scale.recip().abs();
        let before = heights(BEFORE);
        let after = heights(AFTER);
        assert_eq!((before.len(), after.len()), (2, 2), "{:?}", plot.marks);
        for (h, v) in before.iter().zip([2.4, 2.6]) {
            assert!((h - v).abs() < 1.5 * px, "{h} vs {v}");
        }
        for (h, v) in after.iter().zip([0.3, 0.35]) {
            assert!((h - v).abs() < 1.5 * px, "{h} vs {v}");
        }
        assert!(plot.has_text("noise floor") && plot.has_text("held out"));
        assert!(plot.has_text("backlash (X)"));
    }

    #[test]
    fn ranking_bars_are_as_long_as_the_coefficients() {
        let entry = |e: &str, c: f64| RankEntry {
            error: e.into(),
            unit: "urad".into(),
            sensitivity_mean: 0.0,
            sensitivity_max: 0.0,
            contribution_mean_um: 0.0,
            contribution_max_um: 0.0,
            coefficient: c,
        };
        let r = ComponentRanking {
            ranking: vec![
                entry("ECX", 0.4),
                entry("ECZ", 0.3),
                entry("EBX", 0.2),
                entry("EXX", 0.1),
            ],
            key_errors: vec!["ECX".into(), "ECZ".into(), "EBX".into()],
            covered: 0.9,
        };
        let plot = inspect::parse(&ranking_bars("Ex", &r, 3)).unwrap();
        let x = plot.x_axis().unwrap();
        let bars = plot.marks("rect", &hex(BEFORE));
        assert_eq!(bars.len(), 3, "top 3, all key errors");
        assert!(
            plot.marks("rect", &hex(OTHER)).is_empty(),
            "EXX is beyond the top 3"
        );
        // Rank 1 on top, each as long as its coefficient in %.
        assert!(bars[0].points[0].1 < bars[1].points[0].1);
        for (b, v) in bars.iter().zip([40.0, 30.0, 20.0]) {
            let len = x.value(b.points[1].0) - x.value(b.points[0].0);
            assert!((len - v).abs() < 1.5 / x.scale, "{len} vs {v}");
        }
        assert!(plot.has_text("ECX") && plot.has_text("40.0 %") && plot.has_text("90.0 %"));
    }
}
