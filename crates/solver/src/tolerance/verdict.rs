//! A result's verdict: every item with a limit in the profile judged by the rule
//! ([`crate::tolerance::decide`]) with its budget's uncertainty, the items combined,
//! and the items not evaluated with the reason.

use crate::identification::IdentificationResult;
use crate::misfit::ModelCheck;
use crate::terms::{SquarenessTerm, Term};
use crate::tolerance::{
    COVERAGE_K, Decision, Figure, Figures, Limits, Measure, Quantity, RULE, TermLimit, combine,
    decide,
};
use crate::uncertainty::{Budget, ItemBudget, Source, g};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

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
    // A check decided on the explained model says so first, with what that model adds.
    if let Some(c) = how
        .model_check
        .as_ref()
        .filter(|c| c.decided_on_explained_model())
    {
        notes.insert(0, c.statement.clone());
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
pub(super) fn decide_change(
    name: &str,
    group: &str,
    limit: f64,
    fig: &Figure,
    what: &str,
) -> VerdictItem {
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tolerance::*;
    use crate::uncertainty::{Budget, Conditions, Span};
    use std::collections::BTreeMap;

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

    /// A check decided on the explained model is decided, and its verdict says so first
    /// with what the model adds; a partly explained one stays not decided.
    #[test]
    fn a_check_on_the_explained_model_is_decided_and_says_so() {
        let limits = Limits {
            terms: BTreeMap::from([("EXX".into(), TermLimit::range(100.0))]),
            ..Limits::default()
        };
        let on = |explained: bool| Assessment {
            model_check: Some(ModelCheck::explained(
                0.15,
                Some(0.149),
                "backlash (X)",
                explained,
                &["a cyclic error of Y".to_string()],
            )),
            ..Assessment::default()
        };
        let v = evaluate(&limits, &figures(), &on(true));
        assert_eq!(v.decision, Some(Decision::Pass));
        assert!(
            v.notes[0].starts_with("decided on the explained model")
                && v.notes[0].contains("backlash (X)"),
            "{:?}",
            v.notes
        );
        let v = evaluate(&limits, &figures(), &on(false));
        assert_eq!(v.decision, Some(Decision::Misfit));
        assert!(v.notes[0].contains("a cyclic error of Y"), "{:?}", v.notes);
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
}
