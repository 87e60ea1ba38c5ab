//! What one axis's diagnosis reports: the findings with their parameters and
//! uncertainties (Jacobian of the final joint fit with ∂/∂θ columns), where the rigid
//! model's residuals concentrate, what remains unexplained, and the plots.

use super::columns::{Effect, LOST_MOTION_PROFILE, Model};
use super::data::AxisData;
use super::problem::{Candidate, Positioning};
use crate::diagnosis::engine::Selection;
use crate::diagnosis::local_scan::{self, Kind};
use crate::diagnosis::lost_motion;
use crate::diagnosis::lsq;
use crate::diagnosis::repeatability::Repeatability;
use crate::diagnosis::series::{SeriesOptions, decimate, rms};
use crate::diagnosis::{Finding, Mismatch, PlotData, PlotKind, PlotSeries, effects};
use crate::text::with_std;
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
    /// Whether the axis needs an explanation: rigid held-out RMS above the floor, or
    /// outlying approaches set aside.
    pub(super) needs: bool,
}

/// The findings, mismatch, unexplained remainder and plots of a selection.
pub(super) fn outcome(
    a: &AxisData,
    sel: Selection<Positioning>,
    rep: &Repeatability,
    opts: &SeriesOptions,
) -> AxisOutcome {
    let n = a.n();
    let noise = sel.noise;
    let base_res = residuals(a, &sel.base_fit.prediction);
    let jf = final_joint_fit(a, &sel.model);
    let findings = step_findings(a, &sel, &jf, &base_res, rep);
    let res = jf.res.as_slice();
    let final_heldout = sel.heldout_rms();
    let base_heldout = sel.base_heldout_rms();
    let local = local_anomalies(a, res, noise, rep);
    let needs = base_heldout > opts.explained_ratio * noise
        || !rep.set_aside.is_empty()
        || !local.is_empty();
    let mut left = vec![];
    if needs && final_heldout > opts.explained_ratio * noise {
        left.push(format!(
            "held-out RMS {:.3} µm after {} effect(s) against a noise floor of {:.3} µm; the largest remaining residuals: {}",
            final_heldout,
            sel.steps.len(),
            noise,
            worst_places(a, res)
        ));
    }
    left.extend(unexplained_anomalies(a, res, noise, rep, &local));
    let unexplained = (!left.is_empty()).then(|| format!("axis {}: {}", a.axis, left.join("; ")));
    let misfit = (base_res.iter().map(|v| v * v).sum::<f64>() - n as f64 * noise * noise).max(0.0);
    let mismatch = mismatches(a, &base_res, res, misfit, noise, rep, &local);
    AxisOutcome {
        noise,
        base_rms: rms(&base_res),
        base_heldout,
        final_heldout,
        n,
        mismatch,
        findings,
        unexplained,
        plots: plots(a, &sel.model, &jf.fit.coef, &base_res, res, opts),
        misfit,
        needs,
    }
}

/// The residuals of the axis's readings from a prediction.
fn residuals(a: &AxisData, pred: &[f64]) -> Vec<f64> {
    a.y.iter().zip(pred).map(|(y, p)| y - p).collect()
}

/// The final joint fit of a selection's model, with the Jacobian fit that gives its
/// parameters' uncertainties (∂/∂θ columns of the nonlinear terms appended).
struct FinalFit {
    fit: lsq::LsqFit,
    /// Residual of the final fit.
    res: Vec<f64>,
    /// Fit of the residual on the Jacobian: the standard uncertainties and covariance.
    jfit: lsq::LsqFit,
    /// Each term's first column.
    offsets: Vec<usize>,
    /// The first ∂/∂θ column of the Jacobian.
    theta_idx: usize,
    /// The lost-motion profile's first column (after every term's).
    lm_off: usize,
}

/// Final joint fit; parameters and uncertainties from the Jacobian with ∂/∂θ columns.
fn final_joint_fit(a: &AxisData, model: &Model) -> FinalFit {
    let n = a.n();
    // Final joint fit; parameters and uncertainties from the Jacobian with ∂/∂θ columns.
    let d = a.design(model);
    let fit = lsq::solve(&d, &a.y);
    let res = residuals(a, &d.predict(&fit.coef));
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
    // The lost-motion profile's columns come after every term's.
    let lm_off = col;
    FinalFit {
        fit,
        res,
        jfit,
        offsets,
        theta_idx,
        lm_off,
    }
}

