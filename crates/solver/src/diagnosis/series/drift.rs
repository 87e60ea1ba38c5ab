//! Drift logs (datasets contract section 4, ISO 230-3 style): the rigid model predicts no
//! movement, i.e. a constant per displacement channel. The missing physics is thermal
//! growth of the structure, modelled two ways and chosen per channel on the fitting part
//! of the recording alone:
//!
//! * **spindle lags** (parametric, interpretable): the heat input u(t) = (n(t)/n_max)^p
//!   of the spindle speed n (p = 1 or 2) drives one or two first-order lags
//!   Lτ[u]: τ ẋ = u − x ([`first_order_lag`]). Model y = c + Σ_j g_j Lτ_j[u]; g_j is the
//!   steady-state growth at full speed (µm). Each lag is a candidate of the diagnosis
//!   engine ([`crate::diagnosis::engine`]) whose ln τ is searched in 1-D (log grid, then
//!   golden section); a second lag is a candidate once the first is in. Two lags of
//!   opposite sign describe a fast (spindle, head) and a slow (column, bed) path.
//! * **thermal model** ([`crate::thermal`]): ridge regression on a bank of lags of the
//!   spindle heat input (n and n², 0.1–2 h) and of every structure temperature
//!   (0.1–2 h), its penalty chosen by rolling-origin cross-validation; a candidate from
//!   the constant or any spindle-lag model, which it replaces.
//!
//! Protocol: fit on the first `train_fraction` (60 %) of the recording, judge on the rest.
//! The engine's loop chooses on the fitting part alone: its held-out folds are the
//! rolling-origin folds inside it ([`crate::thermal::rolling_origin`]: blocks 3, 4 and 5
//! of 5, each predicted by the model fitted on all rows before it, τ searched again on
//! those rows), so the rest of the recording is never used for a choice. The engine's
//! gate and parsimony rule (BIC, and a held-out gain of `min_heldout_gain`, 10 %, over
//! the current model and over any simpler qualifying candidate) decide whether a lag, a
//! second lag or the thermal model is kept. Reported: held-out RMS and MAE of the rigid
//! constant (fitted on the fitting part) and of the model, and the share of drift
//! predicted, 1 − SSE_after/SSE_rigid on the held-out part.
//!
//! Noise floor per channel, independent of any model: the shared spectral floor
//! ([`crate::noise::spectral_floor`]); a log too short for it falls back to
//! σ = 1.4826·median|Δy| / √2 (the sample-to-sample scatter; slow drift contributes
//! nothing to either).
//! Uncertainties: parametric model, from the Jacobian including ∂/∂ln τ columns; thermal
//! model, from the ridge covariance ([`crate::thermal`]); both multiplied by
//! √((1+ρ)/(1−ρ)) with ρ the lag-1 autocorrelation of the fit residuals (effective sample
//! size of AR(1) residuals). They remain indicative, the residuals of a drift model are
//! not white. Parameters are sorted into determined and undetermined ones by the one rule
//! of every diagnosis ([`crate::diagnosis::effects::classify`]).

use super::{SeriesOptions, decimate, log_grid, rms};
use crate::datasets::{Channel, ChannelKind, DriftLog};
use crate::diagnosis::engine::{self, Fitted, Fold, Problem, Rules};
use crate::diagnosis::lsq::{self, Design};
use crate::diagnosis::{
    Baseline, BeforeAfter, DiagnosisResult, Finding, Mismatch, Monotone, NoProgress, PlotData,
    PlotKind, PlotSeries, Progress, effects,
};
use crate::error::SolverError;
use crate::thermal::{self, Regressor, ThermalFit, ThermalInputs, ThermalOptions};
use std::collections::BTreeMap;

pub use crate::thermal::first_order_lag;

/// Most first-order lags of the spindle heat input in a parametric model.
const MAX_LAGS: usize = 2;

/// Parametric spindle model: heat-input exponent p and lag time constants (s), ascending;
/// no lags: the rigid constant.
#[derive(Debug, Clone, PartialEq)]
struct Lags {
    p: f64,
    taus: Vec<f64>,
}

