//! Result arithmetic: an identified term's value at a position, the difference of two
//! checks and the drift since a baseline, each evaluated only inside the travel the
//! check measured and each with its standard uncertainty (`docs/conventions.md`,
//! "Reporting conventions").
//!
//! A check is seen through [`CheckFunctions`]: per term its monomial coefficients c
//! (f(q) = Σ_{k≥1} c_k q^k, the model function) and their covariance Σ, per axis the
//! measured travel, per squareness its value and standard uncertainty. Both an
//! [`IdentificationResult`] and the service's stored scalars provide that.
//!
//! **Reporting convention.** The value of a term at q is the one the result document
//! reports: the model function, and for a straightness the model function minus its
//! least-squares line over the measured travel of its axis (continuous, uniform weight;
//! [`ls_line_weights`]). Both are linear in c: value = gᵀc with
//! g_k = q^k − (a_k + b_k q), (a_k, b_k) the least-squares line of q^k (zero for the other
//! kinds), and the standard uncertainty is u(q) = √(gᵀ Σ g). So a trend point, a difference
//! or a drift of a straightness is the change of what the result page and the tolerance
//! verdict show, not of the model function (whose line belongs to the squareness).
//!
//! **Differences** of two independent checks: Δ(q) = f_b(q) − f_a(q),
//! u² = u_a(q)² + u_b(q)², only at positions both checks measured. **Drift** between a
//! baseline and a later result is the largest |Δ(q)| over [`DRIFT_GRID_POINTS`] evenly
//! spaced positions of the intersection of the two checks' measured travels, taken
//! separately over the translational terms (µm) and over the angular terms and squareness
//! (µrad), with the uncertainty of the difference where it is largest. A term not
//! identifiable in either check, or whose measured travels do not overlap, is left out and
//! listed: nothing is extrapolated.

use crate::identification::IdentificationResult;
use crate::identification::report::ls_line_weights;
use crate::terms::{SquarenessTerm, Term, TermKind};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// Positions of the drift grid over the common measured travel.
pub const DRIFT_GRID_POINTS: usize = 41;

/// Relative tolerance of "inside the measured travel" (grid ends computed in floating
/// point land on the ends within rounding).
const INSIDE_TOL: f64 = 1e-9;

/// What a check provides for result arithmetic.
pub trait CheckFunctions {
    /// Monomial coefficients (element k ↔ q^(k+1)) of an identifiable term; `None` when
    /// the term is not identifiable or not stored.
    fn coefficients(&self, term: &str) -> Option<&[f64]>;
    /// Covariance of those coefficients (n × n); `None` when not stored.
    fn coefficient_covariance(&self, term: &str) -> Option<&[Vec<f64>]>;
    /// Travel the check measured on `axis`, [min, max] mm.
    fn measured_travel(&self, axis: char) -> Option<[f64; 2]>;
    /// An identified squareness (EC0Y, EB0Z, EA0Z), µrad.
    fn squareness(&self, name: &str) -> Option<f64>;
    /// Its standard uncertainty, µrad.
    fn squareness_std(&self, name: &str) -> Option<f64>;
}

impl CheckFunctions for IdentificationResult {
    fn coefficients(&self, term: &str) -> Option<&[f64]> {
        let t = self.terms.get(term)?;
        (t.identifiable && !t.coefficients.is_empty()).then_some(t.coefficients.as_slice())
    }
    fn coefficient_covariance(&self, term: &str) -> Option<&[Vec<f64>]> {
        let t = self.terms.get(term)?;
        (!t.coefficient_covariance.is_empty()).then_some(t.coefficient_covariance.as_slice())
    }
    fn measured_travel(&self, axis: char) -> Option<[f64; 2]> {
        self.model
            .measured_travel_mm
            .get(&axis.to_string())
            .copied()
    }
    fn squareness(&self, name: &str) -> Option<f64> {
        let s = self.squareness.get(name)?;
        s.identifiable.then_some(s.value_urad).flatten()
    }
    fn squareness_std(&self, name: &str) -> Option<f64> {
        let s = self.squareness.get(name)?;
        s.identifiable.then_some(s.std_urad).flatten()
    }
}

