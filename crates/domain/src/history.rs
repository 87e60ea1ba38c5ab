//! A machine's history: its results of a kind in time order, its baseline, and the
//! difference between two of its identifications.

use crate::error::DomainError;
use crate::kinds::{IDENTIFICATION, result_kind};
use crate::trends;
pub use mtcal_api::history::ResultDiff;
use mtcal_store::{Machine, ResultMeta, SkippedRow, Store};
use serde::Deserialize;

/// A machine's latest diagnosis (the last of its diagnosis results in time order): its
/// stored row and its document, or why the document does not read (said on the page,
/// never taken for "no diagnosis").
pub type LatestDiagnosis = (
    ResultMeta,
    Result<mtcal_solver::diagnosis::DiagnosisResult, String>,
);

/// Machine `id`'s latest diagnosis ([`LatestDiagnosis`]), None when it has none: its
/// findings are what the machine page shows of what the diagnosis knows.
pub async fn latest_diagnosis(
    store: &dyn Store,
    id: &str,
) -> Result<Option<LatestDiagnosis>, DomainError> {
    let list = store.list_results(id, crate::kinds::DIAGNOSIS).await?;
    let Some(meta) = list.last().cloned() else {
        return Ok(None);
    };
    let doc = store.get_result(&meta.id).await?.document;
    let doc = serde_json::from_value(doc).map_err(|e| format!("its document does not read: {e}"));
    Ok(Some((meta, doc)))
}

/// The latest diagnosis of recording `dataset_id` of machine `machine_id` (its stored
/// row), None when none was run: the diagnosis a check identified from that recording is
/// reported with.
pub async fn diagnosis_of_dataset(
    store: &dyn Store,
    machine_id: &str,
    dataset_id: &str,
) -> Result<Option<ResultMeta>, mtcal_store::StoreError> {
    let list = store
        .list_results(machine_id, crate::kinds::DIAGNOSIS)
        .await?;
    Ok(latest_of_dataset(&list, dataset_id).cloned())
}

/// The latest of `results` (time order) from recording `dataset_id`.
pub fn latest_of_dataset<'a>(
    results: &'a [ResultMeta],
    dataset_id: &str,
) -> Option<&'a ResultMeta> {
    results
        .iter()
        .rev()
        .find(|m| m.dataset_id.as_deref() == Some(dataset_id))
}

/// The misfit gate of a stored identification document when its model does not explain
/// its recording (None: it does, it has no noise floor to judge by, or the document is
/// not an identification's). Such a check is not decided: its drift is not a figure and
/// it cannot be a baseline.
pub fn misfit_gate(document: &serde_json::Value) -> Option<mtcal_solver::misfit::ModelCheck> {
    trends::model_check(document).filter(|c| c.is_misfit())
}

/// The baseline among a machine's identifications `results` (time order): its chosen
/// one, else its first check that is not a misfit ([`misfit_gate`]: nothing measured
/// against a model that does not explain its recording would be decided). None when
/// there is no check, or every check is a misfit. Reads the stored check models of the
/// checks before the first that is not a misfit (one, as a rule), no document.
pub async fn baseline<'a>(
    store: &dyn Store,
    machine: &Machine,
    results: &'a [ResultMeta],
) -> Result<Option<&'a ResultMeta>, mtcal_store::StoreError> {
    if let Some(chosen) = chosen_baseline(machine, results) {
        return Ok(Some(chosen));
    }
    for r in results {
        if !trends::stored_check_model(store, &r.id).await?.misfit {
            return Ok(Some(r));
        }
    }
    Ok(None)
}

/// [`baseline`] when the models of `results` are known ([`trends::check_models`]).
pub fn baseline_among<'a>(
    machine: &Machine,
    results: &'a [ResultMeta],
    models: &trends::CheckModels,
) -> Option<&'a ResultMeta> {
    let misfit = |r: &ResultMeta| models.get(&r.id).is_some_and(|m| m.misfit);
    chosen_baseline(machine, results).or_else(|| results.iter().find(|r| !misfit(r)))
}

/// The machine's chosen baseline among `results`, else the first of them, whatever its
/// model: the pair the store's fleet rows name (their basis).
pub fn chosen_or_first<'a>(machine: &Machine, results: &'a [ResultMeta]) -> Option<&'a ResultMeta> {
    chosen_baseline(machine, results).or(results.first())
}

