//! What one axis's diagnosis reports: the findings with their parameters and
//! uncertainties (Jacobian of the final joint fit with ∂/∂θ columns), where the rigid
//! model's residuals concentrate, what remains unexplained, and the plots.

use super::super::{SeriesOptions, decimate, rms};
use super::columns::{Effect, Model};
use super::data::AxisData;
use super::problem::{Candidate, Positioning};
use crate::diagnosis::engine::Selection;
use crate::diagnosis::lsq;
use crate::diagnosis::{Finding, Mismatch, PlotData, PlotKind, PlotSeries, effects};
use std::collections::BTreeMap;

/// What one axis's diagnosis produced.
pub(super) struct AxisOutcome {
    pub(super) noise: f64,
    pub(super) base_rms: f64,
    pub(super) base_heldout: f64,
    pub(super) final_heldout: f64,
    pub(super) n: usize,
    pub(super) mismatch: Vec<Mismatch>,
    pub(super) findings: Vec<Finding>,
    pub(super) unexplained: Option<String>,
    pub(super) plots: Vec<PlotData>,
    pub(super) misfit: f64,
}

/// The findings, mismatch, unexplained remainder and plots of a selection.
pub(super) fn outcome(
    a: &AxisData,
    sel: Selection<Positioning>,
    opts: &SeriesOptions,
) -> AxisOutcome {
    let n = a.n();
    let noise = sel.noise;
    let residuals =
        |pred: &[f64]| -> Vec<f64> { a.y.iter().zip(pred).map(|(y, p)| y - p).collect() };
    let base_res = residuals(&sel.base_fit.prediction);

    // Final joint fit; parameters and uncertainties from the Jacobian with ∂/∂θ columns.
    let d = a.design(&sel.model);
    let fit = lsq::solve(&d, &a.y);
    let res = residuals(&d.predict(&fit.coef));
    let mut jac = d.clone();
    let mut col = sel.model.order + 1;
    let mut offsets = vec![];
    for t in &sel.model.terms {
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
    for st in &sel.steps {
        let mut params = BTreeMap::new();
        let effect = match st.chosen.candidate {
            Candidate::Order(to) => {
                params.insert("order_before".into(), st.before.order as f64);
                params.insert("extra_order".into(), to as f64);
                None
            }
            Candidate::Effect(e) => Some(e),
        };
        let label = effect.map_or("model_order", Effect::name);
        if let Some(e) = effect {
            let ti = sel
                .model
                .terms
                .iter()
                .position(|t| t.effect == e)
                .expect("term present");
            let t = sel.model.terms[ti];
            let c0 = offsets[ti];
            // θ's Jacobian column index: count nonlinear terms before this one.
            let th = theta_idx
                + sel.model.terms[..ti]
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
        let signature = match effect {
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
            effect: label.into(),
            axis: Some(a.axis.to_string()),
            parameters: params,
            physics: effects::physics(label).into(),
            residual_rms_um: st.rms,
            heldout_rms_um: st.heldout,
            undetermined: vec![],
            evidence: format!(
                "ΔBIC {:.1}; held-out RMS (leave one of {} runs out) {:.3} → {:.3} µm; noise floor {:.3} µm; condition number of the final joint fit {:.2e}{signature}",
                st.chosen.dbic,
                a.runs.len(),
                st.heldout.before,
                st.heldout.after,
                noise,
                fit.cond
            ),
            signature: None,
        });
    }
    let final_heldout = sel.heldout_rms();
    let base_heldout = sel.base_heldout_rms();
    let needs = base_heldout > opts.explained_ratio * noise;
    let unexplained = (needs && final_heldout > opts.explained_ratio * noise).then(|| {
        format!(
            "axis {}: held-out RMS {:.3} µm after {} effect(s) against a noise floor of {:.3} µm; the largest remaining residuals: {}",
            a.axis,
            final_heldout,
            sel.steps.len(),
            noise,
            worst_places(a, &res)
        )
    });
    let misfit = (base_res.iter().map(|v| v * v).sum::<f64>() - n as f64 * noise * noise).max(0.0);
    AxisOutcome {
        noise,
        base_rms: rms(&base_res),
        base_heldout,
        final_heldout,
        n,
        mismatch: locate(a, &base_res, noise),
        findings,
        unexplained,
        plots: plots(a, &sel.model, &fit.coef, &base_res, &res, opts),
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
            kind: PlotKind::Cartesian,
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
            kind: PlotKind::Cartesian,
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