/// One finding per step of the selection, with its parameters from the final joint fit.
fn step_findings(
    a: &AxisData,
    sel: &Selection<Positioning>,
    jf: &FinalFit,
    base_res: &[f64],
    rep: &Repeatability,
) -> Vec<Finding> {
    let (fit, noise) = (&jf.fit, sel.noise);
    let mut findings = vec![];
    // Steps that change the lost motion (a constant backlash, then a profile, or a profile
    // raised in order) make one finding when the final model has a profile: the first
    // such step's "before", the last one's "after".
    let lm_steps: Vec<usize> = sel
        .steps
        .iter()
        .enumerate()
        .filter(|(_, st)| {
            sel.model.lost_motion.is_some()
                && matches!(
                    st.chosen.candidate,
                    Candidate::LostMotion(_) | Candidate::Effect(Effect::Backlash)
                )
        })
        .map(|(i, _)| i)
        .collect();
    for (si, st) in sel.steps.iter().enumerate() {
        if lm_steps.contains(&si) && Some(&si) != lm_steps.last() {
            continue;
        }
        let mut params = BTreeMap::new();
        let mut extra = String::new();
        let (mut rms_ba, mut heldout_ba) = (st.rms, st.heldout);
        let effect = match st.chosen.candidate {
            Candidate::Order(to) => {
                params.insert("order_before".into(), st.before.order as f64);
                params.insert("extra_order".into(), to as f64);
                None
            }
            Candidate::LostMotion(_) | Candidate::Effect(Effect::Backlash)
                if lm_steps.contains(&si) =>
            {
                let first = &sel.steps[lm_steps[0]];
                rms_ba.before = first.rms.before;
                heldout_ba.before = first.heldout.before;
                extra = lost_motion_parameters(a, sel, jf, &lm_steps, &mut params);
                Some(None)
            }
            Candidate::LostMotion(_) => unreachable!("a profile step is in lm_steps"),
            Candidate::Effect(e) => Some(Some(e)),
        };
        let label = match effect {
            None => "model_order",
            Some(None) => LOST_MOTION_PROFILE,
            Some(Some(e)) => e.name(),
        };
        let effect = effect.flatten();
        if let Some(e) = effect
            && let Some(x) = effect_parameters(a, sel, jf, e, rep, &mut params)
        {
            extra = x;
        }
        let signature = match effect {
            Some(Effect::Backlash) => {
                // Sign agreement of the per-target step with the fitted lost motion.
                let lm = params.get("lost_motion_um").copied().unwrap_or(0.0);
                let (agree, total) = step_signs(a, base_res, lm);
                format!(
                    "; step − minus + approach has the sign of the lost motion at {agree} of {total} targets"
                )
            }
            _ => extra,
        };
        findings.push(Finding {
            effect: label.into(),
            axis: Some(a.axis.to_string()),
            depends_on: None,
            parameters: params,
            physics: effects::physics(label).into(),
            residual_rms_um: rms_ba,
            heldout_rms_um: heldout_ba,
            undetermined: vec![],
            rivals: Vec::new(),
            evidence: format!(
                "ΔBIC {:.1}; held-out RMS (leave one of {} runs out) {:.3} → {:.3} µm; noise floor {:.3} µm; condition number of the final joint fit {:.2e}{signature}",
                st.chosen.dbic,
                a.runs.len(),
                heldout_ba.before,
                heldout_ba.after,
                noise,
                fit.cond
            ),
            signature: None,
        });
    }
    findings
}

