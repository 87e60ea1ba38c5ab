//! Figures derived from stored results: term values at chosen positions, differences
//! between two results, and drift since a baseline — each evaluated only inside the
//! travel the check measured, each with its standard uncertainty.
//!
//! A term f(q) = Σ_{i≥1} c_i q^i (monomial coefficients, results contract) is evaluated
//! by Horner's rule; its standard uncertainty is u(q) = √(gᵀ Σ g), g = (q, q², …), Σ the
//! coefficients' covariance stored with the result. A difference of two independent
//! checks has u² = u_a² + u_b². Drift between a baseline b and a later result r is the
//! largest |f_r(q) − f_b(q)| over 41 evenly spaced positions of the *intersection* of the
//! two checks' measured travels of the term's axis, taken separately over the
//! translational terms (µm) and over the angular terms and squareness (µrad), with the
//! uncertainty of the difference where it is largest. A term not identifiable in either
//! result is left out and listed; so is a term whose two measured travels do not overlap
//! (or are not recorded): nothing is extrapolated.

use mtcal_solver::terms::Term;
use mtcal_store::ResultScalars;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use utoipa::ToSchema;

const GRID_POINTS: usize = 41;

/// f(q) = Σ c_i q^(i+1).
pub fn eval(coefficients: &[f64], q_mm: f64) -> f64 {
    coefficients
        .iter()
        .rev()
        .fold(0.0, |acc, &c| acc * q_mm + c)
        * q_mm
}

/// Standard uncertainty √(gᵀ Σ g) of f(q), g = (q, q², …), from the coefficients'
/// covariance `cov`.
pub fn std_at(cov: &[Vec<f64>], q_mm: f64) -> f64 {
    let g: Vec<f64> = (1..=cov.len()).map(|k| q_mm.powi(k as i32)).collect();
    let mut v = 0.0;
    for (a, row) in cov.iter().enumerate() {
        for (b, c) in row.iter().enumerate() {
            v += g[a] * g[b] * c;
        }
    }
    v.max(0.0).sqrt()
}

/// Standard uncertainty of term `name` of `s` at q (`None`: no covariance stored).
pub fn term_std(s: &ResultScalars, name: &str, q_mm: f64) -> Option<f64> {
    Some(std_at(s.term_covariance.get(name)?, q_mm))
}

/// Standard uncertainty of a squareness value of `s` (stored as a 1 × 1 covariance).
pub fn squareness_std(s: &ResultScalars, name: &str) -> Option<f64> {
    Some(
        s.term_covariance
            .get(name)?
            .first()?
            .first()?
            .max(0.0)
            .sqrt(),
    )
}

/// `unit` and axis letter of an ISO 230-1 term name (`None` if not one of the 18).
pub fn term_info(name: &str) -> Option<(&'static str, char)> {
    let t = Term::parse(name)?;
    Some((t.unit(), t.axis.letter()))
}

/// Travel the check measured on `axis`, [min, max] mm (`None`: the axis did not move,
/// or the result predates the record).
pub fn measured(s: &ResultScalars, axis: char) -> Option<[f64; 2]> {
    s.measured_travel_mm.get(&axis.to_string()).copied()
}

/// The travel both checks measured on `axis` (`None`: unknown or no overlap).
pub fn common_travel(a: &ResultScalars, b: &ResultScalars, axis: char) -> Option<[f64; 2]> {
    let ([l1, h1], [l2, h2]) = (measured(a, axis)?, measured(b, axis)?);
    let (lo, hi) = (l1.max(l2), h1.min(h2));
    (hi > lo).then_some([lo, hi])
}

/// A sentence stating the measured travel of `axis` in `s`.
pub fn travel_sentence(s: &ResultScalars, axis: char) -> String {
    match measured(s, axis) {
        Some([lo, hi]) => format!("{axis} was measured over [{lo}, {hi}] mm"),
        None => format!("{axis} has no measured travel in this check"),
    }
}

