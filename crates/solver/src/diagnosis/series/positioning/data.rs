//! One axis's positioning records: validation, the derived coordinates (normalised
//! position, approach direction, travel since the reversal, time, temperature) and the
//! model-independent noise floor (the parent module's docs).

use crate::axis::Axis;
use crate::datasets::{Direction, PositioningRecord};
use crate::diagnosis::repeatability::{self, Repeatability};
use crate::diagnosis::temperature::Smoother;
use crate::error::SolverError;

/// One axis's records in file (measurement) order.
pub(super) struct AxisData {
    pub(super) axis: Axis,
    pub(super) x: Vec<f64>,
    pub(super) s: Vec<f64>,
    pub(super) d: Vec<f64>,
    pub(super) u: Vec<f64>,
    pub(super) time: Vec<f64>,
    pub(super) time_in_s: bool,
    /// The logged temperature smoothed ([`Smoother`]), minus its smoothed value at the
    /// first record (K), when every record logs `temp_c`.
    pub(super) temp: Option<Vec<f64>>,
    /// The smoother of the logged temperature (in `time`'s unit).
    pub(super) smoother: Option<Smoother>,
    pub(super) y: Vec<f64>,
    pub(super) run: Vec<i64>,
    pub(super) runs: Vec<i64>,
    pub(super) lo: f64,
    pub(super) hi: f64,
    pub(super) spacing: f64,
    pub(super) targets: Vec<f64>,
    /// (target index, direction) group of each record.
    pub(super) group: Vec<usize>,
    /// Whether each record belongs to the first cycle (the run of the first record).
    pub(super) first: Vec<bool>,
    /// Time of the first cycle's first record (the time unit of `time`).
    pub(super) t_first: f64,
    /// Median time step between successive records of the first cycle, and its duration.
    pub(super) first_step: f64,
    pub(super) first_duration: f64,
}

