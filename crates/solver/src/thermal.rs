//! Thermal drift model of a drift log (datasets contract section 4): the displacement of
//! the tool relative to the table predicted from the spindle's running history and the
//! structure temperatures, as a linear time-invariant response, regularised, with every
//! setting chosen inside the fitting part of the recording.
//!
//! # Model
//!
//! For one displacement channel y (µm), sampled at times tₖ,
//!
//! y(t) = c + Σ_{p, τ} g_{p,τ} · L_τ[(n/n_max)^p](t) + Σ_{i, τ} k_{i,τ} · L_τ[T_i − T_i(t₀)](t)
//!
//! * L_τ is the first-order lag τ ẋ = u − x ([`first_order_lag`]): the exact response of
//!   one thermal capacity behind one resistance to an input held between samples.
//! * Spindle heat input (n/n_max)^p, p ∈ {1, 2} (bearing and motor losses grow between
//!   linearly and quadratically with the speed n), through lags of
//!   τ ∈ {0.1, 0.25, 0.5, 1, 2} h: the fast heat paths (spindle, head) that the
//!   structure sensors do not see. A log without temperature channels adds τ = 4 h and
//!   8 h (kept below half the fitting span), the slow paths the sensors would otherwise
//!   carry.
//! * Each structure temperature T_i through lags of τ ∈ {0.1, 0.5, 2} h: the shortest
//!   one filters sensor noise, the longer ones stand for the parts of the structure that
//!   follow the sensor with a delay (a temperature field diffusing from where it is
//!   measured to where it deforms). g in µm at full speed, k in µm/K.
//!
//! The sum over a fixed bank of time constants replaces a search for a few time
//! constants: it is linear in its coefficients, so the fit is one regularised least-
//! squares problem (a discrete spectrum of relaxation times).
//!
//! # Fit: ridge regression, penalty chosen by rolling-origin cross-validation
//!
//! Only the first `n_fit` samples are used. Columns are centred and scaled to unit norm
//! over the rows of each fit (the intercept c is not penalised); in those coordinates the
//! coefficients minimise ‖y_c − Z b‖² + λ‖b‖², solved from the thin QR of [1 | X | y]
//! (no normal matrix): the trailing block R₂₂ of its triangular factor is the factor of
//! the centred columns, and with R₂₂D⁻¹ = U S Vᵀ (D the column norms)
//! b = D⁻¹ V diag(s/(s² + λ)) Uᵀ (Qᵀy)₂ ([`ridge`]).
//!
//! λ is chosen on a log grid (10⁻⁷ … 10) by rolling-origin cross-validation inside the
//! fitting part ([`rolling_origin`]): the fitting rows are cut into 5 blocks in time; each
//! of the last three is predicted by the model fitted on all rows before it; the λ with
//! the smallest pooled squared prediction error wins. The validation always lies after
//! the data it is predicted from, as in use, and nothing after row `n_fit` is looked at.
//!
//! # Uncertainty and determination
//!
//! cov(b) = σ² D⁻¹ V diag(s²/(s² + λ)²) Vᵀ D⁻¹, σ² = RSS/(n_fit − 1 − edf), edf =
//! Σ s²/(s² + λ) (the effective number of parameters), inflated by (1 + ρ)/(1 − ρ) for the
//! lag-1 autocorrelation ρ of the fit residuals (AR(1) effective sample size). The ridge
//! bias is not included: the figures are indicative.
//!
//! Reported quantities are steady-state sums, which do not depend on how the bank splits
//! a response between neighbouring time constants: the spindle path's growth at full
//! speed G = Σ_{p,τ} g_{p,τ} (µm) and each sensor's sensitivity K_i = Σ_τ k_{i,τ} (µm/K).
//! Whether a quantity is determined is decided by the one rule of every diagnosis
//! (`diagnosis::effects::determined`, docs/diagnosis.md).

use crate::error::SolverError;
use crate::lsq::{QrAccumulator, Reduced};

/// First-order lag of `u` with time constant `tau` (s) on sample times `t`:
/// τ ẋ = u − x, sampled exactly with the input held between samples,
/// x_k = e^{−Δt/τ} x_{k−1} + (1 − e^{−Δt/τ}) u_{k−1}, x_0 = u_0 (at rest at the start).
pub fn first_order_lag(t: &[f64], u: &[f64], tau: f64) -> Vec<f64> {
    let mut x = Vec::with_capacity(u.len());
    if u.is_empty() {
        return x;
    }
    x.push(u[0]);
    for k in 1..u.len() {
        let a = (-(t[k] - t[k - 1]) / tau).exp();
        let prev = x[k - 1];
        x.push(a * prev + (1.0 - a) * u[k - 1]);
    }
    x
}

