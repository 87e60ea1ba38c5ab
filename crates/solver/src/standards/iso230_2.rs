//! ISO 230-2:2014 figures of an axis: accuracy and repeatability of positioning.
//!
//! Readings: x_ij = measured − target position (µm) at target P_i (i = 1..m), run j, for
//! the approach with increasing command (↑, [`Direction::Plus`]) and decreasing command
//! (↓). With n↑, n↓ the readings per target and direction:
//!
//! | figure | formula |
//! |---|---|
//! | mean unidirectional deviation | x̄_i↑ = (1/n↑) Σ_j x_ij↑, x̄_i↓ likewise |
//! | mean bidirectional deviation | x̄_i = (x̄_i↑ + x̄_i↓)/2 |
//! | reversal value at a target | B_i = x̄_i↑ − x̄_i↓ |
//! | standard uncertainty estimator | s_i↑ = √(Σ_j (x_ij↑ − x̄_i↑)² / (n↑ − 1)), s_i↓ likewise |
//! | unidirectional repeatability | R_i↑ = 4 s_i↑, R_i↓ = 4 s_i↓ |
//! | bidirectional repeatability | R_i = max(2 s_i↑ + 2 s_i↓ + \|B_i\|, R_i↑, R_i↓) |
//! | reversal value of the axis | B = max_i \|B_i\| |
//! | mean reversal value | B̄ = (1/m) Σ_i B_i |
//! | repeatability of the axis | R↑ = max_i R_i↑, R↓ = max_i R_i↓, R = max_i R_i |
//! | systematic positional deviation | E↑ = max x̄_i↑ − min x̄_i↑, E↓ likewise; E = max(x̄_i↑, x̄_i↓) − min(x̄_i↑, x̄_i↓) |
//! | range of mean bidirectional deviation | M = max x̄_i − min x̄_i |
//! | accuracy | A↑ = max(x̄_i↑ + 2 s_i↑) − min(x̄_i↑ − 2 s_i↑), A↓ likewise; A = max over both directions of (x̄ + 2s) − min over both of (x̄ − 2s) |
//!
//! E is not max(E↑, E↓) and R is not max(R↑, R↓): both take the two directions together.
//!
//! **Uncertainty** of each figure (the `u` map): the sampling standard uncertainty from
//! the run-to-run scatter, at the targets that determine the figure (first-order; the
//! instrument's own uncertainty is not included): u(x̄) = s/√n, u(s) = s/√(2(n − 1)),
//! combined in quadrature through the figure's formula (e.g. u(E↑) = √(u(x̄_max)² +
//! u(x̄_min)²), u(R_i↑) = 4 u(s_i↑), u(A↑) from u(x̄ ± 2s) = √(s²/n + 4 u(s)²)).
//!
//! **Line passes of a session** ([`from_session`]): each pass of a line test at constant
//! feed is read as one approach of a bidirectional run over evenly spaced targets of the
//! line's common travel (deviation at a target: local straight-line fit of the samples of
//! that pass within a small window). It is not a standstill test, and a grid encoder's
//! zero is set per run, so each pass is referred to its mean over the targets: a constant
//! reversal (lost motion) is not observed and B̄ is 0 by construction. The result says so.

use crate::axis::Axis;
use crate::datasets::{Direction, PositioningRecord, PositioningRuns};
use crate::error::SolverError;
use crate::standards::{NotEvaluated, ScalarFigure, extremes};
use crate::text::{num, signed};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

mod line_passes;
pub use line_passes::{from_session, line_target_count};

/// Where the readings of an ISO 230-2 evaluation come from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
#[serde(rename_all = "snake_case")]
pub enum Source {
    /// Standstill readings of a positioning-run file (datasets contract, section 3).
    PositioningRuns,
    /// Constant-feed line passes of a grid-encoder session (module docs).
    LinePasses,
}

