//! Drift logs (datasets contract section 4, ISO 230-3 style): the rigid model predicts no
//! movement, i.e. a constant per displacement channel. The missing physics is thermal
//! growth of the structure, modelled two ways and chosen per channel by held-out error:
//!
//! * **spindle history**: the heat input u(t) = (n(t)/n_max)^p of the spindle speed n
//!   (p = 1 or 2) drives one or two first-order lags
//!   Lτ[u]: τ ẋ = u − x, sampled exactly with the input held between samples,
//!   x_k = e^{−Δt/τ} x_{k−1} + (1 − e^{−Δt/τ}) u_{k−1}, x_0 = u_0 (at rest).
//!   Model y = c + Σ_j g_j Lτ_j[u]; g_j is the steady-state growth at full speed (µm);
//!   τ_j by a 1-D log-grid search refined by golden section (two lags: grid of pairs,
//!   then coordinate refinement). Two lags of opposite sign describe a fast (spindle,
//!   head) and a slow (column, bed) path.
//! * **structure temperatures**: y = c + Σ_i k_i T_i over a few sensors chosen by forward
//!   selection (k_i in µm/K); optionally together with the spindle lags.
//!
//! Protocol: fit on the first `train_fraction` (60 %) of the recording, judge on the rest.
//! The family (lags, exponent, sensors) is chosen by blocked 4-fold cross-validation
//! inside the training part only, so the last 40 % is never used for a choice. Reported:
//! held-out RMS of the rigid constant (fitted on the training part) and of the model,
//! and the share of drift predicted, 1 − SSE_after/SSE_rigid on the held-out part.
//!
//! Noise floor per channel, independent of any model: σ = 1.4826·median|Δy| / √2 (the
//! sample-to-sample scatter; slow drift contributes nothing to it).
//! Uncertainties: from the Jacobian including ∂/∂ln τ columns, multiplied by
//! √((1+ρ)/(1−ρ)) with ρ the lag-1 autocorrelation of the training residuals (effective
//! sample size of AR(1) residuals); they remain indicative, the residuals of a drift
//! model are not white.

use super::lsq::{self, Design};
use super::{SeriesOptions, decimate, golden_min, log_grid, rms};
use crate::datasets::{Channel, ChannelKind, DriftLog};
use crate::diagnosis::{
    Baseline, BeforeAfter, DiagnosisResult, Finding, Mismatch, PlotData, PlotSeries, Verdict,
};
use crate::error::SolverError;
use std::collections::BTreeMap;

/// First-order lag of `u` with time constant `tau` (s) on sample times `t` (module docs).
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

/// Which model family explains a channel.
#[derive(Debug, Clone, PartialEq)]
struct Model {
    /// Spindle heat-input exponent p and lag time constants (s); empty: no spindle term.
    p: f64,
    taus: Vec<f64>,
    /// Indices into the temperature channels.
    sensors: Vec<usize>,
}

struct Inputs<'a> {
    t: &'a [f64],
    speed: Option<&'a Channel>,
    rpm_max: f64,
    temps: Vec<&'a Channel>,
    n_train: usize,
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
        for &i in &m.sensors {
            d.push(self.temps[i].name.clone(), self.temps[i].values.clone());
        }
        d
    }
}

/// Blocked k-fold cross-validation SSE on rows `0..n_train` (contiguous blocks).
fn cv_sse(d: &Design, y: &[f64], n_train: usize, folds: usize) -> f64 {
    let mut total = 0.0;
    for f in 0..folds {
        let (a, b) = (f * n_train / folds, (f + 1) * n_train / folds);
        let train: Vec<usize> = (0..n_train).filter(|&i| i < a || i >= b).collect();
        let test: Vec<usize> = (a..b).collect();
        let fit = lsq::solve(
            &d.rows(&train),
            &train.iter().map(|&i| y[i]).collect::<Vec<_>>(),
        );
        let pred = d.rows(&test).predict(&fit.coef);
        total += test
            .iter()
            .zip(&pred)
            .map(|(&i, p)| (y[i] - p).powi(2))
            .sum::<f64>();
    }
    total
}

const FOLDS: usize = 4;

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

