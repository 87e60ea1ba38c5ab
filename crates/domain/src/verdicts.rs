//! The verdict of a result against the tolerance profile that applies to its machine
//! ([`crate::profiles`]).
//!
//! **The verdict** is the solver's decision rule ([`mtcal_solver::tolerance::evaluate`],
//! ISO 14253-1 style with U = 2u) applied to the result's figures: for an identification
//! its identifiable error functions on their reporting grid over the measured travel and
//! its squareness errors ([`mtcal_solver::tolerance::identification_figures`]); for every
//! kind the figures of the standards stored with it (ISO 230-2 per axis, ISO 230-4 per
//! plane).

use crate::error::DomainError;
use crate::kinds::IDENTIFICATION;
use crate::profiles::{applicable, limits};
pub use mtcal_api::tolerances::{ProfileRef, ResultVerdict};
use mtcal_solver::identification::IdentificationResult;
use mtcal_solver::positioning_check::DiagnosisDocument;
use mtcal_solver::standards::{Standards, StandardsResult};
use mtcal_solver::tolerance::{self, Assessment, Figures, Verdict};
use mtcal_store::{Machine, Store, StoreError, StoredResult, ToleranceProfile};

/// What a stored result offers to be judged and how (its figures; the misfit gate of its
/// model, its uncertainty budget and the machine's registered travel), given the figures
/// of the standards stored with it (blocking: the identification's functions are
/// evaluated over their measured travel).
fn assess(
    r: &StoredResult,
    stored: &[mtcal_store::Figure],
    m: &Machine,
) -> Result<(Figures, Assessment), StoreError> {
    let unreadable = |what: &str, e: serde_json::Error| {
        StoreError::Conflict(format!(
            "result {} does not read as {what}: {e}; exclude it and run the check again",
            r.meta.id
        ))
    };
    let mut how = Assessment {
        registered_travel_mm: m.travel_mm.clone(),
        ..Assessment::default()
    };
    let mut f = match r.meta.kind.as_str() {
        IDENTIFICATION => {
            let doc = serde_json::from_value::<IdentificationResult>(r.document.clone())
                .map_err(|e| unreadable("an identification", e))?;
            how = Assessment::of_identification(&doc, how.registered_travel_mm);
            tolerance::identification_figures(&doc)
        }
        // The figures of the standards with what they span, from the document; a
        // document that does not give them (an import) is judged on the stored figures.
        "standards" => {
            let mut f = Figures::default();
            if let Ok(doc) = serde_json::from_value::<StandardsResult>(r.document.clone()) {
                f.add_standards(&doc.standards);
            }
            f
        }
        "diagnosis" => {
            // A positioning-run diagnosis carries the ISO 230-2 figures of its runs.
            let mut f = Figures::default();
            if let Ok(doc) = serde_json::from_value::<DiagnosisDocument>(r.document.clone()) {
                f.add_standards(&Standards {
                    iso230_2: doc.iso230_2,
                    ..Standards::default()
                });
            }
            f
        }
        _ => Figures::default(),
    };
    f.add_stored(stored.iter().map(|s| (s.name.as_str(), s.value, s.u)));
    Ok((f, how))
}

/// The verdict of result `r` of machine `m` against the profile that applies among
/// `profiles` (`None`: no profile applies). The decision is worked out off the async
/// threads ([`crate::blocking`]).
pub async fn verdict(
    store: &dyn Store,
    profiles: &[ToleranceProfile],
    m: &Machine,
    r: &StoredResult,
) -> Result<Option<(ToleranceProfile, Verdict)>, StoreError> {
    let Some(p) = applicable(profiles, m) else {
        return Ok(None);
    };
    let limits = limits(p)?;
    let standards = store.result_figures(&r.meta.id).await?;
    let (r, m) = (r.clone(), m.clone());
    let v = crate::blocking::run::<_, StoreError>(move || {
        assess(&r, &standards, &m).map(|(f, how)| tolerance::evaluate(&limits, &f, &how))
    })
    .await??;
    Ok(Some((p.clone(), v)))
}

/// The verdict of result `id` (`GET /api/v1/results/{id}/verdict`; reports and the
/// dashboard too).
pub async fn result_verdict(store: &dyn Store, id: &str) -> Result<ResultVerdict, DomainError> {
    let r = store.get_result(id).await?;
    let m = store.get_machine(&r.meta.machine_id).await?;
    let profiles = store.list_tolerances().await?;
    let v = verdict(store, &profiles, &m, &r).await?;
    Ok(ResultVerdict {
        result_id: r.meta.id.clone(),
        machine_id: m.id.clone(),
        profile: v.as_ref().map(|(p, _)| ProfileRef {
            id: p.id.clone(),
            scope: p.scope.clone(),
            target: p.target.clone(),
        }),
        verdict: v.map(|(_, v)| v),
    })
}