/// One reading: deviation `x` = measured − target (µm) at a target, in one run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Reading {
    pub target_mm: f64,
    /// Approach with increasing command (↑).
    pub up: bool,
    /// Run (or pass) identifier.
    pub run: i64,
    pub deviation_um: f64,
}

/// The per-target figures (module table), µm.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct TargetFigures {
    pub target_mm: f64,
    pub n_up: usize,
    pub n_down: usize,
    /// x̄_i↑
    pub mean_up_um: f64,
    /// x̄_i↓
    pub mean_down_um: f64,
    /// x̄_i
    pub mean_um: f64,
    /// s_i↑
    pub s_up_um: f64,
    /// s_i↓
    pub s_down_um: f64,
    /// B_i = x̄_i↑ − x̄_i↓ (signed)
    #[serde(rename = "B_um")]
    pub b_um: f64,
    /// R_i↑ = 4 s_i↑
    #[serde(rename = "R_up_um")]
    pub r_up_um: f64,
    /// R_i↓ = 4 s_i↓
    #[serde(rename = "R_down_um")]
    pub r_down_um: f64,
    /// R_i = max(2 s_i↑ + 2 s_i↓ + |B_i|, R_i↑, R_i↓)
    #[serde(rename = "R_um")]
    pub r_um: f64,
}

/// ISO 230-2 figures of one axis (module docs), µm. A figure this recording cannot give
/// ([`Iso2302::not_available`]: for grid-encoder line passes, every figure that depends
/// on each pass's zero) is `None` (`null` in the document), its reason stated once for the
/// list of figures it applies to in the standards' `not_available`
/// ([`crate::standards::Standards`]). A document of an earlier version holding a number
/// there reads back with the number withheld ([`Iso2302::values`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct Iso2302 {
    pub axis: Axis,
    pub source: Source,
    /// Session file the passes come from (line passes only).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub file: Option<String>,
    /// Head offset of that file, mm (line passes only).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub head_offset_mm: Option<[f64; 3]>,
    /// Sentences qualifying the figures (how the readings were taken, departures from the
    /// standard's test cycle).
    #[serde(default)]
    pub notes: Vec<String>,
    /// Number of targets m.
    pub targets: usize,
    /// Number of runs (distinct run or pass identifiers).
    pub runs: usize,
    /// Smallest number of readings per target in the ↑ and in the ↓ direction.
    pub n_up: usize,
    pub n_down: usize,
    pub per_target: Vec<TargetFigures>,
    /// B = max |B_i|
    #[serde(rename = "B_um")]
    pub reversal_b_um: Option<f64>,
    /// B̄ = mean B_i
    #[serde(rename = "B_mean_um")]
    pub mean_reversal_b_um: Option<f64>,
    /// R↑ = max R_i↑
    #[serde(rename = "R_up_um")]
    pub repeatability_r_up_um: Option<f64>,
    /// R↓ = max R_i↓
    #[serde(rename = "R_down_um")]
    pub repeatability_r_down_um: Option<f64>,
    /// R = max R_i
    #[serde(rename = "R_um")]
    pub repeatability_r_um: Option<f64>,
    /// E↑
    #[serde(rename = "E_up_um")]
    pub systematic_e_up_um: Option<f64>,
    /// E↓
    #[serde(rename = "E_down_um")]
    pub systematic_e_down_um: Option<f64>,
    /// E (both directions together)
    #[serde(rename = "E_um")]
    pub systematic_e_um: Option<f64>,
    /// M = max x̄_i − min x̄_i
    #[serde(rename = "M_um")]
    pub mean_range_m_um: Option<f64>,
    /// A↑
    #[serde(rename = "A_up_um")]
    pub accuracy_a_up_um: Option<f64>,
    /// A↓
    #[serde(rename = "A_down_um")]
    pub accuracy_a_down_um: Option<f64>,
    /// A (both directions together)
    #[serde(rename = "A_um")]
    pub accuracy_a_um: Option<f64>,
    /// Standard uncertainty of each axis figure, keyed by its name (`E_um`, ...), µm (none
    /// for a figure that is not available).
    pub u: BTreeMap<String, f64>,
    /// When the outlier test of the repeated readings sets readings aside: the readings
    /// and the axis figures without them (the figures above are the standard's, with every
    /// reading).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub without_outlying: Option<WithoutOutlying>,
}

