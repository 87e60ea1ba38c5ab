//! Verification at the next check: a machine's check is compared with the prediction of
//! the check before it, per finding that had an action with a predicted residual.
//!
//! | rule | value |
//! |---|---|
//! | which checks | a check (identification) and the machine's identification before it in time order (excluded results left out) |
//! | what is verified | each finding of the earlier check's diagnosis with a prediction after compensation ([`predicted_after`]) |
//! | measured after | the same effect on the same axis in the later check's diagnosis (a lost-motion profile stands for a backlash and back: their mean lost motion); a later check whose 21-term model explains its recording has none of it left, unless it was diagnosed all the same (then its diagnosis says what is left below the misfit gate); a later explained model is read through its diagnosis |
//! | state | `gone` (not found later), `still_present` (found later), `pending` (the later check's diagnosis has not landed) |
//! | as predicted | gone, or the measured value within 2 σ (its own standard uncertainty) and 0.5 µm of the prediction |
//!
//! [`predicted_after`] is the one place a prediction is made; a result decided on an
//! explained model that carries its own predicted residuals replaces it there.

use crate::error::DomainError;
use crate::kinds::IDENTIFICATION;
use mtcal_solver::diagnosis::{DiagnosisResult, Finding};
use mtcal_store::{ResultMeta, Store};

/// Below this a measured residual counts as the prediction's 0 whatever its σ, µm.
pub const AS_PREDICTED_UM: f64 = 0.5;

pub use mtcal_api::history::{Verification, VerifiedFinding};

/// The prediction after compensation of a finding: (parameter, value before, predicted
/// value). A backlash or a lost-motion profile compensated by the table's reversal (or
/// the controller's backlash parameter) predicts no lost motion left. Other findings
/// have no table that removes them: no prediction.
pub fn predicted_after(f: &Finding) -> Option<(&'static str, f64, f64)> {
    let name = lost_motion_parameter(f)?;
    Some((name, *f.parameters.get(name)?, 0.0))
}

/// The parameter of a finding's lost motion: a backlash's, or a profile's mean.
fn lost_motion_parameter(f: &Finding) -> Option<&'static str> {
    match f.effect.as_str() {
        "backlash" => Some("lost_motion_um"),
        "lost_motion_profile" => Some("mean_lost_motion_um"),
        _ => None,
    }
}

/// What the later check says of the physics.
#[derive(Debug, Clone, Copy)]
pub enum Later<'a> {
    /// Its model explains its recording: none of the physics is left.
    Explained,
    /// Its diagnosis.
    Diagnosed(&'a DiagnosisResult),
    /// Its model does not explain its recording and its diagnosis has not landed.
    Pending,
}

/// The findings of `before` with a prediction, verified against `later` (module docs).
pub fn verify(before: &[Finding], later: Later<'_>) -> Vec<VerifiedFinding> {
    before
        .iter()
        .filter_map(|f| {
            let (parameter, was, predicted) = predicted_after(f)?;
            let found = match later {
                Later::Diagnosed(d) => d
                    .findings
                    .iter()
                    .find(|g| g.axis == f.axis && lost_motion_parameter(g).is_some()),
                _ => None,
            };
            let measured = found.and_then(|g| {
                let p = lost_motion_parameter(g)?;
                Some((*g.parameters.get(p)?, g.parameters.get(&format!("std_{p}"))))
            });
            let state = match (later, measured) {
                (Later::Pending, _) => "pending",
                (_, Some(_)) => "still_present",
                (_, None) => "gone",
            };
            let as_predicted = match (later, measured) {
                (Later::Pending, _) => None,
                (_, None) => Some(true),
                (_, Some((v, s))) => {
                    let off = (v - predicted).abs();
                    Some(off <= AS_PREDICTED_UM || s.is_some_and(|s| off <= 2.0 * s))
                }
            };
            let name = f.name_in_words();
            let after = match (state, measured) {
                ("pending", _) => "the later check's diagnosis has not landed yet".to_string(),
                (_, Some((v, _))) => format!("{v:.2} µm after compensation"),
                _ => "gone after compensation".to_string(),
            };
            let verdict = match as_predicted {
                Some(true) => "",
                Some(false) => ": not as predicted (the compensation was not set, or did not take)",
                None => "",
            };
            Some(VerifiedFinding {
                effect: f.effect.clone(),
                axis: f.axis.clone(),
                parameter: parameter.to_string(),
                before: was,
                predicted,
                measured: measured.map(|m| m.0),
                state: state.to_string(),
                as_predicted,
                statement: format!(
                    "{name}: {was:.2} → {after} (predicted {}){verdict}",
                    mtcal_solver::text::short(predicted)
                ),
            })
        })
        .collect()
}

