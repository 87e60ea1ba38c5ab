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
//!
//! Parameter names, units and signs are those of every diagnosis
//! ([`crate::diagnosis::effects`]).
//! | `model_order` | P_k(s), k = N+1..K | — |
//!
//! Without `t_s` the record order stands for time (τ is then in records).
//!
//! **Selection** (greedy): each candidate is fitted jointly with the current model (its
//! nonlinear parameter re-searched in every fold) and scored by the LORO held-out sum of
//! squares (whole runs held out) and by BIC = n ln(SSE/n) + k ln n. The candidate with the
//! lowest held-out SSE among those that lower BIC by ≥ `bic_threshold` and the held-out SSE
//! by ≥ `min_heldout_gain` is added; the loop stops when none qualifies or the held-out RMS
//! is within `stop_ratio` × the noise floor.
//!
//! **Noise floor**, independent of the model: the pooled scatter of repeated readings of
//! the same target and direction after removing one offset per pass (run × direction):
//! two-way least squares y = μ_(target,dir) + ρ_pass, σ² = SSE/(n − rank). Slow drift
//! between passes is thus not counted as noise (ISO 230-2's repeatability would include
//! it; [`crate::standards::iso230_2`] gives those figures).

use super::lsq::{self, Design};
use super::{SeriesOptions, bic, decimate, grid_then_golden, log_grid, rms};
use crate::axis::Axis;
use crate::basis::legendre;
use crate::datasets::{Direction, PositioningRecord, PositioningRuns};
use crate::diagnosis::effects;
use crate::diagnosis::{
    Baseline, BeforeAfter, DiagnosisResult, Finding, Mismatch, PlotData, PlotSeries,
};
use crate::error::SolverError;
use std::collections::BTreeMap;
use std::f64::consts::PI;

/// The candidate effects of the module table.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Effect {
    Backlash,
    Spike,
    Cyclic,
    Thermal,
    ThermalTemp,
}

impl Effect {
    fn name(self) -> &'static str {
        match self {
            Effect::Backlash => "backlash",
            Effect::Spike => "reversal_spike",
            Effect::Cyclic => "cyclic",
            Effect::Thermal | Effect::ThermalTemp => "thermal_drift",
        }
    }
    fn nonlinear(self) -> bool {
        matches!(self, Effect::Spike | Effect::Cyclic | Effect::Thermal)
    }
    fn n_linear(self) -> usize {
        match self {
            Effect::Backlash | Effect::Spike => 1,
            _ => 2,
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq)]
struct Term {
    effect: Effect,
    /// λ (mm), P (mm) or τ (time units); unused otherwise.
    theta: f64,
}

#[derive(Debug, Clone, PartialEq)]
struct Model {
    order: usize,
    terms: Vec<Term>,
}

impl Model {
    fn n_params(&self) -> usize {
        self.order
            + 1
            + self
                .terms
                .iter()
                .map(|t| t.effect.n_linear() + usize::from(t.effect.nonlinear()))
                .sum::<usize>()
    }
}

/// One axis's records in file (measurement) order.
struct AxisData {
    axis: Axis,
    x: Vec<f64>,
    s: Vec<f64>,
    d: Vec<f64>,
    u: Vec<f64>,
    time: Vec<f64>,
    time_in_s: bool,
    temp: Option<Vec<f64>>,
    y: Vec<f64>,
    run: Vec<i64>,
    runs: Vec<i64>,
    lo: f64,
    hi: f64,
    spacing: f64,
    targets: Vec<f64>,
    /// (target index, direction) group of each record.
    group: Vec<usize>,
}

impl AxisData {
    fn new(axis: Axis, recs: &[&PositioningRecord]) -> Result<AxisData, SolverError> {
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
        let temp = recs.iter().all(|r| r.temp_c.is_some()).then(|| {
            let t0 = recs[0].temp_c.unwrap_or(0.0);
            recs.iter().map(|r| r.temp_c.unwrap_or(0.0) - t0).collect()
        });
        let (c, h) = (0.5 * (lo + hi), 0.5 * (hi - lo));
        Ok(AxisData {
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
            runs,
            lo,
            hi,
            spacing,
            targets,
        })
    }
}