/// A reading the outlier test of the repeated readings set aside
/// ([`crate::diagnosis::repeatability`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct OutlyingReading {
    pub run: i64,
    pub target_mm: f64,
    /// Approach with increasing command (↑).
    pub up: bool,
    /// The reading x = measured − target, µm.
    pub deviation_um: f64,
    /// Its distance from the other runs' readings at the same target and direction (the
    /// two-way layout of target means and pass offsets fitted without it), µm.
    pub off_um: f64,
    /// Its studentised residual, against the critical value `critical_t`.
    pub t: f64,
}

/// The axis figures without the outlying readings (the standard's own figures keep them).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct WithoutOutlying {
    /// The readings set aside, largest |t| first.
    pub readings: Vec<OutlyingReading>,
    /// Bonferroni critical value of the outlier test (familywise rate 1 % per axis).
    pub critical_t: f64,
    /// The axis figures ([`FIGURES`] names) without those readings, µm.
    pub figures: BTreeMap<String, f64>,
    /// Their standard uncertainties, µm.
    pub u: BTreeMap<String, f64>,
    /// The figures those readings dominate: changed by more than [`DOMINATES`] of their
    /// value when the readings are left out.
    pub dominated: Vec<String>,
}

/// A figure changed by more than this fraction when the outlying readings are left out
/// is dominated by them.
pub const DOMINATES: f64 = 0.10;

/// Names of the axis figures, in the order of [`Iso2302::values`].
pub const FIGURES: [&str; 12] = [
    "B_um",
    "B_mean_um",
    "R_up_um",
    "R_down_um",
    "R_um",
    "E_up_um",
    "E_down_um",
    "E_um",
    "M_um",
    "A_up_um",
    "A_down_um",
    "A_um",
];

impl Iso2302 {
    /// The axis figures in [`FIGURES`] order; `None` for one that is not available
    /// (also when an earlier version's document holds a number for it).
    pub fn values(&self) -> [Option<f64>; 12] {
        let all = [
            self.reversal_b_um,
            self.mean_reversal_b_um,
            self.repeatability_r_up_um,
            self.repeatability_r_down_um,
            self.repeatability_r_um,
            self.systematic_e_up_um,
            self.systematic_e_down_um,
            self.systematic_e_um,
            self.mean_range_m_um,
            self.accuracy_a_up_um,
            self.accuracy_a_down_um,
            self.accuracy_a_um,
        ];
        let mut i = 0;
        all.map(|v| {
            i += 1;
            v.filter(|_| self.not_available(FIGURES[i - 1]).is_none())
        })
    }

    /// Why figure `name` ([`FIGURES`]) is not available from this recording (None: it
    /// is): for line passes, every figure that depends on each pass's zero
    /// ([`depends_on_zero`]).
    pub fn not_available(&self, name: &str) -> Option<&'static str> {
        (self.source == Source::LinePasses && depends_on_zero(name)).then_some(NOT_FROM_LINE_PASSES)
    }

    /// The figures that are not available withheld: `None`, without their uncertainty,
    /// and out of the figures without the outlying readings.
    fn withhold(&mut self) {
        let [b, bm, ru, rd, r, eu, ed, e, m, au, ad, a] = self.values();
        self.reversal_b_um = b;
        self.mean_reversal_b_um = bm;
        self.repeatability_r_up_um = ru;
        self.repeatability_r_down_um = rd;
        self.repeatability_r_um = r;
        self.systematic_e_up_um = eu;
        self.systematic_e_down_um = ed;
        self.systematic_e_um = e;
        self.mean_range_m_um = m;
        self.accuracy_a_up_um = au;
        self.accuracy_a_down_um = ad;
        self.accuracy_a_um = a;
        for name in FIGURES {
            if self.not_available(name).is_some() {
                self.u.remove(name);
                if let Some(w) = &mut self.without_outlying {
                    w.figures.remove(name);
                    w.u.remove(name);
                    w.dominated.retain(|d| d != name);
                }
            }
        }
    }

    /// The available axis figures as stored scalars, named `iso230_2.<axis>.<figure>`
    /// (the ones [`Iso2302::not_available`] names are left out).
    pub fn scalar_figures(&self) -> Vec<ScalarFigure> {
        FIGURES
            .iter()
            .zip(self.values())
            .filter_map(|(name, value)| Some((name, value?)))
            .map(|(name, value)| ScalarFigure {
                name: format!("iso230_2.{}.{name}", self.axis),
                value,
                u: self.u.get(*name).copied(),
            })
            .collect()
    }
}

