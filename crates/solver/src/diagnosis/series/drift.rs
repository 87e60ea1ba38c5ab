//! Drift logs (datasets contract section 4, ISO 230-3 style): the rigid model predicts no
//! movement, i.e. a constant per displacement channel. The missing physics is thermal
//! growth of the structure, modelled two ways and chosen per channel on the fitting part
//! of the recording alone:
//!
//! * **spindle lags** (parametric, interpretable): the heat input u(t) = (n(t)/n_max)^p
//!   of the spindle speed n (p = 1 or 2) drives one or two first-order lags
//!   Lτ[u]: τ ẋ = u − x ([`first_order_lag`]). Model y = c + Σ_j g_j Lτ_j[u]; g_j is the
//!   steady-state growth at full speed (µm); τ_j by a 1-D log-grid search of the fit's
//!   sum of squares refined by golden section (two lags: grid of pairs, then coordinate
//!   refinement). Two lags of opposite sign describe a fast (spindle, head) and a slow
//!   (column, bed) path.
//! * **thermal model** ([`crate::thermal`]): ridge regression on a bank of lags of the
//!   spindle heat input (n and n², 0.1–2 h) and of every structure temperature
//!   (0.1–2 h), its penalty chosen by rolling-origin cross-validation.
//!
//! Protocol: fit on the first `train_fraction` (60 %) of the recording, judge on the rest.
//! Every candidate, and the rigid constant, is scored by the same rolling-origin
//! cross-validation inside the fitting part ([`crate::thermal::rolling_origin`]: blocks
//! 3, 4 and 5 of 5, each predicted by the model fitted on all rows before it), so the
//! rest of the recording is never used for a choice. (The parametric candidates' time
//! constants are searched once on the whole fitting part, a mild optimism of their CV
//! figure.) Parsimony ([`PARSIMONY`]): a second lag, and the thermal model instead of the
//! parametric one, must each lower the CV sum of squares by more than 10 %; the chosen
//! model must lower the rigid constant's CV sum of squares by `min_heldout_gain`.
//! Reported: held-out RMS and MAE of the rigid constant (fitted on the fitting part) and
//! of the model, and the share of drift predicted, 1 − SSE_after/SSE_rigid on the
//! held-out part.
//!
//! Noise floor per channel, independent of any model: σ = 1.4826·median|Δy| / √2 (the
//! sample-to-sample scatter; slow drift contributes nothing to it).
//! Uncertainties: parametric model, from the Jacobian including ∂/∂ln τ columns; thermal
//! model, from the ridge covariance ([`crate::thermal`]); both multiplied by
//! √((1+ρ)/(1−ρ)) with ρ the lag-1 autocorrelation of the fit residuals (effective sample
//! size of AR(1) residuals). They remain indicative, the residuals of a drift model are
//! not white. A parameter whose standard uncertainty exceeds a third of its magnitude is
//! not reported as a finding's parameter but listed as undetermined, with what data
//! would decide it.

use super::lsq::{self, Design};
use super::{SeriesOptions, decimate, golden_min, log_grid, rms};
use crate::datasets::{Channel, ChannelKind, DriftLog};
use crate::diagnosis::{
    Baseline, BeforeAfter, DiagnosisResult, Finding, Mismatch, Monotone, NoProgress, PlotData,
    PlotSeries, Progress, Undetermined, Verdict,
};
use crate::error::SolverError;
use crate::thermal::{self, DETERMINED_Z, Regressor, ThermalFit, ThermalInputs, ThermalOptions};
use std::collections::BTreeMap;

pub use crate::thermal::first_order_lag;

/// Parsimony: a richer model (a second lag; the thermal model instead of the parametric
/// one) is chosen only when its cross-validated sum of squares is below this fraction of
/// the simpler one's.
pub const PARSIMONY: f64 = 0.9;

/// Parametric spindle model: heat-input exponent p and lag time constants (s); no lags:
/// the rigid constant.
#[derive(Debug, Clone, PartialEq)]
struct Model {
    p: f64,
    taus: Vec<f64>,
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

