//! History by machine: all results in time order, the latest, one result, and the
//! difference from a baseline.

use crate::AppState;
use crate::audit::{Actor, Change, json};
use crate::auth::{ReadKey, WriteKey};
use crate::error::{ApiError, ApiJson, ApiQuery, ErrorBody};
use axum::Json;
use axum::extract::{Path, State};
pub use mtcal_api::history::Reason;
use mtcal_domain::history;
pub use mtcal_domain::history::{DiffQuery, ResultDiff};
pub use mtcal_domain::verification::{Verification, VerifiedFinding};
use mtcal_store::{Figure, ResultMeta, SetAside, SkippedRow, StoredResult};
use serde::Deserialize;
use utoipa::IntoParams;

#[derive(Debug, Deserialize, IntoParams)]
#[into_params(parameter_in = Query)]
pub struct KindQuery {
    /// Result kind: `identification` (default), `diagnosis`, `cradle`, `standards` or
    /// `sensitivity`.
    #[param(pattern = "^(identification|diagnosis|cradle|standards|sensitivity)$")]
    pub kind: Option<String>,
}

#[utoipa::path(operation_id = "history_list", summary = "A machine's results in time order", get, path = "/api/v1/machines/{id}/results", tag = "history",
    security(("api_key" = [])), params(("id" = String, Path), KindQuery),
    responses((status = 200, body = Vec<ResultMeta>, description = "in time order (measured_at)",
               headers(("x-mtcal-warning" = String, description = "present when stored results were left out because their rows do not decode: one sentence each, naming the result, separated by `; `"))),
              (status = 400, body = ErrorBody), (status = 404, body = ErrorBody)))]
pub async fn list(
    _key: ReadKey,
    State(s): State<AppState>,
    Path(id): Path<String>,
    ApiQuery(q): ApiQuery<KindQuery>,
) -> Result<(axum::http::HeaderMap, Json<Vec<ResultMeta>>), ApiError> {
    let (list, skipped) =
        history::results_checked(s.store.as_ref(), &id, q.kind.as_deref()).await?;
    let mut headers = axum::http::HeaderMap::new();
    if !skipped.is_empty() {
        let text: Vec<String> = skipped.iter().map(SkippedRow::warning).collect();
        // Header values are visible ASCII.
        let text: String = text
            .join("; ")
            .chars()
            .map(|c| {
                if c.is_ascii_graphic() || c == ' ' {
                    c
                } else {
                    '?'
                }
            })
            .take(4096)
            .collect();
        if let Ok(v) = axum::http::HeaderValue::from_str(&text) {
            headers.insert("x-mtcal-warning", v);
        }
    }
    Ok((headers, Json(list)))
}

#[utoipa::path(operation_id = "history_latest", summary = "A machine's latest result", get, path = "/api/v1/machines/{id}/results/latest", tag = "history",
    security(("api_key" = [])), params(("id" = String, Path), KindQuery),
    responses((status = 200, body = crate::contract::StoredResultSchema), (status = 400, body = ErrorBody),
              (status = 404, body = ErrorBody)))]
pub async fn latest(
    _key: ReadKey,
    State(s): State<AppState>,
    Path(id): Path<String>,
    ApiQuery(q): ApiQuery<KindQuery>,
) -> Result<Json<StoredResult>, ApiError> {
    s.store.get_machine(&id).await?;
    let last = s
        .store
        .list_results(&id, mtcal_domain::kinds::result_kind(q.kind.as_deref())?)
        .await?
        .pop()
        .ok_or_else(|| ApiError::NotFound(format!("no result for machine {id}")))?;
    Ok(Json(s.store.get_result(&last.id).await?))
}

#[utoipa::path(operation_id = "history_get", summary = "A stored result", get, path = "/api/v1/results/{id}", tag = "history",
    security(("api_key" = [])), params(("id" = String, Path)),
    responses((status = 200, body = crate::contract::StoredResultSchema), (status = 404, body = ErrorBody)))]
pub async fn get(
    _key: ReadKey,
    State(s): State<AppState>,
    Path(id): Path<String>,
) -> Result<Json<StoredResult>, ApiError> {
    Ok(Json(s.store.get_result(&id).await?))
}

#[utoipa::path(operation_id = "history_figures", summary = "The named figures of a result", get, path = "/api/v1/results/{id}/figures", tag = "history",
    security(("api_key" = [])), params(("id" = String, Path)),
    responses((status = 200, body = Vec<Figure>, description = "the result's named figures (standards), by name"),
              (status = 404, body = ErrorBody)))]
