//! What follows when an identification result lands (the worker, after storing it): the
//! machine's fleet row is refreshed, then the drift alert check runs; a result whose
//! model does not explain its recording gets a diagnosis of its dataset queued.

use crate::alerts::{self, AlertView};
use crate::fleet;
use mtcal_solver::misfit::ModelCheck;
use mtcal_store::{Job, JobKind, JobState, NewJob, Store, StoreError};
use std::sync::Arc;

/// An identification `result_id` of machine `machine_id` has landed: its drift row is
/// refreshed ([`fleet::refresh_machine`]), then the drift alert check runs
/// ([`alerts::check_landed`], its webhooks delivered where `webhooks` allows); the alert
/// raised, if any.
pub async fn result_landed(
    store: &Arc<dyn Store>,
    machine_id: &str,
    result_id: &str,
    webhooks: &crate::webhooks::TargetPolicy,
) -> Result<Option<AlertView>, StoreError> {
    fleet::refresh_machine(store.as_ref(), machine_id).await?;
    alerts::check_landed(store, machine_id, result_id, webhooks).await
}

/// Most jobs of one state read to see whether a diagnosis of a dataset is already queued
/// or running (the queue's newest first; an older one beyond it is not seen, and a second
/// diagnosis of the same recording is then queued: harmless, only work).
const JOBS_SEEN: i64 = 1000;

/// The misfit gate's outcome of a stored identification document: its `model_check`, or
/// for a document of an earlier version the gate worked out from its fit's residual and
/// noise floor (`mtcal_solver::misfit`).
pub fn model_check(document: &serde_json::Value) -> Option<ModelCheck> {
    if let Some(m) = document.get("model_check") {
        return serde_json::from_value(m.clone()).ok();
    }
    let fit = document.get("fit")?;
    let residual = fit.get("residual_rms_um")?.as_f64()?;
    let floor = fit.get("noise_estimate_um").and_then(|v| v.as_f64());
    Some(ModelCheck::of(residual, floor))
}

/// When identification `result_id` is a misfit (its model does not explain its
/// recording, [`model_check`]) and came from a session dataset that is not excluded, a
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
    if !model_check(&r.document).is_some_and(|m| m.is_misfit()) {
        return Ok(None);
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