impl AxisData {
    fn n(&self) -> usize {
        self.y.len()
    }

    fn time_unit(&self) -> &'static str {
        if self.time_in_s { "s" } else { "records" }
    }

    /// Columns of one effect at parameter `theta`.
    fn effect_cols(&self, e: Effect, theta: f64) -> Vec<(String, Vec<f64>)> {
        let scale: Vec<f64> = self.x.iter().map(|v| v / 1000.0).collect();
        match e {
            Effect::Backlash => vec![(
                "lost_motion_um".into(),
                self.d.iter().map(|d| -0.5 * d).collect(),
            )],
            Effect::Spike => vec![(
                "height_um".into(),
                self.d
                    .iter()
                    .zip(&self.u)
                    .map(|(d, u)| -d * (-u / theta).exp())
                    .collect(),
            )],
            Effect::Cyclic => vec![
                (
                    "sin".into(),
                    self.x
                        .iter()
                        .map(|x| (2.0 * PI * x / theta).sin())
                        .collect(),
                ),
                (
                    "cos".into(),
                    self.x
                        .iter()
                        .map(|x| (2.0 * PI * x / theta).cos())
                        .collect(),
                ),
            ],
            Effect::Thermal => {
                let g: Vec<f64> = self.time.iter().map(|t| 1.0 - (-t / theta).exp()).collect();
                vec![
                    ("offset_um".into(), g.clone()),
                    (
                        "scale_ppm".into(),
                        g.iter().zip(&scale).map(|(a, b)| a * b).collect(),
                    ),
                ]
            }
            Effect::ThermalTemp => {
                let dt = self.temp.clone().unwrap_or_else(|| vec![0.0; self.n()]);
                vec![
                    ("offset_um_per_k".into(), dt.clone()),
                    (
                        "scale_ppm_per_k".into(),
                        dt.iter().zip(&scale).map(|(a, b)| a * b).collect(),
                    ),
                ]
            }
        }
    }

    fn design(&self, m: &Model) -> Design {
        let mut d = Design::new();
        for k in 0..=m.order {
            d.push(
                format!("P{k}"),
                self.s.iter().map(|&s| legendre(k, s).0).collect(),
            );
        }
        for t in &m.terms {
            for (name, col) in self.effect_cols(t.effect, t.theta) {
                d.push(format!("{}:{name}", t.effect.name()), col);
            }
        }
        d
    }

    /// Search grid of an effect's nonlinear parameter.
    fn grid(&self, e: Effect) -> Vec<f64> {
        let travel = self.hi - self.lo;
        match e {
            Effect::Spike => log_grid(0.25 * self.spacing, 0.5 * travel, 24),
            Effect::Cyclic => {
                // Search in frequency: from 1.5 cycles over the travel to 1/(2.2 spacing).
                let (f0, f1) = (1.5 / travel, 1.0 / (2.2 * self.spacing));
                let step = 1.0 / (6.0 * travel);
                let n = (((f1 - f0) / step).ceil() as usize).max(2);
                (0..=n)
                    .map(|i| f0 + (f1 - f0) * i as f64 / n as f64)
                    .collect()
            }
            Effect::Thermal => {
                let dur = self.time.iter().fold(0.0f64, |a, &b| a.max(b)).max(1.0);
                log_grid(dur / 30.0, 5.0 * dur, 24)
            }
            _ => vec![0.0],
        }
    }

    /// θ from a searched value (the cyclic search runs in frequency).
    fn theta_of(e: Effect, v: f64) -> f64 {
        if e == Effect::Cyclic { 1.0 / v } else { v }
    }

    /// Fits `m + e` on `rows`, searching e's nonlinear parameter; returns the term.
    fn search(&self, m: &Model, e: Effect, rows: &[usize]) -> Term {
        if !e.nonlinear() {
            return Term {
                effect: e,
                theta: 0.0,
            };
        }
        let y: Vec<f64> = rows.iter().map(|&i| self.y[i]).collect();
        let sse_at = |v: f64| {
            let mut mm = m.clone();
            mm.terms.push(Term {
                effect: e,
                theta: AxisData::theta_of(e, v),
            });
            lsq::sse(&self.design(&mm).rows(rows), &y)
        };
        let (v, _) = grid_then_golden(&self.grid(e), 20, sse_at);
        Term {
            effect: e,
            theta: AxisData::theta_of(e, v),
        }
    }

    fn all_rows(&self) -> Vec<usize> {
        (0..self.n()).collect()
    }

    /// Leave-one-run-out held-out SSE of `m` (+ `extra`, re-searched in every fold).
    fn loro(&self, m: &Model, extra: Option<Effect>) -> f64 {
        let mut total = 0.0;
        for &r in &self.runs {
            let train: Vec<usize> = (0..self.n()).filter(|&i| self.run[i] != r).collect();
            let test: Vec<usize> = (0..self.n()).filter(|&i| self.run[i] == r).collect();
            let mut mm = m.clone();
            if let Some(e) = extra {
                mm.terms.push(self.search(m, e, &train));
            }
            let d = self.design(&mm);
            let fit = lsq::solve(
                &d.rows(&train),
                &train.iter().map(|&i| self.y[i]).collect::<Vec<_>>(),
            );
            let pred = d.rows(&test).predict(&fit.coef);
            total += test
                .iter()
                .zip(&pred)
                .map(|(&i, p)| (self.y[i] - p).powi(2))
                .sum::<f64>();
        }
        total
    }

    fn fit_all(&self, m: &Model) -> (lsq::LsqFit, Vec<f64>) {
        let d = self.design(m);
        let fit = lsq::solve(&d, &self.y);
        let res = self
            .y
            .iter()
            .zip(d.predict(&fit.coef))
            .map(|(a, b)| a - b)
            .collect();
        (fit, res)
    }

    /// Model-independent noise floor (module docs): two-way fit of group means and pass
    /// offsets.
    fn noise_floor(&self) -> f64 {
        let n = self.n();
        let mut d = Design::new();
        let ng = 2 * self.targets.len();
        for g in 0..ng {
            let col: Vec<f64> = self
                .group
                .iter()
                .map(|&k| f64::from(u8::from(k == g)))
                .collect();
            if col.iter().any(|&v| v > 0.0) {
                d.push("g", col);
            }
        }
        let mut passes: Vec<(i64, bool)> = self
            .run
            .iter()
            .zip(&self.d)
            .map(|(&r, &dd)| (r, dd > 0.0))
            .collect();
        passes.sort_unstable();
        passes.dedup();
        for p in passes.iter().skip(1) {
            d.push(
                "p",
                (0..n)
                    .map(|i| f64::from(u8::from(self.run[i] == p.0 && (self.d[i] > 0.0) == p.1)))
                    .collect(),
            );
        }
        let fit = lsq::solve(&d, &self.y);
        fit.s2().sqrt()
    }
}