impl AxisData {
    pub(super) fn new(axis: Axis, recs: &[&PositioningRecord]) -> Result<AxisData, SolverError> {
        let n = recs.len();
        let x: Vec<f64> = recs.iter().map(|r| r.target_mm).collect();
        let (lo, hi) = x
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
                (a.min(v), b.max(v))
            });
        if hi <= lo || hi.is_nan() {
            return Err(SolverError::InvalidInput(format!(
                "axis {axis}: all targets at the same position"
            )));
        }
        let tol = 1e-6 * (hi - lo);
        let mut targets: Vec<f64> = vec![];
        let mut sorted = x.clone();
        sorted.sort_by(f64::total_cmp);
        for v in sorted {
            if targets.last().is_none_or(|&l| v - l > tol) {
                targets.push(v);
            }
        }
        if targets.len() < 5 {
            return Err(SolverError::InvalidInput(format!(
                "axis {axis}: {} distinct targets, at least 5 needed",
                targets.len()
            )));
        }
        let mut runs: Vec<i64> = recs.iter().map(|r| r.run).collect();
        runs.sort_unstable();
        runs.dedup();
        if runs.len() < 2 {
            return Err(SolverError::InvalidInput(format!(
                "axis {axis}: {} run(s); at least 2 are needed to hold whole runs out",
                runs.len()
            )));
        }
        let mut gaps: Vec<f64> = targets.windows(2).map(|w| w[1] - w[0]).collect();
        gaps.sort_by(f64::total_cmp);
        let spacing = gaps[gaps.len() / 2];
        let tidx = |v: f64| {
            targets
                .iter()
                .position(|&t| (t - v).abs() <= tol)
                .unwrap_or(0)
        };
        let d: Vec<f64> = recs
            .iter()
            .map(|r| {
                if r.direction == Direction::Plus {
                    1.0
                } else {
                    -1.0
                }
            })
            .collect();
        let time_in_s = recs.iter().all(|r| r.t_s.is_some());
        let time: Vec<f64> = if time_in_s {
            let t0 = recs
                .iter()
                .map(|r| r.t_s.unwrap_or(0.0))
                .fold(f64::INFINITY, f64::min);
            recs.iter().map(|r| r.t_s.unwrap_or(0.0) - t0).collect()
        } else {
            (0..n).map(|i| i as f64).collect()
        };
        // A logged temperature is a noisy measurement: the columns follow its smoother
        // (the same as sessions', `diagnosis::temperature`), fitted in record time over
        // the whole axis, the noise estimate's differences taken within each run.
        let smoother = recs.iter().all(|r| r.temp_c.is_some()).then(|| {
            let raw: Vec<f64> = recs.iter().map(|r| r.temp_c.unwrap_or(0.0)).collect();
            let mut ranges = Vec::new();
            let mut start = 0;
            for i in 1..=n {
                if i == n || recs[i].run != recs[start].run {
                    ranges.push(start..i);
                    start = i;
                }
            }
            Smoother::fit(&time, &raw, &ranges)
        });
        let temp = smoother
            .as_ref()
            .map(|sm| time.iter().map(|&t| sm.delta(t)).collect());
        let (c, h) = (0.5 * (lo + hi), 0.5 * (hi - lo));
        let first: Vec<bool> = recs.iter().map(|r| r.run == recs[0].run).collect();
        let t1: Vec<f64> = (0..n).filter(|&i| first[i]).map(|i| time[i]).collect();
        let t_first = t1.iter().copied().fold(f64::INFINITY, f64::min);
        let first_duration = t1.iter().copied().fold(f64::NEG_INFINITY, f64::max) - t_first;
        let mut steps: Vec<f64> = t1
            .windows(2)
            .map(|w| (w[1] - w[0]).abs())
            .filter(|v| *v > 0.0)
            .collect();
        steps.sort_by(f64::total_cmp);
        let first_step = steps.get(steps.len() / 2).copied().unwrap_or(1.0);
        Ok(AxisData {
            first,
            t_first,
            first_step,
            first_duration: first_duration.max(first_step),
            axis,
            s: x.iter().map(|v| (v - c) / h).collect(),
            u: x.iter()
                .zip(&d)
                .map(|(v, &dd)| if dd > 0.0 { v - lo } else { hi - v })
                .collect(),
            group: x
                .iter()
                .zip(&d)
                .map(|(&v, &dd)| 2 * tidx(v) + usize::from(dd < 0.0))
                .collect(),
            y: recs.iter().map(|r| r.deviation_um).collect(),
            run: recs.iter().map(|r| r.run).collect(),
            x,
            d,
            time,
            time_in_s,
            temp,
            smoother,
            runs,
            lo,
            hi,
            spacing,
            targets,
        })
    }
}

impl AxisData {
    pub(super) fn n(&self) -> usize {
        self.y.len()
    }

    pub(super) fn time_unit(&self) -> &'static str {
        if self.time_in_s { "s" } else { "records" }
    }

    /// Pass (run × direction) of each record, as dense indices from 0.
    pub(super) fn pass_index(&self) -> Vec<usize> {
        let key = |i: usize| (self.run[i], self.d[i] > 0.0);
        let mut passes: Vec<(i64, bool)> = (0..self.n()).map(key).collect();
        passes.sort_unstable();
        passes.dedup();
        (0..self.n())
            .map(|i| passes.binary_search(&key(i)).unwrap_or(0))
            .collect()
    }

    /// Model-independent noise floor (module docs): the robust repeatability of the
    /// two-way layout of group means and pass offsets, outlying approaches set aside
    /// ([`crate::diagnosis::repeatability`]).
    pub(super) fn repeatability(&self) -> Result<Repeatability, SolverError> {
        repeatability::repeatability(&self.group, &self.pass_index(), &self.y)
            .map_err(|e| SolverError::InvalidInput(format!("axis {}: {e}", self.axis)))
    }

    /// "run R + at 15.0 mm" for record `i`.
    pub(super) fn place(&self, i: usize) -> String {
        format!(
            "run {} {} at {:.1} mm",
            self.run[i],
            if self.d[i] > 0.0 { "+" } else { "−" },
            self.x[i]
        )
    }
}