/// Lag-1 autocorrelation of a residual series (clamped to (−0.99, 0.999)).
pub fn lag1_autocorr(r: &[f64]) -> f64 {
    let m = r.iter().sum::<f64>() / r.len().max(1) as f64;
    let den: f64 = r.iter().map(|v| (v - m).powi(2)).sum();
    let num: f64 = r.windows(2).map(|w| (w[0] - m) * (w[1] - m)).sum();
    if den > 0.0 {
        (num / den).clamp(-0.99, 0.999)
    } else {
        0.0
    }
}

/// Factor on standard uncertainties for AR(1) residuals: √((1 + ρ)/(1 − ρ)).
pub fn ar1_inflation(residuals: &[f64]) -> f64 {
    let rho = lag1_autocorr(residuals);
    ((1.0 + rho) / (1.0 - rho)).sqrt()
}

/// Number of blocks of the rolling-origin cross-validation, and the first block that is
/// predicted (0-based): blocks 3, 4 and 5 of 5.
pub const ROLLING_BLOCKS: usize = 5;
pub const FIRST_PREDICTED_BLOCK: usize = 2;

/// One rolling-origin fold: fit on rows `0..train_end`, predict `valid`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Fold {
    pub train_end: usize,
    pub valid: std::ops::Range<usize>,
}

/// Rolling-origin folds of the fitting rows `0..n_fit` (module docs).
pub fn rolling_origin(n_fit: usize) -> Vec<Fold> {
    (FIRST_PREDICTED_BLOCK..ROLLING_BLOCKS)
        .map(|f| {
            let a = f * n_fit / ROLLING_BLOCKS;
            let b = (f + 1) * n_fit / ROLLING_BLOCKS;
            Fold {
                train_end: a,
                valid: a..b,
            }
        })
        .filter(|f| f.train_end >= 2 && !f.valid.is_empty())
        .collect()
}

pub mod ridge;

use ridge::RidgeSvd;

/// Where a regressor comes from.
#[derive(Debug, Clone, PartialEq)]
pub enum Source {
    /// Spindle heat input (n/n_max)^p.
    Spindle { exponent: f64 },
    /// Structure temperature, index into [`ThermalInputs::temperatures`].
    Temperature(usize),
}

/// One column of the model: an input through a lag of time constant `tau_s`.
#[derive(Debug, Clone)]
pub struct Regressor {
    pub name: String,
    pub source: Source,
    pub tau_s: f64,
    pub values: Vec<f64>,
}

/// The inputs of a drift log.
#[derive(Debug, Clone, Copy)]
pub struct ThermalInputs<'a> {
    pub t_s: &'a [f64],
    /// Spindle speed, rpm (its magnitude is used).
    pub speed_rpm: Option<&'a [f64]>,
    /// Structure temperatures (name, °C).
    pub temperatures: &'a [(&'a str, &'a [f64])],
}

/// Time constants of the regressor bank and the penalty grid (module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct ThermalOptions {
    pub spindle_exponents: Vec<f64>,
    pub spindle_lags_h: Vec<f64>,
    /// Added to the spindle lags when the log has no temperature channel.
    pub spindle_slow_lags_h: Vec<f64>,
    pub temperature_lags_h: Vec<f64>,
    /// Ridge penalties tried (unit-norm columns).
    pub lambdas: Vec<f64>,
}

impl Default for ThermalOptions {
    fn default() -> Self {
        ThermalOptions {
            spindle_exponents: vec![1.0, 2.0],
            spindle_lags_h: vec![0.1, 0.25, 0.5, 1.0, 2.0],
            spindle_slow_lags_h: vec![4.0, 8.0],
            temperature_lags_h: vec![0.1, 0.5, 2.0],
            lambdas: (0..33)
                .map(|i| 10f64.powf(-7.0 + 0.25 * i as f64))
                .collect(),
        }
    }
}

