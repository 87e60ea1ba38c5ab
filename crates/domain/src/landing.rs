//! What follows when an identification result lands (the worker, after storing it): the
//! machine's fleet row is refreshed, then the drift alert check runs; a result whose
//! model does not explain its recording gets a diagnosis of its dataset queued. When a
//! diagnosis lands, the machine's fleet row is refreshed (it shows the findings).

use crate::alerts::{self, AlertView};
use crate::fleet;
use mtcal_solver::identification::IdentificationResult;
use mtcal_store::{Job, JobKind, JobState, NewJob, Store, StoreError};
use std::sync::Arc;

/// An identification `result_id` of machine `machine_id` has landed: its drift row is
/// refreshed ([`fleet::refresh_machine`]), then the drift alert check runs
/// ([`alerts::check_landed`], its webhooks' deliveries stored with it); the alert
/// raised, if any.
pub async fn result_landed(
    store: &Arc<dyn Store>,
    machine_id: &str,
    result_id: &str,
) -> Result<Option<AlertView>, StoreError> {
    fleet::refresh_machine(store.as_ref(), machine_id).await?;
    alerts::check_landed(store, machine_id, result_id).await
}

/// A diagnosis of machine `machine_id` has landed: the machine's fleet row is refreshed,
/// so that its findings reach the fleet (a machine without an identification has no row
/// and keeps none).
pub async fn diagnosis_landed(store: &dyn Store, machine_id: &str) -> Result<(), StoreError> {
    fleet::refresh_machine(store, machine_id).await
}

/// Most jobs of one state read to see whether a diagnosis of a dataset is already queued
/// or running (the queue's newest first; an older one beyond it is not seen, and a second
/// diagnosis of the same recording is then queued: harmless, only work).
const JOBS_SEEN: i64 = 1000;

/// When identification `result_id` is a misfit (its model does not explain its
/// recording, [`IdentificationResult::model_check`], which gates a document of an earlier
/// version too) and came from a session dataset that is not excluded, a
/// diagnosis of that dataset is queued (`max_attempts` tries), unless one is already
/// stored, queued or running: its findings (a backlash of 6 µm on X, …) then reach the
/// result page, the check report and the machine page without anyone asking. The job
/// queued, if any.
pub async fn queue_diagnosis(
    store: &dyn Store,
    result_id: &str,
    max_attempts: i64,
) -> Result<Option<Job>, StoreError> {
    let r = store.get_result(result_id).await?;
    let Some(dataset_id) = r.meta.dataset_id.clone() else {
        return Ok(None);
    };
    match serde_json::from_value::<IdentificationResult>(r.document) {
        Ok(doc) if doc.model_check().is_misfit() => {}
        Ok(_) => return Ok(None),
        Err(e) => {
            tracing::warn!(result = %result_id, %e, "not an identification document: no misfit diagnosis");
            return Ok(None);
        }
    }
    let ds = store.get_dataset(&dataset_id).await?;
    if ds.excluded.is_some() || !JobKind::Diagnose.accepts(&ds.kind) {
        return Ok(None);
    }
    let stored = store
        .list_results(&r.meta.machine_id, JobKind::Diagnose.result_kind())
        .await?;
    if stored
        .iter()
        .any(|m| m.dataset_id.as_deref() == Some(dataset_id.as_str()))
    {
        return Ok(None);
    }
    for state in [JobState::Queued, JobState::Running] {
        let jobs = store.list_jobs(Some(state), JOBS_SEEN).await?;
        if jobs.iter().any(|j| {
            j.kind == JobKind::Diagnose && j.dataset_id.as_deref() == Some(dataset_id.as_str())
        }) {
            return Ok(None);
        }
    }
    let job = store
        .enqueue(NewJob {
            kind: JobKind::Diagnose,
            machine_id: Some(r.meta.machine_id.clone()),
            dataset_id: Some(dataset_id),
            params: serde_json::json!({}),
            max_attempts,
        })
        .await?;
    Ok(Some(job))
}