/// The parameters of the lost motion's profile (the last lost-motion step of the
/// selection) into `params`; returns the finding's evidence beyond its ΔBIC.
fn lost_motion_parameters(
    a: &AxisData,
    sel: &Selection<Positioning>,
    jf: &FinalFit,
    lm_steps: &[usize],
    params: &mut BTreeMap<String, f64>,
) -> String {
    let (fit, jfit, lm_off) = (&jf.fit, &jf.jfit, jf.lm_off);
    let order = sel.model.lost_motion.unwrap_or(0);
    let prof = a.profile(order);
    let coef = &fit.coef[lm_off..lm_off + order + 1];
    let cov = jfit
        .cov
        .view((lm_off, lm_off), (order + 1, order + 1))
        .into_owned();
    let at = prof.at(coef, &cov, &a.targets);
    for (k, ((b, sb), t)) in at.iter().zip(&a.targets).enumerate() {
        params.insert(format!("lost_motion_um_{}", k + 1), *b);
        params.insert(format!("std_lost_motion_um_{}", k + 1), *sb);
        params.insert(format!("target_mm_{}", k + 1), *t);
    }
    let (mean, sm) = prof.mean(coef, &cov, &a.targets);
    params.insert("mean_lost_motion_um".into(), mean);
    params.insert("std_mean_lost_motion_um".into(), sm);
    let (v, sv) = prof.variation(coef, &cov, &a.targets);
    params.insert("variation_um".into(), v);
    params.insert("std_variation_um".into(), sv);
    params.insert("order".into(), order as f64);
    let steps: Vec<String> = lm_steps
        .iter()
        .map(|&i| {
            let s = &sel.steps[i];
            format!(
                "{} (ΔBIC {:.1}, held-out {:.3} → {:.3} µm)",
                match s.chosen.candidate {
                    Candidate::LostMotion(k) => format!("profile of order {k}"),
                    _ => "constant backlash".into(),
                },
                s.chosen.dbic,
                s.heldout.before,
                s.heldout.after
            )
        })
        .collect();
    format!(
        "; {}; {}; profile b (= −B_i of ISO 230-2) at the targets: {}",
        steps.join(", then "),
        lost_motion::shares(mean, v),
        at.iter()
            .zip(&a.targets)
            .map(|((b, sb), t)| format!("{t:.1} mm {}", with_std(*b, *sb, 2, true)))
            .collect::<Vec<_>>()
            .join(", ")
    )
}

/// The parameters of an effect's term into `params`; returns the evidence of a
/// transient (the others have none beyond their ΔBIC).
fn effect_parameters(
    a: &AxisData,
    sel: &Selection<Positioning>,
    jf: &FinalFit,
    e: Effect,
    rep: &Repeatability,
    params: &mut BTreeMap<String, f64>,
) -> Option<String> {
    let (fit, jfit, res, noise) = (&jf.fit, &jf.jfit, &jf.res, sel.noise);
    let mut extra = None;
    let ti = sel
        .model
        .terms
        .iter()
        .position(|t| t.effect == e)
        .expect("term present");
    let t = sel.model.terms[ti];
    let c0 = jf.offsets[ti];
    // θ's Jacobian column index: count nonlinear terms before this one.
    let th = jf.theta_idx
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
            let sv = smoother_variance(a, [b[0], b[1]]);
            params.insert("offset_um_per_k".into(), b[0]);
            params.insert("std_offset_um_per_k".into(), sb[0].hypot(sv[0].sqrt()));
            params.insert("scale_ppm_per_k".into(), b[1]);
            params.insert("std_scale_ppm_per_k".into(), sb[1].hypot(sv[1].sqrt()));
        }
        Effect::Transient => {
            params.insert("size_um".into(), b[0]);
            params.insert("std_size_um".into(), sb[0]);
            params.insert(format!("time_constant_{unit}"), t.theta);
            params.insert(format!("std_time_constant_{unit}"), jfit.std[th]);
            extra = Some(transient_evidence(
                a,
                b[0],
                t.theta,
                noise,
                rep.critical_t,
                res,
            ));
        }
    }
    extra
}

/// What no effect explains: the outlying approaches the final model does not bring
/// within the outlier test's critical value, and the local anomalies of its residual.
fn unexplained_anomalies(
    a: &AxisData,
    res: &[f64],
    noise: f64,
    rep: &Repeatability,
    local: &[LocalAnomaly],
) -> Vec<String> {
    // Outlying approaches the final model does not bring within the outlier test's
    // critical value are local anomalies left unexplained.
    let anomalies: Vec<String> = rep
        .set_aside
        .iter()
        .filter(|o| res[o.index].abs() > rep.critical_t * noise)
        .map(|o| {
            format!(
                "{} ({:+.2} µm from the model)",
                a.place(o.index),
                res[o.index]
            )
        })
        .collect();
    let mut left = vec![];
    if !anomalies.is_empty() {
        left.push(format!(
            "outlying approaches no effect explains: {}",
            anomalies.join(", ")
        ));
    }
    if !local.is_empty() {
        left.push(format!(
            "local anomalies in the final model's residual, in time order (local scan at {:.1} % family-wise over the axis): {}",
            100.0 * local_scan::FAMILY_WISE_ALPHA,
            local.iter().map(|l| l.text.as_str()).collect::<Vec<_>>().join(", ")
        ));
    }
    left
}

