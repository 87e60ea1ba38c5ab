//! `/api/v1/audit` (admin): the audit trail, newest first, paged and filtered; and its
//! CSV export (rules: [`mtcal_domain::audit`]; recording: the routes that change state).

use crate::AppState;
use crate::auth::AdminKey;
use crate::error::{ApiError, ApiQuery, ErrorBody};
use axum::Json;
use axum::extract::State;
use axum::response::Response;
use mtcal_domain::audit;
pub use mtcal_domain::audit::AuditFilter;
use mtcal_store::AuditEvent;

#[utoipa::path(operation_id = "audit_list", summary = "The audit trail, newest first (admin)", get, path = "/api/v1/audit", tag = "audit",
    security(("api_key" = ["admin"])), params(AuditFilter),
    responses((status = 200, body = Vec<AuditEvent>, description = "newest first; the next page: `before` = the last `seq`"),
              (status = 400, body = ErrorBody), (status = 401, body = ErrorBody), (status = 403, body = ErrorBody)))]
pub async fn list(
    _key: AdminKey,
    State(s): State<AppState>,
    ApiQuery(f): ApiQuery<AuditFilter>,
) -> Result<Json<Vec<AuditEvent>>, ApiError> {
    Ok(Json(audit::page(s.store.as_ref(), &f).await?))
}

#[utoipa::path(operation_id = "audit_export", summary = "The audit trail as CSV (admin)", get, path = "/api/v1/audit/export", tag = "audit",
    security(("api_key" = ["admin"])), params(AuditFilter),
    responses((status = 200, description = "CSV (attachment), newest first, at most 100 000 events of the filter (`before` applies, `limit` does not); \
                                            columns seq, at, actor, actor_name, via, action, target, machine_id, client, before, after \
                                            (JSON text); a cell a spreadsheet would run as a formula starts with `'`",
               content_type = "text/csv", body = String),
              (status = 400, body = ErrorBody), (status = 401, body = ErrorBody), (status = 403, body = ErrorBody)))]
pub async fn export(
    _key: AdminKey,
    State(s): State<AppState>,
    ApiQuery(f): ApiQuery<AuditFilter>,
) -> Result<Response, ApiError> {
    let events = audit::all(s.store.as_ref(), &f).await?;
    let text =
        crate::blocking::run::<_, ApiError>(move || Ok::<_, ApiError>(audit::to_csv(&events)))
            .await??;
    Ok(super::exports::attachment(
        text,
        "text/csv; charset=utf-8",
        Some("audit.csv"),
    ))
}