fn grid([lo, hi]: [f64; 2]) -> impl Iterator<Item = f64> {
    (0..GRID_POINTS).map(move |i| lo + (hi - lo) * i as f64 / (GRID_POINTS - 1) as f64)
}

/// Drift of one machine since its baseline.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
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

/// A term both checks identified: its coefficients in the baseline and the latest, and
/// the travel both measured on its axis.
struct Comparable<'a> {
    term: Term,
    base: &'a [f64],
    latest: &'a [f64],
    travel: [f64; 2],
}

/// The terms two checks can be compared on, and the names of those they cannot (not
/// identifiable in either, or measured travels that do not overlap).
fn comparable<'a>(
    base: &'a ResultScalars,
    latest: &'a ResultScalars,
) -> (Vec<Comparable<'a>>, Vec<String>) {
    let (mut yes, mut no) = (Vec::new(), Vec::new());
    for t in Term::all() {
        let name = t.name();
        match (
            base.term_coefficients.get(&name),
            latest.term_coefficients.get(&name),
            common_travel(base, latest, t.axis.letter()),
        ) {
            (Some(b), Some(l), Some(travel)) => yes.push(Comparable {
                term: t,
                base: b,
                latest: l,
                travel,
            }),
            _ => no.push(name),
        }
    }
    (yes, no)
}

