//! The identification result document, built once from an [`Estimate`] of either
//! method: values on the reporting grid with their uncertainties, straightness about its
//! least-squares line, squareness between the least-squares axis lines, identifiability
//! and nuisance parameters.

use super::{
    CONVENTION, Confounded, Estimate, FitSummary, IdentificationResult, IdentifyOptions, Method,
    ModelInfo, MountingReport, Nuisance, Observability, SquarenessReport, TermReport,
};
use crate::design::{ErrorModel, Fit};
use crate::observability;
use crate::session::Session;
use crate::terms::{SquarenessTerm, Term, TermKind};
use std::collections::BTreeMap;

/// Builds the result document from a method's estimate; `noise` is the noise estimated
/// independently of the model (µm).
pub fn report(
    session: &Session,
    model: &ErrorModel,
    opts: &IdentifyOptions,
    method: Method,
    noise: Option<f64>,
    est: &Estimate,
) -> IdentificationResult {
    report_with(session, model, opts, method, noise, est, None)
}

/// [`report`] of a fit with `extra` columns after the error parameters (the explained
/// model's physics): the residuals are the full model's.
pub fn report_with(
    session: &Session,
    model: &ErrorModel,
    opts: &IdentifyOptions,
    method: Method,
    noise: Option<f64>,
    est: &Estimate,
    extra: Option<&dyn crate::design::ExtraColumns>,
) -> IdentificationResult {
    let (fit, ident) = (&est.fit, &est.ident);
    let all = Term::all();
    let (confounded_with, groups) = confounded_groups(session, model, est);
    let term_ok: Vec<bool> = (0..all.len())
        .map(|i| model.bases[i].is_some() && model.term_range(i).all(|j| ident.param_determined[j]))
        .collect();
    let (terms, lines) = term_reports(model, opts, fit, &term_ok, &confounded_with);
    let squareness = squareness_reports(model, est, &lines, &confounded_with);
    let (identifiable, not_identifiable) = identifiability_lists(&term_ok, &squareness);
    let mountings = mounting_reports(est);
    let rows = fit.reduced.rows;
    // The per-sample residuals and, on a second core, each circle run's geometry (once,
    // for the ISO 230-4 figures and the polar plots) with the standards' figures, which
    // come from the readings alone.
    let (residuals, (circles, standards)) = std::thread::scope(|s| {
        let readings = s.spawn(|| {
            let circles = crate::standards::iso230_4::circle_runs(session);
            let standards = crate::standards::from_session_circles(session, &circles);
            (circles, standards)
        });
        let residuals = crate::design::residuals(session, model, fit, extra);
        let readings = readings
            .join()
            .unwrap_or_else(|p| std::panic::resume_unwind(p));
        (residuals, readings)
    });
    IdentificationResult {
        kind: "identification".into(),
        machine_id: session.machine_id.clone(),
        measured_at: session.measured_at.clone(),
        convention: CONVENTION.into(),
        method,
        model: ModelInfo {
            basis: model.kind,
            order: model.order,
            measured_travel_mm: crate::axis::Axis::ALL
                .into_iter()
                .filter_map(|a| {
                    let (lo, hi) = model.travel[a.index()]?;
                    Some((a.letter().to_string(), [lo, hi]))
                })
                .collect(),
        },
        terms,
        squareness,
        observability: Observability {
            parameters: ident.parameters,
            rank: ident.rank,
            condition_number: ident.condition_number,
            identifiable,
            not_identifiable,
            confounded: groups,
            advice: est.advice.clone(),
        },
        fit: FitSummary {
            samples: session.sample_count(),
            residual_rms_um: round((fit.solution.rss / rows.max(1) as f64).sqrt()),
            noise_estimate_um: noise,
            noise_pass_differences_um: None,
        },
        nuisance: Nuisance {
            mountings,
            runs: session.planes.iter().map(|p| p.runs.len()).sum(),
        },
        reporting: [
            "straightness values are deviations from the least-squares line fitted to the function over the measured travel (uniform weight in position)".into(),
            "squareness is the angle between the least-squares axis lines: X-Y = 90 deg + EC0Y, X-Z = 90 deg - EB0Z, Y-Z = 90 deg + EA0Z".into(),
            "circle direction: counter-clockwise turns from +u toward +v (in XZ that is X toward Z, opposite to G18)".into(),
            "values are zero at the reference position 0 of each axis; std is the standard uncertainty (1 sigma) from the fit's residual variance".into(),
        ]
        .into_iter()
        .chain(est.reporting.iter().cloned())
        .collect(),
        standards,
        circles: crate::standards::iso230_4::circle_plots(session, &circles, Some(&residuals)),
        residuals: crate::residuals::by_file_and_test(session, &residuals),
        model_check: None,
        conditions: session.test_conditions(),
        explained: None,
    }
}