/// The verification of check `result_id` against the check before it on its machine.
pub async fn verification(store: &dyn Store, result_id: &str) -> Result<Verification, DomainError> {
    let r = store.get_result(result_id).await?;
    if r.meta.kind != IDENTIFICATION {
        return Err(DomainError::Conflict(format!(
            "result {result_id} is a {} result; checks (identifications) are verified",
            r.meta.kind
        )));
    }
    let list = store
        .list_results(&r.meta.machine_id, IDENTIFICATION)
        .await?;
    let earlier: Vec<&ResultMeta> = list
        .iter()
        .take_while(|m| m.id != r.meta.id)
        .filter(|m| m.excluded.is_none())
        .collect();
    let mut v = Verification {
        machine_id: r.meta.machine_id.clone(),
        result_id: r.meta.id.clone(),
        measured_at: r.meta.measured_at.clone(),
        previous_result_id: None,
        previous_measured_at: None,
        findings: vec![],
        statement: "nothing to verify: no check before this one".into(),
    };
    let Some(prev) = earlier.last() else {
        return Ok(v);
    };
    v.previous_result_id = Some(prev.id.clone());
    v.previous_measured_at = Some(prev.measured_at.clone());
    let Some(before) = diagnosis(store, prev).await? else {
        v.statement = format!(
            "nothing to verify: the check before ({}) had no finding to act on",
            prev.measured_at
        );
        return Ok(v);
    };
    // A misfit, or an explained model (its physics is what is left): read its diagnosis.
    let misfit = serde_json::from_value::<mtcal_solver::identification::IdentificationResult>(
        r.document.clone(),
    )
    .map(|d| d.model_check().is_misfit() || d.explained.is_some())
    .unwrap_or(true);
    // A check its model explains, diagnosed all the same (the dashboard's "also
    // diagnose"): the diagnosis measures what is left, below the misfit gate.
    let later_doc = diagnosis(store, &r.meta).await?;
    let later = match (misfit, &later_doc) {
        (_, Some(d)) => Later::Diagnosed(d),
        (false, None) => Later::Explained,
        (true, None) => Later::Pending,
    };
    v.findings = verify(&before.findings, later);
    v.statement = if v.findings.is_empty() {
        format!(
            "nothing to verify: the check before ({}) had no finding with a predicted residual",
            prev.measured_at
        )
    } else {
        let ok = v
            .findings
            .iter()
            .filter(|f| f.as_predicted == Some(true))
            .count();
        format!(
            "verified against the check of {}: {ok} of {} as predicted",
            prev.measured_at,
            v.findings.len()
        )
    };
    Ok(v)
}

/// Machine `id`'s checks verified against the check before each, in time order: those
/// whose previous check had a finding with a prediction (the trend of what the actions
/// did).
pub async fn verifications(store: &dyn Store, id: &str) -> Result<Vec<Verification>, DomainError> {
    store.get_machine(id).await?;
    let list = store.list_results(id, IDENTIFICATION).await?;
    let mut out = Vec::new();
    for m in verifiable(&list) {
        let v = verification(store, &m.id).await?;
        if !v.findings.is_empty() {
            out.push(v);
        }
    }
    Ok(out)
}

