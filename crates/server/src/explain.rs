//! The explained model in the service: when a session diagnosis that explains a check's
//! misfit lands, the check is fitted again as the explained model and stored beside the
//! original, which every page, route and export then reads in its place
//! (docs/compensation.md, "The explained model in the service").
//!
//! | step | what happens |
//! |---|---|
//! | trigger | a `diagnose` job of a session succeeds with verdict `explained` or `partly_explained` |
//! | which check | the machine's latest identification of the same dataset, not excluded, a misfit, not itself an explained model |
//! | the fit | [`crate::jobs::explain`]: the 21 terms with the diagnosis's findings, the original job's identify parameters (defaults for an import) |
//! | stored | a new `identification` result of the same dataset and time (an `import` job), its `explained` naming the original and the diagnosis |
//! | the original | excluded from the history by [`BY`], the reason naming the new result: kept, readable by id |
//! | then | what follows any landed check ([`mtcal_domain::landing::result_landed`]): fleet row, drift alerts |
//!
//! | after a crash | at start, [`catch_up`] runs the landing of every stored session diagnosis whose check is still a misfit without its explained model, and finishes an exclusion a crash left undone |
//! | once | the landings of one process run one at a time, and each does nothing when the check's explained model is stored; across processes the store claims the check ([`Store::import_explained`], a unique index on the check an explained model explains): of two landings storing one at the same moment, the second stores nothing and is no error |
//!
//! An `explained` diagnosis whose model leaves the residual at noise level gives a check
//! decided on the explained model; a `partly_explained` one (or a residual still above
//! the gate) gives a check that stays not decided and whose `model_check` says what
//! remains.

use crate::ingest::UploadLimits;
use crate::jobs::{self, ExplainedLink, JobError, JobInput, JobKind};
use mtcal_domain::history::latest_of_dataset;
use mtcal_domain::kinds::{DIAGNOSIS, IDENTIFICATION};
use mtcal_solver::diagnosis::{DiagnosisResult, Verdict};
use mtcal_solver::identification::IdentificationResult;
use mtcal_store::{NewResult, ResultMeta, SetAside, Store, StoreError};
use std::collections::HashSet;
use std::sync::Arc;

/// Who excludes the superseded check (the exclusion's `by`).
pub const BY: &str = "mtcal (explained model)";