/// A drift model of one channel: spindle lags (or the rigid constant), or the ridge
/// thermal model, which replaces them (its bank holds the spindle's own lags).
#[derive(Debug, Clone, PartialEq)]
enum Model {
    Lags(Lags),
    Thermal,
}

/// A candidate: one more spindle lag with exponent p (its ln τ searched in 1-D), or the
/// thermal model.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Candidate {
    Lag(f64),
    Thermal,
}

struct Inputs<'a> {
    t: &'a [f64],
    speed: Option<&'a Channel>,
    rpm_max: f64,
    temps: Vec<(&'a str, &'a [f64])>,
    n_train: usize,
    /// The thermal model's regressors (the same for every channel).
    bank: Vec<Regressor>,
}

impl Inputs<'_> {
    fn heat(&self, p: f64) -> Vec<f64> {
        let s = self.speed.expect("speed channel");
        s.values
            .iter()
            .map(|&n| (n.abs() / self.rpm_max).powf(p))
            .collect()
    }

    fn design(&self, m: &Lags) -> Design {
        let n = self.t.len();
        let mut d = Design::new();
        d.push("constant", vec![1.0; n]);
        if !m.taus.is_empty() {
            let u = self.heat(m.p);
            for (j, &tau) in m.taus.iter().enumerate() {
                d.push(format!("lag{}", j + 1), first_order_lag(self.t, &u, tau));
            }
        }
        d
    }

    fn thermal(&self) -> ThermalInputs<'_> {
        ThermalInputs {
            t_s: self.t,
            speed_rpm: self.speed.map(|c| c.values.as_slice()),
            temperatures: &self.temps,
        }
    }
}

/// One displacement channel as a problem of the diagnosis engine: fitted on the first
/// `n_train` rows, held out by the rolling-origin folds inside them, the thermal model
/// fitted once (its penalty chosen by the same folds, so it scores itself).
struct ChannelProblem<'a> {
    inp: &'a Inputs<'a>,
    y: &'a [f64],
    thermal: Option<ThermalFit>,
}

impl Problem for ChannelProblem<'_> {
    type Model = Model;
    type Candidate = Candidate;

    fn readings(&self) -> &[f64] {
        self.y
    }
    fn fit_rows(&self) -> Vec<usize> {
        (0..self.inp.n_train).collect()
    }
    /// Blocks 3, 4 and 5 of 5, each predicted from all rows before it.
    fn folds(&self) -> Vec<Fold> {
        thermal::rolling_origin(self.inp.n_train)
            .into_iter()
            .map(|f| Fold {
                train: (0..f.train_end).collect(),
                test: f.valid.collect(),
            })
            .collect()
    }
    fn noise_floor(&self) -> f64 {
        noise_floor(self.y)
    }
    fn columns(&self, m: &Model) -> Design {
        match m {
            Model::Lags(l) => self.inp.design(l),
            Model::Thermal => self.inp.design(&RIGID),
        }
    }
    /// The constant, and a gain and a τ per lag; the thermal model's effective parameters.
    fn n_params(&self, m: &Model) -> f64 {
        match m {
            Model::Lags(l) => 1.0 + 2.0 * l.taus.len() as f64,
            Model::Thermal => 1.0 + self.thermal.as_ref().map_or(0.0, |f| f.edf),
        }
    }
    /// From the constant: a lag with p = 1 or 2; then another lag of the same p; the
    /// thermal model from any parametric model.
    fn candidates(&self, m: &Model) -> Vec<Candidate> {
        let Model::Lags(l) = m else { return vec![] };
        let mut c = vec![];
        if self.inp.speed.is_some() && self.inp.rpm_max > 0.0 && l.taus.len() < MAX_LAGS {
            if l.taus.is_empty() {
                c.extend([Candidate::Lag(1.0), Candidate::Lag(2.0)]);
            } else {
                c.push(Candidate::Lag(l.p));
            }
        }
        if self.thermal.is_some() {
            c.push(Candidate::Thermal);
        }
        c
    }
    /// ln τ on a log grid from 4 samples (at least 60 s) to twice the fitting part.
    fn grid(&self, c: Candidate) -> Vec<f64> {
        let (t, nt) = (self.inp.t, self.inp.n_train);
        match c {
            Candidate::Lag(_) => {
                let dt = (t[nt - 1] - t[0]) / (nt - 1) as f64;
                log_grid((4.0 * dt).max(60.0), 2.0 * (t[nt - 1] - t[0]), 22)
                    .into_iter()
                    .map(f64::ln)
                    .collect()
            }
            Candidate::Thermal => vec![],
        }
    }
    fn extend(&self, m: &Model, c: Candidate, v: f64) -> Model {
        match (m, c) {
            (Model::Lags(l), Candidate::Lag(p)) => {
                let mut taus = l.taus.clone();
                taus.push(v.exp());
                taus.sort_by(f64::total_cmp);
                Model::Lags(Lags { p, taus })
            }
            _ => Model::Thermal,
        }
    }
    fn fit(&self, m: &Model, rows: &[usize]) -> Fitted {
        match (m, &self.thermal) {
            (Model::Thermal, Some(f)) => Fitted {
                coef: f.coef.clone(),
                sse: rows
                    .iter()
                    .map(|&i| (self.y[i] - f.prediction[i]).powi(2))
                    .sum(),
                prediction: f.prediction.clone(),
            },
            _ => engine::lsq_fit(self, m, rows),
        }
    }
    fn own_heldout_sse(&self, m: &Model) -> Option<f64> {
        match (m, &self.thermal) {
            (Model::Thermal, Some(f)) => Some(f.cv_rms.powi(2) * f.cv_rows as f64),
            _ => None,
        }
    }
}