/// Readings of one target and direction: mean, s, n.
#[derive(Debug, Clone, Copy)]
struct Stats {
    mean: f64,
    s: f64,
    n: usize,
}

impl Stats {
    fn of(v: &[f64]) -> Option<Stats> {
        if v.len() < 2 {
            return None;
        }
        let n = v.len();
        let mean = v.iter().sum::<f64>() / n as f64;
        let s = (v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1) as f64).sqrt();
        Some(Stats { mean, s, n })
    }
    /// u(x̄) = s/√n
    fn u_mean(&self) -> f64 {
        self.s / (self.n as f64).sqrt()
    }
    /// u(s) = s/√(2(n − 1))
    fn u_s(&self) -> f64 {
        self.s / (2.0 * (self.n - 1) as f64).sqrt()
    }
    /// u(x̄ ± 2s)
    fn u_band(&self) -> f64 {
        (self.u_mean().powi(2) + 4.0 * self.u_s().powi(2)).sqrt()
    }
}

/// Range max − min with its uncertainty √(u_max² + u_min²).
fn range(v: impl IntoIterator<Item = (f64, f64)>) -> (f64, f64) {
    let (hi, lo) = extremes(v);
    (hi.0 - lo.0, hi.1.hypot(lo.1))
}

/// Distinct targets of `x` (sorted), merged within 1e-6 of the travel.
fn distinct_targets(x: &[f64]) -> Vec<f64> {
    let mut sorted: Vec<f64> = x.to_vec();
    sorted.sort_by(f64::total_cmp);
    let tol = 1e-6 * (sorted[sorted.len() - 1] - sorted[0]);
    let mut targets: Vec<f64> = vec![];
    for v in sorted {
        if targets.last().is_none_or(|&l| v - l > tol) {
            targets.push(v);
        }
    }
    targets
}

/// ISO 230-2 figures of one axis from its readings (module docs). Every target needs at
/// least two readings in each direction; at least two targets. When the outlier test of
/// the repeated readings ([`crate::diagnosis::repeatability`]) sets readings aside, the
/// figures without them are added (`without_outlying`) with a note naming the figures
/// they dominate; the figures themselves are the standard's, with every reading.
pub fn evaluate(axis: Axis, source: Source, readings: &[Reading]) -> Result<Iso2302, SolverError> {
    let mut f = evaluate_all(axis, source, readings)?;
    f.without_outlying = without_outlying(axis, source, readings, &f);
    f.withhold();
    let note = match &f.without_outlying {
        Some(w) if !w.dominated.is_empty() => {
            let list = |fig: &BTreeMap<String, f64>| {
                w.dominated
                    .iter()
                    .filter_map(|n| {
                        Some(format!(
                            "{} = {} µm",
                            n.trim_end_matches("_um"),
                            num(*fig.get(n)?)
                        ))
                    })
                    .collect::<Vec<_>>()
                    .join(", ")
            };
            let with: BTreeMap<String, f64> = FIGURES
                .iter()
                .zip(f.values())
                .filter_map(|(n, v)| Some((n.to_string(), v?)))
                .collect();
            Some(format!(
                "{} set by {} reading(s) far from the other runs ({}): without them {} (`without_outlying`); the figures above are the standard's, with every reading",
                list(&with),
                w.readings.len(),
                w.readings
                    .iter()
                    .map(|r| format!(
                        "{} {} at {} mm, {} µm, {} µm off the others",
                        run_label(source, r.run),
                        if r.up { "+" } else { "−" },
                        num(r.target_mm),
                        signed(r.deviation_um),
                        signed(r.off_um)
                    ))
                    .collect::<Vec<_>>()
                    .join("; "),
                list(&w.figures)
            ))
        }
        _ => None,
    };
    f.notes.extend(note);
    Ok(f)
}