impl IdentificationResult {
    /// Value of an identified term at `q_mm` in the result's reporting convention (µm or
    /// µrad), from its stored coefficients ([`term_value`]: for a
    /// straightness, its deviation from its least-squares line over the measured travel
    /// of its axis, as the document's `values` are). `None` when the term is unknown or
    /// not identifiable, or `q_mm` lies outside the measured travel of its axis.
    pub fn reported_value_at(&self, name: &str, q_mm: f64) -> Option<f64> {
        let term = Term::parse(name)?;
        Some(term_value(self, term, q_mm)?.value)
    }
}

/// A value with its standard uncertainty (k = 1; `None` when no covariance is stored).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Value {
    pub value: f64,
    pub u: Option<f64>,
}

/// Whether `q` lies in `[lo, hi]` (within rounding).
pub fn inside([lo, hi]: [f64; 2], q: f64) -> bool {
    let tol = INSIDE_TOL * (1.0 + lo.abs().max(hi.abs()));
    q >= lo - tol && q <= hi + tol
}

/// The travel both checks measured on `axis` (`None`: unknown or no overlap).
pub fn common_travel(
    a: &impl CheckFunctions,
    b: &impl CheckFunctions,
    axis: char,
) -> Option<[f64; 2]> {
    let ([l1, h1], [l2, h2]) = (a.measured_travel(axis)?, b.measured_travel(axis)?);
    let (lo, hi) = (l1.max(l2), h1.min(h2));
    (hi > lo).then_some([lo, hi])
}

/// g with value = gᵀc (see the module documentation) for a term with `n` coefficients
/// at `q`; a straightness needs its axis's measured `travel`.
fn gradient(term: Term, n: usize, q: f64, travel: [f64; 2]) -> Vec<f64> {
    let mut g: Vec<f64> = (1..=n).map(|k| q.powi(k as i32)).collect();
    if term.kind() == TermKind::Straightness {
        let [lo, hi] = travel;
        for (q_k, wa, wb) in ls_line_weights(lo, hi) {
            for (k, gk) in g.iter_mut().enumerate() {
                *gk -= (wa + wb * q) * q_k.powi(k as i32 + 1);
            }
        }
    }
    g
}

/// √(gᵀ Σ g).
fn quadratic_form_sqrt(cov: &[Vec<f64>], g: &[f64]) -> Option<f64> {
    if cov.len() != g.len() || cov.iter().any(|r| r.len() != g.len()) {
        return None;
    }
    let mut v = 0.0;
    for (ga, row) in g.iter().zip(cov) {
        for (gb, c) in g.iter().zip(row) {
            v += ga * gb * c;
        }
    }
    Some(v.max(0.0).sqrt())
}

/// Value of `term` at `q` in the reporting convention, with its standard uncertainty:
/// the one evaluation of a stored term (result pages' trends, differences, the fleet's
/// drift, drift alerts, compensation tables and the CLI all call it).
///
/// With c the term's monomial coefficients ([`CheckFunctions::coefficients`], the model
/// function f(q) = Σ_{k≥1} c_k q^k) and Σ their covariance: value = gᵀc and
/// u = √(gᵀ Σ g), where g_k = q^k for a positioning or an angular term, and for a
/// straightness g_k = q^k − (a_k + b_k q), (a_k, b_k) the least-squares line of q^k over
/// the measured travel of the term's axis (continuous, uniform weight), so that the
/// value is f's deviation from its least-squares line, as the result document's
/// `values` are. `u` is `None` when no covariance is stored. `None` when the term is not
/// identifiable in the check, its axis has no measured travel, or `q` lies outside that
/// travel (nothing is extrapolated).
pub fn term_value(c: &impl CheckFunctions, term: Term, q: f64) -> Option<Value> {
    let name = term.name();
    let coeffs = c.coefficients(&name)?;
    let travel = c.measured_travel(term.axis.letter())?;
    if !q.is_finite() || !inside(travel, q) {
        return None;
    }
    let g = gradient(term, coeffs.len(), q, travel);
    let value = g.iter().zip(coeffs).map(|(g, c)| g * c).sum();
    let u = c
        .coefficient_covariance(&name)
        .and_then(|cov| quadratic_form_sqrt(cov, &g));
    Some(Value { value, u })
}

