//! Tolerances and the decision rule of conformity (ISO 14253-1 style).
//!
//! A measured quantity y with standard uncertainty u is compared with a limit L on |y|
//! using the expanded uncertainty U = k·u, k = [`COVERAGE_K`] = 2:
//!
//! * **pass** when |y| + U ≤ L (conformance proven: the whole uncertainty interval is
//!   inside the tolerance zone);
//! * **fail** when |y| − U > L (non-conformance proven: the whole interval is outside);
//! * **undecided** otherwise (the interval straddles the limit).
//!
//! A figure that varies along an axis (an error function over the measured travel) is
//! checked at every point where it is known: it passes when every point passes and fails
//! when any point fails. That needs only two points of the function, kept in a [`Figure`]:
//! the one where |y| + U is largest (it decides pass) and the one where |y| − U is largest
//! (it decides fail). Such a summary can be stored and decided against any later limit.
//!
//! [`Limits`] is a tolerance profile's content: limits on the 18 error functions (max |f|
//! over the measured travel, µm or µrad), on the three squareness errors (µrad), on the
//! scalar figures of the standards (`iso230_2.X.E_um`, `iso230_4.XY.ccw.G_um`, …) and the
//! drift thresholds that raise alerts. [`evaluate`] decides every limit that a result's
//! [`Figures`] carry and combines them into one [`Verdict`].

use crate::comparison;
use crate::identification::IdentificationResult;
use crate::terms::{SquarenessTerm, Term};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// Coverage factor of the expanded uncertainty U = k·u used by every decision.
pub const COVERAGE_K: f64 = 2.0;

/// The decision rule in one sentence (reported with every verdict).
pub const RULE: &str = "ISO 14253-1 style, U = 2u: pass when |value| + U <= limit, \
                        fail when |value| - U > limit, else undecided; a figure over the \
                        measured travel passes when every point passes and fails when any \
                        point fails";

/// Outcome of comparing a measured value with a limit.
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Decision {
    Pass,
    Undecided,
    Fail,
}

impl Decision {
    pub fn as_str(self) -> &'static str {
        match self {
            Decision::Pass => "pass",
            Decision::Undecided => "undecided",
            Decision::Fail => "fail",
        }
    }

    pub fn parse(s: &str) -> Option<Decision> {
        match s {
            "pass" => Some(Decision::Pass),
            "undecided" => Some(Decision::Undecided),
            "fail" => Some(Decision::Fail),
            _ => None,
        }
    }
}

/// The decision rule: `value` with standard uncertainty `u` against a limit on |value|,
/// with U = [`COVERAGE_K`]·u. A non-finite value or uncertainty, or a negative
/// uncertainty, decides nothing (undecided).
pub fn decide(value: f64, u: f64, limit: f64) -> Decision {
    if !(value.is_finite() && u.is_finite() && u >= 0.0) {
        return Decision::Undecided;
    }
    let big_u = COVERAGE_K * u;
    if value.abs() + big_u <= limit {
        Decision::Pass
    } else if value.abs() - big_u > limit {
        Decision::Fail
    } else {
        Decision::Undecided
    }
}

/// One value of a figure: where it was taken (None for a constant), the value and its
/// standard uncertainty.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Point {
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub position_mm: Option<f64>,
    pub value: f64,
    /// Standard uncertainty (1σ); `None` when the source gives none (then U = 0).
    pub u: Option<f64>,
}

impl Point {
    fn big_u(&self) -> f64 {
        COVERAGE_K * self.u.unwrap_or(0.0)
    }
}

/// What a limit is checked against: a constant, or the two deciding points of a function
/// over the travel where it was measured (see the module documentation).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Figure {
    /// `um` or `urad`.
    pub unit: String,
    /// The point where |value| + U is largest (decides pass).
    pub upper: Point,
    /// The point where |value| − U is largest (decides fail).
    pub lower: Point,
    /// The range the function was evaluated over, mm (None for a constant).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub travel_mm: Option<[f64; 2]>,
}

impl Figure {
    /// A constant figure (a squareness, a figure of a standard).
    pub fn constant(unit: &str, value: f64, u: Option<f64>) -> Figure {
        let p = Point {
            position_mm: None,
            value,
            u,
        };
        Figure {
            unit: unit.to_string(),
            upper: p,
            lower: p,
            travel_mm: None,
        }
    }