/// What one axis's diagnosis produced.
struct AxisOutcome {
    noise: f64,
    base_rms: f64,
    base_heldout: f64,
    final_heldout: f64,
    n: usize,
    mismatch: Vec<Mismatch>,
    findings: Vec<Finding>,
    unexplained: Option<String>,
    plots: Vec<PlotData>,
    misfit: f64,
}

/// One accepted step of the greedy search.
struct Step {
    label: &'static str,
    rms: BeforeAfter,
    heldout: BeforeAfter,
    dbic: f64,
    order: Option<(usize, usize)>,
    effect: Option<Effect>,
}

fn physics(e: &str, axis: Axis) -> String {
    match e {
        "backlash" => format!(
            "lost motion at direction reversal of the {axis} drive (play and elastic wind-up of screw, nut and bearings): the position depends on the approach direction, which the rigid-body model ignores"
        ),
        "reversal_spike" => format!(
            "friction transient after a reversal of the {axis} axis: stick-slip and servo recovery make a deviation that decays with the distance travelled since the reversal"
        ),
        "cyclic" => format!(
            "cyclic error of the {axis} drive periodic in position (screw lead, encoder interpolation): finer than the smooth polynomial of the rigid model"
        ),
        "thermal_drift" => format!(
            "thermal growth of the {axis} drive while the runs proceed (offset and scale growing with time or temperature): the rigid model is constant in time"
        ),
        _ => format!(
            "positioning error of the {axis} axis with more waviness than the chosen polynomial order can follow: repeatable in every pass and both directions"
        ),
    }
}