/// `b − a` of `term` at `q` (both checks must have measured q), u² = u_a² + u_b².
pub fn term_difference(
    a: &impl CheckFunctions,
    b: &impl CheckFunctions,
    term: Term,
    q: f64,
) -> Option<Value> {
    let (va, vb) = (term_value(a, term, q)?, term_value(b, term, q)?);
    Some(Value {
        value: vb.value - va.value,
        u: va.u.zip(vb.u).map(|(x, y)| x.hypot(y)),
    })
}

/// Positions a range is evaluated on: this many evenly spaced over the travel, ends
/// included (0.5 mm apart over 100 mm).
pub const RANGE_GRID_POINTS: usize = 201;

/// The range of a term's reported values over a travel (ISO 230-1: max − min of the
/// deviations), where its maximum and minimum are, and the standard uncertainty of their
/// difference.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Range {
    /// max − min, ≥ 0 (µm or µrad).
    pub range: f64,
    pub at_max_mm: f64,
    pub at_min_mm: f64,
    /// u = √((g_max − g_min)ᵀ Σ (g_max − g_min)): the covariance of the two values is
    /// taken into account (`None` without a stored covariance).
    pub u: Option<f64>,
    /// The travel it was evaluated over.
    pub travel_mm: [f64; 2],
}

/// The range of `term` over `[lo, hi]` (default: the whole measured travel of its axis;
/// clipped to it, `None` outside), from the same evaluation as [`term_value`] on
/// [`RANGE_GRID_POINTS`] evenly spaced positions: a straightness about its
/// least-squares line over the whole measured travel, as reported.
pub fn term_range(c: &impl CheckFunctions, term: Term, over: Option<[f64; 2]>) -> Option<Range> {
    let name = term.name();
    let coeffs = c.coefficients(&name)?;
    let travel = c.measured_travel(term.axis.letter())?;
    let [lo, hi] = match over {
        Some([a, b]) => [a.max(travel[0]), b.min(travel[1])],
        None => travel,
    };
    if !(lo.is_finite() && hi.is_finite() && hi >= lo) {
        return None;
    }
    let n = RANGE_GRID_POINTS;
    let value = |q: f64| -> f64 {
        let g = gradient(term, coeffs.len(), q, travel);
        g.iter().zip(coeffs).map(|(g, c)| g * c).sum()
    };
    // (value, position) of the largest and of the smallest value.
    let (mut max, mut min) = ((f64::NEG_INFINITY, lo), (f64::INFINITY, lo));
    for i in 0..n {
        let q = lo + (hi - lo) * i as f64 / (n - 1) as f64;
        let v = value(q);
        if v > max.0 {
            max = (v, q);
        }
        if v < min.0 {
            min = (v, q);
        }
    }
    let ((vmax, qmax), (vmin, qmin)) = (max, min);
    if !(vmax.is_finite() && vmin.is_finite()) {
        return None;
    }
    let gmax = gradient(term, coeffs.len(), qmax, travel);
    let gmin = gradient(term, coeffs.len(), qmin, travel);
    let d: Vec<f64> = gmax.iter().zip(&gmin).map(|(a, b)| a - b).collect();
    let u = c
        .coefficient_covariance(&name)
        .and_then(|cov| quadratic_form_sqrt(cov, &d));
    Some(Range {
        range: vmax - vmin,
        at_max_mm: qmax,
        at_min_mm: qmin,
        u,
        travel_mm: [lo, hi],
    })
}

/// The [`DRIFT_GRID_POINTS`] evenly spaced positions of `[lo, hi]`, ends included.
pub fn drift_grid([lo, hi]: [f64; 2]) -> impl Iterator<Item = f64> {
    (0..DRIFT_GRID_POINTS).map(move |i| lo + (hi - lo) * i as f64 / (DRIFT_GRID_POINTS - 1) as f64)
}

/// Drift of one machine since its baseline.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct Drift {
    /// Largest change of a translational term over the travel both checks measured, µm.
    pub drift_um: f64,
    /// Its standard uncertainty (both checks' covariances), µm; null when not stored.
    pub drift_um_u: Option<f64>,
    /// Largest change of an angular term or a squareness, µrad.
    pub drift_urad: f64,
    /// Its standard uncertainty, µrad; null when not stored.
    pub drift_urad_u: Option<f64>,
    /// Term with the largest change in µm.
    pub worst_term_um: Option<String>,
    /// Term with the largest change in µrad.
    pub worst_term_urad: Option<String>,
    /// Terms not identifiable in the baseline or the latest result, or whose measured
    /// travels do not overlap (left out: nothing is extrapolated).
    pub not_compared: Vec<String>,
}