    /// A function known at `(position_mm, value, u)` points; `None` when there is no
    /// point or one of them is not finite (such a function cannot be decided).
    pub fn over_travel(
        unit: &str,
        points: impl IntoIterator<Item = (f64, f64, f64)>,
    ) -> Option<Figure> {
        let mut upper: Option<Point> = None;
        let mut lower: Option<Point> = None;
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for (q, value, u) in points {
            if !(q.is_finite() && value.is_finite() && u.is_finite() && u >= 0.0) {
                return None;
            }
            let p = Point {
                position_mm: Some(q),
                value,
                u: Some(u),
            };
            lo = lo.min(q);
            hi = hi.max(q);
            if upper.is_none_or(|b| value.abs() + p.big_u() > b.value.abs() + b.big_u()) {
                upper = Some(p);
            }
            if lower.is_none_or(|b| value.abs() - p.big_u() > b.value.abs() - b.big_u()) {
                lower = Some(p);
            }
        }
        Some(Figure {
            unit: unit.to_string(),
            upper: upper?,
            lower: lower?,
            travel_mm: Some([lo, hi]),
        })
    }

    /// The decision against `limit`, and the point that decided it.
    pub fn decide(&self, limit: f64) -> (Decision, Point) {
        let up = self.upper;
        let low = self.lower;
        if low.value.abs() - low.big_u() > limit {
            (Decision::Fail, low)
        } else if up.value.abs() + up.big_u() <= limit {
            (Decision::Pass, up)
        } else {
            (Decision::Undecided, up)
        }
    }
}

/// The figures of one result that limits can be checked against.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Figures {
    /// By item name: an error function (`EXX`), a squareness (`EC0Y`) or a figure of a
    /// standard (`iso230_2.X.E_um`).
    pub figures: BTreeMap<String, Figure>,
    /// Items the result measured but could not determine, with the reason (e.g. a term
    /// that is not identifiable): a limit on them is undecided.
    #[serde(default)]
    pub undetermined: BTreeMap<String, String>,
}

impl Figures {
    /// Adds the figures of a standard (`iso230_2.X.E_um` → value, standard uncertainty).
    pub fn add_standards<'a>(
        &mut self,
        standards: impl IntoIterator<Item = (&'a str, f64, Option<f64>)>,
    ) {
        for (name, value, u) in standards {
            if value.is_finite() && u.is_none_or(|u| u.is_finite() && u >= 0.0) {
                let unit = if name.ends_with("_urad") {
                    "urad"
                } else {
                    "um"
                };
                self.figures
                    .insert(name.to_string(), Figure::constant(unit, value, u));
            } else {
                self.undetermined
                    .insert(name.to_string(), "the stored value is not finite".into());
            }
        }
    }
}

/// The figures of an identification result: each identifiable error function on its
/// reporting grid over the measured travel (values and standard uncertainties as
/// reported), and each identified squareness. Terms and squareness that are not
/// identifiable are listed as undetermined.
pub fn identification_figures(r: &IdentificationResult) -> Figures {
    let mut f = Figures::default();
    for (name, t) in &r.terms {
        let fig = t.identifiable.then(|| {
            Figure::over_travel(
                &t.unit,
                t.positions_mm
                    .iter()
                    .zip(&t.values)
                    .zip(&t.std)
                    .map(|((&q, &v), &u)| (q, v, u)),
            )
        });
        match fig.flatten() {
            Some(fig) => {
                f.figures.insert(name.clone(), fig);
            }
            None => {
                f.undetermined
                    .insert(name.clone(), not_determined(&t.confounded_with));
            }
        }
    }
    for (name, s) in &r.squareness {
        match (s.identifiable, s.value_urad) {
            (true, Some(v)) if v.is_finite() => {
                f.figures.insert(
                    name.clone(),
                    Figure::constant("urad", v, s.std_urad.filter(|u| u.is_finite())),
                );
            }
            _ => {
                f.undetermined
                    .insert(name.clone(), not_determined(&s.confounded_with));
            }
        }
    }
    f
}