/// Which terms each term is confounded with (by index, [`name_index`]), and the
/// confounded groups as reported.
fn confounded_groups(
    session: &Session,
    model: &ErrorModel,
    est: &Estimate,
) -> (Vec<Vec<String>>, Vec<Confounded>) {
    let (ident, all) = (&est.ident, Term::all());
    // Which terms each term is confounded with.
    let mut confounded_with: Vec<Vec<String>> = vec![Vec::new(); all.len() + 3];
    let mut groups = Vec::new();
    for g in &ident.groups {
        let names = observability::group_terms(model, g);
        for n in &names {
            let i = name_index(n);
            confounded_with[i] = names.iter().filter(|m| *m != n).cloned().collect();
        }
        groups.push(Confounded {
            seen_as: match est.seen_as {
                Some(f) => f(&names),
                None => seen_as(&names, session),
            },
            terms: names,
        });
    }
    (confounded_with, groups)
}

/// Each error function's values on the reporting grid with their uncertainties (a
/// straightness about its least-squares line over the travel), and the least-squares
/// lines' functionals of the straightnesses.
#[allow(clippy::type_complexity)]
fn term_reports(
    model: &ErrorModel,
    opts: &IdentifyOptions,
    fit: &Fit,
    term_ok: &[bool],
    confounded_with: &[Vec<String>],
) -> (
    BTreeMap<String, TermReport>,
    Vec<Option<(Vec<f64>, Vec<f64>)>>,
) {
    let (x, all) = (fit.error_params(), Term::all());
    let mut terms = BTreeMap::new();
    let mut lines: Vec<Option<(Vec<f64>, Vec<f64>)>> = vec![None; all.len()];
    for (i, term) in all.into_iter().enumerate() {
        let name = term.name();
        let mut rep = TermReport {
            unit: term.unit().to_string(),
            positions_mm: vec![],
            values: vec![],
            std: vec![],
            identifiable: term_ok[i],
            confounded_with: confounded_with[i].clone(),
            coefficients: vec![],
            coefficient_covariance: vec![],
        };
        if let (true, Some((lo, hi))) = (term_ok[i], model.travel[term.axis.index()]) {
            let straight = term.kind() == TermKind::Straightness;
            // Least-squares line of the function over the travel (straightness only),
            // as functionals (a, b) of the parameters.
            let line = straight.then(|| ls_line_functionals(model, i, lo, hi));
            if let Some(l) = &line {
                lines[i] = Some(l.clone());
            }
            for q in grid(lo, hi, opts.grid_step_mm) {
                let mut w = model.term_value_gradient(i, q);
                if let Some((a, b)) = &line {
                    for j in 0..w.len() {
                        w[j] -= a[j] + b[j] * q;
                    }
                }
                let v: f64 = w.iter().zip(x).map(|(w, x)| w * x).sum();
                rep.positions_mm.push(q);
                rep.values.push(round(v));
                rep.std
                    .push(round(observability::functional_variance(fit, &w).sqrt()));
            }
            rep.coefficients = monomial_coefficients(model, i, x);
            rep.coefficient_covariance = coefficient_covariance(model, fit, i);
        }
        terms.insert(name, rep);
    }
    (terms, lines)
}

/// Every squareness as the angle between the least-squares axis lines, or the model
/// constant alone when that angle is not estimable.
fn squareness_reports(
    model: &ErrorModel,
    est: &Estimate,
    lines: &[Option<(Vec<f64>, Vec<f64>)>],
    confounded_with: &[Vec<String>],
) -> BTreeMap<String, SquarenessReport> {
    let (fit, ident) = (&est.fit, &est.ident);
    let (x, all) = (fit.error_params(), Term::all());
    // Reported squareness: γ − s_XY − s_YX, β + s_XZ + s_ZX, α − s_YZ − s_ZY (µrad; the
    // slopes s in µm/mm are mrad, hence × 1000).
    let mut squareness = BTreeMap::new();
    for s in SquarenessTerm::ALL {
        let (pa, pb, sign) = match s {
            SquarenessTerm::EC0Y => ("EXY", "EYX", -1.0),
            SquarenessTerm::EB0Z => ("EXZ", "EZX", 1.0),
            SquarenessTerm::EA0Z => ("EYZ", "EZY", -1.0),
        };
        let mut w = vec![0.0; model.len()];
        w[model.squareness_index(s)] = 1.0;
        let mut ok = true;
        for name in [pa, pb] {
            let i = name_index(name);
            match (&lines[i], model.travel[all[i].axis.index()]) {
                (Some((_, b)), _) => {
                    for j in 0..w.len() {
                        w[j] += sign * 1000.0 * b[j];
                    }
                }
                (None, Some((lo, hi))) => {
                    // Straightness not reported on its own: its slope may still be
                    // estimable in combination.
                    let (_, b) = ls_line_functionals(model, i, lo, hi);
                    for j in 0..w.len() {
                        w[j] += sign * 1000.0 * b[j];
                    }
                }
                (None, None) => ok = false,
            }
        }
        let sq_index = model.squareness_index(s);
        let param_ok = ident.param_determined[sq_index];
        let lines_ok = ok && observability::estimable(fit, &w);
        // The model constant alone, when the least-squares-line angle is not estimable.
        let w = if lines_ok {
            w
        } else {
            let mut w0 = vec![0.0; model.len()];
            w0[sq_index] = 1.0;
            w0
        };
        let ok = lines_ok || param_ok;
        let idx = all.len() + SquarenessTerm::ALL.iter().position(|&t| t == s).unwrap();
        squareness.insert(
            s.name().to_string(),
            SquarenessReport {
                value_urad: ok.then(|| round(w.iter().zip(x).map(|(a, b)| a * b).sum())),
                std_urad: ok.then(|| round(observability::functional_variance(fit, &w).sqrt())),
                identifiable: ok,
                confounded_with: if ok {
                    vec![]
                } else {
                    confounded_with[idx].clone()
                },
                reported_as: ok.then(|| {
                    if lines_ok {
                        "ls_axis_lines"
                    } else {
                        "model_constant"
                    }
                    .to_string()
                }),
            },
        );
    }
    squareness
}