/// The machine's chosen baseline among `results`, when it is one of them.
fn chosen_baseline<'a>(machine: &Machine, results: &'a [ResultMeta]) -> Option<&'a ResultMeta> {
    let chosen = machine.baseline_result_id.as_ref()?;
    results.iter().find(|r| &r.id == chosen)
}

/// The results of kind `kind` (default identification) of machine `id` in time order,
/// with the stored rows left out because they do not decode.
pub async fn results_checked(
    store: &dyn Store,
    id: &str,
    kind: Option<&str>,
) -> Result<(Vec<ResultMeta>, Vec<SkippedRow>), DomainError> {
    let kind = result_kind(kind)?;
    store.get_machine(id).await?;
    Ok(store.list_results_checked(id, kind).await?)
}

/// [`results_checked`] without the rows left out.
pub async fn results(
    store: &dyn Store,
    id: &str,
    kind: Option<&str>,
) -> Result<Vec<ResultMeta>, DomainError> {
    Ok(results_checked(store, id, kind).await?.0)
}

/// Which two results a difference compares, and on what grid.
#[derive(Debug, Clone, Default, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::IntoParams))]
#[cfg_attr(feature = "openapi", into_params(parameter_in = Query))]
pub struct DiffQuery {
    /// Baseline result (default: the machine's baseline, else its first result that is
    /// not a misfit check).
    pub baseline: Option<String>,
    /// Result compared with it (default: the latest).
    pub against: Option<String>,
    /// Grid step, mm (default 5, at least 0.001); at most 10 000 positions per term over
    /// the travel.
    #[cfg_attr(feature = "openapi", param(minimum = 0.001))]
    pub step_mm: Option<f64>,
}

/// The difference of two identifications of machine `id` (`GET …/results/diff`; the
/// dashboard's compare page too). A named result that is not one of this machine's
/// identifications is refused as a baseline change would be (a conflict when it belongs
/// to another machine).
pub async fn diff(store: &dyn Store, id: &str, q: &DiffQuery) -> Result<ResultDiff, DomainError> {
    let machine = store.get_machine(id).await?;
    let (all, skipped) = store.list_results_checked(id, IDENTIFICATION).await?;
    for rid in [q.baseline.as_ref(), q.against.as_ref()]
        .into_iter()
        .flatten()
    {
        if all.iter().any(|m| &m.id == rid) {
            continue;
        }
        let other = store.get_result(rid).await?;
        return Err(if other.meta.machine_id != id {
            DomainError::Conflict(format!(
                "result {rid} belongs to machine {}, not {id}",
                other.meta.machine_id
            ))
        } else {
            DomainError::Invalid(format!(
                "result {rid} is a {} result; the difference compares {IDENTIFICATION} results",
                other.meta.kind
            ))
        });
    }
    let pick =
        |rid: Option<&String>, default: Option<&ResultMeta>| -> Result<ResultMeta, DomainError> {
            match rid {
                Some(r) => all.iter().find(|m| &m.id == r).cloned().ok_or_else(|| {
                    DomainError::NotFound(format!("result {r} of machine {id} not found"))
                }),
                None => default
                    .cloned()
                    .ok_or_else(|| DomainError::NotFound(format!("no result for machine {id}"))),
            }
        };
    let default = baseline(store, &machine, &all).await?;
    if q.baseline.is_none() && default.is_none() && !all.is_empty() {
        return Err(DomainError::NotFound(format!(
            "no baseline for machine {id}: every check of it is a misfit (its model does not \
             explain its recording); name one with baseline="
        )));
    }
    let baseline = pick(q.baseline.as_ref(), default)?;
    let against = pick(q.against.as_ref(), all.last())?;
    let step = q.step_mm.unwrap_or(5.0);
    let (machine_id, warnings) = (
        id.to_string(),
        skipped.iter().map(SkippedRow::warning).collect(),
    );
    crate::blocking::run::<_, DomainError>(move || {
        trends::check_diff_step(&baseline.scalars, &against.scalars, step)
            .map_err(DomainError::Invalid)?;
        let (terms, squareness) = trends::diff(&baseline.scalars, &against.scalars, step);
        Ok(ResultDiff {
            machine_id,
            drift: trends::drift(&baseline.scalars, &against.scalars),
            baseline,
            against,
            terms,
            squareness,
            warnings,
        })
    })
    .await?
}
