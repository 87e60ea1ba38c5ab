//! 21-term identification from planar grid-encoder sessions (patent CN101982726).
//!
//! The joint method solves one least-squares problem over every run and mounting: the
//! observation model of [`crate::design`] (the contract's linearised kinematics with the
//! Abbe arms, plus a plate rotation per mounting and two zero offsets per run), reduced
//! by streaming Householder QR and solved by SVD of the column-scaled triangular factor
//! ([`crate::lsq`]) — never by normal equations. The rank analysis of
//! [`crate::observability`] says which terms the plan determines; a term it cannot
//! determine is reported without numbers (`identifiable: false`) with the terms it is
//! confounded with, and [`advice`] recomputes the rank with candidate extra tests to say
//! which one resolves them.
//!
//! Reported values follow the contract's reporting conventions: values on a grid over
//! the measured travel (every 5 mm, always including 0); straightness as deviation from
//! its least-squares line over the travel (continuous, uniform weight: Gauss–Legendre
//! quadrature of the polynomial); squareness as the angle between the least-squares axis
//! lines (EC0Y = γ − s_XY − s_YX, EB0Z = β + s_XZ + s_ZX, EA0Z = α − s_YZ − s_ZY). Each
//! value's standard uncertainty is √(wᵀ Σ w) for its functional w and the parameter
//! covariance Σ = σ̂² (RᵀR)⁺ taken from the SVD.

use crate::basis::BasisKind;
use crate::design::{self, ErrorModel, Fit, measured_travel};
use crate::error::SolverError;
use crate::noise::noise_from_repeated_passes;
use crate::observability::{self, Identifiability};
use crate::session::Session;
use crate::terms::{SquarenessTerm, Term, TermKind};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// The convention line every result document carries (see docs/conventions.md).
pub const CONVENTION: &str =
    "mtcal kinematics v1: tool-relative-to-workpiece, X primary, Y secondary";

/// Which estimator to run.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Method {
    /// One least-squares problem over all runs, nuisance parameters estimated jointly.
    #[default]
    Joint,
    /// The seed patent's two steps: lines → 12 translational terms, circles → 9 angular.
    Stepwise,
}

/// Options of an identification.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct IdentifyOptions {
    pub method: Method,
    pub basis: BasisKind,
    /// Polynomial order N (default 3).
    pub order: usize,
    /// Spacing of the reported value grid, mm (default 5; the grid always includes 0).
    pub grid_step_mm: f64,
    /// Topology to use when the session does not declare one.
    pub topology: Option<crate::axis::Topology>,
}

impl Default for IdentifyOptions {
    fn default() -> Self {
        IdentifyOptions {
            method: Method::Joint,
            basis: BasisKind::Polynomial,
            order: 3,
            grid_step_mm: 5.0,
            topology: None,
        }
    }
}

/// Values of one of the 18 error functions on the reporting grid (results contract).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TermReport {
    /// `um` or `urad`.
    pub unit: String,
    pub positions_mm: Vec<f64>,
    pub values: Vec<f64>,
    /// Standard uncertainty of each value.
    pub std: Vec<f64>,
    pub identifiable: bool,
    /// Terms this one cannot be separated from (when not identifiable).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub confounded_with: Vec<String>,
    /// Monomial coefficients, element i ↔ q^(i+1) (µm/mm^k or µrad/mm^k), as reported
    /// (straightness: after removing its least-squares line). Empty when not identifiable.
    #[serde(default)]
    pub coefficients: Vec<f64>,
}

/// One squareness value (results contract).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SquarenessReport {
    pub value_urad: Option<f64>,
    pub std_urad: Option<f64>,
    pub identifiable: bool,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub confounded_with: Vec<String>,
    /// `ls_axis_lines` (the contract's reporting convention: the angle between the
    /// least-squares axis lines) or `model_constant` (the constant of u_Y / u_Z, when
    /// the straightness slopes that convention needs are not determined by the data).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reported_as: Option<String>,
}