    fn design(&self, m: &Model) -> Design {
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

/// Rolling-origin cross-validation sum of squares of a least-squares design on the
/// fitting rows `0..n_train` (folds of [`thermal::rolling_origin`]).
fn cv_sse(d: &Design, y: &[f64], n_train: usize) -> f64 {
    thermal::rolling_origin(n_train)
        .iter()
        .map(|f| {
            let train: Vec<usize> = (0..f.train_end).collect();
            let fit = lsq::solve(&d.rows(&train), &y[..f.train_end]);
            let valid: Vec<usize> = f.valid.clone().collect();
            let pred = d.rows(&valid).predict(&fit.coef);
            valid
                .iter()
                .zip(&pred)
                .map(|(&i, p)| (y[i] - p).powi(2))
                .sum::<f64>()
        })
        .sum()
}

/// Number of rows the rolling-origin folds predict.
fn cv_rows(n_train: usize) -> usize {
    thermal::rolling_origin(n_train)
        .iter()
        .map(|f| f.valid.len())
        .sum()
}

/// Training-part SSE of y on [1, columns...].
fn train_sse(cols: &[&[f64]], y: &[f64], n_train: usize) -> f64 {
    let mut d = Design::new();
    d.push("c", vec![1.0; n_train]);
    for c in cols {
        d.push("x", c[..n_train].to_vec());
    }
    lsq::sse(&d, &y[..n_train])
}

/// Best spindle-lag model with `nlags` lags for exponent `p`, by training SSE.
fn search_lags(inp: &Inputs, y: &[f64], p: f64, nlags: usize) -> Vec<f64> {
    let t = inp.t;
    let nt = inp.n_train;
    let dt = (t[nt - 1] - t[0]) / (nt - 1) as f64;
    let grid = log_grid((4.0 * dt).max(60.0), 2.0 * (t[nt - 1] - t[0]), 22);
    let u = inp.heat(p);
    let bank: Vec<Vec<f64>> = grid
        .iter()
        .map(|&tau| first_order_lag(t, &u, tau))
        .collect();
    let eval = |taus: &[f64]| -> f64 {
        let cols: Vec<Vec<f64>> = taus
            .iter()
            .map(|&tau| first_order_lag(t, &u, tau))
            .collect();
        let refs: Vec<&[f64]> = cols.iter().map(|c| c.as_slice()).collect();
        train_sse(&refs, y, nt)
    };
    let mut best: Vec<usize> = vec![];
    let mut best_sse = f64::INFINITY;
    if nlags == 1 {
        for i in 0..grid.len() {
            let s = train_sse(&[&bank[i]], y, nt);
            if s < best_sse {
                best_sse = s;
                best = vec![i];
            }
        }
    } else {
        for i in 0..grid.len() {
            for j in i + 1..grid.len() {
                let s = train_sse(&[&bank[i], &bank[j]], y, nt);
                if s < best_sse {
                    best_sse = s;
                    best = vec![i, j];
                }
            }
        }
    }
    // Further lags one at a time (the others held at their grid points).
    while best.len() < nlags {
        let mut add: Option<(usize, f64)> = None;
        for k in 0..grid.len() {
            if best.contains(&k) {
                continue;
            }
            let mut cols: Vec<&[f64]> = best.iter().map(|&i| bank[i].as_slice()).collect();
            cols.push(&bank[k]);
            let s = train_sse(&cols, y, nt);
            if add.is_none_or(|(_, b)| s < b) {
                add = Some((k, s));
            }
        }
        match add {
            Some((k, _)) => best.push(k),
            None => break,
        }
    }
    // Coordinate refinement of each ln τ between the neighbouring grid points.
    let step = (grid[1] / grid[0]).ln();
    let mut taus: Vec<f64> = best.iter().map(|&i| grid[i]).collect();
    for _round in 0..2 {
        for k in 0..taus.len() {
            let l0 = taus[k].ln();
            let (lbest, _) = golden_min(l0 - step, l0 + step, 14, |l| {
                let mut tt = taus.clone();
                tt[k] = l.exp();
                eval(&tt)
            });
            let mut tt = taus.clone();
            tt[k] = lbest.exp();
            if eval(&tt) <= eval(&taus) {
                taus = tt;
            }
        }
    }
    taus.sort_by(f64::total_cmp);
    taus
}

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
    let p = if m.p == 1.0 { "n" } else { "n²" };
    format!(
        "{} first-order lag(s) of spindle heat input ∝ {p}",
        m.taus.len()
    )
}

/// The model chosen for a channel.
enum Chosen {
    Parametric { desc: String, model: Model, cv: f64 },
    Thermal(Box<ThermalFit>),
}

/// Splits (name, value, std) into determined parameters and undetermined ones (`decide`:
/// the data that would decide it).
fn sort_parameter(
    params: &mut BTreeMap<String, f64>,
    undetermined: &mut Vec<Undetermined>,
    (name, value, std): (String, f64, f64),
    decide: &str,
) {
    if value.abs() >= DETERMINED_Z * std && std.is_finite() {
        params.insert(format!("std_{name}"), std);
        params.insert(name, value);
    } else {
        undetermined.push(Undetermined::new(name, value, std, decide));
    }
}

/// Diagnoses one displacement channel, reporting its phases within the part `span` of the
/// whole work.
fn analyse_channel(
    ch: &Channel,
    inp: &Inputs,
    opts: &SeriesOptions,
    progress: &mut Monotone,
    span: (f64, f64),
) -> ChannelOutcome {
    let y = &ch.values;
    let n = y.len();
    let nt = inp.n_train;
    let noise = noise_floor(y);
    let rigid = Model {
        p: 1.0,
        taus: vec![],
    };
    let nv = cv_rows(nt).max(1) as f64;
    let cv_rigid = cv_sse(&inp.design(&rigid), y, nt);
    let mean_train = y[..nt].iter().sum::<f64>() / nt as f64;
    let rigid_res: Vec<f64> = y.iter().map(|v| v - mean_train).collect();

    // Candidates, each scored by rolling-origin CV on the fitting part only.
    let mut cands: Vec<(String, Model, f64)> = vec![];
    if inp.speed.is_some() && inp.rpm_max > 0.0 {
        for p in [1.0, 2.0] {
            for nl in [1, 2] {
                progress.report_in(
                    span,
                    &format!("{}: spindle-lag candidates", ch.name),
                    0.15 * cands.len() as f64,
                );
                let m = Model {
                    p,
                    taus: search_lags(inp, y, p, nl),
                };
                let s = cv_sse(&inp.design(&m), y, nt);
                cands.push((describe(&m), m, s));
            }
        }
    }
    // The best one-lag model; a second lag must earn its place the same way.
    let best_of = |nl: usize| {
        cands
            .iter()
            .filter(|c| c.1.taus.len() == nl)
            .min_by(|a, b| a.2.total_cmp(&b.2))
            .cloned()
    };
    let parametric = match (best_of(1), best_of(2)) {
        (Some(one), Some(two)) if two.2 < PARSIMONY * one.2 => Some(two),
        (one, _) => one,
    };
    progress.report_in(span, &format!("{}: thermal model", ch.name), 0.6);
    let thermal_fit = if inp.bank.is_empty() {
        None
    } else {
        thermal::fit_thermal(&inp.bank, &inp.thermal(), y, nt, &ThermalOptions::default()).ok()
    };
    let thermal_cv = thermal_fit
        .as_ref()
        .map(|f| f.cv_rms.powi(2) * f.cv_rows as f64);
    let thermal_wins = |cv: f64| thermal_cv.is_some_and(|s| s < PARSIMONY * cv);
    let chosen = match (parametric, thermal_fit) {
        (Some((_, _, cv)), Some(t)) if thermal_wins(cv) => Some(Chosen::Thermal(Box::new(t))),
        (Some((desc, model, cv)), _) => Some(Chosen::Parametric { desc, model, cv }),
        (None, Some(t)) => Some(Chosen::Thermal(Box::new(t))),
        (None, None) => None,
    };
    let chosen_cv = |c: &Chosen| match c {
        Chosen::Parametric { cv, .. } => *cv,
        Chosen::Thermal(_) => thermal_cv.unwrap_or(f64::INFINITY),
    };
    let chosen = chosen.filter(|c| chosen_cv(c) < (1.0 - opts.min_heldout_gain) * cv_rigid);

    let rigid_train_rms = rms(&rigid_res[..nt]);
    let rigid_test_rms = rms(&rigid_res[nt..]);
    let sse_rigid_test: f64 = rigid_res[nt..].iter().map(|v| v * v).sum();
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
    let mut out = ChannelOutcome {
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
    };
    let Some(chosen) = chosen else {
        return out;
    };

    // The chosen model fitted on the fitting part; judged on the rest.
    let mut params = BTreeMap::new();
    let mut undetermined = vec![];
    let (pred, physics, model_txt) = match &chosen {
        Chosen::Parametric { desc, model, .. } => (
            parametric_fit(inp, y, model, &mut params, &mut undetermined),
            format!(
                "thermal growth of the structure: {} follows {desc}; the rigid-body model \
                     assumes a constant position",
                ch.name
            ),
            format!("{desc}, CV RMS {:.3} µm", (chosen_cv(&chosen) / nv).sqrt()),
        ),
        Chosen::Thermal(f) => {
            for g in &f.gains {
                let (name, decide) = if g.input == "spindle" {
                    (
                        "spindle_gain_um".to_string(),
                        "the spindle paths and the temperatures move together in this log; a \
                         run held at one speed for longer than the longest lag (2 h), \
                         temperatures logged,"
                            .to_string(),
                    )
                } else {
                    let short = g.input.trim_end_matches("_c");
                    (
                        format!("{short}_um_per_k"),
                        "the sensor's temperature moves together with other inputs in \
                         this log; a log in which it changes on its own (e.g. an ambient \
                         change with the spindle at rest)"
                            .to_string(),
                    )
                };
                sort_parameter(
                    &mut params,
                    &mut undetermined,
                    (name, g.value, g.std),
                    &decide,
                );
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
                format!(
                    "thermal growth of the structure: {} follows {} through first-order lags \
                     of 0.1–2 h; the rigid-body model assumes a constant position",
                    ch.name,
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
    };
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
    let others: Vec<String> = cands
        .iter()
        .map(|(d, _, s)| format!("{d}: {:.3}", (s / nv).sqrt()))
        .collect();
    let evidence = format!(
        "rolling-origin CV RMS on the first {:.0} % (blocks 3–5 of 5, each predicted from the \
         rows before it): rigid {:.3} µm, chosen {model_txt}; parametric candidates — {}; \
         held-out MAE {:.3} µm (rigid {:.3} µm); lag-1 autocorrelation of residuals {:.2}",
        100.0 * opts.train_fraction,
        (cv_rigid / nv).sqrt(),
        if others.is_empty() {
            "none (no spindle speed)".to_string()
        } else {
            others.join("; ")
        },
        thermal::mae(y, &out.pred, nt..n),
        thermal::mae(y, &vec![mean_train; n], nt..n),
        rho
    );
    out.finding = Some(Finding {
        effect: "thermal_drift".into(),
        axis: Some(ch.name.trim_end_matches("_um").to_string()),
        parameters: params,
        undetermined,
        physics,
        residual_rms_um: BeforeAfter {
            before: rigid_train_rms,
            after: out.after_train_rms,
        },
        heldout_rms_um: BeforeAfter {
            before: rigid_test_rms,
            after: out.after_test_rms,
        },
        evidence,
        signature: None,
    });
    out
}

/// Least-squares fit of a parametric spindle model on the fitting part: its prediction
/// at every sample; τ and gains sorted into determined parameters and
/// undetermined ones (uncertainties from the Jacobian with ∂/∂ln τ columns, AR(1)
/// inflation).
fn parametric_fit(
    inp: &Inputs,
    y: &[f64],
    model: &Model,
    params: &mut BTreeMap<String, f64>,
    undetermined: &mut Vec<Undetermined>,
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
        sort_parameter(
            params,
            undetermined,
            (
                format!("tau{}_s", j + 1),
                tau,
                tau * jfit.std[d.len() + j] * inflate,
            ),
            "a longer recording with the spindle held at one speed for several time constants \
            ",
        );
        sort_parameter(
            params,
            undetermined,
            (
                format!("gain{}_um", j + 1),
                fit.coef[1 + j],
                jfit.std[1 + j] * inflate,
            ),
            "speed steps that move the channel by many times its noise, each held for several \
             time constants",
        );
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
    let inp = Inputs {
        t: &log.t_s,
        speed,
        rpm_max,
        temps,
        n_train,
        bank,
    };
    let displacements: Vec<&Channel> = log
        .channels
        .iter()
        .filter(|c| c.kind == ChannelKind::DisplacementUm)
        .collect();
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

    let needs = |o: &ChannelOutcome| o.rigid_test_rms > opts.explained_ratio * o.noise;
    let findings: Vec<Finding> = outs.iter().filter_map(|o| o.finding.clone()).collect();
    let mut unexplained = vec![];
    for o in &outs {
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
    let verdict = if !outs.iter().any(needs) {
        Verdict::Consistent
    } else if unexplained.is_empty() {
        Verdict::Explained
    } else {
        Verdict::PartlyExplained
    };

    // Plots: measured, rigid, model against time (h), with the split marked.
    let t_h: Vec<f64> = log.t_s.iter().map(|t| (t - log.t_s[0]) / 3600.0).collect();
    let t_split = t_h[n_train];
    let idx = decimate(t_h.len(), opts.plot_points);
    let pick = |v: &[f64]| -> Vec<f64> { idx.iter().map(|&i| v[i]).collect() };
    let mut plots = vec![];
    for (o, ch) in outs.iter().zip(
        log.channels
            .iter()
            .filter(|c| c.kind == ChannelKind::DisplacementUm),
    ) {
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
            kind: "cartesian".into(),
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

    let predictions = DriftPredictions {
        t_s: log.t_s.clone(),
        n_fit: n_train,
        channels: outs
            .iter()
            .zip(
                log.channels
                    .iter()
                    .filter(|c| c.kind == ChannelKind::DisplacementUm),
            )
            .map(|(o, ch)| ChannelPrediction {
                name: ch.name.clone(),
                measured_um: ch.values.clone(),
                model_at_start_um: o.pred[0],
                model_um: o.pred.clone(),
                thermal_model: o.finding.is_some(),
            })
            .collect(),
    };
    let result = DiagnosisResult {
        kind: "diagnosis".into(),
        machine_id: machine_id.into(),
        source: "drift_log".into(),
        baseline,
        mismatch,
        findings,
        possible: vec![],
        rejected: vec![],
        verdict,
        unexplained,
        plots,
    };
    progress.report("done", 1.0);
    Ok((result, predictions))
}