fn not_determined(confounded_with: &[String]) -> String {
    if confounded_with.is_empty() {
        "not identifiable from this check".into()
    } else {
        format!(
            "not identifiable from this check (confounded with {})",
            confounded_with.join(", ")
        )
    }
}

/// A tolerance profile's limits. Every limit is on the magnitude and positive; units are
/// those of the item (µm or µrad; a figure of a standard carries its unit in its name).
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Limits {
    /// Per error function (`EXX`, …): max |f(q)| over the measured travel, µm or µrad.
    #[serde(default)]
    pub terms: BTreeMap<String, f64>,
    /// Per squareness (`EC0Y`, `EB0Z`, `EA0Z`): |value|, µrad.
    #[serde(default)]
    pub squareness: BTreeMap<String, f64>,
    /// Per figure of a standard (`iso230_2.X.E_um`, `iso230_4.XY.bi.G_um`, …).
    #[serde(default)]
    pub standards: BTreeMap<String, f64>,
    /// Drift threshold on translational terms, µm: an alert is raised when a term's
    /// change since the baseline exceeds it by more than the expanded uncertainty.
    #[serde(default)]
    pub drift_um: Option<f64>,
    /// Drift threshold on angular terms and squareness, µrad.
    #[serde(default)]
    pub drift_urad: Option<f64>,
}

impl Limits {
    /// Checks names and values; the message names the offending entry.
    pub fn validate(&self) -> Result<(), String> {
        let check = |what: &str, v: f64| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(format!(
                    "{what}: a limit must be a positive finite number, got {v}"
                ))
            }
        };
        for (name, &v) in &self.terms {
            if Term::parse(name).is_none() {
                return Err(format!(
                    "terms.{name}: not one of the 18 ISO 230-1 error functions (EXX … ECZ)"
                ));
            }
            check(&format!("terms.{name}"), v)?;
        }
        for (name, &v) in &self.squareness {
            if SquarenessTerm::parse(name).is_none() {
                return Err(format!("squareness.{name}: one of EC0Y, EB0Z, EA0Z"));
            }
            check(&format!("squareness.{name}"), v)?;
        }
        for (name, &v) in &self.standards {
            if !is_standard_figure(name) {
                return Err(format!(
                    "standards.{name}: a figure is named iso230_2.<X|Y|Z>.<figure>_um|_urad or \
                     iso230_4.<XY|XZ|YZ>.<ccw|cw|bi>.<figure>_um"
                ));
            }
            check(&format!("standards.{name}"), v)?;
        }
        if let Some(v) = self.drift_um {
            check("drift_um", v)?;
        }
        if let Some(v) = self.drift_urad {
            check("drift_urad", v)?;
        }
        Ok(())
    }

    /// Number of limits (drift thresholds included).
    pub fn len(&self) -> usize {
        self.terms.len()
            + self.squareness.len()
            + self.standards.len()
            + self.drift_um.is_some() as usize
            + self.drift_urad.is_some() as usize
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The drift threshold for an item of `unit` (`um` or `urad`).
    pub fn drift_threshold(&self, unit: &str) -> Option<f64> {
        if unit == "urad" {
            self.drift_urad
        } else {
            self.drift_um
        }
    }
}

/// Whether `name` has the shape of a figure of a standard: `iso230_2.<axis>.<figure>` or
/// `iso230_4.<plane>.<direction>.<figure>`, the figure ending in `_um` or `_urad`.
pub fn is_standard_figure(name: &str) -> bool {
    let parts: Vec<&str> = name.split('.').collect();
    let figure_ok = |f: &str| {
        (f.ends_with("_um") || f.ends_with("_urad"))
            && f.len() > 3
            && f.chars().all(|c| c.is_ascii_alphanumeric() || c == '_')
    };
    match parts.as_slice() {
        ["iso230_2", axis, figure] => matches!(*axis, "X" | "Y" | "Z") && figure_ok(figure),
        ["iso230_4", plane, dir, figure] => {
            matches!(*plane, "XY" | "XZ" | "YZ")
                && matches!(*dir, "ccw" | "cw" | "bi")
                && figure_ok(figure)
        }
        _ => false,
    }
}