/// The terms two checks can be compared on, with the travel both measured, and the names
/// of those they cannot (not identifiable in either, or measured travels that do not
/// overlap).
pub fn comparable(
    a: &impl CheckFunctions,
    b: &impl CheckFunctions,
) -> (Vec<(Term, [f64; 2])>, Vec<String>) {
    let (mut yes, mut no) = (Vec::new(), Vec::new());
    for t in Term::all() {
        let name = t.name();
        match (
            a.coefficients(&name),
            b.coefficients(&name),
            common_travel(a, b, t.axis.letter()),
        ) {
            (Some(_), Some(_), Some(travel)) => yes.push((t, travel)),
            _ => no.push(name),
        }
    }
    (yes, no)
}

/// Each squareness in two checks: name and the change `b − a` with its uncertainty
/// (`None` when either check did not identify it).
pub fn squareness_changes(
    a: &impl CheckFunctions,
    b: &impl CheckFunctions,
) -> [(&'static str, Option<Value>); 3] {
    SquarenessTerm::ALL.map(|s| {
        let name = s.name();
        let change = a
            .squareness(name)
            .zip(b.squareness(name))
            .map(|(x, y)| Value {
                value: y - x,
                u: a.squareness_std(name)
                    .zip(b.squareness_std(name))
                    .map(|(x, y)| x.hypot(y)),
            });
        (name, change)
    })
}

/// Drift between a baseline and a later check, over the intersection of their measured
/// travels (module documentation).
pub fn drift(base: &impl CheckFunctions, latest: &impl CheckFunctions) -> Drift {
    let mut d = Drift {
        drift_um: 0.0,
        drift_um_u: None,
        drift_urad: 0.0,
        drift_urad_u: None,
        worst_term_um: None,
        worst_term_urad: None,
        not_compared: Vec::new(),
    };
    let (terms, not_compared) = comparable(base, latest);
    d.not_compared = not_compared;
    for (t, travel) in terms {
        let Some(largest) = drift_grid(travel)
            .filter_map(|q| term_difference(base, latest, t, q))
            .reduce(|best, x| {
                if x.value.abs() > best.value.abs() {
                    x
                } else {
                    best
                }
            })
        else {
            d.not_compared.push(t.name());
            continue;
        };
        let (best, best_u, worst) = if t.is_angular() {
            (
                &mut d.drift_urad,
                &mut d.drift_urad_u,
                &mut d.worst_term_urad,
            )
        } else {
            (&mut d.drift_um, &mut d.drift_um_u, &mut d.worst_term_um)
        };
        if largest.value.abs() > *best || worst.is_none() {
            *best = largest.value.abs();
            *best_u = largest.u;
            *worst = Some(t.name());
        }
    }
    for (name, change) in squareness_changes(base, latest) {
        match change {
            Some(c) => {
                if c.value.abs() > d.drift_urad || d.worst_term_urad.is_none() {
                    d.drift_urad = c.value.abs();
                    d.drift_urad_u = c.u;
                    d.worst_term_urad = Some(name.into());
                }
            }
            None => d.not_compared.push(name.into()),
        }
    }
    d
}

/// Change of one term between two results on a grid of the travel both measured.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct TermDiff {
    pub unit: String,
    /// The travel both checks measured on the term's axis, [min, max] mm (null when they
    /// do not overlap or it is not recorded: then no position is compared).
    pub travel_mm: Option<[f64; 2]>,
    pub positions_mm: Vec<f64>,
    /// other − baseline at each position; empty when `identifiable` is false.
    pub delta: Vec<f64>,
    /// Standard uncertainty of each difference (u² = u_baseline² + u_other²); empty when
    /// a covariance is not stored.
    pub u: Vec<f64>,
    /// Identifiable in both results.
    pub identifiable: bool,
}