/// The rigid model: a constant.
const RIGID: Lags = Lags {
    p: 1.0,
    taus: vec![],
};

/// Everything found for one displacement channel.
struct ChannelOutcome {
    name: String,
    noise: f64,
    rigid_pred: f64,
    pred: Vec<f64>,
    rigid_train_rms: f64,
    rigid_test_rms: f64,
    after_train_rms: f64,
    after_test_rms: f64,
    share_predicted: f64,
    misfit_sse: f64,
    finding: Option<Finding>,
    peak: (f64, f64),
    window_h: (f64, f64),
}

/// The shared noise floor ([`crate::noise::spectral_floor`]) of one channel; a log too
/// short for one spectral segment falls back to 1.4826·median|Δy|/√2.
fn noise_floor(y: &[f64]) -> f64 {
    if let Some((s, _)) = crate::noise::spectral_floor([y]) {
        return s;
    }
    let mut d: Vec<f64> = y.windows(2).map(|w| (w[1] - w[0]).abs()).collect();
    if d.is_empty() {
        return 0.0;
    }
    d.sort_by(f64::total_cmp);
    1.4826 * d[d.len() / 2] / 2f64.sqrt()
}

fn describe(m: &Model) -> String {
    match m {
        Model::Lags(l) => format!(
            "{} first-order lag(s) of spindle heat input ∝ {}",
            l.taus.len(),
            if l.p == 1.0 { "n" } else { "n²" }
        ),
        Model::Thermal => "thermal model".into(),
    }
}

/// Diagnoses one displacement channel by the engine's loop, reporting its phases within
/// the part `span` of the whole work.
fn analyse_channel(
    ch: &Channel,
    inp: &Inputs,
    opts: &SeriesOptions,
    progress: &mut Monotone,
    span: (f64, f64),
) -> ChannelOutcome {
    let y = &ch.values;
    progress.report_in(span, &format!("{}: thermal model", ch.name), 0.0);
    let thermal_fit = if inp.bank.is_empty() {
        None
    } else {
        let to = ThermalOptions::default();
        thermal::fit_thermal(&inp.bank, &inp.thermal(), y, inp.n_train, &to).ok()
    };
    let problem = ChannelProblem {
        inp,
        y,
        thermal: thermal_fit,
    };
    let rules = Rules {
        bic_threshold: opts.bic_threshold,
        min_heldout_gain: opts.min_heldout_gain,
        stop_ratio: opts.stop_ratio,
        max_findings: opts.max_findings,
    };
    let sel = engine::select(
        &problem,
        Model::Lags(RIGID),
        &rules,
        &ch.name,
        progress,
        span,
    );
    let out = rigid_outcome(ch, inp, sel.noise, sel.base_fit.prediction[0]);
    if sel.steps.is_empty() {
        return out;
    }
    with_chosen_model(out, ch, &problem, &sel, opts)
}