/// The figures without the readings the outlier test sets aside (`None`: none set aside,
/// or too few repeated readings for the test).
fn without_outlying(
    axis: Axis,
    source: Source,
    readings: &[Reading],
    with: &Iso2302,
) -> Option<WithoutOutlying> {
    let targets: Vec<f64> = with.per_target.iter().map(|t| t.target_mm).collect();
    let tol = 1e-6 * (targets[targets.len() - 1] - targets[0]);
    let group: Vec<usize> = readings
        .iter()
        .map(|r| {
            let t = targets
                .iter()
                .position(|&t| (t - r.target_mm).abs() <= tol)
                .unwrap_or(0);
            2 * t + usize::from(!r.up)
        })
        .collect();
    let mut passes: Vec<(i64, bool)> = readings.iter().map(|r| (r.run, r.up)).collect();
    passes.sort_unstable();
    passes.dedup();
    let pass: Vec<usize> = readings
        .iter()
        .map(|r| passes.binary_search(&(r.run, r.up)).unwrap_or(0))
        .collect();
    let y: Vec<f64> = readings.iter().map(|r| r.deviation_um).collect();
    let rep = crate::diagnosis::repeatability::repeatability(&group, &pass, &y).ok()?;
    if rep.set_aside.is_empty() {
        return None;
    }
    let kept: Vec<Reading> = readings
        .iter()
        .enumerate()
        .filter(|(i, _)| !rep.set_aside.iter().any(|o| o.index == *i))
        .map(|(_, r)| *r)
        .collect();
    let g = evaluate_all(axis, source, &kept).ok()?;
    let dominated = FIGURES
        .iter()
        .zip(with.values().iter().zip(g.values()))
        .filter_map(|(n, (a, b))| Some((n, (*a)?, b?)))
        .filter(|(_, a, b)| (a - b).abs() > DOMINATES * a.abs().max(b.abs()))
        .map(|(n, _, _)| n.to_string())
        .collect();
    Some(WithoutOutlying {
        readings: rep
            .set_aside
            .iter()
            .map(|o| {
                let r = readings[o.index];
                OutlyingReading {
                    run: r.run,
                    target_mm: r.target_mm,
                    up: r.up,
                    deviation_um: r.deviation_um,
                    off_um: o.residual_um,
                    t: o.t,
                }
            })
            .collect(),
        critical_t: rep.critical_t,
        figures: FIGURES
            .iter()
            .zip(g.values())
            .filter_map(|(n, v)| Some((n.to_string(), v?)))
            .collect(),
        u: g.u,
        dominated,
    })
}