fn diagnose_axis(a: &AxisData, opts: &SeriesOptions) -> AxisOutcome {
    let n = a.n();
    let noise = a.noise_floor();
    // Rigid model: order by LORO among 1..=max_base_order.
    let mut model = (1..=opts.max_base_order.max(1))
        .map(|k| Model {
            order: k,
            terms: vec![],
        })
        .min_by(|m1, m2| a.loro(m1, None).total_cmp(&a.loro(m2, None)))
        .expect("at least one order");
    let (base_fit, base_res) = a.fit_all(&model);
    let base_rms = rms(&base_res);
    let mut cur_loro = a.loro(&model, None);
    let base_heldout = (cur_loro / n as f64).sqrt();
    let mut cur_sse = base_fit.sse;
    let mut steps: Vec<Step> = vec![];

    let mut effects = vec![
        Effect::Backlash,
        Effect::Spike,
        Effect::Cyclic,
        Effect::Thermal,
    ];
    if a.temp.is_some() {
        effects.push(Effect::ThermalTemp);
    }
    while steps.len() < opts.max_findings {
        if (cur_loro / n as f64).sqrt() <= opts.stop_ratio * noise {
            break;
        }
        let k_cur = model.n_params();
        let cur_bic = bic(cur_sse, n, k_cur);
        // (candidate model, held-out SSE, ΔBIC, effect or order change)
        let mut best: Option<(Model, f64, f64, Option<Effect>)> = None;
        let mut consider = |m: Model, ho: f64, sse: f64, e: Option<Effect>| {
            let dbic = bic(sse, n, m.n_params()) - cur_bic;
            let ok = dbic <= -opts.bic_threshold && ho <= (1.0 - opts.min_heldout_gain) * cur_loro;
            if ok && best.as_ref().is_none_or(|b| ho < b.1) {
                best = Some((m, ho, dbic, e));
            }
        };
        for &e in &effects {
            let taken = model
                .terms
                .iter()
                .any(|t| t.effect == e || (t.effect.name() == e.name()));
            if taken {
                continue;
            }
            let term = a.search(&model, e, &a.all_rows());
            let mut m = model.clone();
            m.terms.push(term);
            let sse = a.fit_all(&m).0.sse;
            let ho = a.loro(&model, Some(e));
            consider(m, ho, sse, Some(e));
        }
        for k in model.order + 1..=opts.max_order {
            let m = Model {
                order: k,
                ..model.clone()
            };
            let sse = a.fit_all(&m).0.sse;
            let ho = a.loro(&m, None);
            consider(m, ho, sse, None);
        }
        let Some((m, ho, dbic, e)) = best else { break };
        let sse = a.fit_all(&m).0.sse;
        steps.push(Step {
            label: e.map_or("model_order", Effect::name),
            rms: BeforeAfter {
                before: (cur_sse / n as f64).sqrt(),
                after: (sse / n as f64).sqrt(),
            },
            heldout: BeforeAfter {
                before: (cur_loro / n as f64).sqrt(),
                after: (ho / n as f64).sqrt(),
            },
            dbic,
            order: e.is_none().then_some((model.order, m.order)),
            effect: e,
        });
        model = m;
        cur_loro = ho;
        cur_sse = sse;
    }

    // Final joint fit; parameters and uncertainties from the Jacobian with ∂/∂θ columns.
    let d = a.design(&model);
    let (fit, res) = a.fit_all(&model);
    let mut jac = d.clone();
    let mut col = model.order + 1;
    let mut offsets = vec![];
    for t in &model.terms {
        offsets.push(col);
        if t.effect.nonlinear() {
            let h = 1e-4 * t.theta;
            let cp = a.effect_cols(t.effect, t.theta + h);
            let cm = a.effect_cols(t.effect, t.theta - h);
            let mut dcol = vec![0.0; n];
            for (j, ((_, p), (_, m))) in cp.iter().zip(&cm).enumerate() {
                for i in 0..n {
                    dcol[i] += fit.coef[col + j] * (p[i] - m[i]) / (2.0 * h);
                }
            }
            jac.push("theta", dcol);
        }
        col += t.effect.n_linear();
    }
    let jfit = lsq::solve(&jac, &res);
    let theta_idx = d.len();
    let mut findings = vec![];
    for st in &steps {
        let mut params = BTreeMap::new();
        if let Some((from, to)) = st.order {
            params.insert("order_before".into(), from as f64);
            params.insert("extra_order".into(), to as f64);
        }
        if let Some(e) = st.effect {
            let ti = model
                .terms
                .iter()
                .position(|t| t.effect == e)
                .expect("term present");
            let t = model.terms[ti];
            let c0 = offsets[ti];
            // θ's Jacobian column index: count nonlinear terms before this one.
            let th = theta_idx
                + model.terms[..ti]
                    .iter()
                    .filter(|t| t.effect.nonlinear())
                    .count();
            let (b, sb) = (&fit.coef[c0..], &jfit.std[c0..]);
            let unit = a.time_unit();
            match e {
                Effect::Backlash => {
                    params.insert("lost_motion_um".into(), b[0]);
                    params.insert("std_lost_motion_um".into(), sb[0]);
                }
                Effect::Spike => {
                    params.insert("height_um".into(), b[0]);
                    params.insert("std_height_um".into(), sb[0]);
                    params.insert("decay_mm".into(), t.theta);
                    params.insert("std_decay_mm".into(), jfit.std[th]);
                }
                Effect::Cyclic => {
                    let amp = b[0].hypot(b[1]);
                    params.insert("amplitude_um".into(), amp);
                    params.insert("std_amplitude_um".into(), sb[0].hypot(sb[1]) / 2f64.sqrt());
                    params.insert("phase_rad".into(), b[1].atan2(b[0]));
                    params.insert("period_mm".into(), t.theta);
                    params.insert("std_period_mm".into(), jfit.std[th]);
                }
                Effect::Thermal => {
                    params.insert("offset_um".into(), b[0]);
                    params.insert("std_offset_um".into(), sb[0]);
                    params.insert("scale_ppm".into(), b[1]);
                    params.insert("std_scale_ppm".into(), sb[1]);
                    params.insert(format!("time_constant_{unit}"), t.theta);
                    params.insert(format!("std_time_constant_{unit}"), jfit.std[th]);
                }
                Effect::ThermalTemp => {
                    params.insert("offset_um_per_k".into(), b[0]);
                    params.insert("std_offset_um_per_k".into(), sb[0]);
                    params.insert("scale_ppm_per_k".into(), b[1]);
                    params.insert("std_scale_ppm_per_k".into(), sb[1]);
                }
            }
        }
        let signature = match st.effect {
            Some(Effect::Backlash) => {
                // Sign agreement of the per-target step with the fitted lost motion.
                let lm = params.get("lost_motion_um").copied().unwrap_or(0.0);
                let (agree, total) = step_signs(a, &base_res, lm);
                format!(
                    "; step − minus + approach has the sign of the lost motion at {agree} of {total} targets"
                )
            }
            _ => String::new(),
        };
        findings.push(Finding {
            effect: st.label.into(),
            axis: Some(a.axis.to_string()),
            parameters: params,
            physics: physics(st.label, a.axis),
            residual_rms_um: st.rms,
            heldout_rms_um: st.heldout,
            undetermined: vec![],
            evidence: format!(
                "ΔBIC {:.1}; held-out RMS (leave one of {} runs out) {:.3} → {:.3} µm; noise floor {:.3} µm; condition number of the final joint fit {:.2e}{signature}",
                st.dbic,
                a.runs.len(),
                st.heldout.before,
                st.heldout.after,
                noise,
                fit.cond
            ),
            decide: None,
            signature: None,
        });
    }
    let final_heldout = (cur_loro / n as f64).sqrt();
    let needs = base_heldout > opts.explained_ratio * noise;
    let unexplained = (needs && final_heldout > opts.explained_ratio * noise).then(|| {
        format!(
            "axis {}: held-out RMS {:.3} µm after {} effect(s) against a noise floor of {:.3} µm; the largest remaining residuals: {}",
            a.axis,
            final_heldout,
            steps.len(),
            noise,
            worst_places(a, &res)
        )
    });
    let misfit = (base_res.iter().map(|v| v * v).sum::<f64>() - n as f64 * noise * noise).max(0.0);
    AxisOutcome {
        noise,
        base_rms,
        base_heldout,
        final_heldout,
        n,
        mismatch: locate(a, &base_res, noise),
        findings,
        unexplained,
        plots: plots(a, &model, &fit.coef, &base_res, &res, opts),
        misfit,
    }
}