/// The regressor bank of a log (module docs); `fit_span_s` bounds the slow spindle lags.
pub fn regressors(inp: &ThermalInputs, opts: &ThermalOptions, fit_span_s: f64) -> Vec<Regressor> {
    let t = inp.t_s;
    let mut out = vec![];
    if let Some(speed) = inp.speed_rpm {
        let n_max = speed.iter().fold(0.0f64, |a, v| a.max(v.abs()));
        if n_max > 0.0 {
            let mut taus = opts.spindle_lags_h.clone();
            if inp.temperatures.is_empty() {
                taus.extend(
                    opts.spindle_slow_lags_h
                        .iter()
                        .filter(|&&h| h * 3600.0 <= 0.5 * fit_span_s),
                );
            }
            for &p in &opts.spindle_exponents {
                let u: Vec<f64> = speed.iter().map(|n| (n.abs() / n_max).powf(p)).collect();
                for &h in &taus {
                    out.push(Regressor {
                        name: format!("spindle^{p} lag {h} h"),
                        source: Source::Spindle { exponent: p },
                        tau_s: h * 3600.0,
                        values: first_order_lag(t, &u, h * 3600.0),
                    });
                }
            }
        }
    }
    for (i, (name, v)) in inp.temperatures.iter().enumerate() {
        let v0 = v.first().copied().unwrap_or(0.0);
        let d: Vec<f64> = v.iter().map(|x| x - v0).collect();
        for &h in &opts.temperature_lags_h {
            out.push(Regressor {
                name: format!("{name} lag {h} h"),
                source: Source::Temperature(i),
                tau_s: h * 3600.0,
                values: first_order_lag(t, &d, h * 3600.0),
            });
        }
    }
    out
}

/// A steady-state gain: a sum of coefficients with its standard uncertainty.
#[derive(Debug, Clone, PartialEq)]
pub struct Gain {
    /// `spindle` or the temperature channel's name.
    pub input: String,
    /// µm at full speed (spindle) or µm/K (temperature).
    pub value: f64,
    pub std: f64,
}

/// The fitted thermal model of one channel.
#[derive(Debug, Clone)]
pub struct ThermalFit {
    /// Chosen penalty and the effective number of parameters at it.
    pub lambda: f64,
    pub edf: f64,
    /// Rolling-origin cross-validation RMS at the chosen λ (µm), and the number of rows
    /// it was computed on.
    pub cv_rms: f64,
    pub cv_rows: usize,
    pub intercept: f64,
    /// One coefficient per regressor (µm per input unit).
    pub coef: Vec<f64>,
    /// Prediction at every sample of the log (µm).
    pub prediction: Vec<f64>,
    /// Residual standard deviation on the fitting rows (µm) and the AR(1) inflation.
    pub sigma: f64,
    pub inflation: f64,
    /// Steady-state gains: the spindle path first (if any), then each sensor.
    pub gains: Vec<Gain>,
}

/// Squared prediction error, pooled over the rolling-origin folds, for every λ of
/// `lambdas`, and the number of predicted rows.
pub fn rolling_cv_sse(
    x: &[Regressor],
    y: &[f64],
    n_fit: usize,
    lambdas: &[f64],
) -> (Vec<f64>, usize) {
    let folds = rolling_origin(n_fit);
    let mut acc = QrAccumulator::new(1 + x.len());
    let mut sse = vec![0.0; lambdas.len()];
    let mut rows = 0;
    let mut pushed = 0;
    let mut row = vec![0.0; 1 + x.len()];
    for fold in &folds {
        push_rows(&mut acc, x, y, pushed..fold.train_end, &mut row);
        pushed = fold.train_end;
        let svd = RidgeSvd::new(&acc.snapshot());
        for (s, &l) in sse.iter_mut().zip(lambdas) {
            let (c, b) = svd.coefficients(l);
            *s += fold
                .valid
                .clone()
                .map(|i| (y[i] - predict_row(x, c, &b, i)).powi(2))
                .sum::<f64>();
        }
        rows += fold.valid.len();
    }
    (sse, rows)
}

fn push_rows(
    acc: &mut QrAccumulator,
    x: &[Regressor],
    y: &[f64],
    rows: std::ops::Range<usize>,
    row: &mut [f64],
) {
    for i in rows {
        row[0] = 1.0;
        for (r, c) in row[1..].iter_mut().zip(x) {
            *r = c.values[i];
        }
        acc.push(row, y[i]);
    }
}