/// The names of the identifiable and the not identifiable terms and squarenesses.
fn identifiability_lists(
    term_ok: &[bool],
    squareness: &BTreeMap<String, SquarenessReport>,
) -> (Vec<String>, Vec<String>) {
    let all = Term::all();
    let mut identifiable = Vec::new();
    let mut not_identifiable = Vec::new();
    for (i, t) in all.into_iter().enumerate() {
        if term_ok[i] {
            identifiable.push(t.name());
        } else {
            not_identifiable.push(t.name());
        }
    }
    for s in SquarenessTerm::ALL {
        if squareness[s.name()].identifiable {
            identifiable.push(s.name().to_string());
        } else {
            not_identifiable.push(s.name().to_string());
        }
    }
    (identifiable, not_identifiable)
}

/// Each mounting's rotation with its standard uncertainty, where determined.
fn mounting_reports(est: &Estimate) -> BTreeMap<String, MountingReport> {
    let (fit, ident) = (&est.fit, &est.ident);
    let mut mountings = BTreeMap::new();
    for (m, name) in fit.layout.mountings.iter().enumerate() {
        let ok = ident.rotation_determined[m];
        mountings.insert(
            name.clone(),
            MountingReport {
                rotation_urad: ok.then(|| round(fit.solution.x[m])),
                std_urad: ok.then(|| round(fit.solution.cov[(m, m)].max(0.0).sqrt())),
            },
        );
    }
    mountings
}

/// Rounds a reported figure to 1e-6 of its unit (keeps documents readable).
pub(crate) fn round(v: f64) -> f64 {
    (v * 1e6).round() / 1e6
}

/// Index of a term or squareness name in [`Term::all`] order then EC0Y, EB0Z, EA0Z.
fn name_index(name: &str) -> usize {
    if let Some(t) = Term::parse(name) {
        Term::all().iter().position(|&x| x == t).unwrap()
    } else {
        let s = SquarenessTerm::parse(name).expect("a term or squareness name");
        18 + SquarenessTerm::ALL.iter().position(|&x| x == s).unwrap()
    }
}

/// Reporting grid: multiples of `step` inside [lo, hi], and always 0.
pub fn grid(lo: f64, hi: f64, step: f64) -> Vec<f64> {
    let mut g: Vec<f64> = Vec::new();
    let first = (lo / step).ceil() as i64;
    let last = (hi / step).floor() as i64;
    for k in first..=last {
        g.push(k as f64 * step);
    }
    if !g.contains(&0.0) {
        g.push(0.0);
        g.sort_by(f64::total_cmp);
    }
    g
}

/// Gauss–Legendre nodes and weights on [−1, 1] (8 points: exact to degree 15).
const GL8: [(f64, f64); 8] = [
    (-0.960_289_856_497_536_3, 0.101_228_536_290_376_26),
    (-0.796_666_477_413_626_7, 0.222_381_034_453_374_47),
    (-0.525_532_409_916_329, 0.313_706_645_877_887_3),
    (-0.183_434_642_495_649_8, 0.362_683_783_378_362),
    (0.183_434_642_495_649_8, 0.362_683_783_378_362),
    (0.525_532_409_916_329, 0.313_706_645_877_887_3),
    (0.796_666_477_413_626_7, 0.222_381_034_453_374_47),
    (0.960_289_856_497_536_3, 0.101_228_536_290_376_26),
];