/// Targets where (mean − approach − mean + approach) of the rigid residuals has the sign of
/// `lost_motion` (its convention, [`crate::diagnosis::effects`]), and the number of
/// targets with both directions.
fn step_signs(a: &AxisData, res: &[f64], lost_motion: f64) -> (usize, usize) {
    let (mut agree, mut total) = (0, 0);
    for t in 0..a.targets.len() {
        let mean = |g: usize| {
            let v: Vec<f64> = (0..a.n())
                .filter(|&i| a.group[i] == g)
                .map(|i| res[i])
                .collect();
            (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64)
        };
        if let (Some(p), Some(m)) = (mean(2 * t), mean(2 * t + 1)) {
            total += 1;
            if (m - p) * lost_motion > 0.0 {
                agree += 1;
            }
        }
    }
    (agree, total)
}

fn dir_name(plus: bool) -> &'static str {
    if plus { "+" } else { "−" }
}

/// The three largest |residual| means per (target, direction).
fn worst_places(a: &AxisData, res: &[f64]) -> String {
    let mut v: Vec<(f64, usize)> = (0..2 * a.targets.len())
        .filter_map(|g| {
            let r: Vec<f64> = (0..a.n())
                .filter(|&i| a.group[i] == g)
                .map(|i| res[i])
                .collect();
            (!r.is_empty()).then(|| (r.iter().sum::<f64>() / r.len() as f64, g))
        })
        .collect();
    v.sort_by(|x, y| y.0.abs().total_cmp(&x.0.abs()));
    v.iter()
        .take(3)
        .map(|(m, g)| {
            format!(
                "{:.1} mm {} {:+.2} µm",
                a.targets[g / 2],
                dir_name(g % 2 == 0),
                m
            )
        })
        .collect::<Vec<_>>()
        .join(", ")
}