/// A channel's outcome under the rigid constant `mean_train` (fitted on the fitting
/// part): its residual RMS on both parts, the misfit above the noise floor `noise`, and
/// where the drift is largest.
fn rigid_outcome(ch: &Channel, inp: &Inputs, noise: f64, mean_train: f64) -> ChannelOutcome {
    let y = &ch.values;
    let (n, nt) = (y.len(), inp.n_train);
    let rigid_res: Vec<f64> = y.iter().map(|v| v - mean_train).collect();
    let rigid_train_rms = rms(&rigid_res[..nt]);
    let rigid_test_rms = rms(&rigid_res[nt..]);
    let misfit_sse =
        (rigid_res.iter().map(|v| v * v).sum::<f64>() - n as f64 * noise * noise).max(0.0);
    // Where: the peak and the span where |drift| exceeds half of it.
    let (ipk, pk) = rigid_res
        .iter()
        .enumerate()
        .map(|(i, v)| (i, v.abs()))
        .max_by(|a, b| a.1.total_cmp(&b.1))
        .unwrap_or((0, 0.0));
    let over: Vec<usize> = (0..n).filter(|&i| rigid_res[i].abs() >= 0.5 * pk).collect();
    let hours = |i: usize| (inp.t[i] - inp.t[0]) / 3600.0;
    let window_h = (
        over.first().map_or(0.0, |&i| hours(i)),
        over.last().map_or(0.0, |&i| hours(i)),
    );
    ChannelOutcome {
        name: ch.name.clone(),
        noise,
        rigid_pred: mean_train,
        pred: vec![mean_train; n],
        rigid_train_rms,
        rigid_test_rms,
        after_train_rms: rigid_train_rms,
        after_test_rms: rigid_test_rms,
        share_predicted: 0.0,
        misfit_sse,
        finding: None,
        peak: (rigid_res[ipk], hours(ipk)),
        window_h,
    }
}

/// The chosen model's prediction at every sample, its parameters, what the channel
/// follows under it and the model described with its cross-validated RMS.
fn chosen_fit(
    problem: &ChannelProblem<'_>,
    sel: &engine::Selection<ChannelProblem<'_>>,
) -> (Vec<f64>, BTreeMap<String, f64>, String, String) {
    let inp = problem.inp;
    let mut params = BTreeMap::new();
    match (&sel.model, &problem.thermal) {
        (Model::Lags(l), _) => (
            parametric_fit(inp, problem.y, l, &mut params),
            params,
            describe(&sel.model),
            format!(
                "{}, CV RMS {:.3} µm",
                describe(&sel.model),
                sel.heldout_rms()
            ),
        ),
        (Model::Thermal, Some(f)) => {
            for g in &f.gains {
                let name = if g.input == "spindle" {
                    "spindle_gain_um".to_string()
                } else {
                    format!("{}_um_per_k", g.input.trim_end_matches("_c"))
                };
                params.insert(format!("std_{name}"), g.std);
                params.insert(name, g.value);
            }
            let mut inputs = vec![];
            if inp
                .bank
                .iter()
                .any(|r| matches!(r.source, thermal::Source::Spindle { .. }))
            {
                inputs.push("the spindle's running history (heat input ∝ n and n²)".to_string());
            }
            if !inp.temps.is_empty() {
                inputs.push(format!("{} structure temperatures", inp.temps.len()));
            }
            (
                f.prediction.clone(),
                params,
                format!(
                    "{} through first-order lags of 0.1–2 h",
                    inputs.join(" and ")
                ),
                format!(
                    "thermal model (ridge, λ = {:.2e}, {:.1} effective parameters of {}), CV \
                     RMS {:.3} µm",
                    f.lambda,
                    f.edf,
                    inp.bank.len(),
                    f.cv_rms
                ),
            )
        }
        (Model::Thermal, None) => unreachable!("the thermal candidate needs its fit"),
    }
}