/// The multiples of `step_mm` inside `[lo, hi]` (0 among them when inside).
pub fn step_grid([lo, hi]: [f64; 2], step_mm: f64) -> Vec<f64> {
    let k0 = (lo / step_mm).ceil() as i64;
    let k1 = (hi / step_mm).floor() as i64;
    (k0..=k1).map(|k| k as f64 * step_mm).collect()
}

/// Most positions per term of a [`diff`] (a memory bound, whatever the step and travel).
pub const MAX_DIFF_POSITIONS: usize = 10_000;

/// Checks a diff's step: positive, finite, and at most [`MAX_DIFF_POSITIONS`] per term
/// over the widest travel both checks measured; the error says why, in a sentence.
/// Finest grid step of a difference or a compensation table, mm (1 µm): a finer step
/// says nothing a person or a controller can use, and is refused as the schema says.
pub const MIN_STEP_MM: f64 = 0.001;

pub fn check_diff_step(
    base: &impl CheckFunctions,
    other: &impl CheckFunctions,
    step_mm: f64,
) -> Result<(), String> {
    if !(step_mm >= MIN_STEP_MM && step_mm.is_finite()) {
        return Err(format!(
            "step_mm {step_mm}: give a number of mm of at least {MIN_STEP_MM}"
        ));
    }
    let widest = ['X', 'Y', 'Z']
        .iter()
        .filter_map(|&a| common_travel(base, other, a))
        .map(|[lo, hi]| hi - lo)
        .fold(0.0, f64::max);
    if widest / step_mm > MAX_DIFF_POSITIONS as f64 {
        return Err(format!(
            "step_mm {step_mm}: at most {MAX_DIFF_POSITIONS} positions per term over the \
             travel ({widest} mm); use step_mm >= {}",
            widest / MAX_DIFF_POSITIONS as f64
        ));
    }
    Ok(())
}

