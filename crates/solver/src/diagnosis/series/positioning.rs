//! Positioning runs (datasets contract section 3, ISO 230-2 style): repeated bidirectional
//! runs along one axis, deviation (µm) at each target (mm) per approach direction.
//!
//! **Rigid model**: a smooth positioning error per axis, E(x) = Σ_{k=0..N} c_k P_k(s),
//! s = (x − x_c)/h mapping the measured travel onto [−1, 1] (Legendre columns for
//! conditioning), the same for both approach directions and constant in time; N ≤ 3
//! chosen by leave-one-run-out (LORO) error.
//!
//! **Candidate effects**, each an extra set of columns fitted jointly with the polynomial
//! (d = +1 for a + approach, −1 for a − approach):
//!
//! | effect | columns | nonlinear parameter (1-D search) |
//! |---|---|---|
//! | `backlash` (lost motion) | −d/2 (coefficient b = mean(−) − mean(+), the negative of ISO 230-2's B) | — |
//! | `reversal_spike` | −d·exp(−u/λ), u = distance from the first target after the reversal | decay length λ |
//! | `cyclic` | sin(2πx/P), cos(2πx/P) | period P |
//! | `thermal_drift` (time) | g, g·x/1000, g = 1 − exp(−(t − t₀)/τ) | time constant τ |
//! | `thermal_drift` (temperature) | ΔT, ΔT·x/1000 | — |
//! | `model_order` | P_k(s), k = N+1..K | — |
//!
//! Parameter names, units and signs are those of every diagnosis
//! ([`crate::diagnosis::effects`]).
//!
//! Without `t_s` the record order stands for time (τ is then in records).
//!
//! **Selection**: the diagnosis engine's loop ([`crate::diagnosis::engine`]): each
//! candidate (an effect of the table not yet in the model, or a higher polynomial order
//! up to `max_order`) is fitted jointly with the current model, its nonlinear parameter
//! searched in 1-D and searched again in every fold, and scored by the leave-one-run-out
//! held-out sum of squares (whole runs held out) and by BIC = n ln(SSE/n) + k ln n; the
//! engine's gate, parsimony and stop rules choose.
//!
//! **Noise floor**, independent of the model: the pooled scatter of repeated readings of
//! the same target and direction after removing one offset per pass (run × direction):
//! two-way least squares y = μ_(target,dir) + ρ_pass, σ² = SSE/(n − rank). Slow drift
//! between passes is thus not counted as noise (ISO 230-2's repeatability would include
//! it; [`crate::standards::iso230_2`] gives those figures).
//!
//! **Local scan**: the final residual of each axis in time order is scanned for a step, a
//! burst or an isolated excursion ([`crate::diagnosis::local_scan`], 0.1 % family-wise);
//! an axis with such an anomaly is never consistent.
//!
//! Submodules, one concept each: `data` (validation and derived coordinates, noise
//! floor), `columns` (rigid and effect columns, search grids), `problem` (the axis as a
//! problem of the diagnosis engine, which runs the 1-D searches, held-out scores and the greedy
//! selection), `report` (parameters, findings, mismatch, plots).

mod columns;
mod data;
mod problem;
mod report;

use super::SeriesOptions;
use crate::axis::Axis;
use crate::datasets::{PositioningRecord, PositioningRuns};
use crate::diagnosis::{Baseline, DiagnosisResult, Mismatch, Monotone, NoProgress, Progress};
use crate::error::SolverError;
use data::AxisData;
use report::AxisOutcome;

/// Diagnoses positioning runs (module docs), each axis separately; findings carry the axis.
pub fn diagnose_positioning(
    runs: &PositioningRuns,
    machine_id: &str,
    opts: &SeriesOptions,
) -> Result<DiagnosisResult, SolverError> {
    diagnose_positioning_with_progress(runs, machine_id, opts, &mut NoProgress)
}

/// [`diagnose_positioning`], reporting its phases (per axis: noise floor and rigid order,
/// each round of candidates, report) with a monotone fraction of the work that ends at 1
/// with `done`.
pub fn diagnose_positioning_with_progress(
    runs: &PositioningRuns,
    machine_id: &str,
    opts: &SeriesOptions,
    progress: &mut dyn Progress,
) -> Result<DiagnosisResult, SolverError> {
    if runs.records.is_empty() {
        return Err(SolverError::InvalidInput("no positioning records".into()));
    }
    if runs
        .records
        .iter()
        .any(|r| !r.target_mm.is_finite() || !r.deviation_um.is_finite())
    {
        return Err(SolverError::InvalidInput(
            "non-finite target or deviation".into(),
        ));
    }
    let mut progress = Monotone::new(progress);
    progress.report("validating the records", 0.0);
    let axes: Vec<Vec<&PositioningRecord>> = Axis::ALL
        .iter()
        .map(|&axis| runs.records.iter().filter(|r| r.axis == axis).collect())
        .filter(|recs: &Vec<&PositioningRecord>| !recs.is_empty())
        .collect();
    let mut outs = vec![];
    for (k, recs) in axes.iter().enumerate() {
        let a = AxisData::new(recs[0].axis, recs)?;
        // Each axis is an equal part of the work.
        let span = (
            k as f64 / axes.len() as f64,
            (k + 1) as f64 / axes.len() as f64,
        );
        let p = problem::Positioning::new(&a, opts)?;
        let sel = problem::select(&p, opts, &mut progress, span);
        progress.report_in(span, &format!("axis {}: report", a.axis), 0.95);
        outs.push(report::outcome(&a, sel, &p.rep, opts));
    }
    progress.report("done", 1.0);
    let ntot: usize = outs.iter().map(|o| o.n).sum();
    let pooled = |f: &dyn Fn(&AxisOutcome) -> f64| {
        (outs.iter().map(|o| f(o).powi(2) * o.n as f64).sum::<f64>() / ntot as f64).sqrt()
    };
    let baseline = Baseline {
        residual_rms_um: pooled(&|o| o.base_rms),
        heldout_rms_um: pooled(&|o| o.base_heldout),
        noise_estimate_um: pooled(&|o| o.noise),
    };
    let total_misfit: f64 = outs.iter().map(|o| o.misfit).sum::<f64>().max(1e-300);
    let mut mismatch = vec![];
    let mut findings = vec![];
    let mut unexplained = vec![];
    let mut plots = vec![];
    let mut any_needs = false;
    for o in outs {
        let needs = o.needs || !o.findings.is_empty();
        any_needs |= needs;
        if needs {
            for mut m in o.mismatch {
                m.share_of_misfit *= o.misfit / total_misfit;
                mismatch.push(m);
            }
        }
        findings.extend(o.findings);
        unexplained.extend(o.unexplained);
        plots.extend(o.plots);
        let _ = o.final_heldout;
    }
    mismatch.sort_by(|x: &Mismatch, y| y.share_of_misfit.total_cmp(&x.share_of_misfit));
    Ok(super::result(
        machine_id,
        "positioning",
        baseline,
        mismatch,
        findings,
        !any_needs,
        unexplained,
        plots,
    ))
}