/// The outcome `out` of the rigid constant with the model the engine chose: fitted on the
/// fitting part, judged on the rest, and its finding.
fn with_chosen_model(
    mut out: ChannelOutcome,
    ch: &Channel,
    problem: &ChannelProblem<'_>,
    sel: &engine::Selection<ChannelProblem<'_>>,
    opts: &SeriesOptions,
) -> ChannelOutcome {
    let y = &ch.values;
    let (n, nt) = (y.len(), problem.inp.n_train);
    let mean_train = out.rigid_pred;
    let sse_rigid_test: f64 = y[nt..]
        .iter()
        .map(|v| {
            let r = v - mean_train;
            r * r
        })
        .sum();
    let nv = sel.n_heldout.max(1) as f64;
    let (pred, mut params, follows, model_txt) = chosen_fit(problem, sel);
    let res: Vec<f64> = y.iter().zip(&pred).map(|(a, b)| a - b).collect();
    let sse_after_test: f64 = res[nt..].iter().map(|v| v * v).sum();
    out.after_train_rms = rms(&res[..nt]);
    out.after_test_rms = rms(&res[nt..]);
    out.share_predicted = if sse_rigid_test > 0.0 {
        1.0 - sse_after_test / sse_rigid_test
    } else {
        0.0
    };
    params.insert("share_predicted".into(), out.share_predicted);
    let rho = thermal::lag1_autocorr(&res[..nt]);
    out.pred = pred;
    let others: Vec<String> = sel
        .tried
        .iter()
        .map(|s| format!("{}: {:.3}", describe(&s.model), (s.heldout_sse / nv).sqrt()))
        .collect();
    let evidence = format!(
        "{} follows {follows}; rolling-origin CV RMS on the first {:.0} % (blocks 3–5 of 5, \
         each predicted from the rows before it): rigid {:.3} µm, chosen {model_txt}; \
         candidates — {}; held-out MAE {:.3} µm (rigid {:.3} µm); lag-1 autocorrelation of \
         residuals {:.2}",
        ch.name,
        100.0 * opts.train_fraction,
        sel.base_heldout_rms(),
        others.join("; "),
        thermal::mae(y, &out.pred, nt..n),
        thermal::mae(y, &vec![mean_train; n], nt..n),
        rho
    );
    out.finding = Some(Finding {
        effect: "thermal_drift".into(),
        axis: Some(ch.name.trim_end_matches("_um").to_string()),
        depends_on: None,
        parameters: params,
        undetermined: vec![],
        rivals: Vec::new(),
        physics: effects::physics("thermal_drift").into(),
        residual_rms_um: BeforeAfter {
            before: out.rigid_train_rms,
            after: out.after_train_rms,
        },
        heldout_rms_um: BeforeAfter {
            before: out.rigid_test_rms,
            after: out.after_test_rms,
        },
        evidence,
        signature: None,
    });
    out
}

/// Least-squares fit of a parametric spindle model on the fitting part: its prediction
/// at every sample; τ and gains with their uncertainties (Jacobian with ∂/∂ln τ columns,
/// AR(1) inflation) into `params`.
fn parametric_fit(
    inp: &Inputs,
    y: &[f64],
    model: &Lags,
    params: &mut BTreeMap<String, f64>,
) -> Vec<f64> {
    let nt = inp.n_train;
    let d = inp.design(model);
    let train: Vec<usize> = (0..nt).collect();
    let fit = lsq::solve(&d.rows(&train), &y[..nt]);
    let pred = d.predict(&fit.coef);
    let res: Vec<f64> = y.iter().zip(&pred).map(|(a, b)| a - b).collect();
    let inflate = thermal::ar1_inflation(&res[..nt]);
    let mut jac = d.rows(&train);
    let u = inp.heat(model.p);
    for (j, &tau) in model.taus.iter().enumerate() {
        let h: f64 = 1e-3;
        let a = first_order_lag(inp.t, &u, tau * h.exp());
        let b = first_order_lag(inp.t, &u, tau * (-h).exp());
        let g = fit.coef[1 + j];
        jac.push(
            format!("lntau{}", j + 1),
            (0..nt).map(|i| g * (a[i] - b[i]) / (2.0 * h)).collect(),
        );
    }
    let jfit = lsq::solve(&jac, &res[..nt]);
    params.insert("rpm_exponent".into(), model.p);
    for (j, &tau) in model.taus.iter().enumerate() {
        let k = j + 1;
        params.insert(format!("tau{k}_s"), tau);
        params.insert(
            format!("std_tau{k}_s"),
            tau * jfit.std[d.len() + j] * inflate,
        );
        params.insert(format!("gain{k}_um"), fit.coef[k]);
        params.insert(format!("std_gain{k}_um"), jfit.std[k] * inflate);
    }
    pred
}

