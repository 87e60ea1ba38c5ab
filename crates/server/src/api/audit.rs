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
use mtcal_store::{ApiKey, AuditEvent};

#[utoipa::path(operation_id = "audit_list", summary = "The audit trail, newest first (admin)", get, path = "/api/v1/audit", tag = "audit",
    security(("api_key" = ["admin"])), params(AuditFilter),
    responses((status = 200, body = Vec<AuditEvent>, description = "newest first; the next page: `before` = the last `seq`"),
              (status = 400, body = ErrorBody), (status = 401, body = ErrorBody), (status = 403, body = ErrorBody)))]
pub async fn list(
    AdminKey(key): AdminKey,
    State(s): State<AppState>,
    ApiQuery(f): ApiQuery<AuditFilter>,
) -> Result<Json<Vec<AuditEvent>>, ApiError> {
    Ok(Json(page_within(&s, &f, &key).await?))
}

/// One page of the trail as `key` may read it (the API's page; the dashboard's): a key
/// limited to sites or tags reads the events of its machines only, page after page of
/// the whole trail until its page is full or the trail ends.
pub async fn page_within(
    s: &AppState,
    f: &AuditFilter,
    key: &ApiKey,
) -> Result<Vec<AuditEvent>, ApiError> {
    let Some(ids) = crate::auth::scope::Within(key).machine_ids(s).await? else {
        return Ok(audit::page(s.store.as_ref(), f).await?);
    };
    let limit = mtcal_domain::paging::limit(f.limit, audit::DEFAULT_EVENTS, audit::MAX_EVENTS)?;
    let mut q = AuditFilter {
        limit: Some(audit::MAX_EVENTS),
        ..f.clone()
    };
    let mut out = Vec::new();
    loop {
        let page = audit::page(s.store.as_ref(), &q).await?;
        let done = page.len() < audit::MAX_EVENTS;
        q.before = page.last().map(|e| e.seq);
        out.extend(page.into_iter().filter(|e| in_scope(e, &ids)));
        if done || out.len() >= limit {
            break;
        }
    }
    out.truncate(limit);
    Ok(out)
}

/// Whether an event concerns one of `ids`' machines.
fn in_scope(e: &AuditEvent, ids: &std::collections::HashSet<String>) -> bool {
    e.event.machine_id.as_ref().is_some_and(|m| ids.contains(m))
}

#[utoipa::path(operation_id = "audit_export", summary = "The audit trail as CSV (admin)", get, path = "/api/v1/audit/export", tag = "audit",
    security(("api_key" = ["admin"])), params(AuditFilter),
    responses((status = 200, description = "CSV (attachment), newest first, at most 100 000 events of the filter (`before` applies, `limit` does not); \
                                            columns seq, at, actor, actor_name, via, action, target, machine_id, client, before, after \
                                            (JSON text); a cell a spreadsheet would run as a formula starts with `'`",
               content_type = "text/csv", body = String),
              (status = 400, body = ErrorBody), (status = 401, body = ErrorBody), (status = 403, body = ErrorBody)))]
pub async fn export(
    AdminKey(key): AdminKey,
    State(s): State<AppState>,
    ApiQuery(f): ApiQuery<AuditFilter>,
) -> Result<Response, ApiError> {
    let mut events = audit::all(s.store.as_ref(), &f).await?;
    if let Some(ids) = crate::auth::scope::Within(&key).machine_ids(&s).await? {
        events.retain(|e| in_scope(e, &ids));
    }
    let text =
        crate::blocking::run::<_, ApiError>(move || Ok::<_, ApiError>(audit::to_csv(&events)))
            .await??;
    Ok(super::exports::attachment(
        text,
        "text/csv; charset=utf-8",
        Some("audit.csv"),
    ))
}
