//! Tolerances and the decision rule of conformity (ISO 14253-1), with the uncertainty of
//! an ISO/TR 230-9 budget, on the quantities ISO 230-1 and ISO 230-2 state limits for.
//!
//! **What is judged** ([`figures`]): an error function by its **range** (max − min) over
//! the travel the check measured (ISO 230-1: positioning and straightness deviations are
//! ranges, a straightness about its least-squares reference line, so no verdict depends
//! on the arbitrary zero of a function); a squareness by its magnitude; a figure of ISO
//! 230-2 (E, M, A, B, R, …) or ISO 230-4 (G, H, F, …) by its magnitude against its own
//! limit. A limit on an error function may be stated per length ([`TermLimit`]).
//!
//! **The rule**: a measured quantity y (a range, or |value|) with combined standard
//! uncertainty u_c (the budget of [`crate::uncertainty`]: instrument, thermal, setup and
//! the fit) against a limit L, with U = k·u_c, k = [`COVERAGE_K`] = 2:
//!
//! * **pass** when y + U ≤ L (conformance proven);
//! * **fail** when y − U > L (non-conformance proven);
//! * **undecided** otherwise (the interval straddles the limit);
//! * **not decided: model misfit** ([`Decision::Misfit`]) for a quantity of a fitted
//!   model that does not explain its recording ([`crate::misfit`]): no value of such a
//!   model is judged. The figures of the standards, taken from the readings directly,
//!   are still judged.
//!
//! The result's decision combines its items: fail when any fails, else not decided
//! (misfit) when any is, else undecided when any is, else pass. An item covering only
//! part of the machine's registered travel says which part ([`Assessment`]).
//!
//! [`Limits`] is a tolerance profile's content. Drift thresholds judge changes since a
//! baseline, pointwise ([`Figure`], [`drift_alerts`]).

pub mod figures;

pub use figures::{Figures, Measure, Quantity, identification_figures};

use crate::comparison;
use crate::identification::IdentificationResult;
use crate::misfit::ModelCheck;
use crate::terms::{SquarenessTerm, Term};
use crate::uncertainty::{Budget, ItemBudget, Source, g};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// Coverage factor of the expanded uncertainty U = k·u used by every decision.
pub const COVERAGE_K: f64 = 2.0;

/// The decision rule in one sentence (reported with every verdict).
pub const RULE: &str = "ISO 14253-1, U = 2u with u the combined standard uncertainty of the \
                        budget (ISO/TR 230-9: instrument, thermal, setup, fit): pass when \
                        value + U <= limit, fail when value - U > limit, else undecided; an \
                        error function is judged by its range (max - min) over the measured \
                        travel (ISO 230-1), a squareness or a figure of a standard by its \
                        magnitude; the values of a model that does not explain its recording \
                        are not decided (model misfit)";

/// Outcome of comparing a measured value with a limit. Ordered so that the combination
/// of several is their maximum: pass < undecided < misfit < fail.
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Decision {
    Pass,
    Undecided,
    /// Not decided: the model does not explain its recording (the misfit gate).
    Misfit,
    Fail,
}