fn validate(log: &DriftLog, opts: &SeriesOptions) -> Result<usize, SolverError> {
    let n = log.t_s.len();
    if n < 40 {
        return Err(SolverError::InvalidInput(format!(
            "drift log has {n} samples, at least 40 needed"
        )));
    }
    if log.t_s.windows(2).any(|w| w[1] <= w[0] || w[1].is_nan())
        || log.t_s.iter().any(|v| !v.is_finite())
    {
        return Err(SolverError::InvalidInput(
            "drift log time t_s must be finite and strictly increasing".into(),
        ));
    }
    for c in &log.channels {
        if c.values.len() != n {
            return Err(SolverError::InvalidInput(format!(
                "channel {} has {} values, t_s has {n}",
                c.name,
                c.values.len()
            )));
        }
        if c.values.iter().any(|v| !v.is_finite()) {
            return Err(SolverError::InvalidInput(format!(
                "channel {} has a non-finite value",
                c.name
            )));
        }
    }
    if !log
        .channels
        .iter()
        .any(|c| c.kind == ChannelKind::DisplacementUm)
    {
        return Err(SolverError::InvalidInput(
            "drift log has no displacement channel (<name>_um)".into(),
        ));
    }
    if !(0.2..=0.9).contains(&opts.train_fraction) {
        return Err(SolverError::InvalidInput(
            "train_fraction must lie in [0.2, 0.9]".into(),
        ));
    }
    Ok(((n as f64) * opts.train_fraction).floor() as usize)
}

/// The chosen models' predictions at full resolution (one value per sample), for export
/// to a controller-side compensation.
#[derive(Debug, Clone, PartialEq)]
pub struct DriftPredictions {
    pub t_s: Vec<f64>,
    /// Samples `0..n_fit` were used to fit; the rest is held out.
    pub n_fit: usize,
    pub channels: Vec<ChannelPrediction>,
}

/// One displacement channel: measured and predicted values (µm, the channel's own sign:
/// the displacement of the tool relative to the table along the channel's direction).
#[derive(Debug, Clone, PartialEq)]
pub struct ChannelPrediction {
    /// Channel name as in the log (`ch1_um`).
    pub name: String,
    pub measured_um: Vec<f64>,
    /// The chosen model (the rigid constant when no thermal model was kept).
    pub model_um: Vec<f64>,
    /// The model's value at the first sample: `model_um − model_at_start_um` is the
    /// thermal drift since the start of the log.
    pub model_at_start_um: f64,
    /// Whether a thermal model was kept for this channel.
    pub thermal_model: bool,
}

/// Diagnoses a drift log (module docs): one `thermal_drift` finding per displacement
/// channel the inputs explain (`axis` carries the channel name without `_um`), held-out
/// figures on the last `1 − train_fraction` of the recording, and one plot per channel.
pub fn diagnose_drift_log(
    log: &DriftLog,
    machine_id: &str,
    opts: &SeriesOptions,
) -> Result<DiagnosisResult, SolverError> {
    diagnose_drift_log_with_predictions(log, machine_id, opts).map(|(r, _)| r)
}

/// [`diagnose_drift_log`] and the models' predictions at every sample.
pub fn diagnose_drift_log_with_predictions(
    log: &DriftLog,
    machine_id: &str,
    opts: &SeriesOptions,
) -> Result<(DiagnosisResult, DriftPredictions), SolverError> {
    diagnose_drift_log_with_progress(log, machine_id, opts, &mut NoProgress)
}