/// Where the rigid model's residuals concentrate: shares of the misfit above noise
/// carried by direction, by (target, direction) pattern and by pass (run × direction).
fn locate(a: &AxisData, res: &[f64], noise: f64) -> Vec<Mismatch> {
    let n = a.n();
    let excess = (res.iter().map(|v| v * v).sum::<f64>() - n as f64 * noise * noise).max(1e-300);
    let explained_by = |key: &dyn Fn(usize) -> i64| -> (f64, BTreeMap<i64, (f64, usize)>) {
        let mut m: BTreeMap<i64, (f64, usize)> = BTreeMap::new();
        for i in 0..n {
            let e = m.entry(key(i)).or_insert((0.0, 0));
            e.0 += res[i];
            e.1 += 1;
        }
        let ss = m.values().map(|(s, c)| s * s / *c as f64).sum();
        (ss, m)
    };
    let mut out = vec![];
    let (ss_dir, by_dir) = explained_by(&|i| i64::from(a.d[i] > 0.0));
    let mean =
        |m: &BTreeMap<i64, (f64, usize)>, k: i64| m.get(&k).map_or(0.0, |(s, c)| s / *c as f64);
    out.push(Mismatch {
        where_: format!(
            "axis {}: + and − approaches differ by {:+.2} µm on average (+ minus −), at every target",
            a.axis,
            mean(&by_dir, 1) - mean(&by_dir, 0)
        ),
        tests: vec![format!("{} all runs", a.axis)],
        share_of_misfit: (ss_dir / excess).min(1.0),
    });
    let (ss_g, _) = explained_by(&|i| a.group[i] as i64);
    out.push(Mismatch {
        where_: format!(
            "axis {}: repeatable pattern along the travel beyond a direction step; largest at {}",
            a.axis,
            worst_places(a, res)
        ),
        tests: vec![format!("{} all runs", a.axis)],
        share_of_misfit: ((ss_g - ss_dir).max(0.0) / excess).min(1.0),
    });
    let (ss_p, by_p) = explained_by(&|i| 2 * a.run[i] + i64::from(a.d[i] > 0.0));
    let mut passes: Vec<(i64, f64)> = by_p.iter().map(|(&k, (s, c))| (k, s / *c as f64)).collect();
    passes.sort_by(|x, y| y.1.abs().total_cmp(&x.1.abs()));
    out.push(Mismatch {
        where_: format!(
            "axis {}: passes offset from one another (drift between runs); largest: {}",
            a.axis,
            passes
                .iter()
                .take(3)
                .map(|(k, m)| format!(
                    "run {} {} {:+.2} µm",
                    k.div_euclid(2),
                    dir_name(k.rem_euclid(2) == 1),
                    m
                ))
                .collect::<Vec<_>>()
                .join(", ")
        ),
        tests: passes
            .iter()
            .take(3)
            .map(|(k, _)| format!("{}#run {}", a.axis, k.div_euclid(2)))
            .collect(),
        share_of_misfit: ((ss_p - ss_dir).max(0.0) / excess).min(1.0),
    });
    out.retain(|m| m.share_of_misfit >= 0.1);
    out.sort_by(|x, y| y.share_of_misfit.total_cmp(&x.share_of_misfit));
    out
}