impl Decision {
    pub fn as_str(self) -> &'static str {
        match self {
            Decision::Pass => "pass",
            Decision::Undecided => "undecided",
            Decision::Misfit => "misfit",
            Decision::Fail => "fail",
        }
    }

    /// What a person reads: `pass`, `fail`, `undecided`, `not decided: model misfit`.
    pub fn label(self) -> &'static str {
        match self {
            Decision::Misfit => "not decided: model misfit",
            d => d.as_str(),
        }
    }

    pub fn parse(s: &str) -> Option<Decision> {
        match s {
            "pass" => Some(Decision::Pass),
            "undecided" => Some(Decision::Undecided),
            "misfit" => Some(Decision::Misfit),
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

/// One value of a pointwise figure: where it was taken (None for a constant), the value
/// and its standard uncertainty.
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

/// A change since a baseline judged pointwise against a drift threshold: a constant, or
/// the two deciding points of a function over the travel both checks measured — the one
/// where |value| + U is largest (it decides "within") and the one where |value| − U is
/// largest (it decides "beyond"): every point is within when the first is, some point is
/// beyond when the second is.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Figure {
    /// `um` or `urad`.
    pub unit: String,
    /// The point where |value| + U is largest.
    pub upper: Point,
    /// The point where |value| − U is largest.
    pub lower: Point,
    /// The range the function was evaluated over, mm (None for a constant).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub travel_mm: Option<[f64; 2]>,
}

impl Figure {
    /// A constant figure (a squareness's change).
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

/// A limit on an error function: the range (max − min) of its values over the measured
/// travel (ISO 230-1), µm or µrad. In a profile, a bare number (`"EXX": 4`) is a range
/// limit over the whole measured travel; an object states it per length
/// (`{"range": 10, "per_length_mm": 300, "min": 1}`: 10 µm per 300 mm).
///
/// **Per length** (ISO 230-1's rule of proportionality): the limit for a measured length
/// L is t(L) = range × L / per_length_mm, for L shorter or longer than the reference
/// length, but not less than `min` (default [`MIN_PROPORTIONAL_UM`] µm, or µrad): a
/// proportional tolerance is not reduced below a minimum, as ISO 230-1 lets a test code
/// state one.
///
/// *Reading:* a stored profile of an earlier version held a bare number meaning max
/// |f(q)| over the travel. It is **interpreted**, not migrated: read as a range limit.
/// Since f(0) = 0 lies in the range whenever the travel includes 0, the range is at least
/// max |f|, so the reading is never more lenient (docs/api.md).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TermLimit {
    pub range: f64,
    pub per_length_mm: Option<f64>,
    pub min: Option<f64>,
}

/// The floor of a proportional limit when the profile states none (µm or µrad).
pub const MIN_PROPORTIONAL_UM: f64 = 1.0;

impl TermLimit {
    /// A range limit over the whole measured travel.
    pub fn range(range: f64) -> TermLimit {
        TermLimit {
            range,
            per_length_mm: None,
            min: None,
        }
    }

    /// The limit for a measured length `l_mm` (None: unknown length) and how it was
    /// worked out (None for a plain range limit).
    pub fn at_length(&self, l_mm: Option<f64>) -> (f64, Option<String>) {
        let Some(per) = self.per_length_mm else {
            return (self.range, None);
        };
        let floor = self.min.unwrap_or(MIN_PROPORTIONAL_UM);
        let Some(l) = l_mm else {
            return (
                self.range,
                Some(format!(
                    "{} per {} mm, the measured length unknown: taken as stated",
                    g(self.range),
                    g(per)
                )),
            );
        };
        let t = self.range * l / per;
        if t < floor {
            (
                floor,
                Some(format!(
                    "{} per {} mm over L = {} mm gives {}, below the minimum {}: {}",
                    g(self.range),
                    g(per),
                    g(l),
                    g(t),
                    g(floor),
                    g(floor)
                )),
            )
        } else {
            (
                t,
                Some(format!(
                    "{} per {} mm over L = {} mm: {} × {}/{} = {}",
                    g(self.range),
                    g(per),
                    g(l),
                    g(self.range),
                    g(l),
                    g(per),
                    g(t)
                )),
            )
        }
    }

    fn validate(&self, at: &str) -> Result<(), String> {
        let pos = |what: &str, v: f64| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(format!(
                    "{at}{what}: a limit must be a positive finite number, got {v}"
                ))
            }
        };
        pos("", self.range)?;
        if let Some(l) = self.per_length_mm {
            pos(".per_length_mm", l)?;
        }
        if let Some(m) = self.min {
            pos(".min", m)?;
        }
        if self.min.is_some() && self.per_length_mm.is_none() {
            return Err(format!(
                "{at}.min: a minimum applies to a per-length limit only (give per_length_mm)"
            ));
        }
        Ok(())
    }
}

impl Serialize for TermLimit {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        if self.per_length_mm.is_none() && self.min.is_none() {
            return s.serialize_f64(self.range);
        }
        #[derive(Serialize)]
        struct Spec {
            range: f64,
            #[serde(skip_serializing_if = "Option::is_none")]
            per_length_mm: Option<f64>,
            #[serde(skip_serializing_if = "Option::is_none")]
            min: Option<f64>,
        }
        Spec {
            range: self.range,
            per_length_mm: self.per_length_mm,
            min: self.min,
        }
        .serialize(s)
    }
}

impl<'de> Deserialize<'de> for TermLimit {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        use serde::de::Error;
        let v = serde_json::Value::deserialize(d)?;
        let num = |v: &serde_json::Value, what: &str| {
            v.as_f64()
                .ok_or_else(|| D::Error::custom(format!("{what}: a number, got {v}")))
        };
        match &v {
            serde_json::Value::Number(_) => Ok(TermLimit::range(num(&v, "a limit")?)),
            serde_json::Value::Object(o) => {
                for k in o.keys() {
                    if !["range", "per_length_mm", "min"].contains(&k.as_str()) {
                        return Err(D::Error::custom(format!(
                            "unknown field `{k}` of a limit (range, per_length_mm, min)"
                        )));
                    }
                }
                let range = o
                    .get("range")
                    .ok_or_else(|| D::Error::custom("a limit object needs `range`"))?;
                Ok(TermLimit {
                    range: num(range, "range")?,
                    per_length_mm: o
                        .get("per_length_mm")
                        .map(|v| num(v, "per_length_mm"))
                        .transpose()?,
                    min: o.get("min").map(|v| num(v, "min")).transpose()?,
                })
            }
            other => Err(D::Error::custom(format!(
                "a limit is a number (the range) or {{\"range\", \"per_length_mm\", \"min\"}}, got {other}"
            ))),
        }
    }
}