/// [`diagnose_drift_log_with_predictions`], reporting its phases (per channel: the
/// spindle-lag candidates, the thermal model) with a monotone fraction of the work that
/// ends at 1 with `done`.
pub fn diagnose_drift_log_with_progress(
    log: &DriftLog,
    machine_id: &str,
    opts: &SeriesOptions,
    progress: &mut dyn Progress,
) -> Result<(DiagnosisResult, DriftPredictions), SolverError> {
    let n_train = validate(log, opts)?;
    let mut progress = Monotone::new(progress);
    progress.report("regressors of the thermal model", 0.0);
    let inp = inputs(log, n_train);
    let displacements: Vec<&Channel> = displacements(log).collect();
    // Each channel is an equal part of the work.
    let part = |k: usize| k as f64 / displacements.len() as f64;
    let outs: Vec<ChannelOutcome> = displacements
        .iter()
        .enumerate()
        .map(|(k, c)| analyse_channel(c, &inp, opts, &mut progress, (part(k), part(k + 1))))
        .collect();

    let quad = |f: &dyn Fn(&ChannelOutcome) -> f64| -> f64 {
        (outs.iter().map(|o| f(o).powi(2)).sum::<f64>() / outs.len() as f64).sqrt()
    };
    let baseline = Baseline {
        residual_rms_um: quad(&|o| o.rigid_train_rms),
        heldout_rms_um: quad(&|o| o.rigid_test_rms),
        noise_estimate_um: quad(&|o| o.noise),
    };
    let needs = |o: &ChannelOutcome| o.rigid_test_rms > opts.explained_ratio * o.noise;
    let findings: Vec<Finding> = outs.iter().filter_map(|o| o.finding.clone()).collect();
    let result = super::result(
        machine_id,
        "drift_log",
        baseline,
        mismatches(&outs, opts),
        findings,
        !outs.iter().any(needs),
        unexplained(&outs, opts),
        drift_plots(log, &outs, n_train, opts),
    );
    progress.report("done", 1.0);
    Ok((result, predictions(log, &outs, n_train)))
}

/// The displacement channels of a log, in its order.
fn displacements(log: &DriftLog) -> impl Iterator<Item = &Channel> {
    log.channels
        .iter()
        .filter(|c| c.kind == ChannelKind::DisplacementUm)
}

/// The inputs of every channel's models: the spindle speed, the structure temperatures
/// and the thermal model's regressors (lags fitted on the first `n_train` samples).
fn inputs(log: &DriftLog, n_train: usize) -> Inputs<'_> {
    let speed = log
        .channels
        .iter()
        .find(|c| c.kind == ChannelKind::SpeedRpm);
    let rpm_max = speed.map_or(0.0, |s| s.values.iter().fold(0.0f64, |a, v| a.max(v.abs())));
    let temps: Vec<(&str, &[f64])> = log
        .channels
        .iter()
        .filter(|c| c.kind == ChannelKind::TemperatureC)
        .map(|c| (c.name.as_str(), c.values.as_slice()))
        .collect();
    let bank = thermal::regressors(
        &ThermalInputs {
            t_s: &log.t_s,
            speed_rpm: speed.map(|c| c.values.as_slice()),
            temperatures: &temps,
        },
        &ThermalOptions::default(),
        log.t_s[n_train - 1] - log.t_s[0],
    );
    Inputs {
        t: &log.t_s,
        speed,
        rpm_max,
        temps,
        n_train,
        bank,
    }
}

