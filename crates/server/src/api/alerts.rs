//! Drift alerts: listed (by machine, active or not) and acknowledged (rules:
//! [`crate::alerts`]).

use crate::AppState;
use crate::alerts::AlertView;
use crate::auth::{ReadKey, WriteKey};
use crate::error::{ApiError, ApiQuery, ErrorBody};
use axum::Json;
use axum::extract::{Path, State};
use serde::Deserialize;
use utoipa::IntoParams;

/// Most alerts one list returns.
pub const MAX_ALERTS: usize = 1000;

#[derive(Debug, Default, Deserialize, IntoParams)]
#[into_params(parameter_in = Query)]
pub struct AlertQuery {
    /// Only this machine's alerts.
    pub machine: Option<String>,
    /// `true`: only alerts not acknowledged; `false`: only acknowledged ones.
    pub active: Option<bool>,
    /// At most this many, newest first (default 100, at most 1000).
    pub limit: Option<usize>,
}

/// Alerts newest first (`GET /api/v1/alerts`; the dashboard's pages too).
pub async fn list_alerts(s: &AppState, q: &AlertQuery) -> Result<Vec<AlertView>, ApiError> {
    let limit = q.limit.unwrap_or(100);
    if limit == 0 || limit > MAX_ALERTS {
        return Err(ApiError::InvalidRequest(format!(
            "limit: 1 to {MAX_ALERTS}, got {limit}"
        )));
    }
    let rows = s
        .store
        .list_alerts(q.machine.as_deref(), q.active, limit as i64)
        .await?;
    Ok(rows.iter().map(AlertView::of).collect::<Result<_, _>>()?)
}

#[utoipa::path(operation_id = "alerts_list", summary = "Drift alerts, newest first", get, path = "/api/v1/alerts", tag = "alerts",
    security(("api_key" = [])), params(AlertQuery),
    responses((status = 200, body = Vec<AlertView>), (status = 400, body = ErrorBody), (status = 401, body = ErrorBody)))]
pub async fn list(
    _key: ReadKey,
    State(s): State<AppState>,
    ApiQuery(q): ApiQuery<AlertQuery>,
) -> Result<Json<Vec<AlertView>>, ApiError> {
    Ok(Json(list_alerts(&s, &q).await?))
}

/// Acknowledges alert `id` as `by` (the first acknowledgement is kept).
pub async fn acknowledge(s: &AppState, id: &str, by: &str) -> Result<AlertView, ApiError> {
    Ok(AlertView::of(&s.store.acknowledge_alert(id, by).await?)?)
}

#[utoipa::path(operation_id = "alerts_ack", summary = "Acknowledge a drift alert (who and when recorded)", post, path = "/api/v1/alerts/{id}/ack", tag = "alerts",
    security(("api_key" = [])), params(("id" = String, Path)),
    responses((status = 200, body = AlertView, description = "acknowledged (an acknowledged alert keeps its first acknowledgement)"),
              (status = 401, body = ErrorBody), (status = 403, body = ErrorBody), (status = 404, body = ErrorBody)))]
pub async fn ack(
    WriteKey(key): WriteKey,
    State(s): State<AppState>,
    Path(id): Path<String>,
) -> Result<Json<AlertView>, ApiError> {
    let by = format!("key {} ({})", key.id, key.label);
    Ok(Json(acknowledge(&s, &id, &by).await?))
}