/// The OpenAPI shape of a [`TermLimit`] (a number, or an object).
#[cfg(feature = "openapi")]
#[derive(utoipa::ToSchema)]
#[allow(dead_code)]
#[serde(untagged)]
pub enum TermLimitSchema {
    /// The range limit over the whole measured travel.
    Range(f64),
    /// A limit per length: range × L / per_length_mm, not less than `min`.
    PerLength {
        range: f64,
        per_length_mm: f64,
        min: Option<f64>,
    },
}

/// A tolerance profile's limits. Every limit is positive; units are those of the item
/// (µm or µrad; a figure of a standard carries its unit in its name).
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Limits {
    /// Per error function (`EXX`, …): the range (max − min) over the measured travel,
    /// µm or µrad, as a number, or per length as `{"range", "per_length_mm", "min"}`.
    #[serde(default)]
    #[cfg_attr(feature = "openapi", schema(value_type = BTreeMap<String, TermLimitSchema>))]
    pub terms: BTreeMap<String, TermLimit>,
    /// Per squareness (`EC0Y`, `EB0Z`, `EA0Z`): |value|, µrad.
    #[serde(default)]
    pub squareness: BTreeMap<String, f64>,
    /// Per figure of a standard (`iso230_2.X.E_um`, `iso230_4.XY.bi.G_um`, …): |value|.
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
        for (name, l) in &self.terms {
            if Term::parse(name).is_none() {
                return Err(format!(
                    "terms.{name}: not one of the 18 ISO 230-1 error functions (EXX … ECZ)"
                ));
            }
            l.validate(&format!("terms.{name}"))?;
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

/// An item's name as a person reads it: the error function's or squareness's ISO 230-1
/// name, a figure of a standard with its standard's symbol and name (`ISO 230-2 X: E,
/// bidirectional systematic positional deviation`), never a raw key.
pub fn display_name(item: &str) -> String {
    let parts: Vec<&str> = item.split('.').collect();
    match parts.as_slice() {
        ["iso230_2", axis, figure] => match crate::standards::iso230_2::figure_name(figure) {
            Some((symbol, name)) => format!("ISO 230-2 {axis}: {symbol}, {name}"),
            None => format!("ISO 230-2 {axis}: {figure}"),
        },
        ["iso230_4", plane, dir, figure] => {
            let dir = match *dir {
                "bi" => "bidirectional",
                "ccw" => "ccw",
                "cw" => "cw",
                other => other,
            };
            match crate::standards::iso230_4::figure_name(figure) {
                Some((symbol, name)) => format!("ISO 230-4 {plane} {dir}: {symbol}, {name}"),
                None => format!("ISO 230-4 {plane} {dir}: {figure}"),
            }
        }
        _ => item.to_string(),
    }
}

/// How a verdict is made beyond the limits and the quantities: the misfit gate of the
/// result's model, the uncertainty budget, and the machine's registered travel.
#[derive(Debug, Clone, Default)]
pub struct Assessment {
    /// The result's misfit gate (None: a result without a fitted model).
    pub model_check: Option<ModelCheck>,
    pub budget: Budget,
    /// The machine's registered travel per axis letter, mm (empty: unknown).
    pub registered_travel_mm: BTreeMap<String, [f64; 2]>,
}

impl Assessment {
    /// How an identification result is assessed: the misfit gate of its model and the
    /// budget of its session's conditions (the instrument's data from the session), on a
    /// machine whose registered travel is `registered_travel_mm` (empty: unknown).
    pub fn of_identification(
        r: &IdentificationResult,
        registered_travel_mm: BTreeMap<String, [f64; 2]>,
    ) -> Assessment {
        Assessment {
            model_check: Some(r.model_check()),
            budget: Budget::new(r.conditions.clone(), Some("session")),
            registered_travel_mm,
        }
    }
}

/// One limit decided against one quantity.
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct VerdictItem {
    /// `EXX`, `EC0Y`, `iso230_2.X.E_um`, …
    pub item: String,
    /// `term`, `squareness` or `standard`.
    pub group: String,
    /// The limit it was decided against (for a per-length limit, the limit at the
    /// measured length: `limit_basis` says how).
    pub limit: f64,
    pub unit: String,
    pub decision: Decision,
    /// `range` (an error function: max − min over `travel_mm`) or `magnitude`; absent on
    /// a drift alert's item (a change at a point).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub measure: Option<Measure>,
    /// The value decided: the range, or the signed value whose magnitude is decided
    /// (None when the item is undetermined).
    pub value: Option<f64>,
    /// Its combined standard uncertainty u_c (the budget's, None when undetermined or
    /// unknown).
    pub u: Option<f64>,
    /// Expanded uncertainty U = k·u_c used in the decision (0 when u is unknown).
    pub expanded_u: Option<f64>,
    /// Where along the travel the deciding value was taken (a drift alert's change).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub position_mm: Option<f64>,
    /// Where a range has its maximum and its minimum, mm.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub at_mm: Option<[f64; 2]>,
    /// The travel the item was checked over, mm.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub travel_mm: Option<[f64; 2]>,
    /// Which part of the machine's registered travel the verdict covers, when not all
    /// of it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub coverage: Option<String>,
    /// How a per-length limit was applied to the measured length.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub limit_basis: Option<String>,
    /// The uncertainty budget of the value (absent on a drift alert's item).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub budget: Option<ItemBudget>,
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
    /// Fail when any item fails, else misfit when any is not decided for a model misfit,
    /// else undecided when any is undecided, else pass; `None` when no limit of the
    /// profile applies to the result.
    pub decision: Option<Decision>,
    /// Coverage factor k of the expanded uncertainties.
    pub k: f64,
    pub rule: String,
    pub items: Vec<VerdictItem>,
    pub not_evaluated: Vec<NotEvaluated>,
    /// The misfit gate of the result's model (absent: no fitted model).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub model_check: Option<ModelCheck>,
    /// The budget's inputs: the test's conditions, where the instrument's data came
    /// from, and what was assumed.
    #[serde(default)]
    pub budget: Budget,
    /// What the verdict leaves out or could not do, one sentence each (e.g. "the
    /// instrument's uncertainty is not included").
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub notes: Vec<String>,
}

/// Decides every limit of `limits` that `figures` can answer (drift thresholds excluded:
/// they apply to changes, see [`drift_alerts`]), with the budget, the misfit gate and
/// the registered travel of `how`.
pub fn evaluate(limits: &Limits, figures: &Figures, how: &Assessment) -> Verdict {
    let mut items = Vec::new();
    let mut not_evaluated = Vec::new();
    let mut wanted: Vec<(&str, &str, TermLimit)> = vec![];
    for (n, l) in &limits.terms {
        wanted.push(("term", n, *l));
    }
    for (n, &l) in &limits.squareness {
        wanted.push(("squareness", n, TermLimit::range(l)));
    }
    for (n, &l) in &limits.standards {
        wanted.push(("standard", n, TermLimit::range(l)));
    }
    for (group, name, limit) in wanted {
        if let Some(q) = figures.figures.get(name) {
            items.push(decide_quantity(name, group, &limit, q, how));
        } else if let Some(why) = figures.undetermined.get(name) {
            items.push(VerdictItem {
                item: name.to_string(),
                group: group.into(),
                limit: limit.range,
                unit: unit_of(name),
                decision: Decision::Undecided,
                measure: None,
                value: None,
                u: None,
                expanded_u: None,
                position_mm: None,
                at_mm: None,
                travel_mm: None,
                coverage: None,
                limit_basis: None,
                budget: None,
                reason: format!("{why}: conformance cannot be shown"),
            });
        } else {
            not_evaluated.push(NotEvaluated {
                item: name.to_string(),
                reason: "this result has no such figure".into(),
            });
        }
    }
    let mut notes = vec![];
    let judged = || items.iter().filter(|i| i.budget.is_some());
    for source in [Source::Instrument, Source::Thermal, Source::Setup] {
        let missing: Vec<&str> = judged()
            .filter(|i| {
                i.budget
                    .as_ref()
                    .is_some_and(|b| b.not_included.contains(&source))
            })
            .map(|i| i.item.as_str())
            .collect();
        if missing.is_empty() {
            continue;
        }
        let why = judged()
            .find_map(|i| {
                i.budget
                    .as_ref()?
                    .contributions
                    .iter()
                    .find(|c| c.source == source && c.u.is_none())
            })
            .map(|c| c.basis.clone())
            .unwrap_or_default();
        let what = match source {
            Source::Instrument => "the instrument's uncertainty",
            Source::Thermal => "the thermal contribution",
            _ => "the setup contribution",
        };
        let whom = if missing.len() == judged().count() {
            "any item".to_string()
        } else {
            missing.join(", ")
        };
        notes.push(format!("{what} is not included for {whom}: {why}"));
    }
    if let Some(c) = how.model_check.as_ref().filter(|c| c.is_misfit()) {
        notes.insert(
            0,
            format!(
                "{}: the values of the model are not decided (model misfit); the diagnosis \
                 of the recording says which physics is missing",
                c.statement
            ),
        );
    }
    Verdict {
        decision: combine(items.iter().map(|i| i.decision)),
        k: COVERAGE_K,
        rule: RULE.into(),
        items,
        not_evaluated,
        model_check: how.model_check.clone(),
        budget: how.budget.clone(),
        notes,
    }
}

/// Fail over misfit over undecided over pass; `None` for no decision at all.
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

/// µm, µrad: the unit as a person reads it.
fn unit_text(unit: &str) -> &str {
    match unit {
        "um" => "µm",
        "urad" => "µrad",
        other => other,
    }
}

/// The part of the registered travel a quantity covers, when it is not all of it.
fn coverage(q: &Quantity, how: &Assessment) -> Option<String> {
    let (axis, [lo, hi]) = (q.axis?, q.travel_mm?);
    let [rlo, rhi] = *how.registered_travel_mm.get(&axis.to_string())?;
    let tol = 1e-6 * (1.0 + rlo.abs().max(rhi.abs()));
    if lo <= rlo + tol && hi >= rhi - tol {
        return None;
    }
    let share = 100.0 * ((hi.min(rhi) - lo.max(rlo)).max(0.0)) / (rhi - rlo).max(f64::MIN_POSITIVE);
    Some(format!(
        "covers {axis} [{}, {}] mm of the registered travel [{}, {}] mm ({:.0} %)",
        g(lo),
        g(hi),
        g(rlo),
        g(rhi),
        share
    ))
}

/// Decides one limit against one quantity, with its budget.
fn decide_quantity(
    name: &str,
    group: &str,
    limit: &TermLimit,
    q: &Quantity,
    how: &Assessment,
) -> VerdictItem {
    let budget = how.budget.item(q.span, q.u);
    let u_c = budget.combined_u;
    let big_u = COVERAGE_K * u_c;
    let (lim, limit_basis) = limit.at_length(q.length_mm());
    let y = q.value.abs();
    let unit = unit_text(&q.unit);
    let what = match q.measure {
        Measure::Range => "range",
        Measure::Magnitude => "|value|",
    };
    let misfit = q.from_model && how.model_check.as_ref().is_some_and(ModelCheck::is_misfit);
    let decision = if misfit {
        Decision::Misfit
    } else {
        decide(y, u_c, lim)
    };
    let mut reason = match decision {
        Decision::Pass => format!("{what} + U = {} + {} <= {} {unit}", g(y), g(big_u), g(lim)),
        Decision::Fail => format!("{what} - U = {} - {} > {} {unit}", g(y), g(big_u), g(lim)),
        Decision::Undecided => format!(
            "{what} = {} {unit} with U = {}: the interval straddles the limit {} {unit}",
            g(y),
            g(big_u),
            g(lim)
        ),
        Decision::Misfit => format!(
            "not decided: model misfit ({what} = {} {unit}, U = {}, limit {} {unit}): {}",
            g(y),
            g(big_u),
            g(lim),
            how.model_check
                .as_ref()
                .map(|c| c.statement.as_str())
                .unwrap_or_default()
        ),
    };
    if let (Measure::Range, Some([lo, hi])) = (q.measure, q.travel_mm) {
        reason.push_str(&format!(
            " over the measured travel [{}, {}] mm",
            g(lo),
            g(hi)
        ));
    }
    if let Some(b) = &limit_basis {
        reason.push_str(&format!(" (limit {b})"));
    }
    let cov = coverage(q, how);
    if let Some(c) = &cov {
        reason.push_str(&format!("; {c}"));
    }
    if !budget.not_included.is_empty() {
        let names: Vec<&str> = budget.not_included.iter().map(|s| s.as_str()).collect();
        reason.push_str(&format!("; not included in U: {}", names.join(", ")));
    }
    VerdictItem {
        item: name.to_string(),
        group: group.to_string(),
        limit: lim,
        unit: q.unit.clone(),
        decision,
        measure: Some(q.measure),
        value: Some(q.value),
        u: Some(u_c),
        expanded_u: Some(big_u),
        position_mm: None,
        at_mm: q.at_mm,
        travel_mm: q.travel_mm,
        coverage: cov,
        limit_basis,
        budget: Some(budget),
        reason,
    }
}

/// Decides one drift threshold against a pointwise change; `what` names the quantity in
/// the reason.
fn decide_change(name: &str, group: &str, limit: f64, fig: &Figure, what: &str) -> VerdictItem {
    let (decision, p) = fig.decide(limit);
    let big_u = p.big_u();
    let unit = unit_text(&fig.unit);
    let at = match (p.position_mm, fig.travel_mm) {
        (Some(q), Some([lo, hi])) => {
            format!(
                " at {} mm (checked over the measured travel [{}, {}] mm)",
                g(q),
                g(lo),
                g(hi)
            )
        }
        _ => String::new(),
    };
    let u_note = if p.u.is_none() {
        " (uncertainty unknown: decided on the value alone)"
    } else {
        ""
    };
    let reason = match decision {
        Decision::Fail => format!(
            "{what} - U = {} - {} > {} {unit}{at}{u_note}",
            g(p.value.abs()),
            g(big_u),
            g(limit)
        ),
        Decision::Pass => format!(
            "{what} + U = {} + {} <= {} {unit}{at}{u_note}",
            g(p.value.abs()),
            g(big_u),
            g(limit)
        ),
        _ => format!(
            "{what} = {} {unit} with U = {}{at}: the interval straddles the threshold {} {unit}",
            g(p.value.abs()),
            g(big_u),
            g(limit)
        ),
    };
    VerdictItem {
        item: name.to_string(),
        group: group.to_string(),
        limit,
        unit: fig.unit.clone(),
        decision,
        measure: None,
        value: Some(p.value),
        u: p.u,
        expanded_u: Some(big_u),
        position_mm: p.position_mm,
        at_mm: None,
        travel_mm: fig.travel_mm,
        coverage: None,
        limit_basis: None,
        budget: None,
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
            let item = decide_change(name, group, threshold, fig, "|change|");
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
    use crate::uncertainty::{Conditions, Span};

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
    fn decisions_combine_fail_over_misfit_over_undecided_over_pass() {
        use Decision::*;
        assert_eq!(combine([Pass, Undecided]), Some(Undecided));
        assert_eq!(combine([Pass, Misfit, Undecided]), Some(Misfit));
        assert_eq!(combine([Misfit, Fail]), Some(Fail));
        assert_eq!(combine([]), None);
        for d in [Pass, Undecided, Misfit, Fail] {
            assert_eq!(Decision::parse(d.as_str()), Some(d));
        }
        assert_eq!(Misfit.label(), "not decided: model misfit");
        assert_eq!(serde_json::to_value(Misfit).unwrap(), "misfit");
    }

    #[test]
    fn a_change_is_within_only_when_every_point_is() {
        // f = 1, 8, −6 µm with u = 0.5, 0.4, 2: |f| + U = 2, 8.8, 10 → the deciding point
        // for "within" is q = 10 (|f| + U = 10), although q = 0 has the largest |f|.
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
        let (d, p) = fig.decide(7.19);
        assert_eq!((d, p.position_mm), (Decision::Fail, Some(0.0)));
        assert_eq!(fig.decide(7.2).0, Decision::Undecided);
        assert!(Figure::over_travel("um", []).is_none());
        assert!(Figure::over_travel("um", [(0.0, f64::NAN, 1.0)]).is_none());
    }

    /// A range quantity of a positioning function over [−50, 50] mm.
    fn exx(range: f64, u: f64) -> Quantity {
        Quantity {
            unit: "um".into(),
            measure: Measure::Range,
            value: range,
            u: Some(u),
            span: Span::Length { mm: 100.0 },
            axis: Some('X'),
            travel_mm: Some([-50.0, 50.0]),
            at_mm: Some([50.0, -50.0]),
            from_model: true,
        }
    }

    fn figures() -> Figures {
        let mut f = Figures::default();
        f.figures.insert("EXX".into(), exx(7.0, 0.2));
        f.figures.insert(
            "EC0Y".into(),
            Quantity::magnitude("urad", 25.0, Some(1.0), Span::Squareness, true),
        );
        f.undetermined
            .insert("EYX".into(), "not identifiable from this check".into());
        f.add_stored([("iso230_2.X.E_um", 6.0, None)]);
        f
    }

    #[test]
    fn verdict_combines_items_and_says_why() {
        let how = Assessment::default();
        let mut limits = Limits::default();
        limits.terms.insert("EXX".into(), TermLimit::range(8.0)); // 7 + 0.4 ≤ 8: pass
        limits.squareness.insert("EC0Y".into(), 30.0); // 25 + 2 ≤ 30: pass
        let v = evaluate(&limits, &figures(), &how);
        assert_eq!(v.decision, Some(Decision::Pass));
        let i = &v.items[0];
        assert_eq!(
            (i.measure, i.at_mm),
            (Some(Measure::Range), Some([50.0, -50.0]))
        );
        assert_eq!(i.travel_mm, Some([-50.0, 50.0]));
        assert!(
            i.reason.contains("range + U = 7 + 0.4 <= 8 µm"),
            "{}",
            i.reason
        );
        // Nothing stated: the instrument's uncertainty is not included, and it is said,
        // on the item and on the verdict.
        assert!(
            i.reason.contains("not included in U: instrument"),
            "{}",
            i.reason
        );
        assert!(
            v.notes[0].starts_with("the instrument's uncertainty is not included for any item"),
            "{:?}",
            v.notes
        );

        // A limit on a term the check could not determine makes it undecided.
        limits.terms.insert("EYX".into(), TermLimit::range(5.0));
        let v = evaluate(&limits, &figures(), &how);
        assert_eq!(v.decision, Some(Decision::Undecided));
        assert!(v.items.iter().any(|i| i.item == "EYX" && i.value.is_none()));

        // One fail decides the whole: |EC0Y| − U = 23 > 20.
        limits.squareness.insert("EC0Y".into(), 20.0);
        assert_eq!(
            evaluate(&limits, &figures(), &how).decision,
            Some(Decision::Fail)
        );

        // A standard's figure without uncertainty is decided on the value alone.
        let limits = Limits {
            standards: BTreeMap::from([
                ("iso230_2.X.E_um".into(), 6.0),
                ("iso230_4.XY.bi.G_um".into(), 3.0),
            ]),
            ..Limits::default()
        };
        let v = evaluate(&limits, &figures(), &how);
        assert_eq!(v.decision, Some(Decision::Pass));
        assert_eq!(v.not_evaluated[0].item, "iso230_4.XY.bi.G_um");

        // No applicable limit: no decision.
        let limits = Limits {
            standards: BTreeMap::from([("iso230_4.XY.bi.G_um".into(), 3.0)]),
            ..Limits::default()
        };
        assert_eq!(evaluate(&limits, &figures(), &how).decision, None);
    }

    /// The issue's case: EXX 3.747 ± 0.010 µm (fit) against 4 µm passed on the fit's
    /// uncertainty alone; with the worked example's budget (docs/conventions.md,
    /// "Uncertainty budget": u_c = 0.5553 µm, U = 1.1106 µm) it is undecided.
    #[test]
    fn the_budget_decides_the_worked_example() {
        let conditions = Conditions::worked_example();
        let how = Assessment {
            budget: Budget::new(conditions, Some("session")),
            ..Assessment::default()
        };
        let mut f = Figures::default();
        f.figures.insert("EXX".into(), exx(3.747, 0.010));
        let limits = Limits {
            terms: BTreeMap::from([("EXX".into(), TermLimit::range(4.0))]),
            ..Limits::default()
        };
        // The fit alone: 3.747 + 0.020 ≤ 4: pass.
        let alone = evaluate(&limits, &f, &Assessment::default());
        assert_eq!(alone.decision, Some(Decision::Pass));
        let v = evaluate(&limits, &f, &how);
        let i = &v.items[0];
        assert!((i.u.unwrap() - 0.555_290).abs() < 1e-5, "{i:?}");
        assert!((i.expanded_u.unwrap() - 1.110_58).abs() < 1e-4);
        assert_eq!(i.decision, Decision::Undecided);
        assert!(v.notes.is_empty(), "{:?}", v.notes);
        assert_eq!(i.budget.as_ref().unwrap().contributions.len(), 4);
        // 3.747 − 1.1106 = 2.64 > 2.6: fail; 3.747 + 1.1106 = 4.858 ≤ 4.86: pass.
        let at = |l: f64| {
            let limits = Limits {
                terms: BTreeMap::from([("EXX".into(), TermLimit::range(l))]),
                ..Limits::default()
            };
            evaluate(&limits, &f, &how).decision
        };
        assert_eq!(at(2.6), Some(Decision::Fail));
        assert_eq!(at(4.86), Some(Decision::Pass));
    }

    #[test]
    fn a_misfit_is_not_decided_but_the_standards_still_are() {
        let how = Assessment {
            model_check: Some(ModelCheck::of(0.976, Some(0.149))),
            ..Assessment::default()
        };
        let mut f = figures();
        f.figures.insert(
            "iso230_4.XY.bi.G_um".into(),
            Quantity::magnitude("um", 9.0, Some(0.1), Span::Form, false),
        );
        let mut limits = Limits {
            terms: BTreeMap::from([("EXX".into(), TermLimit::range(100.0))]),
            squareness: BTreeMap::from([("EC0Y".into(), 1000.0)]),
            ..Limits::default()
        };
        let v = evaluate(&limits, &f, &how);
        assert_eq!(v.decision, Some(Decision::Misfit));
        assert!(v.items.iter().all(|i| i.decision == Decision::Misfit));
        assert!(
            v.items[0].reason.starts_with("not decided: model misfit"),
            "{}",
            v.items[0].reason
        );
        assert!(v.notes[0].contains("the model does not explain this recording"));
        // A figure of a standard comes from the readings: still judged, and its fail
        // decides the whole.
        limits.standards.insert("iso230_4.XY.bi.G_um".into(), 5.0);
        let v = evaluate(&limits, &f, &how);
        assert_eq!(v.decision, Some(Decision::Fail));
        // Without the gate, the same limits pass the model's values.
        let v = evaluate(&limits, &f, &Assessment::default());
        assert_eq!(
            v.items.iter().find(|i| i.item == "EXX").unwrap().decision,
            Decision::Pass
        );
    }

    /// ISO 230-1's rule of proportionality, by hand: 10 µm per 300 mm.
    #[test]
    fn a_per_length_limit_by_hand() {
        let l = TermLimit {
            range: 10.0,
            per_length_mm: Some(300.0),
            min: None,
        };
        // Over 100 mm: 10 × 100/300 = 3.333 µm; over 600 mm: 20 µm.
        assert!((l.at_length(Some(100.0)).0 - 10.0 / 3.0).abs() < 1e-12);
        assert_eq!(l.at_length(Some(600.0)).0, 20.0);
        // Over 20 mm: 0.667 µm, below the default minimum 1 µm: 1 µm.
        assert_eq!(l.at_length(Some(20.0)).0, 1.0);
        assert!(
            l.at_length(Some(20.0))
                .1
                .unwrap()
                .contains("below the minimum 1")
        );
        let with_min = TermLimit {
            min: Some(2.0),
            ..l
        };
        assert_eq!(with_min.at_length(Some(100.0)).0, 10.0 / 3.0);
        assert_eq!(with_min.at_length(Some(50.0)).0, 2.0);
        // In a verdict: a 3 µm range over 100 mm, u = 0.1: 3 + 0.2 ≤ 3.333: pass.
        let mut f = Figures::default();
        f.figures.insert("EXX".into(), exx(3.0, 0.1));
        let limits = Limits {
            terms: BTreeMap::from([("EXX".into(), l)]),
            ..Limits::default()
        };
        let v = evaluate(&limits, &f, &Assessment::default());
        let i = &v.items[0];
        assert_eq!(i.decision, Decision::Pass);
        assert!((i.limit - 10.0 / 3.0).abs() < 1e-12);
        assert!(
            i.limit_basis
                .as_ref()
                .unwrap()
                .contains("10 × 100/300 = 3.333"),
            "{:?}",
            i.limit_basis
        );
        // The same profile as JSON, and a plain number as a range limit.
        let json = r#"{"terms": {"EXX": {"range": 10, "per_length_mm": 300}, "EYY": 4}}"#;
        let parsed: Limits = serde_json::from_str(json).unwrap();
        assert_eq!(parsed.terms["EXX"], l);
        assert_eq!(parsed.terms["EYY"], TermLimit::range(4.0));
        assert_eq!(
            serde_json::to_value(&parsed).unwrap()["terms"],
            serde_json::json!({"EXX": {"range": 10.0, "per_length_mm": 300.0}, "EYY": 4.0})
        );
        for bad in [
            r#"{"terms": {"EXX": {"range": 10, "per": 300}}}"#,
            r#"{"terms": {"EXX": {"per_length_mm": 300}}}"#,
            r#"{"terms": {"EXX": "10"}}"#,
        ] {
            let e = serde_json::from_str::<Limits>(bad).unwrap_err().to_string();
            assert!(e.contains("limit") || e.contains("range"), "{bad}: {e}");
        }
    }

    #[test]
    fn a_verdict_on_part_of_the_travel_says_which_part() {
        let how = Assessment {
            registered_travel_mm: BTreeMap::from([("X".into(), [-300.0, 300.0])]),
            ..Assessment::default()
        };
        let limits = Limits {
            terms: BTreeMap::from([("EXX".into(), TermLimit::range(8.0))]),
            ..Limits::default()
        };
        let v = evaluate(&limits, &figures(), &how);
        let c = v.items[0].coverage.as_deref().unwrap();
        assert_eq!(
            c,
            "covers X [-50, 50] mm of the registered travel [-300, 300] mm (17 %)"
        );
        assert!(v.items[0].reason.contains(c));
        // The whole registered travel measured: nothing to say.
        let how = Assessment {
            registered_travel_mm: BTreeMap::from([("X".into(), [-50.0, 50.0])]),
            ..Assessment::default()
        };
        assert_eq!(evaluate(&limits, &figures(), &how).items[0].coverage, None);
    }

    #[test]
    fn limits_are_validated_with_the_entry_named() {
        let mut l = Limits::default();
        l.terms.insert("EQX".into(), TermLimit::range(1.0));
        assert!(l.validate().unwrap_err().contains("terms.EQX"));
        let mut l = Limits::default();
        l.terms.insert("EXX".into(), TermLimit::range(0.0));
        assert!(l.validate().unwrap_err().contains("positive"));
        let mut l = Limits::default();
        l.terms.insert(
            "EXX".into(),
            TermLimit {
                range: 1.0,
                per_length_mm: Some(-3.0),
                min: None,
            },
        );
        assert!(
            l.validate()
                .unwrap_err()
                .contains("terms.EXX.per_length_mm")
        );
        let mut l = Limits::default();
        l.terms.insert(
            "EXX".into(),
            TermLimit {
                range: 1.0,
                per_length_mm: None,
                min: Some(1.0),
            },
        );
        assert!(l.validate().unwrap_err().contains("terms.EXX.min"));
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
    fn items_are_named_as_the_standards_name_them() {
        assert_eq!(
            display_name("iso230_2.X.E_um"),
            "ISO 230-2 X: E, bidirectional systematic positional deviation"
        );
        assert_eq!(
            display_name("iso230_4.XY.bi.H_um"),
            "ISO 230-4 XY bidirectional: H, circular hysteresis"
        );
        assert_eq!(display_name("EXX"), "EXX");
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