/// Quadrature weights of the least-squares line a + b·q of a function f over [lo, hi]
/// (continuous, uniform weight): a = Σ_k wa_k f(q_k), b = Σ_k wb_k f(q_k), returned as
/// (q_k, wa_k, wb_k). With s = (q − c)/h mapping the travel onto [−1, 1]: a' = ½∫f ds,
/// b' = (3/2)∫f s ds (Legendre projection), then b = b'/h, a = a' − b c; the integrals by
/// 8-point Gauss–Legendre, exact for polynomials up to degree 15.
pub fn ls_line_weights(lo: f64, hi: f64) -> [(f64, f64, f64); 8] {
    let c = 0.5 * (lo + hi);
    let h = 0.5 * (hi - lo);
    GL8.map(|(s, w)| {
        let wb = 1.5 * w * s / h;
        (c + h * s, 0.5 * w - wb * c, wb)
    })
}

/// The least-squares line a + b·q of term `i` over [lo, hi] ([`ls_line_weights`]), as
/// linear functionals (a, b) of the error parameters.
pub fn ls_line_functionals(model: &ErrorModel, i: usize, lo: f64, hi: f64) -> (Vec<f64>, Vec<f64>) {
    let n = model.len();
    let mut a = vec![0.0; n];
    let mut b = vec![0.0; n];
    for (q, wa, wb) in ls_line_weights(lo, hi) {
        let g = model.term_value_gradient(i, q);
        for j in 0..n {
            a[j] += wa * g[j];
            b[j] += wb * g[j];
        }
    }
    (a, b)
}

/// Monomial coefficients (element k ↔ q^(k+1)) of term `i` from the fitted parameters,
/// by interpolation of the fitted function at order+1 points (exact for polynomials).
fn monomial_coefficients(model: &ErrorModel, i: usize, x: &[f64]) -> Vec<f64> {
    let Some((lo, hi)) = model.travel[Term::all()[i].axis.index()] else {
        return vec![];
    };
    let n = model.order;
    let c = 0.5 * (lo + hi);
    let h = (0.5 * (hi - lo)).max(1.0);
    // Fit f(q)/q? f has no constant term: solve V c = f at n Chebyshev nodes (q ≠ 0).
    let nodes: Vec<f64> = (0..n)
        .map(|k| c + h * ((2 * k + 1) as f64 * std::f64::consts::PI / (2 * n) as f64).cos())
        .map(|q| if q.abs() < 1e-9 { q + 1e-3 } else { q })
        .collect();
    let v = nalgebra::DMatrix::from_fn(n, n, |r, k| nodes[r].powi(k as i32 + 1));
    let f = nalgebra::DVector::from_fn(n, |r, _| model.term_value(i, x, nodes[r]));
    match v.col_piv_qr().solve(&f) {
        Some(sol) => sol.iter().copied().collect(),
        None => vec![],
    }
}

/// Covariance of the monomial coefficients of term `i` ([`monomial_coefficients`] is
/// linear in the parameters: its gradient is its value at the unit vectors), as
/// g_kᵀ Σ g_l from the fit's covariance.
fn coefficient_covariance(model: &ErrorModel, fit: &Fit, i: usize) -> Vec<Vec<f64>> {
    let range = model.term_range(i);
    let mut unit = vec![0.0; model.len()];
    let mut rows: Vec<Vec<f64>> = Vec::new();
    for j in range.clone() {
        unit[j] = 1.0;
        let c = monomial_coefficients(model, i, &unit);
        unit[j] = 0.0;
        if rows.is_empty() {
            rows = vec![vec![0.0; model.len()]; c.len()];
        }
        for (k, v) in c.into_iter().enumerate() {
            rows[k][j] = v;
        }
    }
    rows.iter()
        .map(|a| {
            rows.iter()
                .map(|b| observability::functional_covariance(fit, a, b))
                .collect()
        })
        .collect()
}

/// A sentence saying how a confounded group is seen by the data.
fn seen_as(names: &[String], session: &Session) -> String {
    let mut offsets: Vec<String> = Vec::new();
    for p in &session.planes {
        let t = format!(
            "({}, {}, {})",
            p.head_offset_mm[0], p.head_offset_mm[1], p.head_offset_mm[2]
        );
        if !offsets.contains(&t) {
            offsets.push(t);
        }
    }
    if names.len() == 1 {
        return format!(
            "{} has no effect of its own on the readings of this plan at head offset(s) {} mm (zero Abbe arm, or an effect equal to the plate rotation and zero offsets)",
            names[0],
            offsets.join(", ")
        );
    }
    format!(
        "{} cannot be separated: they act on the readings only in combination (translations plus angles times their Abbe arms at head offset(s) {} mm); the data determine those combinations, not the terms",
        names.join(" + "),
        offsets.join(", ")
    )
}