/// A squareness error in two checks: name, baseline value, latest value and the standard
/// uncertainty of their difference (None when a covariance is not stored).
type SquarenessPair = (&'static str, Option<f64>, Option<f64>, Option<f64>);

/// The three squareness errors of two checks.
fn squareness_pairs(base: &ResultScalars, latest: &ResultScalars) -> [SquarenessPair; 3] {
    let u = |name: &str| {
        squareness_std(base, name)
            .zip(squareness_std(latest, name))
            .map(|(x, y)| x.hypot(y))
    };
    [
        ("EC0Y", base.ec0y_urad, latest.ec0y_urad, u("EC0Y")),
        ("EB0Z", base.eb0z_urad, latest.eb0z_urad, u("EB0Z")),
        ("EA0Z", base.ea0z_urad, latest.ea0z_urad, u("EA0Z")),
    ]
}

/// Drift between two results' scalars: over the intersection of their measured travels.
pub fn drift(base: &ResultScalars, latest: &ResultScalars) -> Drift {
    let mut d = Drift {
        drift_um: 0.0,
        drift_um_u: None,
        drift_urad: 0.0,
        drift_urad_u: None,
        worst_term_um: None,
        worst_term_urad: None,
        not_compared: Vec::new(),
    };
    let u_diff = |name: &str, q: f64| -> Option<f64> {
        Some(term_std(base, name, q)?.hypot(term_std(latest, name, q)?))
    };
    let (terms, not_compared) = comparable(base, latest);
    d.not_compared = not_compared;
    for Comparable {
        term: t,
        base: b,
        latest: l,
        travel,
    } in terms
    {
        let name = t.name();
        let (m, at) = grid(travel)
            .map(|q| ((eval(l, q) - eval(b, q)).abs(), q))
            .fold(
                (0.0, travel[0]),
                |best, x| if x.0 > best.0 { x } else { best },
            );
        let (best, best_u, worst) = if t.is_angular() {
            (
                &mut d.drift_urad,
                &mut d.drift_urad_u,
                &mut d.worst_term_urad,
            )
        } else {
            (&mut d.drift_um, &mut d.drift_um_u, &mut d.worst_term_um)
        };
        if m > *best || worst.is_none() {
            *best = m;
            *best_u = u_diff(&name, at);
            *worst = Some(name);
        }
    }
    for (name, b, l, u) in squareness_pairs(base, latest) {
        match (b, l) {
            (Some(b), Some(l)) => {
                if (l - b).abs() > d.drift_urad || d.worst_term_urad.is_none() {
                    d.drift_urad = (l - b).abs();
                    d.drift_urad_u = u;
                    d.worst_term_urad = Some(name.into());
                }
            }
            _ => d.not_compared.push(name.into()),
        }
    }
    d
}

/// Each change since the baseline as a figure of the decision rule
/// ([`mtcal_solver::tolerance::Figure`]): a term's `latest − base` with its standard
/// uncertainty (u² = u_base² + u_latest²) on the drift grid of the travel both checks
/// measured; a squareness's difference with its uncertainty. Left out (nothing to decide
/// on): a term not identifiable in either check, without overlapping measured travels,
/// or without a stored covariance in either (a change is only judged with its
/// uncertainty).
pub fn changes(
    base: &ResultScalars,
    latest: &ResultScalars,
) -> BTreeMap<String, mtcal_solver::tolerance::Figure> {
    use mtcal_solver::tolerance::Figure;
    let mut out = BTreeMap::new();
    for Comparable {
        term: t,
        base: b,
        latest: l,
        travel,
    } in comparable(base, latest).0
    {
        let name = t.name();
        let points: Option<Vec<(f64, f64, f64)>> = grid(travel)
            .map(|q| {
                let u = term_std(base, &name, q)?.hypot(term_std(latest, &name, q)?);
                Some((q, eval(l, q) - eval(b, q), u))
            })
            .collect();
        if let Some(fig) = points.and_then(|p| Figure::over_travel(t.unit(), p)) {
            out.insert(name, fig);
        }
    }
    for (name, b, l, u) in squareness_pairs(base, latest) {
        if let (Some(b), Some(l), Some(u)) = (b, l, u) {
            out.insert(name.to_string(), Figure::constant("urad", l - b, Some(u)));
        }
    }
    out
}

/// Change of one term between two results on a grid of the travel both measured.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
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

/// Term-by-term differences (other − baseline) on every `step_mm` of the travel both
/// checks measured (including 0 when inside), plus the squareness differences.
pub fn diff(
    base: &ResultScalars,
    other: &ResultScalars,
    step_mm: f64,
) -> (BTreeMap<String, TermDiff>, BTreeMap<String, Option<f64>>) {
    let mut terms = BTreeMap::new();
    for t in Term::all() {
        let name = t.name();
        let travel = common_travel(base, other, t.axis.letter());
        let positions: Vec<f64> = travel.map_or_else(Vec::new, |[lo, hi]| {
            let k0 = (lo / step_mm).ceil() as i64;
            let k1 = (hi / step_mm).floor() as i64;
            (k0..=k1).map(|k| k as f64 * step_mm).collect()
        });
        let entry = match (
            base.term_coefficients.get(&name),
            other.term_coefficients.get(&name),
        ) {
            (Some(b), Some(o)) => TermDiff {
                unit: t.unit().into(),
                travel_mm: travel,
                delta: positions.iter().map(|&q| eval(o, q) - eval(b, q)).collect(),
                u: positions
                    .iter()
                    .map(|&q| Some(term_std(base, &name, q)?.hypot(term_std(other, &name, q)?)))
                    .collect::<Option<Vec<f64>>>()
                    .unwrap_or_default(),
                positions_mm: positions,
                identifiable: true,
            },
            _ => TermDiff {
                unit: t.unit().into(),
                travel_mm: travel,
                positions_mm: Vec::new(),
                delta: Vec::new(),
                u: Vec::new(),
                identifiable: false,
            },
        };
        terms.insert(name, entry);
    }
    let sq = |b: Option<f64>, o: Option<f64>| Some(o? - b?);
    let squareness = BTreeMap::from([
        ("EC0Y".to_string(), sq(base.ec0y_urad, other.ec0y_urad)),
        ("EB0Z".to_string(), sq(base.eb0z_urad, other.eb0z_urad)),
        ("EA0Z".to_string(), sq(base.ea0z_urad, other.ea0z_urad)),
    ]);
    (terms, squareness)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Scalars of a check that measured X over `travel`, with EXX, optionally EAX, and
    /// EC0Y; every coefficient with standard uncertainty `u` (independent).
    fn scalars(
        exx: Vec<f64>,
        eax: Option<Vec<f64>>,
        ec0y: f64,
        travel: [f64; 2],
        u: f64,
    ) -> ResultScalars {
        let mut s = ResultScalars {
            ec0y_urad: Some(ec0y),
            ..Default::default()
        };
        s.measured_travel_mm.insert("X".into(), travel);
        let diag = |n: usize| {
            (0..n)
                .map(|i| (0..n).map(|j| if i == j { u * u } else { 0.0 }).collect())
                .collect::<Vec<Vec<f64>>>()
        };
        s.term_covariance.insert("EXX".into(), diag(exx.len()));
        s.term_coefficients.insert("EXX".into(), exx);
        if let Some(a) = eax {
            s.term_covariance.insert("EAX".into(), diag(a.len()));
            s.term_coefficients.insert("EAX".into(), a);
        }
        s.term_covariance.insert("EC0Y".into(), vec![vec![0.04]]);
        s
    }

    #[test]
    fn horner_matches_the_power_sum() {
        let c = [0.5, -0.01, 2e-4];
        for q in [-120.0, 0.0, 7.5, 250.0] {
            let direct = 0.5 * q - 0.01 * q * q + 2e-4 * q * q * q;
            assert!((eval(&c, q) - direct).abs() < 1e-9 * (1.0 + direct.abs()));
        }
    }

    #[test]
    fn std_at_is_the_quadratic_form_of_the_monomials() {
        // f = c1 q + c2 q², Var c1 = 1e-4, Var c2 = 1e-8, Cov = -1e-6: by hand at q = 10,
        // Var f = 100·1e-4 + 1e4·1e-8 + 2·10·100·(−1e-6) = 0.01 + 1e-4 − 2e-3 = 0.0081.
        let cov = vec![vec![1e-4, -1e-6], vec![-1e-6, 1e-8]];
        assert!((std_at(&cov, 10.0) - 0.0081f64.sqrt()).abs() < 1e-12);
        assert_eq!(std_at(&cov, 0.0), 0.0);
    }

    #[test]
    fn drift_is_the_largest_change_over_the_travel_both_checks_measured() {
        // ΔEXX(q) = 0.01 q. The baseline measured X over [−200, 300], the latest over
        // [−50, 50]: the drift is |0.01 · 50| = 0.5 µm at q = 50, not 3 µm at 300.
        let b = scalars(vec![0.0], Some(vec![0.001]), 5.0, [-200.0, 300.0], 0.002);
        let l = scalars(vec![0.01], Some(vec![0.001]), 3.5, [-50.0, 50.0], 0.002);
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
    }

    #[test]
    fn checks_whose_travels_do_not_overlap_are_not_compared() {
        let b = scalars(vec![0.0], None, 5.0, [-200.0, -100.0], 0.002);
        let l = scalars(vec![0.01], None, 5.0, [0.0, 100.0], 0.002);
        let d = drift(&b, &l);
        assert_eq!(d.drift_um, 0.0);
        assert!(d.worst_term_um.is_none());
        assert!(d.not_compared.contains(&"EXX".to_string()), "{d:?}");
        let (terms, _) = diff(&b, &l, 10.0);
        assert!(terms["EXX"].travel_mm.is_none());
        assert!(terms["EXX"].positions_mm.is_empty());
        // A result without a recorded travel is not compared either.
        let mut old = b.clone();
        old.measured_travel_mm.clear();
        assert!(drift(&old, &l).not_compared.contains(&"EXX".to_string()));
    }

    #[test]
    fn diff_grid_includes_zero_and_stays_inside_the_common_travel() {
        let b = scalars(vec![0.0, 1e-4], None, 1.0, [-200.0, 300.0], 0.001);
        let o = scalars(vec![0.002, 1e-4], None, 2.0, [-120.0, 180.0], 0.001);
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
    }
}