/// A group of terms the data cannot separate, and how it is seen.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Confounded {
    pub terms: Vec<String>,
    pub seen_as: String,
}

/// Identifiability of the error model for the session's plan.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Observability {
    /// Number of error-model parameters (51 for the cubic model).
    pub parameters: usize,
    /// Rank of the error-parameter block after eliminating the nuisance parameters.
    pub rank: usize,
    /// Condition number of the (column-scaled) identifiable part.
    pub condition_number: f64,
    pub identifiable: Vec<String>,
    pub not_identifiable: Vec<String>,
    pub confounded: Vec<Confounded>,
    pub advice: Vec<String>,
}

/// Goodness of fit.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FitSummary {
    pub samples: usize,
    pub residual_rms_um: f64,
    /// Noise estimated independently of the model, from repeated passes.
    pub noise_estimate_um: Option<f64>,
}

/// Nuisance parameters estimated with the errors.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MountingReport {
    /// In-plane rotation φ of the plate (+φ turns it from u toward v), `None` when the
    /// data cannot determine it.
    pub rotation_urad: Option<f64>,
    pub std_urad: Option<f64>,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Nuisance {
    pub mountings: BTreeMap<String, MountingReport>,
    /// Number of runs (each with two zero offsets).
    pub runs: usize,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ModelInfo {
    pub basis: BasisKind,
    pub order: usize,
}

/// The identification result document (shared/spec/results.md, "Identification result").
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct IdentificationResult {
    /// Always `identification`.
    pub kind: String,
    pub machine_id: String,
    pub measured_at: String,
    pub convention: String,
    pub method: Method,
    pub model: ModelInfo,
    /// The 18 functions, keyed by ISO 230-1 name.
    pub terms: BTreeMap<String, TermReport>,
    /// EC0Y, EB0Z, EA0Z.
    pub squareness: BTreeMap<String, SquarenessReport>,
    pub observability: Observability,
    pub fit: FitSummary,
    pub nuisance: Nuisance,
    /// Sentences stating the reporting conventions used (straightness, squareness,
    /// circle direction).
    pub reporting: Vec<String>,
}

impl IdentificationResult {
    /// Value of an identified term at `q_mm` from its coefficients (µm or µrad);
    /// `None` when the term is unknown or not identifiable.
    pub fn term_value_at(&self, name: &str, q_mm: f64) -> Option<f64> {
        let t = self.terms.get(name)?;
        if !t.identifiable || t.coefficients.is_empty() {
            return None;
        }
        let mut acc = 0.0;
        for &c in t.coefficients.iter().rev() {
            acc = acc * q_mm + c;
        }
        Some(acc * q_mm)
    }
}

/// Identifies the 21 terms of the machine measured in `session`.
///
/// Topology: the session's, else `opts.topology`, else the default (workpiece [X, Y],
/// tool [Z]).
pub fn identify(
    session: &Session,
    opts: &IdentifyOptions,
) -> Result<IdentificationResult, SolverError> {
    let model = prepare(session, opts)?;
    match opts.method {
        Method::Joint => joint(session, &model, opts),
        Method::Stepwise => crate::stepwise::identify(session, &model, opts),
    }
}

/// Checks the session and builds the error model over its measured travel.
pub fn prepare(session: &Session, opts: &IdentifyOptions) -> Result<ErrorModel, SolverError> {
    if session.planes.is_empty() || session.sample_count() == 0 {
        return Err(SolverError::InvalidInput(
            "the session has no samples".into(),
        ));
    }
    if opts.order == 0 || opts.order > MAX_ORDER {
        return Err(SolverError::InvalidInput(format!(
            "polynomial order must be 1..={MAX_ORDER}, got {}",
            opts.order
        )));
    }
    if opts.grid_step_mm.is_nan() || opts.grid_step_mm <= 0.0 {
        return Err(SolverError::InvalidInput(
            "grid step must be positive".into(),
        ));
    }
    let topology = session
        .topology
        .clone()
        .or_else(|| opts.topology.clone())
        .unwrap_or_default();
    topology.validate().map_err(SolverError::InvalidInput)?;
    let travel = measured_travel(session);
    if travel.iter().all(Option::is_none) {
        return Err(SolverError::Degenerate(
            "no axis moved in the session".into(),
        ));
    }
    Ok(ErrorModel::new(topology, opts.basis, opts.order, travel))
}

/// Highest polynomial order accepted.
pub const MAX_ORDER: usize = 9;

fn joint(
    session: &Session,
    model: &ErrorModel,
    opts: &IdentifyOptions,
) -> Result<IdentificationResult, SolverError> {
    let fit = design::fit(session, model, &|_, _| true, None);
    let ident = observability::analyse(&fit, model);
    let advice = advice(session, model, &ident);
    Ok(report(
        session,
        model,
        opts,
        Method::Joint,
        &fit,
        &ident,
        advice,
    ))
}

/// Builds the result document from a fit.
pub fn report(
    session: &Session,
    model: &ErrorModel,
    opts: &IdentifyOptions,
    method: Method,
    fit: &Fit,
    ident: &Identifiability,
    advice: Vec<String>,
) -> IdentificationResult {
    let x = fit.error_params();
    let all = Term::all();
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
            seen_as: seen_as(&names, session),
            terms: names,
        });
    }
    let term_ok: Vec<bool> = (0..all.len())
        .map(|i| model.bases[i].is_some() && model.term_range(i).all(|j| ident.param_determined[j]))
        .collect();
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
        }
        terms.insert(name, rep);
    }
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
    let rows = fit.reduced.rows;
    IdentificationResult {
        kind: "identification".into(),
        machine_id: session.machine_id.clone(),
        measured_at: session.measured_at.clone(),
        convention: CONVENTION.into(),
        method,
        model: ModelInfo {
            basis: model.kind,
            order: model.order,
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
            advice,
        },
        fit: FitSummary {
            samples: session.sample_count(),
            residual_rms_um: round((fit.solution.rss / rows.max(1) as f64).sqrt()),
            noise_estimate_um: noise_from_repeated_passes(session).map(round),
        },
        nuisance: Nuisance {
            mountings,
            runs: session.planes.iter().map(|p| p.runs.len()).sum(),
        },
        reporting: vec![
            "straightness values are deviations from the least-squares line fitted to the function over the measured travel (uniform weight in position)".into(),
            "squareness is the angle between the least-squares axis lines: X-Y = 90 deg + EC0Y, X-Z = 90 deg - EB0Z, Y-Z = 90 deg + EA0Z".into(),
            "circle direction: counter-clockwise turns from +u toward +v (in XZ that is X toward Z, opposite to G18)".into(),
            "values are zero at the reference position 0 of each axis; std is the standard uncertainty (1 sigma) from the fit's residual variance".into(),
        ],
    }
}