/// Forward selection of temperature sensors on top of `base`, by blocked CV on the
/// training part; a sensor is added when it lowers the CV SSE by at least 2 %.
fn select_sensors(inp: &Inputs, y: &[f64], base: &Model, max: usize) -> (Model, f64) {
    let mut m = base.clone();
    let mut cur = cv_sse(&inp.design(&m), y, inp.n_train, FOLDS);
    while m.sensors.len() < max {
        let mut best: Option<(usize, f64)> = None;
        for i in 0..inp.temps.len() {
            if m.sensors.contains(&i) {
                continue;
            }
            let mut trial = m.clone();
            trial.sensors.push(i);
            let s = cv_sse(&inp.design(&trial), y, inp.n_train, FOLDS);
            if best.is_none_or(|(_, b)| s < b) {
                best = Some((i, s));
            }
        }
        match best {
            Some((i, s)) if s < 0.98 * cur => {
                m.sensors.push(i);
                cur = s;
            }
            _ => break,
        }
    }
    (m, cur)
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

fn lag1_autocorr(r: &[f64]) -> f64 {
    let m = r.iter().sum::<f64>() / r.len().max(1) as f64;
    let den: f64 = r.iter().map(|v| (v - m).powi(2)).sum();
    let num: f64 = r.windows(2).map(|w| (w[0] - m) * (w[1] - m)).sum();
    if den > 0.0 {
        (num / den).clamp(-0.99, 0.999)
    } else {
        0.0
    }
}

fn describe(m: &Model, inp: &Inputs) -> String {
    let mut parts = vec![];
    if !m.taus.is_empty() {
        let p = if m.p == 1.0 { "n" } else { "n²" };
        parts.push(format!(
            "{} first-order lag(s) of spindle heat input ∝ {p}",
            m.taus.len()
        ));
    }
    if !m.sensors.is_empty() {
        let names: Vec<&str> = m
            .sensors
            .iter()
            .map(|&i| inp.temps[i].name.as_str())
            .collect();
        parts.push(format!("temperatures {}", names.join(", ")));
    }
    if parts.is_empty() {
        "constant".into()
    } else {
        parts.join(" + ")
    }
}

fn analyse_channel(ch: &Channel, inp: &Inputs, opts: &SeriesOptions) -> ChannelOutcome {
    let y = &ch.values;
    let n = y.len();
    let nt = inp.n_train;
    let noise = noise_floor(y);
    let rigid = Model {
        p: 1.0,
        taus: vec![],
        sensors: vec![],
    };
    let cv_rigid = cv_sse(&inp.design(&rigid), y, nt, FOLDS);
    let mean_train = y[..nt].iter().sum::<f64>() / nt as f64;
    let rigid_res: Vec<f64> = y.iter().map(|v| v - mean_train).collect();

    // Candidates, each scored by blocked CV on the training part only.
    let mut cands: Vec<(String, Model, f64)> = vec![];
    let mut best_spindle: Option<(Model, f64)> = None;
    if inp.speed.is_some() && inp.rpm_max > 0.0 {
        for p in [1.0, 2.0] {
            for nl in [1, 2] {
                let m = Model {
                    p,
                    taus: search_lags(inp, y, p, nl),
                    sensors: vec![],
                };
                let s = cv_sse(&inp.design(&m), y, nt, FOLDS);
                cands.push((describe(&m, inp), m.clone(), s));
                if best_spindle.as_ref().is_none_or(|(_, b)| s < *b) {
                    best_spindle = Some((m, s));
                }
            }
        }
    }
    if !inp.temps.is_empty() && opts.max_sensors > 0 {
        let (m, s) = select_sensors(inp, y, &rigid, opts.max_sensors);
        cands.push((describe(&m, inp), m, s));
        if let Some((bm, _)) = &best_spindle {
            let (m, s) = select_sensors(inp, y, bm, opts.max_sensors);
            if !m.sensors.is_empty() {
                cands.push((describe(&m, inp), m, s));
            }
        }
    }
    let chosen = cands
        .iter()
        .min_by(|a, b| a.2.total_cmp(&b.2))
        .filter(|c| c.2 < (1.0 - opts.min_heldout_gain) * cv_rigid)
        .cloned();

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
    let Some((desc, model, cv_model)) = chosen else {
        return out;
    };

    // Final fit on the training part; judge on the rest.
    let d = inp.design(&model);
    let train: Vec<usize> = (0..nt).collect();
    let fit = lsq::solve(&d.rows(&train), &y[..nt]);
    let pred = d.predict(&fit.coef);
    let res: Vec<f64> = y.iter().zip(&pred).map(|(a, b)| a - b).collect();
    let sse_after_test: f64 = res[nt..].iter().map(|v| v * v).sum();
    out.after_train_rms = rms(&res[..nt]);
    out.after_test_rms = rms(&res[nt..]);
    out.share_predicted = if sse_rigid_test > 0.0 {
        1.0 - sse_after_test / sse_rigid_test
    } else {
        0.0
    };
    out.pred = pred;

    // Uncertainties: Jacobian with ∂/∂ln τ columns, AR(1) inflation.
    let rho = lag1_autocorr(&res[..nt]);
    let inflate = ((1.0 + rho) / (1.0 - rho)).sqrt();
    let mut jac = d.rows(&train);
    if !model.taus.is_empty() {
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
    }
    let jfit = lsq::solve(&jac, &res[..nt]);
    let mut params = BTreeMap::new();
    let mut inputs_txt = vec![];
    let nl = model.taus.len();
    if nl > 0 {
        params.insert("rpm_exponent".into(), model.p);
        for (j, &tau) in model.taus.iter().enumerate() {
            params.insert(format!("tau{}_s", j + 1), tau);
            params.insert(
                format!("std_tau{}_s", j + 1),
                tau * jfit.std[d.len() + j] * inflate,
            );
            params.insert(format!("gain{}_um", j + 1), fit.coef[1 + j]);
            params.insert(format!("std_gain{}_um", j + 1), jfit.std[1 + j] * inflate);
        }
    }
    for (k, &i) in model.sensors.iter().enumerate() {
        let name = inp.temps[i].name.trim_end_matches("_c").to_string();
        params.insert(format!("{name}_um_per_k"), fit.coef[1 + nl + k]);
        params.insert(
            format!("std_{name}_um_per_k"),
            jfit.std[1 + nl + k] * inflate,
        );
    }
    params.insert("share_predicted".into(), out.share_predicted);

    // Which inputs carry it: rise of the held-out SSE when one input is dropped (refit).
    let drop_share = |m: &Model| -> f64 {
        let d = inp.design(m);
        let f = lsq::solve(&d.rows(&train), &y[..nt]);
        let p = d.predict(&f.coef);
        let s: f64 = (nt..n).map(|i| (y[i] - p[i]).powi(2)).sum();
        (s - sse_after_test) / sse_rigid_test.max(1e-300)
    };
    if nl > 0 {
        let m = Model {
            taus: vec![],
            ..model.clone()
        };
        inputs_txt.push(format!("spindle history {:.2}", drop_share(&m)));
    }
    for (k, &i) in model.sensors.iter().enumerate() {
        let mut m = model.clone();
        m.sensors.remove(k);
        inputs_txt.push(format!("{} {:.2}", inp.temps[i].name, drop_share(&m)));
    }
    let others: Vec<String> = cands
        .iter()
        .map(|(d, _, s)| format!("{d}: {:.3}", (s / nt as f64).sqrt()))
        .collect();
    let physics = format!(
        "thermal growth of the structure: {} follows {desc}; the rigid-body model assumes a \
         constant position",
        ch.name
    );
    let evidence = format!(
        "blocked 4-fold CV RMS on the first {:.0} %: rigid {:.3} µm, chosen {:.3} µm \
         (candidates — {}); held-out SSE rise when an input is dropped, as a share of the \
         rigid SSE: {}; condition number {:.3e}; lag-1 autocorrelation of residuals {:.2}",
        100.0 * opts.train_fraction,
        (cv_rigid / nt as f64).sqrt(),
        (cv_model / nt as f64).sqrt(),
        others.join("; "),
        inputs_txt.join(", "),
        fit.cond,
        rho
    );
    out.finding = Some(Finding {
        effect: "thermal_drift".into(),
        axis: Some(ch.name.trim_end_matches("_um").to_string()),
        parameters: params,
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
        decide: None,
        signature: None,
    });
    out
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

/// Diagnoses a drift log (module docs): one `thermal_drift` finding per displacement
/// channel the inputs explain (`axis` carries the channel name without `_um`), held-out
/// figures on the last `1 − train_fraction` of the recording, and one plot per channel.
pub fn diagnose_drift_log(
    log: &DriftLog,
    machine_id: &str,
    opts: &SeriesOptions,
) -> Result<DiagnosisResult, SolverError> {
    let n_train = validate(log, opts)?;
    let speed = log
        .channels
        .iter()
        .find(|c| c.kind == ChannelKind::SpeedRpm);
    let rpm_max = speed.map_or(0.0, |s| s.values.iter().fold(0.0f64, |a, v| a.max(v.abs())));
    let inp = Inputs {
        t: &log.t_s,
        speed,
        rpm_max,
        temps: log
            .channels
            .iter()
            .filter(|c| c.kind == ChannelKind::TemperatureC)
            .collect(),
        n_train,
    };
    let outs: Vec<ChannelOutcome> = log
        .channels
        .iter()
        .filter(|c| c.kind == ChannelKind::DisplacementUm)
        .map(|c| analyse_channel(c, &inp, opts))
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

    Ok(DiagnosisResult {
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
    })
}