/// Where the rigid model's misfit lies: the located places, the outlying approaches
/// set aside and the local anomalies, by their share of the misfit.
fn mismatches(
    a: &AxisData,
    base_res: &[f64],
    res: &[f64],
    misfit: f64,
    noise: f64,
    rep: &Repeatability,
    local: &[LocalAnomaly],
) -> Vec<Mismatch> {
    let mut mismatch = locate(a, base_res, noise);
    if !rep.set_aside.is_empty() {
        let excess = misfit.max(1e-300);
        let ss: f64 = rep
            .set_aside
            .iter()
            .map(|o| base_res[o.index].powi(2))
            .sum();
        mismatch.push(Mismatch {
            where_: format!(
                "axis {}: outlying approaches, set aside from the noise floor (outlier test at {:.0} % per axis, |t| > {:.2}): {}",
                a.axis,
                100.0 * crate::diagnosis::repeatability::ALPHA,
                rep.critical_t,
                rep.set_aside
                    .iter()
                    .map(|o| format!("{} {:+.2} µm off the other runs (t = {:.1})", a.place(o.index), o.residual_um, o.t))
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
            tests: rep
                .set_aside
                .iter()
                .map(|o| format!("{}#run {}", a.axis, a.run[o.index]))
                .collect(),
            share_of_misfit: (ss / excess).min(1.0),
        });
        mismatch.sort_by(|x, y| y.share_of_misfit.total_cmp(&x.share_of_misfit));
    }
    if !local.is_empty() {
        let excess = misfit.max(1e-300);
        let ss: f64 = local
            .iter()
            .flat_map(|l| &l.indices)
            .map(|&i| res[i].powi(2))
            .sum();
        mismatch.push(Mismatch {
            where_: format!(
                "axis {}: local anomalies no effect explains: {}",
                a.axis,
                local
                    .iter()
                    .map(|l| l.text.as_str())
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
            tests: local
                .iter()
                .flat_map(|l| &l.indices)
                .map(|&i| a.run[i])
                .collect::<std::collections::BTreeSet<_>>()
                .into_iter()
                .map(|run| format!("{}#run {run}", a.axis))
                .collect(),
            share_of_misfit: (ss / excess).min(1.0),
        });
        mismatch.sort_by(|x, y| y.share_of_misfit.total_cmp(&x.share_of_misfit));
    }
    mismatch
}

/// A local anomaly of an axis's final residual.
struct LocalAnomaly {
    /// Where it is and how large, for a person.
    text: String,
    /// The readings it covers (indices of the records).
    indices: Vec<usize>,
}

/// The local scan ([`local_scan`]: a step that persists, a burst, an isolated excursion,
/// family-wise false-alarm rate [`local_scan::FAMILY_WISE_ALPHA`]) of the final model's
/// residual `res` read as one sequence in time order (a slip carried into later runs is
/// one step), against the noise floor. The approaches the outlier test set aside are
/// left out of the sequence (read as 0, the residual's mean): they are reported as
/// outlying approaches already.
fn local_anomalies(
    a: &AxisData,
    res: &[f64],
    noise: f64,
    rep: &Repeatability,
) -> Vec<LocalAnomaly> {
    let mut order: Vec<usize> = (0..res.len()).collect();
    order.sort_by(|&i, &j| a.time[i].total_cmp(&a.time[j]));
    let aside: Vec<usize> = rep.set_aside.iter().map(|o| o.index).collect();
    let seq: Vec<f64> = order
        .iter()
        .map(|&i| if aside.contains(&i) { 0.0 } else { res[i] })
        .collect();
    local_scan::scan(&[&seq], noise)
        .into_iter()
        .map(|an| {
            let (from, to) = match an.kind {
                // A step covers the readings from its place to the end of the axis.
                Kind::Step => (an.at, seq.len()),
                _ => an.span,
            };
            let indices: Vec<usize> = order[from.min(seq.len())..to.min(seq.len())].to_vec();
            let first = order[an.at.min(seq.len() - 1)];
            let what = match an.kind {
                Kind::Step => format!("a step of {:+.2} µm from", an.size),
                Kind::Burst => format!(
                    "a burst of {:.2} µm RMS over {} readings from",
                    an.size,
                    to - from
                ),
                Kind::Excursion => format!("a reading {:+.2} µm off at", an.size),
            };
            LocalAnomaly {
                text: format!(
                    "{what} {} (time {:.1} {}, z = {:.1})",
                    a.place(first),
                    a.time[first],
                    a.time_unit(),
                    an.z()
                ),
                indices,
            }
        })
        .collect()
}

/// Where the first-cycle transient of size `h` and time constant `tau` lies and how it
/// decays over the cycles. Located: the readings of the first cycle whose deviation from
/// the rest of the model (the residual plus the transient) has the transient's sign and
/// exceeds `crit` noise floors (the critical value of the noise floor's outlier test). Decay: that deviation at the same (target, direction) in every
/// cycle (later cycles: the residual).
fn transient_evidence(
    a: &AxisData,
    h: f64,
    tau: f64,
    noise: f64,
    crit: f64,
    res: &[f64],
) -> String {
    let value = |i: usize| {
        if a.first[i] {
            h * (-(a.time[i] - a.t_first) / tau).exp()
        } else {
            0.0
        }
    };
    let dev = |i: usize| res[i] + value(i);
    let located: Vec<usize> = (0..a.n())
        .filter(|&i| a.first[i] && dev(i).abs() > crit * noise && dev(i) * h > 0.0)
        .collect();
    if located.is_empty() {
        return format!(
            "; no reading of the first cycle deviates from the rest of the model by more than {crit:.2} noise floors ({:.3} µm)",
            crit * noise
        );
    }
    let tnum = |i: usize| {
        a.targets
            .iter()
            .position(|&t| (t - a.x[i]).abs() <= 1e-6 * (a.hi - a.lo))
            .unwrap_or(0)
            + 1
    };
    let places: Vec<String> = located
        .iter()
        .map(|&i| {
            format!(
                "{} at {:.1} mm (target {} of {})",
                if a.d[i] > 0.0 { "+" } else { "−" },
                a.x[i],
                tnum(i),
                a.targets.len(),
            )
        })
        .collect();
    let per_run: Vec<String> = a
        .runs
        .iter()
        .map(|&r| {
            let v: Vec<String> = located
                .iter()
                .map(|&l| {
                    (0..a.n())
                        .filter(|&i| a.run[i] == r && a.group[i] == a.group[l])
                        .map(|i| format!("{:+.1}", dev(i)))
                        .collect::<Vec<_>>()
                        .join("/")
                })
                .collect();
            format!("run {r} {}", v.join(", "))
        })
        .collect();
    format!(
        "; located in the first cycle: run {}, {}; decay over the cycles, deviation from the rest of the model at those readings (µm): {} (noise floor {noise:.3} µm)",
        a.run[located[0]],
        places.join(", "),
        per_run.join("; ")
    )
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

/// The plots of one axis: deviations per approach direction with the rigid model and the
/// model with effects, residuals before and after the effects, and the reversal value
/// along the travel when the model has a lost motion profile.
fn plots(
    a: &AxisData,
    m: &Model,
    coef: &[f64],
    base_res: &[f64],
    res: &[f64],
    opts: &SeriesOptions,
) -> Vec<PlotData> {
    // Model curves on a fine grid of positions (time terms at the mean time).
    let ng = 200;
    let grid: Vec<f64> = (0..=ng)
        .map(|i| a.lo + (a.hi - a.lo) * i as f64 / ng as f64)
        .collect();
    let mut dev = measured_means(a);
    let rigid = Model::rigid(m.order.min(opts.max_base_order));
    let rfit = lsq::solve(&a.design(&rigid), &a.y);
    dev.push(PlotSeries {
        name: "rigid model".into(),
        x: grid.clone(),
        y: model_curve(a, &grid, &rigid, &rfit.coef, true),
    });
    for plus in [true, false] {
        dev.push(PlotSeries {
            name: format!("model with effects {}", dir_name(plus)),
            x: grid.clone(),
            y: model_curve(a, &grid, m, coef, plus),
        });
    }
    let mut out = vec![
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
        residual_plot(a, base_res, res, opts),
    ];
    if let Some(order) = m.lost_motion {
        out.push(reversal_plot(a, m, order, coef, res, &grid));
    }
    out
}

/// The mean measured deviation per target, one series per approach direction.
fn measured_means(a: &AxisData) -> Vec<PlotSeries> {
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
    dev
}

/// A model's prediction along `grid` approached in one direction, its time terms at the
/// axis's mean time and temperature.
fn model_curve(a: &AxisData, grid: &[f64], model: &Model, coef: &[f64], plus: bool) -> Vec<f64> {
    let tmean = a.time.iter().sum::<f64>() / a.n() as f64;
    let tempmean = a
        .temp
        .as_ref()
        .map(|t| t.iter().sum::<f64>() / t.len() as f64);
    let gd = AxisData {
        axis: a.axis,
        x: grid.to_vec(),
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
        smoother: None,
        y: vec![0.0; grid.len()],
        run: vec![0; grid.len()],
        runs: vec![0],
        lo: a.lo,
        hi: a.hi,
        spacing: a.spacing,
        targets: vec![],
        group: vec![0; grid.len()],
        first: vec![false; grid.len()],
        t_first: a.t_first,
        first_step: a.first_step,
        first_duration: a.first_duration,
    };
    gd.design(model).predict(coef)
}

/// Residuals against time (or record) before and after the effects.
fn residual_plot(a: &AxisData, base_res: &[f64], res: &[f64], opts: &SeriesOptions) -> PlotData {
    let idx = decimate(a.n(), opts.plot_points);
    let tx: Vec<f64> = idx
        .iter()
        .map(|&i| a.time[i] / if a.time_in_s { 3600.0 } else { 1.0 })
        .collect();
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
    }
}

/// ISO 230-2's reversal B = x̄↑ − x̄↓ per target, of the readings less every other part of
/// the model, and the model's −b(x) of its lost motion profile (of `order`).
fn reversal_plot(
    a: &AxisData,
    m: &Model,
    order: usize,
    coef: &[f64],
    res: &[f64],
    grid: &[f64],
) -> PlotData {
    let prof = a.profile(order);
    let off = m.order + 1 + m.terms.iter().map(|t| t.effect.n_linear()).sum::<usize>();
    let b = &coef[off..off + order + 1];
    let lm = |i: usize| {
        let p = prof.basis_at(a.x[i]);
        -0.5 * a.d[i] * p.iter().zip(b).map(|(u, v)| u * v).sum::<f64>()
    };
    let mean = |g: usize| {
        let v: Vec<f64> = (0..a.n())
            .filter(|&i| a.group[i] == g)
            .map(|i| res[i] + lm(i))
            .collect();
        (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64)
    };
    let (xs, ys): (Vec<f64>, Vec<f64>) = (0..a.targets.len())
        .filter_map(|t| Some((a.targets[t], mean(2 * t)? - mean(2 * t + 1)?)))
        .unzip();
    PlotData {
        id: format!("positioning_{}_reversal", a.axis),
        title: format!(
            "axis {}: reversal value along the travel (+ minus − approach)",
            a.axis
        ),
        x_label: "target (mm)".into(),
        y_label: "B (µm)".into(),
        kind: PlotKind::Cartesian,
        series: vec![
            PlotSeries {
                name: "measured B_i, other effects removed".into(),
                x: xs,
                y: ys,
            },
            PlotSeries {
                name: "lost motion profile −b(x)".into(),
                x: grid.to_vec(),
                y: grid
                    .iter()
                    .map(|&q| {
                        -prof
                            .basis_at(q)
                            .iter()
                            .zip(b)
                            .map(|(u, v)| u * v)
                            .sum::<f64>()
                    })
                    .collect(),
            },
        ],
    }
}

/// The variance the smoother of the logged temperature adds to the per-kelvin offset and
/// scale `beta` (`temperature::Smoother::coefficient_cov`, one group of every record,
/// centred once as the polynomial's constant term does); infinite where the smoother
/// does not follow the temperature (the coefficients are then undetermined), 0 without
/// a logged temperature.
fn smoother_variance(a: &AxisData, beta: [f64; 2]) -> [f64; 2] {
    let (Some(sm), Some(temp)) = (&a.smoother, &a.temp) else {
        return [0.0; 2];
    };
    if !sm.follows {
        return [f64::INFINITY; 2];
    }
    let n = temp.len();
    let w: Vec<[f64; 2]> = a.x.iter().map(|&x| [1.0, x / 1000.0]).collect();
    let z: Vec<f64> = temp
        .iter()
        .zip(&w)
        .flat_map(|(dt, w)| [dt * w[0], dt * w[1]])
        .collect();
    let growth = w.iter().map(|w| beta[0] * w[0] + beta[1] * w[1]).collect();
    let mean = [0, 1].map(|k| (0..n).map(|i| z[2 * i + k]).sum::<f64>() / n.max(1) as f64);
    let gram = nalgebra::DMatrix::from_fn(2, 2, |k, l| {
        (0..n)
            .map(|i| (z[2 * i + k] - mean[k]) * (z[2 * i + l] - mean[l]))
            .sum::<f64>()
    });
    let group = crate::diagnosis::temperature::Group {
        t_s: a.time.clone(),
        z,
        growth,
    };
    sm.coefficient_cov([group], &gram)
        .map_or([f64::INFINITY; 2], |c| [c[(0, 0)], c[(1, 1)]])
}
