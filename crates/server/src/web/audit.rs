//! `/audit` (admin): the audit trail page, read through the same rules as
//! `GET /api/v1/audit` (`mtcal_domain::audit`).

use super::session::{Session, WebState};
use super::{PageResult, WebError, html};
use crate::error::ApiError;
use axum::extract::{Query, State};
use mtcal_domain::audit::{self, AuditFilter};
use mtcal_views::pages::audit::{AuditFilterView, AuditRow, audit_page};

/// A JSON value as the page shows it (empty: none).
fn text(v: &Option<serde_json::Value>) -> String {
    v.as_ref().map(|v| v.to_string()).unwrap_or_default()
}

/// The page of the filter (blank fields: no filter); a key below admin: 403.
pub async fn page(
    session: Session,
    State(s): State<WebState>,
    Query(mut f): Query<AuditFilter>,
) -> PageResult {
    if !session.key.scope.allows(mtcal_store::Scope::Admin) {
        return Err(WebError(ApiError::Forbidden(format!(
            "the audit trail needs a key with scope admin; key {} has scope {}",
            session.key.prefix,
            session.key.scope.as_str()
        ))));
    }
    for field in [
        &mut f.machine,
        &mut f.actor,
        &mut f.action,
        &mut f.since,
        &mut f.until,
    ] {
        if field.as_deref().is_some_and(|v| v.trim().is_empty()) {
            *field = None;
        }
    }
    let events = crate::api::audit::page_within(&s.app, &f, &session.key).await?;
    let full = events.len() == f.limit.unwrap_or(audit::DEFAULT_EVENTS);
    let rows: Vec<AuditRow> = events
        .iter()
        .map(|e| AuditRow {
            seq: e.seq,
            at: e.at.clone(),
            actor_name: e.event.actor_name.clone(),
            via: e.event.via.clone(),
            action: e.event.action.clone(),
            target: e.event.target.clone(),
            machine_id: e.event.machine_id.clone(),
            client: e.event.client.clone(),
            before: text(&e.event.before),
            after: text(&e.event.after),
        })
        .collect();
    let shown = AuditFilterView {
        machine: f.machine.unwrap_or_default(),
        actor: f.actor.unwrap_or_default(),
        action: f.action.unwrap_or_default(),
        since: f.since.unwrap_or_default(),
        until: f.until.unwrap_or_default(),
    };
    Ok(html(audit_page(&session.viewer(), &rows, &shown, full)))
}