/// Where the rigid constant does not explain a channel, largest share of the misfit
/// first.
fn mismatches(outs: &[ChannelOutcome], opts: &SeriesOptions) -> Vec<Mismatch> {
    let total_misfit: f64 = outs.iter().map(|o| o.misfit_sse).sum();
    let mut mismatch: Vec<Mismatch> = outs
        .iter()
        .filter(|o| {
            o.rigid_test_rms > opts.explained_ratio * o.noise
                || o.rigid_train_rms > opts.explained_ratio * o.noise
        })
        .map(|o| Mismatch {
            where_: format!(
                "{}: drifts away from its constant by up to {:.2} µm (at {:.1} h); |drift| above \
                 half of that from {:.1} h to {:.1} h",
                o.name, o.peak.0, o.peak.1, o.window_h.0, o.window_h.1
            ),
            tests: vec![o.name.clone()],
            share_of_misfit: if total_misfit > 0.0 {
                o.misfit_sse / total_misfit
            } else {
                0.0
            },
        })
        .collect();
    mismatch.sort_by(|a, b| b.share_of_misfit.total_cmp(&a.share_of_misfit));
    mismatch
}

/// The channels that need a model and are still above their noise floor with it.
fn unexplained(outs: &[ChannelOutcome], opts: &SeriesOptions) -> Vec<String> {
    let needs = |o: &ChannelOutcome| o.rigid_test_rms > opts.explained_ratio * o.noise;
    let mut unexplained = vec![];
    for o in outs {
        if needs(o) && o.after_test_rms > opts.explained_ratio * o.noise {
            unexplained.push(format!(
                "{}: held-out RMS {:.3} µm after the model (rigid {:.3} µm, noise floor {:.3} µm); \
                 {:.0} % of the held-out drift predicted{}",
                o.name,
                o.after_test_rms,
                o.rigid_test_rms,
                o.noise,
                100.0 * o.share_predicted,
                if o.finding.is_none() {
                    ", no candidate improved the cross-validated fit"
                } else {
                    ""
                }
            ));
        }
    }
    unexplained
}

/// One plot per channel: measured, rigid, model against time (h), with the split marked.
fn drift_plots(
    log: &DriftLog,
    outs: &[ChannelOutcome],
    n_train: usize,
    opts: &SeriesOptions,
) -> Vec<PlotData> {
    let t_h: Vec<f64> = log.t_s.iter().map(|t| (t - log.t_s[0]) / 3600.0).collect();
    let t_split = t_h[n_train];
    let idx = decimate(t_h.len(), opts.plot_points);
    let pick = |v: &[f64]| -> Vec<f64> { idx.iter().map(|&i| v[i]).collect() };
    let mut plots = vec![];
    for (o, ch) in outs.iter().zip(displacements(log)) {
        let (lo, hi) = ch
            .values
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
                (a.min(v), b.max(v))
            });
        plots.push(PlotData {
            id: format!("drift_{}", o.name.trim_end_matches("_um")),
            title: format!(
                "{}: held-out RMS {:.2} → {:.2} µm, {:.0} % of the held-out drift predicted",
                o.name,
                o.rigid_test_rms,
                o.after_test_rms,
                100.0 * o.share_predicted
            ),
            x_label: "time (h)".into(),
            y_label: format!("{} (µm)", o.name),
            kind: PlotKind::Cartesian,
            series: vec![
                PlotSeries {
                    name: "measured".into(),
                    x: pick(&t_h),
                    y: pick(&ch.values),
                },
                PlotSeries {
                    name: "rigid model (constant)".into(),
                    x: vec![t_h[0], *t_h.last().unwrap_or(&0.0)],
                    y: vec![o.rigid_pred, o.rigid_pred],
                },
                PlotSeries {
                    name: "thermal model".into(),
                    x: pick(&t_h),
                    y: pick(&o.pred),
                },
                PlotSeries {
                    name: "train | test split".into(),
                    x: vec![t_split, t_split],
                    y: vec![lo, hi],
                },
            ],
        });
    }
    plots
}

/// The chosen models' predictions at every sample.
fn predictions(log: &DriftLog, outs: &[ChannelOutcome], n_train: usize) -> DriftPredictions {
    DriftPredictions {
        t_s: log.t_s.clone(),
        n_fit: n_train,
        channels: outs
            .iter()
            .zip(displacements(log))
            .map(|(o, ch)| ChannelPrediction {
                name: ch.name.clone(),
                measured_um: ch.values.clone(),
                model_at_start_um: o.pred[0],
                model_um: o.pred.clone(),
                thermal_model: o.finding.is_some(),
            })
            .collect(),
    }
}
