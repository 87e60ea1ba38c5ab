//! Diagnosis of one-dimensional recordings: positioning runs (datasets contract section 3,
//! ISO 230-2 style) and drift logs (section 4, ISO 230-3 style).
//!
//! Both follow the diagnosis loop (docs/diagnosis.md, docs/diagnosis-series.md): fit the rigid model, **locate** where its residuals
//! concentrate, **explain** them with candidate physical effects fitted jointly with the
//! rigid model (nonlinear parameters such as a period or a time constant by a 1-D search),
//! keep an effect only when it improves the fit on data held out of the fit (whole runs,
//! or the late part of a log) and the information criterion, and **prove** the gain on
//! held-out data.
//!
//! * [`positioning`]: smooth positioning error per axis versus backlash, reversal spikes,
//!   cyclic error, thermal drift and a higher polynomial order.
//! * [`drift`]: constant per channel versus first-order responses to the spindle's
//!   running history and regressions on structure temperatures.
//! * [`simulate`]: seedable simulators of both recordings with known effects (truth).
//!
//! Both run the greedy loop of [`crate::diagnosis::engine`] and fit with the one dense
//! least-squares kernel, [`crate::diagnosis::lsq`].

pub mod drift;
pub mod positioning;
pub mod simulate;

pub use positioning::{diagnose_positioning, diagnose_positioning_with_progress};

pub use drift::diagnose_drift_log;

use crate::diagnosis::{Baseline, DiagnosisResult, Finding, Mismatch, PlotData, effects};
use serde::{Deserialize, Serialize};

/// The diagnosis result of a series (`source`: `positioning` or `drift_log`): the findings
/// whose parameters the data do not determine listed as possible
/// ([`effects::split_undetermined`]), the verdict by the one rule ([`effects::verdict`])
/// from whether the rigid model was at noise level and whether anything stays
/// unexplained. A series rejects no candidate as implausible.
#[allow(clippy::too_many_arguments)] // the result's parts, each named at the call
fn result(
    machine_id: &str,
    source: &str,
    baseline: Baseline,
    mismatch: Vec<Mismatch>,
    findings: Vec<Finding>,
    rigid_at_noise: bool,
    unexplained: Vec<String>,
    plots: Vec<PlotData>,
) -> DiagnosisResult {
    let (findings, possible) = effects::split_undetermined(findings);
    let verdict = effects::verdict(rigid_at_noise, unexplained.is_empty(), findings.len());
    DiagnosisResult {
        kind: "diagnosis".into(),
        machine_id: machine_id.into(),
        source: source.into(),
        baseline,
        mismatch,
        findings,
        possible,
        rejected: vec![],
        verdict,
        unexplained,
        plots,
    }
}

/// Options of the series diagnoses. [`Default`] gives the documented values.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
#[serde(default)]
pub struct SeriesOptions {
    /// Highest polynomial order of the rigid positioning-error model (chosen by held-out
    /// error among 1..=this). Default 3 (the project's cubic default).
    pub max_base_order: usize,
    /// Highest order the `model_order` candidate may raise it to. Default 9.
    pub max_order: usize,
    /// Most effects added per axis or channel. Default 4.
    pub max_findings: usize,
    /// An effect must lower BIC by at least this much (strong evidence). Default 10.
    pub bic_threshold: f64,
    /// ... and lower the held-out sum of squares by at least this fraction. Default 0.10.
    pub min_heldout_gain: f64,
    /// Held-out RMS within this multiple of the noise floor counts as explained. Default 1.5.
    pub explained_ratio: f64,
    /// Stop adding effects once the held-out RMS is within this multiple of the noise
    /// floor. Default 1.1.
    pub stop_ratio: f64,
    /// Drift logs: fraction of the recording used to fit (the rest judges). Default 0.6.
    pub train_fraction: f64,
    /// Drift logs: most temperature sensors in a regression. Default 4.
    pub max_sensors: usize,
    /// Most points per plotted series (plots are decimated to this). Default 600.
    pub plot_points: usize,
}

impl Default for SeriesOptions {
    fn default() -> Self {
        SeriesOptions {
            max_base_order: 3,
            max_order: 9,
            max_findings: 4,
            bic_threshold: 10.0,
            min_heldout_gain: 0.10,
            explained_ratio: 1.5,
            stop_ratio: 1.1,
            train_fraction: 0.6,
            max_sensors: 4,
            plot_points: 600,
        }
    }
}

/// Root mean square of a slice (0 for an empty slice).
pub(crate) fn rms(v: &[f64]) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    (v.iter().map(|x| x * x).sum::<f64>() / v.len() as f64).sqrt()
}

/// `n` points log-spaced from `a` to `b` (both > 0).
pub(crate) fn log_grid(a: f64, b: f64, n: usize) -> Vec<f64> {
    let (la, lb) = (a.ln(), b.ln());
    (0..n)
        .map(|i| (la + (lb - la) * i as f64 / (n.max(2) - 1) as f64).exp())
        .collect()
}

/// Indices of at most `max` points evenly spread over `0..n` (always keeps the last).
pub(crate) fn decimate(n: usize, max: usize) -> Vec<usize> {
    if n <= max || max < 2 {
        return (0..n).collect();
    }
    let step = (n - 1) as f64 / (max - 1) as f64;
    let mut out: Vec<usize> = (0..max)
        .map(|i| (i as f64 * step).round() as usize)
        .collect();
    out.dedup();
    out
}