/// Rounds a reported figure to 1e-6 of its unit (keeps documents readable).
fn round(v: f64) -> f64 {
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

/// The least-squares line a + b·q of term `i` over [lo, hi] (continuous, uniform weight),
/// as linear functionals (a, b) of the error parameters. With s = (q − c)/h mapping the
/// travel onto [−1, 1]: a' = ½∫f ds, b' = (3/2)∫f s ds (Legendre projection), then
/// b = b'/h, a = a' − b c.
pub fn ls_line_functionals(model: &ErrorModel, i: usize, lo: f64, hi: f64) -> (Vec<f64>, Vec<f64>) {
    let c = 0.5 * (lo + hi);
    let h = 0.5 * (hi - lo);
    let n = model.len();
    let mut a = vec![0.0; n];
    let mut b = vec![0.0; n];
    for (s, w) in GL8 {
        let g = model.term_value_gradient(i, c + h * s);
        for j in 0..n {
            a[j] += 0.5 * w * g[j];
            b[j] += 1.5 * w * s * g[j];
        }
    }
    for j in 0..n {
        b[j] /= h;
        a[j] -= b[j] * c;
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
        "{} act on the readings only through one combination (translations plus angles times their Abbe arms at head offset(s) {} mm): the data determine that combination, not the terms",
        names.join(" + "),
        offsets.join(", ")
    )
}

/// Concrete advice: which extra tests would resolve the confounded terms, checked by
/// recomputing the rank with the extra tests added to the plan.
fn advice(session: &Session, model: &ErrorModel, ident: &Identifiability) -> Vec<String> {
    if ident.groups.is_empty() {
        return vec![];
    }
    // A structure-only copy of the session, thinned for speed.
    let thin = thin_session(session, 400);
    let rank_with = |extra_offsets: &[[f64; 3]], keep_mounting: bool| -> usize {
        let mut s = thin.clone();
        for (k, d) in extra_offsets.iter().enumerate() {
            for p in &thin.planes {
                let mut p2 = p.clone();
                p2.head_offset_mm = [
                    p.head_offset_mm[0] + d[0],
                    p.head_offset_mm[1] + d[1],
                    p.head_offset_mm[2] + d[2],
                ];
                p2.file = format!("{}@extra{k}", p.file);
                if !keep_mounting {
                    p2.mounting = format!("{}@extra{k}", p.mounting);
                }
                s.planes.push(p2);
            }
        }
        let f = design::fit(&s, model, &|_, _| true, None);
        observability::analyse(&f, model).rank
    };
    let candidates: [(&str, Vec<[f64; 3]>, bool); 4] = [
        (
            "repeat every plane's tests with a second head offset 100 mm longer (t_z - 100 mm), keeping each plate's mounting (keyed riser)",
            vec![[0.0, 0.0, -100.0]],
            true,
        ),
        (
            "repeat every plane's tests with the head offset 40 mm sideways in X (t_x + 40 mm), keeping each plate's mounting",
            vec![[40.0, 0.0, 0.0]],
            true,
        ),
        (
            "repeat every plane's tests at two more head offsets, t_z - 100 mm and t_x + 40 mm, keeping each plate's mounting (keyed riser)",
            vec![[0.0, 0.0, -100.0], [40.0, 0.0, 0.0]],
            true,
        ),
        (
            "repeat every plane's tests at two more head offsets, t_z - 100 mm and t_x + 40 mm, as new mountings",
            vec![[0.0, 0.0, -100.0], [40.0, 0.0, 0.0]],
            false,
        ),
    ];
    let base = ident.rank;
    let full = ident.parameters;
    let mut best: Option<(usize, &str)> = None;
    for (text, offs, keep) in &candidates {
        let r = rank_with(offs, *keep);
        if r > base && best.is_none_or(|(b, _)| r > b) {
            best = Some((r, text));
        }
        if r == full {
            break;
        }
    }
    match best {
        Some((r, text)) => vec![format!(
            "{text}: the rank rises from {base} to {r} of {full} parameters{}",
            if r == full {
                " (all 21 terms separable)"
            } else {
                ""
            }
        )],
        None => {
            vec!["no added head offset raises the rank: measure the missing axis or plane".into()]
        }
    }
}

/// Every `step`-th sample of every run (structure only: used for rank questions).
pub fn thin_session(session: &Session, max_per_run: usize) -> Session {
    let mut s = session.clone();
    for p in &mut s.planes {
        for r in &mut p.runs {
            let step = r.len().div_ceil(max_per_run.max(1)).max(1);
            let keep: Vec<usize> = (0..r.len()).step_by(step).collect();
            r.t_s = keep.iter().map(|&i| r.t_s[i]).collect();
            r.pos_mm = keep.iter().map(|&i| r.pos_mm[i]).collect();
            r.du_um = keep.iter().map(|&i| r.du_um[i]).collect();
            r.dv_um = keep.iter().map(|&i| r.dv_um[i]).collect();
            r.temp_c = r
                .temp_c
                .as_ref()
                .map(|t| keep.iter().map(|&i| t[i]).collect());
        }
    }
    s
}