/// The last of [`verifications`] of machine `id`, found newest first: a page that shows
/// only the latest does not verify every check of the machine.
pub async fn latest(store: &dyn Store, id: &str) -> Result<Option<Verification>, DomainError> {
    store.get_machine(id).await?;
    let list = store.list_results(id, IDENTIFICATION).await?;
    for m in verifiable(&list).rev() {
        let v = verification(store, &m.id).await?;
        if !v.findings.is_empty() {
            return Ok(Some(v));
        }
    }
    Ok(None)
}

/// The checks of a machine that can be verified (all but its first, none excluded),
/// oldest first.
fn verifiable(list: &[ResultMeta]) -> impl DoubleEndedIterator<Item = &ResultMeta> {
    list.iter().skip(1).filter(|m| m.excluded.is_none())
}

/// The diagnosis of the recording of check `m`, when one landed and reads.
async fn diagnosis(
    store: &dyn Store,
    m: &ResultMeta,
) -> Result<Option<DiagnosisResult>, DomainError> {
    let Some(ds) = &m.dataset_id else {
        return Ok(None);
    };
    let Some(d) = crate::history::diagnosis_of_dataset(store, &m.machine_id, ds).await? else {
        return Ok(None);
    };
    let doc = store.get_result(&d.id).await?.document;
    Ok(serde_json::from_value(doc).ok())
}

#[cfg(test)]
mod tests {
    use super::*;
    use mtcal_solver::diagnosis::{BeforeAfter, Verdict};
    use std::collections::BTreeMap;

    fn finding(effect: &str, axis: &str, p: &[(&str, f64)]) -> Finding {
        let ba = BeforeAfter {
            before: 1.0,
            after: 0.5,
        };
        Finding {
            effect: effect.into(),
            axis: Some(axis.into()),
            depends_on: None,
            parameters: p
                .iter()
                .map(|(k, v)| (k.to_string(), *v))
                .collect::<BTreeMap<_, _>>(),
            physics: String::new(),
            signature: None,
            residual_rms_um: ba,
            heldout_rms_um: ba,
            evidence: String::new(),
            undetermined: vec![],
            rivals: Vec::new(),
        }
    }

    fn diagnosed(findings: Vec<Finding>) -> DiagnosisResult {
        serde_json::from_value(serde_json::json!({
            "kind": "diagnosis", "machine_id": "m", "source": "session",
            "baseline": {"residual_rms_um": 1.0, "heldout_rms_um": 1.0, "noise_estimate_um": 0.1},
            "mismatch": [], "findings": findings, "verdict": Verdict::Explained,
        }))
        .unwrap()
    }

    /// A compensated backlash (0.4 µm left): still present, as predicted; one left alone
    /// (5.9 µm): not as predicted; one the later model explains: gone.
    #[test]
    fn each_finding_is_gone_or_still_present_against_its_prediction() {
        let before = [
            finding(
                "backlash",
                "X",
                &[("lost_motion_um", 5.96), ("std_lost_motion_um", 0.02)],
            ),
            finding("servo_lag", "X", &[("lag_ms", 3.0)]),
        ];
        let fixed = diagnosed(vec![finding(
            "backlash",
            "X",
            &[("lost_motion_um", 0.4), ("std_lost_motion_um", 0.05)],
        )]);
        let v = verify(&before, Later::Diagnosed(&fixed));
        assert_eq!(v.len(), 1, "only the backlash has a prediction");
        assert_eq!(v[0].state, "still_present");
        assert_eq!(v[0].as_predicted, Some(true));
        assert_eq!(
            v[0].statement,
            "backlash (X): 5.96 → 0.40 µm after compensation (predicted 0)"
        );
        let left = diagnosed(vec![finding("backlash", "X", &[("lost_motion_um", 5.9)])]);
        let v = verify(&before, Later::Diagnosed(&left));
        assert_eq!(v[0].as_predicted, Some(false));
        assert!(
            v[0].statement.contains("not as predicted"),
            "{}",
            v[0].statement
        );
        let v = verify(&before, Later::Explained);
        assert_eq!(
            (v[0].state.as_str(), v[0].as_predicted),
            ("gone", Some(true))
        );
        let v = verify(&before, Later::Pending);
        assert_eq!((v[0].state.as_str(), v[0].as_predicted), ("pending", None));
    }
}