/// Why the explained model was not made.
#[derive(Debug, thiserror::Error)]
pub enum ExplainError {
    #[error(transparent)]
    Store(#[from] StoreError),
    #[error("{0}")]
    Job(#[from] JobError),
}

/// The landings of this process, one at a time: the worker's and [`catch_up`]'s of one
/// diagnosis cannot both store its explained model.
static LANDING: tokio::sync::Mutex<()> = tokio::sync::Mutex::const_new(());

/// Diagnosis `diagnosis_id` has landed: when it explains (fully or partly) the misfit of
/// a check of the same session, that check's explained model is stored and the original
/// excluded (module docs). The explained result stored, if any; nothing when it is
/// stored already (an exclusion a crash left undone is finished).
pub async fn diagnosis_landed(
    store: &Arc<dyn Store>,
    limits: UploadLimits,
    diagnosis_id: &str,
) -> Result<Option<ResultMeta>, ExplainError> {
    let _one = LANDING.lock().await;
    land(store, limits, diagnosis_id).await
}

/// [`diagnosis_landed`], its lock held.
async fn land(
    store: &Arc<dyn Store>,
    limits: UploadLimits,
    diagnosis_id: &str,
) -> Result<Option<ResultMeta>, ExplainError> {
    let d = store.get_result(diagnosis_id).await?;
    let Some(dataset_id) = d.meta.dataset_id.clone() else {
        return Ok(None);
    };
    let Ok(diagnosis) = serde_json::from_value::<DiagnosisResult>(d.document) else {
        return Ok(None);
    };
    let explains = matches!(
        diagnosis.verdict,
        Verdict::Explained | Verdict::PartlyExplained
    );
    if diagnosis.source != "session" || !explains || diagnosis.findings.is_empty() {
        return Ok(None);
    }
    let machine_id = d.meta.machine_id.clone();
    let checks = store.list_results(&machine_id, IDENTIFICATION).await?;
    let Some(original) = latest_of_dataset(&checks, &dataset_id) else {
        return Ok(None);
    };
    let stored = store.get_result(&original.id).await?;
    match serde_json::from_value::<IdentificationResult>(stored.document) {
        Ok(doc) if doc.explained.is_none() && doc.model_check().is_misfit() => {}
        Ok(doc) => {
            // Its explained model: a crash may have come before its original was excluded.
            let decided = doc.model_check().decided_on_explained_model();
            let Some(e) = doc.explained else {
                return Ok(None);
            };
            let was = e.original_result_id.as_deref();
            if let Some(was) = was.filter(|w| checks.iter().any(|c| c.id == *w)) {
                let by = e.diagnosis_result_id.as_deref().unwrap_or(diagnosis_id);
                set_aside(store, &machine_id, (was, by), original, decided).await?;
            }
            return Ok(None);
        }
        Err(_) => return Ok(None),
    }
    // The original's identify parameters (an imported check: the defaults).
    let params = match store.get_job(&original.job_id).await {
        Ok(j) if j.kind == JobKind::Identify => j.params,
        _ => serde_json::json!({}),
    };
    let input = JobInput {
        kind: JobKind::Identify,
        params,
        machine: Some(store.get_machine(&machine_id).await?),
        dataset: Some((
            store.get_dataset(&dataset_id).await?,
            store.dataset_files(&dataset_id).await?,
        )),
        limits,
    };
    let original_id = original.id.clone();
    let link_ids = (original_id.clone(), diagnosis_id.to_string());
    let out = tokio::task::spawn_blocking(move || {
        let link = ExplainedLink {
            original: &link_ids.0,
            diagnosis: &link_ids.1,
        };
        jobs::explain(&input, &diagnosis, link)
    })
    .await
    .map_err(|e| JobError::Transient(format!("the explained model's fit panicked: {e}")))??;
    let decided = serde_json::from_value::<IdentificationResult>(out.document.clone())
        .map(|r| r.model_check().decided_on_explained_model())
        .unwrap_or(false);
    // Another process (a worker of its own, or one that started) may have stored it
    // during the fit, or store it now: the store's claim on the original stores one.
    let explained = NewResult {
        machine_id: machine_id.clone(),
        dataset_id: Some(dataset_id),
        kind: IDENTIFICATION.to_string(),
        measured_at: out.measured_at,
        check_model: Some(mtcal_domain::trends::check_model(&out.document)),
        document: out.document,
        scalars: out.scalars,
        figures: out.figures,
    };
    let Some(meta) = store.import_explained(&original_id, explained).await? else {
        return Ok(None);
    };
    set_aside(
        store,
        &machine_id,
        (&original_id, diagnosis_id),
        &meta,
        decided,
    )
    .await?;
    Ok(Some(meta))
}

/// Excludes the original check of `link` (its id, the diagnosis's), superseded by its
/// explained model `explained`, then runs what follows a landed check for it.
async fn set_aside(
    store: &Arc<dyn Store>,
    machine_id: &str,
    (original_id, diagnosis_id): (&str, &str),
    explained: &ResultMeta,
    decided: bool,
) -> Result<(), ExplainError> {
    let reason = if decided {
        format!(
            "superseded by result {}: the explained model of the same recording (diagnosis {diagnosis_id}), on which the check is decided",
            explained.id
        )
    } else {
        format!(
            "superseded by result {}: the explained model of the same recording (diagnosis {diagnosis_id}); it explains the misfit only partly and says what remains",
            explained.id
        )
    };
    store
        .exclude_result(
            original_id,
            SetAside {
                by: BY,
                reason: &reason,
            },
        )
        .await?;
    if let Err(e) = mtcal_domain::landing::result_landed(store, machine_id, &explained.id).await {
        tracing::warn!(machine = %machine_id, %e, "fleet drift or drift alerts not refreshed after the explained model");
    }
    Ok(())
}

/// Most machines read per page by [`catch_up`].
const MACHINES_PER_PAGE: i64 = 1000;

/// What a crash between a diagnosis landing and its explained fit left undone, done at
/// start: for every machine, the latest diagnosis of each session whose check is still
/// listed is landed again ([`diagnosis_landed`]: nothing when the check is no misfit or
/// its explained model is stored). The explained results stored.
pub async fn catch_up(
    store: &Arc<dyn Store>,
    limits: UploadLimits,
) -> Result<Vec<ResultMeta>, ExplainError> {
    let mut made = Vec::new();
    let mut after: Option<String> = None;
    loop {
        let page = store
            .list_machines(after.as_deref(), MACHINES_PER_PAGE)
            .await?;
        for m in &page {
            let diagnoses = store.list_results(&m.id, DIAGNOSIS).await?;
            if diagnoses.is_empty() {
                continue;
            }
            let checks = store.list_results(&m.id, IDENTIFICATION).await?;
            let checked: HashSet<&str> = checks
                .iter()
                .filter_map(|c| c.dataset_id.as_deref())
                .collect();
            let mut seen = HashSet::new();
            for d in diagnoses.iter().rev() {
                let Some(ds) = d.dataset_id.as_deref() else {
                    continue;
                };
                if !checked.contains(ds) || !seen.insert(ds) {
                    continue;
                }
                match diagnosis_landed(store, limits, &d.id).await {
                    Ok(Some(r)) => made.push(r),
                    Ok(None) => {}
                    Err(e) => {
                        tracing::warn!(diagnosis = %d.id, %e, "the explained model was not made at start")
                    }
                }
            }
        }
        match page.last() {
            Some(m) if page.len() as i64 == MACHINES_PER_PAGE => after = Some(m.id.clone()),
            _ => return Ok(made),
        }
    }
}