/// The standard's figures of every reading (module docs), in its phases: the readings
/// checked and grouped by target, the per-target statistics, the axis figures with their
/// uncertainties, and the notes on what the test lacks.
fn evaluate_all(axis: Axis, source: Source, readings: &[Reading]) -> Result<Iso2302, SolverError> {
    let targets = checked_targets(axis, readings)?;
    let (per_target, stats) = per_target(axis, readings, &targets)?;
    let values = axis_figures(&per_target, &stats);
    let m = targets.len();
    let mut runs: Vec<i64> = readings.iter().map(|r| r.run).collect();
    runs.sort_unstable();
    runs.dedup();
    let (n_up, n_down) = (
        stats.iter().map(|(a, _)| a.n).min().unwrap_or(0),
        stats.iter().map(|(_, b)| b.n).min().unwrap_or(0),
    );
    let u = FIGURES
        .iter()
        .zip(values)
        .map(|(n, (_, u))| (n.to_string(), u))
        .collect();
    let [b, bm, ru, rd, r, eu, ed, e, mm, au, ad, a] = values.map(|(v, _)| Some(v));
    Ok(Iso2302 {
        axis,
        source,
        file: None,
        head_offset_mm: None,
        notes: shortfall_notes(n_up, n_down, m),
        targets: m,
        runs: runs.len(),
        n_up,
        n_down,
        per_target,
        reversal_b_um: b,
        mean_reversal_b_um: bm,
        repeatability_r_up_um: ru,
        repeatability_r_down_um: rd,
        repeatability_r_um: r,
        systematic_e_up_um: eu,
        systematic_e_down_um: ed,
        systematic_e_um: e,
        mean_range_m_um: mm,
        accuracy_a_up_um: au,
        accuracy_a_down_um: ad,
        accuracy_a_um: a,
        u,
        without_outlying: None,
    })
}

/// The distinct targets of finite readings; at least two are needed.
fn checked_targets(axis: Axis, readings: &[Reading]) -> Result<Vec<f64>, SolverError> {
    if readings
        .iter()
        .any(|r| !r.target_mm.is_finite() || !r.deviation_um.is_finite())
    {
        return Err(SolverError::InvalidInput(format!(
            "axis {axis}: non-finite target or deviation"
        )));
    }
    if readings.is_empty() {
        return Err(SolverError::InvalidInput(format!(
            "axis {axis}: no readings"
        )));
    }
    let x: Vec<f64> = readings.iter().map(|r| r.target_mm).collect();
    let targets = distinct_targets(&x);
    if targets.len() < 2 {
        return Err(SolverError::InvalidInput(format!(
            "axis {axis}: {} target(s); at least 2 are needed",
            targets.len()
        )));
    }
    Ok(targets)
}

/// The figures at each target, with the statistics of each direction (↑, ↓); at least
/// two readings per target and direction are needed.
#[allow(clippy::type_complexity)]
fn per_target(
    axis: Axis,
    readings: &[Reading],
    targets: &[f64],
) -> Result<(Vec<TargetFigures>, Vec<(Stats, Stats)>), SolverError> {
    let tol = 1e-6 * (targets[targets.len() - 1] - targets[0]);
    let mut per_target = Vec::with_capacity(targets.len());
    let mut stats = Vec::with_capacity(targets.len());
    for &t in targets {
        let dir = |up: bool| -> Result<Stats, SolverError> {
            let v: Vec<f64> = readings
                .iter()
                .filter(|r| r.up == up && (r.target_mm - t).abs() <= tol)
                .map(|r| r.deviation_um)
                .collect();
            Stats::of(&v).ok_or_else(|| {
                SolverError::InvalidInput(format!(
                    "axis {axis}: target {t} mm has {} reading(s) approached {}; at least 2 per direction are needed",
                    v.len(),
                    if up { "with increasing command (+)" } else { "with decreasing command (−)" }
                ))
            })
        };
        let (up, down) = (dir(true)?, dir(false)?);
        let b = up.mean - down.mean;
        let bi = 2.0 * up.s + 2.0 * down.s + b.abs();
        per_target.push(TargetFigures {
            target_mm: t,
            n_up: up.n,
            n_down: down.n,
            mean_up_um: up.mean,
            mean_down_um: down.mean,
            mean_um: 0.5 * (up.mean + down.mean),
            s_up_um: up.s,
            s_down_um: down.s,
            b_um: b,
            r_up_um: 4.0 * up.s,
            r_down_um: 4.0 * down.s,
            r_um: bi.max(4.0 * up.s).max(4.0 * down.s),
        });
        stats.push((up, down));
    }
    Ok((per_target, stats))
}