fn plots(
    a: &AxisData,
    m: &Model,
    coef: &[f64],
    base_res: &[f64],
    res: &[f64],
    opts: &SeriesOptions,
) -> Vec<PlotData> {
    let mut dev = vec![];
    for plus in [true, false] {
        let (xs, ys): (Vec<f64>, Vec<f64>) = (0..a.targets.len())
            .filter_map(|t| {
                let g = 2 * t + usize::from(!plus);
                let v: Vec<f64> = (0..a.n())
                    .filter(|&i| a.group[i] == g)
                    .map(|i| a.y[i])
                    .collect();
                (!v.is_empty()).then(|| (a.targets[t], v.iter().sum::<f64>() / v.len() as f64))
            })
            .unzip();
        dev.push(PlotSeries {
            name: format!("measured mean {}", dir_name(plus)),
            x: xs,
            y: ys,
        });
    }
    // Model curves on a fine grid of positions (time terms at the mean time).
    let ng = 200;
    let grid: Vec<f64> = (0..=ng)
        .map(|i| a.lo + (a.hi - a.lo) * i as f64 / ng as f64)
        .collect();
    let tmean = a.time.iter().sum::<f64>() / a.n() as f64;
    let tempmean = a
        .temp
        .as_ref()
        .map(|t| t.iter().sum::<f64>() / t.len() as f64);
    let curve = |model: &Model, coef: &[f64], plus: bool| -> Vec<f64> {
        let gd = AxisData {
            axis: a.axis,
            x: grid.clone(),
            s: grid
                .iter()
                .map(|v| (v - 0.5 * (a.lo + a.hi)) / (0.5 * (a.hi - a.lo)))
                .collect(),
            d: vec![if plus { 1.0 } else { -1.0 }; grid.len()],
            u: grid
                .iter()
                .map(|v| if plus { v - a.lo } else { a.hi - v })
                .collect(),
            time: vec![tmean; grid.len()],
            time_in_s: a.time_in_s,
            temp: tempmean.map(|t| vec![t; grid.len()]),
            y: vec![0.0; grid.len()],
            run: vec![0; grid.len()],
            runs: vec![0],
            lo: a.lo,
            hi: a.hi,
            spacing: a.spacing,
            targets: vec![],
            group: vec![0; grid.len()],
        };
        gd.design(model).predict(coef)
    };
    let rigid = Model {
        order: m.order.min(opts.max_base_order),
        terms: vec![],
    };
    let rfit = lsq::solve(&a.design(&rigid), &a.y);
    dev.push(PlotSeries {
        name: "rigid model".into(),
        x: grid.clone(),
        y: curve(&rigid, &rfit.coef, true),
    });
    for plus in [true, false] {
        dev.push(PlotSeries {
            name: format!("model with effects {}", dir_name(plus)),
            x: grid.clone(),
            y: curve(m, coef, plus),
        });
    }
    let idx = decimate(a.n(), opts.plot_points);
    let tx: Vec<f64> = idx
        .iter()
        .map(|&i| a.time[i] / if a.time_in_s { 3600.0 } else { 1.0 })
        .collect();
    vec![
        PlotData {
            id: format!("positioning_{}", a.axis),
            title: format!(
                "axis {}: positioning deviation per approach direction",
                a.axis
            ),
            x_label: "target (mm)".into(),
            y_label: "deviation (µm)".into(),
            kind: "cartesian".into(),
            series: dev,
        },
        PlotData {
            id: format!("positioning_{}_residuals", a.axis),
            title: format!("axis {}: residuals before and after the effects", a.axis),
            x_label: if a.time_in_s {
                "time (h)".into()
            } else {
                "record".into()
            },
            y_label: "residual (µm)".into(),
            kind: "cartesian".into(),
            series: vec![
                PlotSeries {
                    name: "rigid model".into(),
                    x: tx.clone(),
                    y: idx.iter().map(|&i| base_res[i]).collect(),
                },
                PlotSeries {
                    name: "with effects".into(),
                    x: tx,
                    y: idx.iter().map(|&i| res[i]).collect(),
                },
            ],
        },
    ]
}

/// Diagnoses positioning runs (module docs), each axis separately; findings carry the axis.
pub fn diagnose_positioning(
    runs: &PositioningRuns,
    machine_id: &str,
    opts: &SeriesOptions,
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
    let mut outs = vec![];
    for axis in Axis::ALL {
        let recs: Vec<&PositioningRecord> =
            runs.records.iter().filter(|r| r.axis == axis).collect();
        if recs.is_empty() {
            continue;
        }
        let a = AxisData::new(axis, &recs)?;
        outs.push(diagnose_axis(&a, opts));
    }
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
        let needs = o.base_heldout > opts.explained_ratio * o.noise || !o.findings.is_empty();
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
    // Findings whose parameters the data do not determine are listed as possible.
    let (findings, possible) = effects::split_undetermined(findings);
    let verdict = effects::verdict(!any_needs, unexplained.is_empty(), findings.len());
    Ok(DiagnosisResult {
        kind: "diagnosis".into(),
        machine_id: machine_id.into(),
        source: "positioning".into(),
        baseline,
        mismatch,
        findings,
        possible,
        rejected: vec![],
        verdict,
        unexplained,
        plots,
    })
}