/// One limit decided against one figure.
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct VerdictItem {
    /// `EXX`, `EC0Y`, `iso230_2.X.E_um`, …
    pub item: String,
    /// `term`, `squareness` or `standard`.
    pub group: String,
    pub limit: f64,
    pub unit: String,
    pub decision: Decision,
    /// The deciding value (None when the item is undetermined).
    pub value: Option<f64>,
    /// Its standard uncertainty (None when undetermined or unknown).
    pub u: Option<f64>,
    /// Expanded uncertainty U = k·u used in the decision (0 when u is unknown).
    pub expanded_u: Option<f64>,
    /// Where along the travel the deciding value was taken.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub position_mm: Option<f64>,
    /// The travel the function was checked over, mm.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub travel_mm: Option<[f64; 2]>,
    /// Why, in words: the comparison made.
    pub reason: String,
}

/// A limit of the profile the result has no figure for (a standard's figure in a result
/// that does not compute it): it does not take part in the verdict.
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct NotEvaluated {
    pub item: String,
    pub reason: String,
}

/// A result's verdict against a profile's limits.
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Verdict {
    /// Fail when any item fails, else undecided when any is undecided, else pass; `None`
    /// when no limit of the profile applies to the result.
    pub decision: Option<Decision>,
    /// Coverage factor k of the expanded uncertainties.
    pub k: f64,
    pub rule: String,
    pub items: Vec<VerdictItem>,
    pub not_evaluated: Vec<NotEvaluated>,
}

/// Decides every limit of `limits` that `figures` can answer (drift thresholds excluded:
/// they apply to changes, see [`drift_alerts`]).
pub fn evaluate(limits: &Limits, figures: &Figures) -> Verdict {
    let mut items = Vec::new();
    let mut not_evaluated = Vec::new();
    let groups = [
        ("term", &limits.terms),
        ("squareness", &limits.squareness),
        ("standard", &limits.standards),
    ];
    for (group, map) in groups {
        for (name, &limit) in map {
            if let Some(fig) = figures.figures.get(name) {
                items.push(decide_item(name, group, limit, fig, "|value|"));
            } else if let Some(why) = figures.undetermined.get(name) {
                items.push(VerdictItem {
                    item: name.clone(),
                    group: group.into(),
                    limit,
                    unit: unit_of(name),
                    decision: Decision::Undecided,
                    value: None,
                    u: None,
                    expanded_u: None,
                    position_mm: None,
                    travel_mm: None,
                    reason: format!("{why}: conformance cannot be shown"),
                });
            } else {
                not_evaluated.push(NotEvaluated {
                    item: name.clone(),
                    reason: "this result has no such figure".into(),
                });
            }
        }
    }
    Verdict {
        decision: combine(items.iter().map(|i| i.decision)),
        k: COVERAGE_K,
        rule: RULE.into(),
        items,
        not_evaluated,
    }
}

/// Fail over undecided over pass; `None` for no decision at all.
pub fn combine(decisions: impl IntoIterator<Item = Decision>) -> Option<Decision> {
    decisions.into_iter().max()
}

fn unit_of(name: &str) -> String {
    if let Some(t) = Term::parse(name) {
        t.unit().into()
    } else if SquarenessTerm::parse(name).is_some() || name.ends_with("_urad") {
        "urad".into()
    } else {
        "um".into()
    }
}

/// Decides one limit against one figure; `what` names the quantity in the reason.
fn decide_item(name: &str, group: &str, limit: f64, fig: &Figure, what: &str) -> VerdictItem {
    let (decision, p) = fig.decide(limit);
    let big_u = p.big_u();
    let unit = &fig.unit;
    let at = match (p.position_mm, fig.travel_mm) {
        (Some(q), Some([lo, hi])) => {
            format!(" at {q} mm (checked over the measured travel [{lo}, {hi}] mm)")
        }
        _ => String::new(),
    };
    let u_note = if p.u.is_none() {
        " (uncertainty unknown: decided on the value alone)"
    } else {
        ""
    };
    let reason = match decision {
        Decision::Pass => format!(
            "{what} + U = {:.4} + {:.4} <= {limit} {unit}{at}{u_note}",
            p.value.abs(),
            big_u
        ),
        Decision::Fail => format!(
            "{what} - U = {:.4} - {:.4} > {limit} {unit}{at}{u_note}",
            p.value.abs(),
            big_u
        ),
        Decision::Undecided => format!(
            "{what} = {:.4} {unit} with U = {:.4}{at}: the interval straddles the limit {limit} {unit}",
            p.value.abs(),
            big_u
        ),
    };
    VerdictItem {
        item: name.to_string(),
        group: group.to_string(),
        limit,
        unit: unit.clone(),
        decision,
        value: Some(p.value),
        u: p.u,
        expanded_u: Some(big_u),
        position_mm: p.position_mm,
        travel_mm: fig.travel_mm,
        reason,
    }
}

