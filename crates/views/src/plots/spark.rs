//! A sparkline: a small line of values in order, without axes, the last point marked.

use super::{COLORS, svg};
use plotters::prelude::*;

/// Size of a sparkline, px.
pub const SPARK: (u32, u32) = (120, 28);

/// The finite values of `values`, in order, scaled to fill the box (2 px inset); a
/// single value is a dot in the middle. Empty (no finite value): an empty box.
pub fn sparkline(values: &[f64]) -> String {
    let v: Vec<(f64, f64)> = values
        .iter()
        .enumerate()
        .filter(|(_, y)| y.is_finite())
        .map(|(i, &y)| (i as f64, y))
        .collect();
    svg(SPARK, "sparkline", |root| draw(root, &v))
}

fn draw(root: &super::Area, v: &[(f64, f64)]) -> super::DrawResult {
    let (lo, hi) = v
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
            (a.min(p.1), b.max(p.1))
        });
    if !lo.is_finite() {
        return Ok(());
    }
    let (lo, hi) = if hi > lo {
        (lo, hi)
    } else {
        (lo - 1.0, hi + 1.0)
    };
    let n = v.len() as f64;
    let (x0, x1) = if n > 1.0 { (0.0, n - 1.0) } else { (-1.0, 1.0) };
    let mut chart = ChartBuilder::on(root)
        .margin(3)
        .build_cartesian_2d(x0..x1, lo..hi)?;
    let color = COLORS[0];
    chart.draw_series(LineSeries::new(v.iter().copied(), color.stroke_width(1)))?;
    if let Some(&last) = v.last() {
        chart.draw_series(std::iter::once(Circle::new(last, 2, color.filled())))?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plots::inspect::{self, hex};

    #[test]
    fn sparkline_follows_the_values() {
        let values = [1.0, 3.0, f64::NAN, 2.0, 5.0];
        let plot = inspect::parse(&sparkline(&values)).unwrap();
        assert_eq!((plot.width, plot.height), (120.0, 28.0));
        let line = &plot.marks("polyline", &hex(COLORS[0]))[0];
        assert_eq!(line.points.len(), 4, "the NaN is left out");
        // Higher values higher up (smaller y); the maximum at the top inset, the
        // minimum at the bottom one.
        let ys: Vec<f64> = line.points.iter().map(|p| p.1).collect();
        assert!(ys[0] > ys[2] && ys[2] > ys[1] && ys[1] > ys[3], "{ys:?}");
        assert!(ys[3] <= 4.0 && ys[0] >= 24.0, "{ys:?}");
        // Proportional: (3 − 1)/(5 − 1) of the height between min and max.
        let frac = (ys[0] - ys[1]) / (ys[0] - ys[3]);
        assert!((frac - 0.5).abs() < 0.06, "{frac}");
        assert!(plot.texts.is_empty(), "no axes or labels");
    }

    #[test]
    fn degenerate_sparklines_render() {
        for v in [&[][..], &[f64::NAN][..], &[2.0][..], &[2.0, 2.0][..]] {
            let s = sparkline(v);
            assert!(s.starts_with("<svg"), "{v:?}");
            assert!(inspect::parse(&s).is_ok());
        }
    }
}