/// The axis figures in [`FIGURES`] order, each (value, standard uncertainty).
fn axis_figures(per_target: &[TargetFigures], stats: &[(Stats, Stats)]) -> [(f64, f64); 12] {
    let m = per_target.len();
    // u(B_i) = √(s↑²/n↑ + s↓²/n↓)
    let u_b: Vec<f64> = stats
        .iter()
        .map(|(a, b)| a.u_mean().hypot(b.u_mean()))
        .collect();
    let (b_max, _) = extremes(per_target.iter().zip(&u_b).map(|(p, &u)| (p.b_um.abs(), u)));
    let b_mean = per_target.iter().map(|p| p.b_um).sum::<f64>() / m as f64;
    let u_b_mean = u_b.iter().map(|u| u * u).sum::<f64>().sqrt() / m as f64;
    let (r_up, _) = extremes(stats.iter().map(|(a, _)| (4.0 * a.s, 4.0 * a.u_s())));
    let (r_down, _) = extremes(stats.iter().map(|(_, b)| (4.0 * b.s, 4.0 * b.u_s())));
    let (r, _) = extremes(
        per_target
            .iter()
            .zip(stats)
            .zip(&u_b)
            .map(|((p, (a, b)), ub)| {
                let bi = 2.0 * a.s + 2.0 * b.s + p.b_um.abs();
                let u = if bi >= 4.0 * a.s && bi >= 4.0 * b.s {
                    (4.0 * a.u_s().powi(2) + 4.0 * b.u_s().powi(2) + ub * ub).sqrt()
                } else if a.s >= b.s {
                    4.0 * a.u_s()
                } else {
                    4.0 * b.u_s()
                };
                (p.r_um, u)
            }),
    );
    let ups = || stats.iter().map(|(a, _)| *a);
    let downs = || stats.iter().map(|(_, b)| *b);
    let e_up = range(ups().map(|a| (a.mean, a.u_mean())));
    let e_down = range(downs().map(|a| (a.mean, a.u_mean())));
    let e = range(ups().chain(downs()).map(|a| (a.mean, a.u_mean())));
    let mm = range(
        stats
            .iter()
            .map(|(a, b)| (0.5 * (a.mean + b.mean), 0.5 * a.u_mean().hypot(b.u_mean()))),
    );
    let accuracy = |v: Vec<Stats>| {
        let (hi, _) = extremes(v.iter().map(|a| (a.mean + 2.0 * a.s, a.u_band())));
        let (_, lo) = extremes(v.iter().map(|a| (a.mean - 2.0 * a.s, a.u_band())));
        (hi.0 - lo.0, hi.1.hypot(lo.1))
    };
    [
        (b_max.0, b_max.1),
        (b_mean, u_b_mean),
        r_up,
        r_down,
        r,
        e_up,
        e_down,
        e,
        mm,
        accuracy(ups().collect()),
        accuracy(downs().collect()),
        accuracy(ups().chain(downs()).collect()),
    ]
}

/// What the test lacks against the standard's minimum of readings and targets.
fn shortfall_notes(n_up: usize, n_down: usize, m: usize) -> Vec<String> {
    let mut notes = vec![];
    if n_up < 5 || n_down < 5 {
        notes.push(format!(
            "ISO 230-2 asks for 5 readings per target and direction; this test has at least {n_up} (+) and {n_down} (−)"
        ));
    }
    if m < 5 {
        notes.push(format!(
            "ISO 230-2 asks for at least 5 targets; this test has {m}"
        ));
    }
    notes
}

fn readings_of(recs: &[&PositioningRecord]) -> Vec<Reading> {
    recs.iter()
        .map(|r| Reading {
            target_mm: r.target_mm,
            up: r.direction == Direction::Plus,
            run: r.run,
            deviation_um: r.deviation_um,
        })
        .collect()
}

