//! Drift alerts: listed (by machine, active or not) and acknowledged (rules:
//! [`mtcal_domain::alerts`]).

use crate::AppState;
use crate::audit::{Actor, Change, json};
use crate::auth::{ReadKey, WriteKey};
use crate::error::{ApiError, ApiQuery, ErrorBody};
use axum::Json;
use axum::extract::{Path, State};
use mtcal_domain::alerts;
pub use mtcal_domain::alerts::{Acknowledgement, AlertQuery, AlertView, MAX_ALERTS};

#[utoipa::path(operation_id = "alerts_list", summary = "Drift alerts, newest first", get, path = "/api/v1/alerts", tag = "alerts",
    security(("api_key" = [])), params(AlertQuery),
    responses((status = 200, body = Vec<AlertView>), (status = 400, body = ErrorBody), (status = 401, body = ErrorBody)))]
pub async fn list(
    ReadKey(key): ReadKey,
    State(s): State<AppState>,
    ApiQuery(q): ApiQuery<AlertQuery>,
) -> Result<Json<Vec<AlertView>>, ApiError> {
    Ok(Json(list_within(&s, &q, &key).await?))
}

/// The alerts of `q` within `key`'s scope (the API's list; the dashboard's pages): for a
/// scoped key, its machines' among the newest [`MAX_ALERTS`].
pub async fn list_within(
    s: &AppState,
    q: &AlertQuery,
    key: &mtcal_store::ApiKey,
) -> Result<Vec<AlertView>, ApiError> {
    let Some(ids) = crate::auth::scope::Within(key).machine_ids(s).await? else {
        return Ok(alerts::list(s.store.as_ref(), q).await?);
    };
    let limit = mtcal_domain::paging::limit(q.limit, 100, MAX_ALERTS)?;
    let wide = AlertQuery {
        limit: Some(MAX_ALERTS),
        ..q.clone()
    };
    let mut list = alerts::list(s.store.as_ref(), &wide).await?;
    list.retain(|a| ids.contains(&a.raised.machine_id));
    list.truncate(limit);
    Ok(list)
}

#[utoipa::path(operation_id = "alerts_ack", summary = "Acknowledge a drift alert (who, when and a comment recorded)", post, path = "/api/v1/alerts/{id}/ack", tag = "alerts",
    security(("api_key" = ["write"])), params(("id" = String, Path)),
    request_body(content = Acknowledgement, content_type = "application/json", description = "optional: the comment (an empty body acknowledges without one)"),
    responses((status = 200, body = AlertView, description = "acknowledged (an acknowledged alert keeps its first acknowledgement)"),
              (status = 400, body = ErrorBody), (status = 401, body = ErrorBody), (status = 403, body = ErrorBody), (status = 404, body = ErrorBody)))]
pub async fn ack(
    _key: WriteKey,
    who: Actor,
    State(s): State<AppState>,
    Path(id): Path<String>,
    headers: axum::http::HeaderMap,
    body: axum::body::Bytes,
) -> Result<Json<AlertView>, ApiError> {
    if let Some(t) = headers.get(axum::http::header::CONTENT_TYPE)
        && !t.as_bytes().starts_with(b"application/json")
    {
        return Err(ApiError::UnsupportedMediaType(
            "the acknowledgement's body is JSON (`{\"comment\": \"…\"}`) or empty".into(),
        ));
    }
    let ack: Acknowledgement = if body.iter().all(u8::is_ascii_whitespace) {
        Acknowledgement::default()
    } else {
        serde_json::from_slice(&body).map_err(|e| ApiError::InvalidRequest(format!("body: {e}")))?
    };
    Ok(Json(
        acknowledge(&s, &id, &who, ack.comment.as_deref()).await?,
    ))
}

/// Acknowledges an alert as `who` and records it (`POST /api/v1/alerts/{id}/ack`; the
/// dashboard's button).
pub async fn acknowledge(
    s: &AppState,
    id: &str,
    who: &Actor,
    comment: Option<&str>,
) -> Result<AlertView, ApiError> {
    let before = AlertView::of(&s.store.get_alert(id).await?)?;
    let after = alerts::acknowledge(s.store.as_ref(), id, &who.by, comment).await?;
    let change = Change {
        action: "alert.ack",
        target: &after.raised.id,
        machine: Some(&after.raised.machine_id),
        before: json(&before),
        after: json(&after),
    };
    who.record(s.store.as_ref(), change).await?;
    Ok(after)
}