pub async fn figures(
    _key: ReadKey,
    State(s): State<AppState>,
    Path(id): Path<String>,
) -> Result<Json<Vec<Figure>>, ApiError> {
    Ok(Json(s.store.result_figures(&id).await?))
}

#[utoipa::path(operation_id = "history_verification", summary = "A check verified against the predictions of the check before it", get, path = "/api/v1/results/{id}/verification", tag = "history",
    security(("api_key" = [])), params(("id" = String, Path)),
    responses((status = 200, body = Verification, description = "per finding of the previous check with a predicted residual after compensation \
                                                                  (a backlash: 0): still present or gone at this check, measured against \
                                                                  predicted; empty findings with the reason when there is nothing to verify"),
              (status = 409, body = ErrorBody, description = "conflict: not an identification result"),
              (status = 404, body = ErrorBody)))]
pub async fn verification(
    _key: ReadKey,
    State(s): State<AppState>,
    Path(id): Path<String>,
) -> Result<Json<Verification>, ApiError> {
    Ok(Json(
        mtcal_domain::verification::verification(s.store.as_ref(), &id).await?,
    ))
}

#[utoipa::path(operation_id = "history_diff", summary = "Difference of a result from the baseline, term by term", get, path = "/api/v1/machines/{id}/results/diff", tag = "history",
    security(("api_key" = [])), params(("id" = String, Path), DiffQuery),
    responses((status = 200, body = ResultDiff), (status = 400, body = ErrorBody), (status = 404, body = ErrorBody), (status = 409, body = ErrorBody, description = "a named result belongs to another machine")))]
pub async fn diff(
    _key: ReadKey,
    State(s): State<AppState>,
    Path(id): Path<String>,
    ApiQuery(q): ApiQuery<DiffQuery>,
) -> Result<Json<ResultDiff>, ApiError> {
    Ok(Json(history::diff(s.store.as_ref(), &id, &q).await?))
}

/// The reason trimmed, checked (1 to 1000 characters), with who gives it: `key ID
/// (LABEL)`, as every exclusion and deletion records it.
pub fn recorded<'a>(r: &'a Reason, key: &mtcal_store::ApiKey) -> Result<Recorded<'a>, ApiError> {
    let reason = r.reason.trim();
    if reason.is_empty() || reason.chars().count() > 1000 {
        return Err(ApiError::InvalidRequest(
            "reason: say why, in 1 to 1000 characters".into(),
        ));
    }
    Ok(Recorded {
        by: format!("key {} ({})", key.id, key.label),
        reason,
    })
}

/// A checked reason with who gives it ([`recorded`]).
pub struct Recorded<'a> {
    by: String,
    reason: &'a str,
}

impl Recorded<'_> {
    /// The record as the store takes it.
    pub fn set_aside(&self) -> SetAside<'_> {
        SetAside {
            by: &self.by,
            reason: self.reason,
        }
    }
}

/// Excludes a result from the machine's history: it stays stored and readable here, with
/// who excluded it, when and why, but no list, trend, difference, drift or figure trend
/// uses it any more (a check with a wrong setup, or one whose figures would mislead).
/// The fleet's drift of the machine is recomputed at once.
#[utoipa::path(operation_id = "history_exclude", summary = "Exclude a result from the history (recorded)", post, path = "/api/v1/results/{id}/exclude", tag = "history",
    security(("api_key" = ["write"])), params(("id" = String, Path)), request_body = Reason,
    responses((status = 200, body = ResultMeta), (status = 400, body = ErrorBody), (status = 401, body = ErrorBody),
              (status = 403, body = ErrorBody), (status = 404, body = ErrorBody)))]
pub async fn exclude(
    WriteKey(key): WriteKey,
    who: Actor,
    State(s): State<AppState>,
    Path(id): Path<String>,
    ApiJson(body): ApiJson<Reason>,
) -> Result<Json<ResultMeta>, ApiError> {
    let why = recorded(&body, &key)?;
    let before = s.store.get_result(&id).await?.meta;
    let meta = s.store.exclude_result(&id, why.set_aside()).await?;
    let change = Change {
        action: "result.exclude",
        target: &meta.id,
        machine: Some(&meta.machine_id),
        before: json(&before),
        after: json(&meta),
    };
    who.record(s.store.as_ref(), change).await?;
    mtcal_domain::fleet::refresh_machine(s.store.as_ref(), &meta.machine_id).await?;
    Ok(Json(meta))
}