/// ISO 230-2 figures of every axis of positioning runs, and the axes that could not be
/// evaluated (with the reason).
pub fn from_positioning_runs(runs: &PositioningRuns) -> (Vec<Iso2302>, Vec<NotEvaluated>) {
    let mut out = vec![];
    let mut skipped = vec![];
    for axis in Axis::ALL {
        let recs: Vec<&PositioningRecord> =
            runs.records.iter().filter(|r| r.axis == axis).collect();
        if recs.is_empty() {
            continue;
        }
        match evaluate(axis, Source::PositioningRuns, &readings_of(&recs)) {
            Ok(f) => out.push(f),
            Err(e) => skipped.push(NotEvaluated {
                standard: "iso230_2".into(),
                what: axis.to_string(),
                reason: e.to_string(),
            }),
        }
    }
    (out, skipped)
}

/// ISO 230-2 figures per axis of positioning runs; axes that cannot be evaluated are
/// left out ([`from_positioning_runs`] says why).
pub fn iso230_2(runs: &PositioningRuns) -> Vec<Iso2302> {
    from_positioning_runs(runs).0
}

/// A run as a person names it: `run 3` of positioning runs; `run 16, pass 6` of line
/// passes, whose readings carry the run's number and the pass's index in one identifier
/// (run × 1 000 000 + pass index, [`evaluate_passes`]).
pub fn run_label(source: Source, run: i64) -> String {
    match source {
        Source::PositioningRuns => format!("run {run}"),
        Source::LinePasses => format!(
            "run {}, pass {}",
            run.div_euclid(PASS_ID),
            run.rem_euclid(PASS_ID) + 1
        ),
    }
}

/// The factor of a line pass's run number in its readings' run identifier.
const PASS_ID: i64 = 1_000_000;

/// Why the zero-dependent figures of grid-encoder line passes are not given.
pub const NOT_FROM_LINE_PASSES: &str = "not available from this plan: a grid encoder's zero \
     is set per pass, so each pass is referred to its own mean and what compares passes \
     (the reversal, the repeatability, E and A over both directions) is not observed; the \
     diagnosis of the session estimates the lost motion";

/// Whether an axis figure ([`FIGURES`] name) of line passes depends on each pass's zero:
/// the reversal values B and B̄ (the constant lost motion is removed with the pass's
/// mean), the repeatabilities R↑, R↓, R (a shift between passes, which a standstill test
/// counts, is removed) and the figures that set one direction's means against the
/// other's or add the repeatability (E, A↑, A↓, A). E↑, E↓ and M are ranges of means that
/// a common shift of the passes does not change.
pub fn depends_on_zero(figure: &str) -> bool {
    !matches!(figure, "E_up_um" | "E_down_um" | "M_um")
}

/// Whether an axis figure is a difference at one target (B, B̄, R↑, R↓, R), not a range
/// over the travel.
pub fn is_local(figure: &str) -> bool {
    matches!(
        figure,
        "B_um" | "B_mean_um" | "R_up_um" | "R_down_um" | "R_um"
    )
}

/// The standard's symbol and name of an axis figure ([`FIGURES`] name).
pub fn figure_name(figure: &str) -> Option<(&'static str, &'static str)> {
    Some(match figure {
        "B_um" => ("B", "reversal value of the axis"),
        "B_mean_um" => ("B̄", "mean reversal value of the axis"),
        "R_up_um" => ("R↑", "unidirectional repeatability of positioning"),
        "R_down_um" => ("R↓", "unidirectional repeatability of positioning"),
        "R_um" => ("R", "bidirectional repeatability of positioning"),
        "E_up_um" => ("E↑", "unidirectional systematic positional deviation"),
        "E_down_um" => ("E↓", "unidirectional systematic positional deviation"),
        "E_um" => ("E", "bidirectional systematic positional deviation"),
        "M_um" => ("M", "range of the mean bidirectional positional deviation"),
        "A_up_um" => ("A↑", "unidirectional accuracy of positioning"),
        "A_down_um" => ("A↓", "unidirectional accuracy of positioning"),
        "A_um" => ("A", "bidirectional accuracy of positioning"),
        _ => return None,
    })
}