/// Term-by-term differences (other − baseline) on every `step_mm` of the travel both
/// checks measured (including 0 when inside), plus the squareness differences. The
/// caller checks the step first ([`check_diff_step`]).
pub fn diff(
    base: &impl CheckFunctions,
    other: &impl CheckFunctions,
    step_mm: f64,
) -> (BTreeMap<String, TermDiff>, BTreeMap<String, Option<f64>>) {
    let mut terms = BTreeMap::new();
    for t in Term::all() {
        let travel = common_travel(base, other, t.axis.letter());
        let positions = travel.map_or_else(Vec::new, |tr| step_grid(tr, step_mm));
        let diffs: Option<Vec<Value>> = positions
            .iter()
            .map(|&q| term_difference(base, other, t, q))
            .collect();
        let identifiable =
            base.coefficients(&t.name()).is_some() && other.coefficients(&t.name()).is_some();
        let entry = match diffs.filter(|_| identifiable) {
            Some(d) => TermDiff {
                unit: t.unit().into(),
                travel_mm: travel,
                delta: d.iter().map(|v| v.value).collect(),
                u: d.iter()
                    .map(|v| v.u)
                    .collect::<Option<Vec<f64>>>()
                    .unwrap_or_default(),
                positions_mm: positions,
                identifiable: true,
            },
            None => TermDiff {
                unit: t.unit().into(),
                travel_mm: travel,
                positions_mm: Vec::new(),
                delta: Vec::new(),
                u: Vec::new(),
                identifiable: false,
            },
        };
        terms.insert(t.name(), entry);
    }
    let squareness = squareness_changes(base, other)
        .into_iter()
        .map(|(name, c)| (name.to_string(), c.map(|c| c.value)))
        .collect();
    (terms, squareness)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A check as plain maps (the service's stored scalars have this shape).
    #[derive(Default, Clone)]
    struct Check {
        coefficients: BTreeMap<String, Vec<f64>>,
        covariance: BTreeMap<String, Vec<Vec<f64>>>,
        travel: BTreeMap<char, [f64; 2]>,
        squareness: BTreeMap<String, (f64, f64)>,
    }

    impl CheckFunctions for Check {
        fn coefficients(&self, term: &str) -> Option<&[f64]> {
            self.coefficients.get(term).map(Vec::as_slice)
        }
        fn coefficient_covariance(&self, term: &str) -> Option<&[Vec<f64>]> {
            self.covariance.get(term).map(Vec::as_slice)
        }
        fn measured_travel(&self, axis: char) -> Option<[f64; 2]> {
            self.travel.get(&axis).copied()
        }
        fn squareness(&self, name: &str) -> Option<f64> {
            self.squareness.get(name).map(|s| s.0)
        }
        fn squareness_std(&self, name: &str) -> Option<f64> {
            self.squareness.get(name).map(|s| s.1)
        }
    }

    #[test]
    fn a_range_by_hand() {
        let mut c = Check::default();
        c.travel.insert('X', [-50.0, 50.0]);
        // EXX = 0.3 q − 1e-4 q³: extremes where f' = 0.3 − 3e-4 q² = 0, q = ±√1000 =
        // ±31.623 mm, f = ±2·0.3·31.623/3 = ±6.3246 µm: range 12.649 µm (the ends give
        // only ±2.5 µm).
        c.coefficients.insert("EXX".into(), vec![0.3, 0.0, -1e-4]);
        // u of c1 = 0.001, others 0: u(f(q1) − f(q2)) = |q1 − q2|·0.001.
        c.covariance.insert(
            "EXX".into(),
            vec![vec![1e-6, 0.0, 0.0], vec![0.0; 3], vec![0.0; 3]],
        );
        let r = term_range(&c, Term::parse("EXX").unwrap(), None).unwrap();
        assert!((r.range - 12.649_111).abs() < 1e-3, "{r:?}");
        assert!((r.at_max_mm - 31.623).abs() < 0.5 && (r.at_min_mm + 31.623).abs() < 0.5);
        assert!((r.u.unwrap() - (r.at_max_mm - r.at_min_mm) * 1e-3).abs() < 1e-12);
        // Over [0, 50] only: max 6.3246 at 31.6, min 0 at 0.
        let r = term_range(&c, Term::parse("EXX").unwrap(), Some([0.0, 80.0])).unwrap();
        assert_eq!(r.travel_mm, [0.0, 50.0]);
        assert!((r.range - 6.324_555).abs() < 1e-3 && r.at_min_mm == 0.0);
        // A straightness is judged about its least-squares line: EYX = 0.001 q² over
        // [−50, 50] deviates by 0.001·(q² − 2500/3): +1.6667 at the ends, −0.8333 at 0,
        // range 0.001 × 2500 = 2.5 µm.
        c.coefficients.insert("EYX".into(), vec![0.0, 0.001]);
        let r = term_range(&c, Term::parse("EYX").unwrap(), None).unwrap();
        assert!((r.range - 2.5).abs() < 1e-9, "{r:?}");
        assert_eq!((r.at_max_mm.abs(), r.at_min_mm), (50.0, 0.0));
        assert_eq!(r.u, None, "no covariance stored");
        // Not identifiable, or no travel: no range.
        assert!(term_range(&c, Term::parse("EZZ").unwrap(), None).is_none());
    }

    fn diag(n: usize, u: f64) -> Vec<Vec<f64>> {
        (0..n)
            .map(|i| (0..n).map(|j| if i == j { u * u } else { 0.0 }).collect())
            .collect()
    }

    /// A check that measured X over `travel`, with EXX, optionally EAX, and EC0Y
    /// (u = 0.2 µrad); every coefficient with standard uncertainty `u` (independent).
    fn check(exx: Vec<f64>, eax: Option<Vec<f64>>, ec0y: f64, travel: [f64; 2], u: f64) -> Check {
        let mut c = Check::default();
        c.travel.insert('X', travel);
        c.covariance.insert("EXX".into(), diag(exx.len(), u));
        c.coefficients.insert("EXX".into(), exx);
        if let Some(a) = eax {
            c.covariance.insert("EAX".into(), diag(a.len(), u));
            c.coefficients.insert("EAX".into(), a);
        }
        c.squareness.insert("EC0Y".into(), (ec0y, 0.2));
        c
    }

    fn t(name: &str) -> Term {
        Term::parse(name).unwrap()
    }

    #[test]
    fn a_positioning_value_is_the_power_sum_and_its_u_the_quadratic_form() {
        // f = 0.5 q − 0.01 q² + 2e-4 q³; Var c_k = u² independent: by hand at q = 10,
        // f = 5 − 1 + 0.2 = 4.2, Var f = u² (10² + 10⁴ + 10⁶).
        let c = check(vec![0.5, -0.01, 2e-4], None, 0.0, [-100.0, 100.0], 1e-3);
        let v = term_value(&c, t("EXX"), 10.0).unwrap();
        assert!((v.value - 4.2).abs() < 1e-12, "{v:?}");
        let want = 1e-3 * (1e2f64 + 1e4 + 1e6).sqrt();
        assert!((v.u.unwrap() - want).abs() < 1e-12, "{v:?}");
        // A correlated pair, by hand: Var c1 = 1e-4, Var c2 = 1e-8, Cov = −1e-6 at
        // q = 10: 100·1e-4 + 1e4·1e-8 − 2·10·100·1e-6 = 0.0081.
        let mut c = check(vec![0.0, 0.0], None, 0.0, [-100.0, 100.0], 0.0);
        c.covariance
            .insert("EXX".into(), vec![vec![1e-4, -1e-6], vec![-1e-6, 1e-8]]);
        let u = term_value(&c, t("EXX"), 10.0).unwrap().u.unwrap();
        assert!((u - 0.0081f64.sqrt()).abs() < 1e-12);
    }

    #[test]
    fn a_straightness_value_is_its_deviation_from_its_least_squares_line() {
        // EYX = c₂ q² + c₃ q³ over X ∈ [−50, 50]. By hand (continuous least squares over
        // the travel): the line of q² is its mean 2500/3, of q³ the slope
        // ∫q⁴/∫q² = (3/5)·2500 = 1500 (through 0). So at q = 50:
        // 1e-3 · (2500 − 833.33…) + 1e-5 · (125 000 − 1500 · 50) = 1.6667 + 0.5.
        let mut c = Check::default();
        c.travel.insert('X', [-50.0, 50.0]);
        // A linear coefficient too: the model's straightness has none, but the line
        // removal must take it out whole.
        c.coefficients.insert("EYX".into(), vec![0.02, 1e-3, 1e-5]);
        c.covariance.insert("EYX".into(), diag(3, 1e-6));
        let v = term_value(&c, t("EYX"), 50.0).unwrap();
        let want = 1e-3 * (2500.0 - 2500.0 / 3.0) + 1e-5 * (125_000.0 - 1500.0 * 50.0);
        assert!((v.value - want).abs() < 1e-9, "{} vs {want}", v.value);
        // u: the same gradient, g = (0, 2500 − 833.3, 125 000 − 75 000), Σ = 1e-12 I.
        let g = [0.0, 2500.0 - 2500.0 / 3.0, 50_000.0];
        let u = 1e-6 * g.iter().map(|g| g * g).sum::<f64>().sqrt();
        assert!((v.u.unwrap() - u).abs() < 1e-9, "{v:?} vs {u}");
        // The value is the deviation from a line: it averages to zero over the travel.
        // (midpoint rule, exact to O(h²)).
        let mean: f64 = (0..1000)
            .map(|i| {
                term_value(&c, t("EYX"), -50.0 + 0.1 * (i as f64 + 0.5))
                    .unwrap()
                    .value
            })
            .sum::<f64>()
            / 1000.0;
        assert!(mean.abs() < 1e-5, "{mean}");
    }

    #[test]
    fn nothing_is_evaluated_outside_the_measured_travel() {
        let c = check(vec![0.01], None, 0.0, [-50.0, 50.0], 1e-3);
        assert!(term_value(&c, t("EXX"), 50.0).is_some());
        assert!(term_value(&c, t("EXX"), 50.001).is_none());
        assert!(term_value(&c, t("EXX"), f64::NAN).is_none());
        // A term the check did not identify, or an axis it did not move.
        assert!(term_value(&c, t("EAX"), 0.0).is_none());
        let mut moved_nothing = c.clone();
        moved_nothing.travel.clear();
        assert!(term_value(&moved_nothing, t("EXX"), 0.0).is_none());
    }

    #[test]
    fn drift_is_the_largest_change_over_the_travel_both_checks_measured() {
        // ΔEXX(q) = 0.01 q. The baseline measured X over [−200, 300], the latest over
        // [−50, 50]: the drift is |0.01 · 50| = 0.5 µm at q = 50, not 3 µm at 300.
        let b = check(vec![0.0], Some(vec![0.001]), 5.0, [-200.0, 300.0], 0.002);
        let l = check(vec![0.01], Some(vec![0.001]), 3.5, [-50.0, 50.0], 0.002);
        let d = drift(&b, &l);
        assert!((d.drift_um - 0.5).abs() < 1e-12, "{d:?}");
        assert_eq!(d.worst_term_um.as_deref(), Some("EXX"));
        // u of the difference at q = 50: √2 · 0.002 · 50.
        let u = d.drift_um_u.unwrap();
        assert!((u - 2f64.sqrt() * 0.1).abs() < 1e-12, "{u}");
        // Squareness moved by 1.5 µrad (u = √2 · 0.2); EAX did not move.
        assert!((d.drift_urad - 1.5).abs() < 1e-12);
        assert_eq!(d.worst_term_urad.as_deref(), Some("EC0Y"));
        assert!((d.drift_urad_u.unwrap() - 2f64.sqrt() * 0.2).abs() < 1e-12);
        assert!(d.not_compared.contains(&"EYY".to_string()));
        assert!(!d.not_compared.contains(&"EAX".to_string()));
        // The same change as a figure of the decision rule, largest at the end.
        let ch = crate::tolerance::changes(&b, &l);
        assert!(
            (ch["EXX"].upper.value.abs() - 0.5).abs() < 1e-12,
            "{:?}",
            ch["EXX"]
        );
        assert_eq!(ch["EXX"].travel_mm, Some([-50.0, 50.0]));
    }

    #[test]
    fn checks_whose_travels_do_not_overlap_are_not_compared() {
        let b = check(vec![0.0], None, 5.0, [-200.0, -100.0], 0.002);
        let l = check(vec![0.01], None, 5.0, [0.0, 100.0], 0.002);
        let d = drift(&b, &l);
        assert_eq!(d.drift_um, 0.0);
        assert!(d.worst_term_um.is_none());
        assert!(d.not_compared.contains(&"EXX".to_string()), "{d:?}");
        assert!(!crate::tolerance::changes(&b, &l).contains_key("EXX"));
        let (terms, _) = diff(&b, &l, 10.0);
        assert!(terms["EXX"].travel_mm.is_none());
        assert!(terms["EXX"].positions_mm.is_empty());
        // A check without a recorded travel is not compared either.
        let mut old = b.clone();
        old.travel.clear();
        assert!(drift(&old, &l).not_compared.contains(&"EXX".to_string()));
    }

    #[test]
    fn diff_grid_includes_zero_and_stays_inside_the_common_travel() {
        let b = check(vec![0.0, 1e-4], None, 1.0, [-200.0, 300.0], 0.001);
        let o = check(vec![0.002, 1e-4], None, 2.0, [-120.0, 180.0], 0.001);
        let (terms, sq) = diff(&b, &o, 50.0);
        let exx = &terms["EXX"];
        assert_eq!(exx.travel_mm, Some([-120.0, 180.0]));
        assert_eq!(exx.positions_mm.first(), Some(&-100.0));
        assert_eq!(exx.positions_mm.last(), Some(&150.0));
        let i0 = exx.positions_mm.iter().position(|&q| q == 0.0).unwrap();
        assert_eq!((exx.delta[i0], exx.u[i0]), (0.0, 0.0));
        let i = exx.positions_mm.iter().position(|&q| q == 100.0).unwrap();
        assert!((exx.delta[i] - 0.2).abs() < 1e-12);
        // u at 100: √2 · √(0.001² · 100² + 0.001² · 100⁴).
        let want = 2f64.sqrt() * (1e-6f64 * 1e4 + 1e-6 * 1e8).sqrt();
        assert!((exx.u[i] - want).abs() < 1e-9, "{} vs {want}", exx.u[i]);
        assert!(!terms["EAX"].identifiable);
        assert_eq!(sq["EC0Y"], Some(1.0));
        assert_eq!(sq["EB0Z"], None);
        // The step: positive, and a bounded number of positions over the 300 mm.
        assert!(check_diff_step(&b, &o, 50.0).is_ok());
        for bad in [0.0, -1.0, f64::NAN, f64::INFINITY, 0.01] {
            assert!(check_diff_step(&b, &o, bad).is_err(), "{bad}");
        }
        assert!(check_diff_step(&b, &o, 0.03).is_ok());
    }
}