fn predict_row(x: &[Regressor], c: f64, b: &[f64], i: usize) -> f64 {
    c + x.iter().zip(b).map(|(r, bj)| r.values[i] * bj).sum::<f64>()
}

/// The reduction of [1 | X | y] over the rows `0..n`.
fn reduce(x: &[Regressor], y: &[f64], n: usize) -> Reduced {
    let mut acc = QrAccumulator::new(1 + x.len());
    let mut row = vec![0.0; 1 + x.len()];
    push_rows(&mut acc, x, y, 0..n, &mut row);
    acc.finish()
}

/// Fits the model of `y` on `x` over rows `0..n_fit`, λ by rolling-origin CV (module
/// docs), and predicts every row.
pub fn fit_thermal(
    x: &[Regressor],
    inputs: &ThermalInputs,
    y: &[f64],
    n_fit: usize,
    opts: &ThermalOptions,
) -> Result<ThermalFit, SolverError> {
    let n = y.len();
    if x.is_empty() {
        return Err(SolverError::InvalidInput(
            "thermal model: no spindle speed and no temperature channel".into(),
        ));
    }
    if n_fit < 2 * ROLLING_BLOCKS || n_fit > n || x.iter().any(|r| r.values.len() != n) {
        return Err(SolverError::InvalidInput(format!(
            "thermal model: {n_fit} fitting rows of {n} (at least {} needed)",
            2 * ROLLING_BLOCKS
        )));
    }
    if opts.lambdas.is_empty() || opts.lambdas.iter().any(|l| l.is_nan() || *l <= 0.0) {
        return Err(SolverError::InvalidInput(
            "thermal model: the penalty grid must hold positive values".into(),
        ));
    }
    let (cv, cv_rows) = rolling_cv_sse(x, y, n_fit, &opts.lambdas);
    // Smallest pooled error; ties go to the larger penalty (the simpler model).
    let mut best = 0;
    for (k, v) in cv.iter().enumerate() {
        if *v <= cv[best] {
            best = k;
        }
    }
    let lambda = opts.lambdas[best];
    let svd = RidgeSvd::new(&reduce(x, y, n_fit));
    let (intercept, coef) = svd.coefficients(lambda);
    let prediction: Vec<f64> = (0..n)
        .map(|i| predict_row(x, intercept, &coef, i))
        .collect();
    let res: Vec<f64> = (0..n_fit).map(|i| y[i] - prediction[i]).collect();
    let edf = svd.edf(lambda);
    let rss: f64 = res.iter().map(|v| v * v).sum();
    let sigma = (rss / (n_fit as f64 - 1.0 - edf).max(1.0)).sqrt();
    let inflation = ar1_inflation(&res);
    let cov = svd.covariance(lambda, (sigma * inflation).powi(2));
    let sum_gain = |input: String, cols: Vec<usize>| -> Gain {
        let value = cols.iter().map(|&j| coef[j]).sum();
        let var: f64 = cols
            .iter()
            .flat_map(|&a| cols.iter().map(move |&b| (a, b)))
            .map(|(a, b)| cov[(a, b)])
            .sum();
        Gain {
            input,
            value,
            std: var.max(0.0).sqrt(),
        }
    };
    let mut gains = vec![];
    let spindle: Vec<usize> = (0..x.len())
        .filter(|&j| matches!(x[j].source, Source::Spindle { .. }))
        .collect();
    if !spindle.is_empty() {
        gains.push(sum_gain("spindle".into(), spindle));
    }
    for (i, (name, _)) in inputs.temperatures.iter().enumerate() {
        let cols: Vec<usize> = (0..x.len())
            .filter(|&j| x[j].source == Source::Temperature(i))
            .collect();
        if !cols.is_empty() {
            gains.push(sum_gain(name.to_string(), cols));
        }
    }
    Ok(ThermalFit {
        lambda,
        edf,
        cv_rms: (cv[best] / cv_rows.max(1) as f64).sqrt(),
        cv_rows,
        intercept,
        coef,
        prediction,
        sigma,
        inflation,
        gains,
    })
}

/// Mean absolute error of `pred` against `y` on `rows`.
pub fn mae(y: &[f64], pred: &[f64], rows: std::ops::Range<usize>) -> f64 {
    let n = rows.len().max(1) as f64;
    rows.map(|i| (y[i] - pred[i]).abs()).sum::<f64>() / n
}
