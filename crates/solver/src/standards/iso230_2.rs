//! ISO 230-2 figures of positioning runs.
//!
//! Reversal value B = max |x̄↑ − x̄↓|, repeatability R = max over targets of
//! max(2s↑ + 2s↓ + |B_i|, 4s↑, 4s↓), systematic positioning error E = max x̄ − min x̄
//! over both directions, accuracy A = max(x̄ + 2s) − min(x̄ − 2s) over both directions
//! (x = measured − target, s: sample standard deviation of a target's readings in one
//! direction).

use crate::axis::Axis;
use crate::datasets::{Direction, PositioningRecord, PositioningRuns};
use serde::{Deserialize, Serialize};

/// ISO 230-2 figures of one axis (bidirectional), µm (module docs).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Iso2302 {
    pub axis: Axis,
    pub reversal_b_um: f64,
    pub repeatability_r_um: f64,
    pub systematic_e_um: f64,
    pub accuracy_a_um: f64,
    pub targets: usize,
    pub runs: usize,
}

/// The distinct targets of `x` (sorted), merged within 1e-6 of the travel.
fn distinct_targets(x: &[f64]) -> Vec<f64> {
    let mut sorted: Vec<f64> = x.to_vec();
    sorted.sort_by(f64::total_cmp);
    let (lo, hi) = (sorted[0], sorted[sorted.len() - 1]);
    let tol = 1e-6 * (hi - lo);
    let mut targets: Vec<f64> = vec![];
    for v in sorted {
        if targets.last().is_none_or(|&l| v - l > tol) {
            targets.push(v);
        }
    }
    targets
}

/// Mean and sample standard deviation of at least two readings.
fn mean_std(v: &[f64]) -> Option<(f64, f64)> {
    if v.len() < 2 {
        return None;
    }
    let m = v.iter().sum::<f64>() / v.len() as f64;
    let s = (v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (v.len() - 1) as f64).sqrt();
    Some((m, s))
}

/// ISO 230-2 figures per axis (module docs); axes with fewer than 2 runs or 5 targets are
/// skipped.
pub fn iso230_2(runs: &PositioningRuns) -> Vec<Iso2302> {
    let mut out = vec![];
    for axis in Axis::ALL {
        let recs: Vec<&PositioningRecord> = runs
            .records
            .iter()
            .filter(|r| r.axis == axis && r.target_mm.is_finite() && r.deviation_um.is_finite())
            .collect();
        if recs.is_empty() {
            continue;
        }
        let x: Vec<f64> = recs.iter().map(|r| r.target_mm).collect();
        let targets = distinct_targets(&x);
        let mut run_ids: Vec<i64> = recs.iter().map(|r| r.run).collect();
        run_ids.sort_unstable();
        run_ids.dedup();
        if targets.len() < 5 || run_ids.len() < 2 {
            continue;
        }
        let tol = 1e-6 * (targets[targets.len() - 1] - targets[0]);
        let readings = |t: f64, dir: Direction| -> Vec<f64> {
            recs.iter()
                .filter(|r| r.direction == dir && (r.target_mm - t).abs() <= tol)
                .map(|r| r.deviation_um)
                .collect()
        };
        let (mut b, mut r, mut hi, mut lo, mut ahi, mut alo) = (
            0.0f64,
            0.0f64,
            f64::NEG_INFINITY,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::INFINITY,
        );
        for &t in &targets {
            let p = mean_std(&readings(t, Direction::Plus));
            let m = mean_std(&readings(t, Direction::Minus));
            for (mu, s) in [p, m].into_iter().flatten() {
                hi = hi.max(mu);
                lo = lo.min(mu);
                ahi = ahi.max(mu + 2.0 * s);
                alo = alo.min(mu - 2.0 * s);
                r = r.max(4.0 * s);
            }
            if let (Some((mp, sp)), Some((mm, sm))) = (p, m) {
                b = b.max((mp - mm).abs());
                r = r.max(2.0 * sp + 2.0 * sm + (mp - mm).abs());
            }
        }
        out.push(Iso2302 {
            axis,
            reversal_b_um: b,
            repeatability_r_um: r,
            systematic_e_um: hi - lo,
            accuracy_a_um: ahi - alo,
            targets: targets.len(),
            runs: run_ids.len(),
        });
    }
    out
}
