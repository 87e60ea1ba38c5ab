//! Drift since a baseline: the change of every figure over the common travel, and the
//! alerts where a change exceeds the profile's drift threshold beyond its expanded
//! uncertainty.

use crate::comparison;
use crate::terms::Term;
use crate::tolerance::verdict::decide_change;
use crate::tolerance::{Decision, Figure, Limits, VerdictItem};
use std::collections::BTreeMap;

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
    use crate::tolerance::*;

    use std::collections::BTreeMap;

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
