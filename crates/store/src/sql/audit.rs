//! The statements of [`crate::Audit`]: an insert and a filtered read, nothing else (the
//! table's triggers refuse any other change).

use super::Backend;
use crate::audit::{AuditEvent, AuditQuery, NewAuditEvent};
use crate::error::Db as _;
use crate::rows::{self, AUDIT_COLUMNS};
use crate::{Audit, StoreFuture, now_rfc3339};

/// A JSON value as stored (text), `None` kept as SQL `NULL`.
fn json_text(v: &Option<serde_json::Value>) -> Option<String> {
    v.as_ref().map(serde_json::Value::to_string)
}

impl Audit for Backend {
    fn record_audit<'a>(&'a self, e: &'a NewAuditEvent) -> StoreFuture<'a, AuditEvent> {
        Box::pin(async move {
            let at = now_rfc3339();
            let q = format!(
                "INSERT INTO audit_events (at, actor, actor_name, via, action, target, \
                 machine_id, before_json, after_json, client) \
                 VALUES ($1, $2, $3, $4, $5, $6, $7, $8, $9, $10) RETURNING {AUDIT_COLUMNS}"
            );
            let row = run!(
                fetch_one(&self.pool),
                sqlx::AssertSqlSafe(q),
                &at,
                &e.actor,
                &e.actor_name,
                &e.via,
                &e.action,
                &e.target,
                &e.machine_id,
                json_text(&e.before),
                json_text(&e.after),
                &e.client
            )?;
            rows::audit_event(&row)
        })
    }

    fn list_audit<'a>(&'a self, q: &'a AuditQuery) -> StoreFuture<'a, Vec<AuditEvent>> {
        Box::pin(async move {
            let sql = format!(
                "SELECT {AUDIT_COLUMNS} FROM audit_events \
                 WHERE ($1 IS NULL OR machine_id = $1) \
                 AND ($2 IS NULL OR actor = $2 OR actor_name = $2) \
                 AND ($3 IS NULL OR action = $3) AND ($4 IS NULL OR at >= $4) \
                 AND ($5 IS NULL OR at < $5) AND ($6 IS NULL OR seq < $6) \
                 ORDER BY seq DESC LIMIT $7"
            );
            run!(
                fetch_all(&self.pool),
                sqlx::AssertSqlSafe(sql),
                &q.machine_id,
                &q.actor,
                &q.action,
                &q.since,
                &q.until,
                q.before,
                q.limit
            )?
            .iter()
            .map(rows::audit_event)
            .collect()
        })
    }
}
