//! The audit trail: [`Audit`], an append-only record of every change of state a person
//! made through the service (its API and dashboard) or with `mtcal admin` on the database
//! (who, what, before and after, when, from where).
//!
//! Append-only is the database's rule, not only this crate's: the migration's triggers
//! refuse every `UPDATE` and `DELETE` of `audit_events` on both backends (and `TRUNCATE`
//! on PostgreSQL), so that no statement of the service, nor anyone with the service's
//! database role, rewrites a row without dropping the triggers first.

use crate::StoreFuture;
use serde::{Deserialize, Serialize};
use serde_json::Value;

/// Keeps the audit trail. Implementations only ever insert.
pub trait Audit: Send + Sync {
    /// Appends one event; answers it with its place in the trail and its time.
    fn record_audit<'a>(&'a self, e: &'a NewAuditEvent) -> StoreFuture<'a, AuditEvent>;

    /// Events newest first, filtered and paged by `q`.
    fn list_audit<'a>(&'a self, q: &'a AuditQuery) -> StoreFuture<'a, Vec<AuditEvent>>;
}

/// One event of the audit trail.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct AuditEvent {
    /// Its place in the trail: increasing, never reused (the page cursor `before`).
    pub seq: i64,
    /// When it was recorded (RFC 3339 UTC, milliseconds).
    pub at: String,
    #[serde(flatten)]
    pub event: NewAuditEvent,
}

/// An event about to be recorded.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct NewAuditEvent {
    /// Who: the id of the API key (a dashboard session acts as the key it signed in
    /// with); empty when no key was recognised (a failed sign-in).
    pub actor: String,
    /// The key's label and prefix, as it was then.
    pub actor_name: String,
    /// Through what: `api`, `dashboard`, or `cli` (`mtcal admin` on the database).
    pub via: String,
    /// What: `machine.create`, `baseline.set`, `profile.replace`, … (docs/audit.md).
    pub action: String,
    /// The id of what changed (a machine, result, dataset, profile, alert, key, job).
    pub target: String,
    /// The machine the change concerns, when one does (the filter `machine`).
    pub machine_id: Option<String>,
    /// The target before the change (`null`: it did not exist).
    #[cfg_attr(feature = "openapi", schema(value_type = Option<Object>))]
    pub before: Option<Value>,
    /// The target after the change (`null`: it no longer exists).
    #[cfg_attr(feature = "openapi", schema(value_type = Option<Object>))]
    pub after: Option<Value>,
    /// From where: the client's address as the service saw it.
    pub client: Option<String>,
}

/// Which events [`Audit::list_audit`] answers.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct AuditQuery {
    pub machine_id: Option<String>,
    /// A key id or a key's name (`actor_name`).
    pub actor: Option<String>,
    pub action: Option<String>,
    /// Recorded at or after this stored time ([`crate::rfc3339_millis`]).
    pub since: Option<String>,
    /// Recorded before this stored time.
    pub until: Option<String>,
    /// Only events before this `seq` (the next page).
    pub before: Option<i64>,
    pub limit: i64,
}