/// Drift alerts: every change figure (`EXX` → its change since the baseline over the
/// common travel, with the standard uncertainty of the difference) whose change exceeds
/// the profile's drift threshold of its unit by more than the expanded uncertainty
/// (the `fail` side of the decision rule). Returns the items that alert.
pub fn drift_alerts(limits: &Limits, changes: &BTreeMap<String, Figure>) -> Vec<VerdictItem> {
    changes
        .iter()
        .filter_map(|(name, fig)| {
            let threshold = limits.drift_threshold(&fig.unit)?;
            let group = if Term::parse(name).is_some() {
                "term"
            } else {
                "squareness"
            };
            let item = decide_item(name, group, threshold, fig, "|change|");
            (item.decision == Decision::Fail).then_some(item)
        })
        .collect()
}

/// Each change since the baseline as a figure of the decision rule ([`Figure`]): a
/// term's `latest − base` with its standard uncertainty on the drift grid of the travel
/// both checks measured ([`comparison::term_difference`]); a squareness's difference with its uncertainty. Left out
/// (nothing to decide on): a term not identifiable in either check, without overlapping
/// measured travels, or without a stored covariance in either (a change is only judged
/// with its uncertainty).
pub fn changes(
    base: &impl comparison::CheckFunctions,
    latest: &impl comparison::CheckFunctions,
) -> BTreeMap<String, Figure> {
    let mut out = BTreeMap::new();
    for (t, travel) in comparison::comparable(base, latest).0 {
        let points: Option<Vec<(f64, f64, f64)>> = comparison::drift_grid(travel)
            .map(|q| {
                let d = comparison::term_difference(base, latest, t, q)?;
                Some((q, d.value, d.u?))
            })
            .collect();
        if let Some(fig) = points.and_then(|p| Figure::over_travel(t.unit(), p)) {
            out.insert(t.name(), fig);
        }
    }
    for (name, change) in comparison::squareness_changes(base, latest) {
        if let Some(comparison::Value { value, u: Some(u) }) = change {
            out.insert(name.to_string(), Figure::constant("urad", value, Some(u)));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    // The rule at the limit L = 10 with u = 1 (U = 2). Values chosen exactly
    // representable, so "at the limit" is exact: 8 + 2 = 10 ≤ 10 passes.
    #[test]
    fn pass_boundary_value_plus_u() {
        assert_eq!(decide(8.0, 1.0, 10.0), Decision::Pass); // |y| + U = 10 = L
        assert_eq!(decide(7.999, 1.0, 10.0), Decision::Pass); // 9.999, just below
        assert_eq!(decide(8.001, 1.0, 10.0), Decision::Undecided); // 10.001, just above
        assert_eq!(decide(-8.0, 1.0, 10.0), Decision::Pass); // on |y|
        assert_eq!(decide(-8.001, 1.0, 10.0), Decision::Undecided);
    }

    #[test]
    fn fail_boundary_value_minus_u() {
        assert_eq!(decide(12.0, 1.0, 10.0), Decision::Undecided); // |y| − U = 10, not > L
        assert_eq!(decide(11.999, 1.0, 10.0), Decision::Undecided); // 9.999, just below
        assert_eq!(decide(12.001, 1.0, 10.0), Decision::Fail); // 10.001, just above
        assert_eq!(decide(-12.001, 1.0, 10.0), Decision::Fail);
        assert_eq!(decide(10.5, 0.0, 10.0), Decision::Fail); // no uncertainty: plain compare
        assert_eq!(decide(10.0, 0.0, 10.0), Decision::Pass);
    }

    #[test]
    fn the_coverage_factor_is_two() {
        // With U = 1·u this would pass (9.5 + 0.5 ≤ 10); with U = 2u it must not.
        assert_eq!(decide(9.5, 0.5, 10.0), Decision::Undecided);
        assert_eq!(decide(9.0, 0.5, 10.0), Decision::Pass);
    }

    #[test]
    fn nonsense_decides_nothing() {
        assert_eq!(decide(f64::NAN, 1.0, 10.0), Decision::Undecided);
        assert_eq!(decide(1.0, f64::INFINITY, 10.0), Decision::Undecided);
        assert_eq!(decide(1.0, -1.0, 10.0), Decision::Undecided);
        assert_eq!(decide(f64::INFINITY, 0.0, 10.0), Decision::Undecided);
    }

    #[test]
    fn a_function_passes_only_when_every_point_passes() {
        // f = 1, 8, −6 µm with u = 0.5, 0.4, 2: |f| + U = 2, 8.8, 10 → the deciding point
        // for pass is q = 10 (|f| + U = 10), although q = 0 has the largest |f|.
        let fig = Figure::over_travel(
            "um",
            [(-10.0, 1.0, 0.5), (0.0, 8.0, 0.4), (10.0, -6.0, 2.0)],
        )
        .unwrap();
        assert_eq!(fig.upper.position_mm, Some(10.0));
        assert_eq!(fig.lower.position_mm, Some(0.0)); // |f| − U = 7.2
        assert_eq!(fig.travel_mm, Some([-10.0, 10.0]));
        assert_eq!(fig.decide(10.0).0, Decision::Pass);
        assert_eq!(fig.decide(9.99).0, Decision::Undecided);
        // Fails as soon as one point is wholly above: 8 − 0.8 = 7.2 > 7.19.
        let (d, p) = fig.decide(7.19);
        assert_eq!((d, p.position_mm), (Decision::Fail, Some(0.0)));
        assert_eq!(fig.decide(7.2).0, Decision::Undecided);
        // Each point decided on its own gives the same answers.
        for limit in [5.0, 7.19, 7.2, 8.8, 9.99, 10.0, 11.0] {
            let each =
                combine([(1.0, 0.5), (8.0, 0.4), (-6.0, 2.0)].map(|(v, u)| decide(v, u, limit)))
                    .unwrap();
            // Pointwise: fail if any fails, pass only if all pass.
            let expected = if each == Decision::Fail {
                Decision::Fail
            } else if [(1.0, 0.5), (8.0, 0.4), (-6.0, 2.0)]
                .iter()
                .all(|&(v, u)| decide(v, u, limit) == Decision::Pass)
            {
                Decision::Pass
            } else {
                Decision::Undecided
            };
            assert_eq!(fig.decide(limit).0, expected, "limit {limit}");
        }
        assert!(Figure::over_travel("um", []).is_none());
        assert!(Figure::over_travel("um", [(0.0, f64::NAN, 1.0)]).is_none());
    }

    fn figures() -> Figures {
        let mut f = Figures::default();
        f.figures.insert(
            "EXX".into(),
            Figure::over_travel(
                "um",
                [(-50.0, -3.0, 0.2), (0.0, 0.0, 0.0), (50.0, 4.0, 0.2)],
            )
            .unwrap(),
        );
        f.figures
            .insert("EC0Y".into(), Figure::constant("urad", 25.0, Some(1.0)));
        f.undetermined
            .insert("EYX".into(), "not identifiable from this check".into());
        f.add_standards([("iso230_2.X.E_um", 6.0, None)]);
        f
    }

    #[test]
    fn verdict_combines_items_and_says_why() {
        let mut limits = Limits::default();
        limits.terms.insert("EXX".into(), 5.0); // 4 + 0.4 ≤ 5: pass
        limits.squareness.insert("EC0Y".into(), 30.0); // 25 + 2 ≤ 30: pass
        let v = evaluate(&limits, &figures());
        assert_eq!(v.decision, Some(Decision::Pass));
        assert_eq!(v.items[0].position_mm, Some(50.0));
        assert_eq!(v.items[0].travel_mm, Some([-50.0, 50.0]));
        assert!(
            v.items[0].reason.contains("<= 5 um"),
            "{}",
            v.items[0].reason
        );

        // A limit on a term the check could not determine makes it undecided.
        limits.terms.insert("EYX".into(), 5.0);
        let v = evaluate(&limits, &figures());
        assert_eq!(v.decision, Some(Decision::Undecided));
        assert!(v.items.iter().any(|i| i.item == "EYX" && i.value.is_none()));

        // One fail decides the whole: |EC0Y| − U = 23 > 20.
        limits.squareness.insert("EC0Y".into(), 20.0);
        let v = evaluate(&limits, &figures());
        assert_eq!(v.decision, Some(Decision::Fail));

        // A standard's figure without uncertainty is decided on the value alone.
        let limits = Limits {
            standards: BTreeMap::from([
                ("iso230_2.X.E_um".into(), 6.0),
                ("iso230_4.XY.bi.G_um".into(), 3.0),
            ]),
            ..Limits::default()
        };
        let v = evaluate(&limits, &figures());
        assert_eq!(v.decision, Some(Decision::Pass));
        assert!(v.items[0].reason.contains("uncertainty unknown"));
        assert_eq!(v.not_evaluated[0].item, "iso230_4.XY.bi.G_um");

        // No applicable limit: no decision.
        let limits = Limits {
            standards: BTreeMap::from([("iso230_4.XY.bi.G_um".into(), 3.0)]),
            ..Limits::default()
        };
        assert_eq!(evaluate(&limits, &figures()).decision, None);
    }

    #[test]
    fn limits_are_validated_with_the_entry_named() {
        let mut l = Limits::default();
        l.terms.insert("EQX".into(), 1.0);
        assert!(l.validate().unwrap_err().contains("terms.EQX"));
        let mut l = Limits::default();
        l.terms.insert("EXX".into(), 0.0);
        assert!(l.validate().unwrap_err().contains("positive"));
        let mut l = Limits::default();
        l.squareness.insert("EC0Y".into(), f64::INFINITY);
        assert!(l.validate().is_err());
        let mut l = Limits::default();
        l.standards.insert("iso230_2.W.E_um".into(), 1.0);
        assert!(
            l.validate()
                .unwrap_err()
                .contains("standards.iso230_2.W.E_um")
        );
        let l = Limits {
            drift_um: Some(-1.0),
            ..Limits::default()
        };
        assert!(l.validate().unwrap_err().contains("drift_um"));
        for ok in [
            "iso230_2.X.E_um",
            "iso230_2.Z.R_up_um",
            "iso230_4.XY.ccw.G_um",
            "iso230_4.YZ.bi.H_um",
        ] {
            assert!(is_standard_figure(ok), "{ok}");
        }
        for bad in ["iso230_2.X.E", "iso230_4.XY.up.G_um", "iso230_2.X", "EXX"] {
            assert!(!is_standard_figure(bad), "{bad}");
        }
        serde_json::from_str::<Limits>(r#"{"termz": {}}"#).unwrap_err();
    }

    #[test]
    fn a_drift_alerts_only_beyond_threshold_plus_expanded_uncertainty() {
        // Threshold 5 µm; the change has σ = 1 µm (U = 2 µm).
        let limits = Limits {
            drift_um: Some(5.0),
            ..Limits::default()
        };
        let change = |d: f64| {
            BTreeMap::from([(
                "EXX".to_string(),
                Figure::over_travel("um", [(-50.0, 0.0, 1.0), (50.0, d, 1.0)]).unwrap(),
            )])
        };
        // 1σ beyond the threshold: inside the uncertainty, no alert.
        assert!(drift_alerts(&limits, &change(6.0)).is_empty());
        // Exactly 2σ beyond: |Δ| − U = 5, not > 5: no alert.
        assert!(drift_alerts(&limits, &change(7.0)).is_empty());
        // 3σ beyond: alert, at the point that shows it.
        let a = drift_alerts(&limits, &change(-8.0));
        assert_eq!(a.len(), 1);
        assert_eq!(a[0].position_mm, Some(50.0));
        assert_eq!(a[0].decision, Decision::Fail);
        // An angular change is not judged against the µm threshold.
        let angular = BTreeMap::from([(
            "EC0Y".to_string(),
            Figure::constant("urad", 80.0, Some(1.0)),
        )]);
        assert!(drift_alerts(&limits, &angular).is_empty());
    }
}
