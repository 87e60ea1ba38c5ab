//! Reading the audit trail (recorded by the server's routes, kept append-only by
//! `mtcal_store::audit`): its filters and pages ([`AuditFilter`], [`page`]) and its CSV
//! export ([`to_csv`]).

use crate::error::DomainError;
use mtcal_store::{AuditEvent, AuditQuery, Store};
use serde::Deserialize;

/// Events one page holds by default, and at most.
pub const DEFAULT_EVENTS: usize = 100;
pub const MAX_EVENTS: usize = 1000;
/// Most events one CSV export holds (newest first; narrow the filter for older ones).
pub const MAX_EXPORT: usize = 100_000;

/// Which events to read: every filter is optional and they combine.
#[derive(Debug, Clone, Default, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::IntoParams))]
#[cfg_attr(feature = "openapi", into_params(parameter_in = Query))]
#[serde(deny_unknown_fields)]
pub struct AuditFilter {
    /// Events concerning this machine.
    pub machine: Option<String>,
    /// Events of this actor: a key id (`key_…`) or a key's name as recorded
    /// (`label (prefix)`).
    pub actor: Option<String>,
    /// Events of this action (`machine.create`, `profile.replace`, …).
    pub action: Option<String>,
    /// Recorded at or after this time (RFC 3339).
    pub since: Option<String>,
    /// Recorded before this time (RFC 3339).
    pub until: Option<String>,
    /// Events before this `seq` (the next page: the last `seq` of the page before).
    #[cfg_attr(feature = "openapi", param(minimum = 1))]
    pub before: Option<i64>,
    /// At most this many (default 100, at most 1000).
    #[cfg_attr(feature = "openapi", param(minimum = 1, maximum = 1000))]
    pub limit: Option<usize>,
}

/// A time of the filter as the stored times are written (they compare as text).
fn stored_time(field: &str, given: &Option<String>) -> Result<Option<String>, DomainError> {
    given
        .as_deref()
        .map(|t| {
            time::OffsetDateTime::parse(t, &time::format_description::well_known::Rfc3339)
                .map(mtcal_store::rfc3339_millis)
                .map_err(|e| {
                    DomainError::Invalid(format!(
                        "{field}: an RFC 3339 time (2026-11-25T16:10:00Z): {e}"
                    ))
                })
        })
        .transpose()
}

impl AuditFilter {
    /// The store's query for at most `limit` events.
    fn query(&self, limit: usize) -> Result<AuditQuery, DomainError> {
        if let Some(b) = self.before
            && b < 1
        {
            return Err(DomainError::Invalid(format!("before: at least 1, got {b}")));
        }
        Ok(AuditQuery {
            machine_id: self.machine.clone(),
            actor: self.actor.clone(),
            action: self.action.clone(),
            since: stored_time("since", &self.since)?,
            until: stored_time("until", &self.until)?,
            before: self.before,
            limit: limit as i64,
        })
    }
}

/// One page of events, newest first.
pub async fn page(store: &dyn Store, f: &AuditFilter) -> Result<Vec<AuditEvent>, DomainError> {
    let limit = crate::paging::limit(f.limit, DEFAULT_EVENTS, MAX_EVENTS)?;
    Ok(store.list_audit(&f.query(limit)?).await?)
}

/// Every event of the filter (at most [`MAX_EXPORT`], newest first), page by page.
pub async fn all(store: &dyn Store, f: &AuditFilter) -> Result<Vec<AuditEvent>, DomainError> {
    let mut q = f.query(MAX_EVENTS)?;
    let mut out: Vec<AuditEvent> = Vec::new();
    while out.len() < MAX_EXPORT {
        let page = store.list_audit(&q).await?;
        let done = page.len() < MAX_EVENTS;
        q.before = page.last().map(|e| e.seq);
        out.extend(page);
        if done {
            break;
        }
    }
    out.truncate(MAX_EXPORT);
    Ok(out)
}

/// The columns of the CSV export, in order.
pub const CSV_COLUMNS: [&str; 11] = [
    "seq",
    "at",
    "actor",
    "actor_name",
    "via",
    "action",
    "target",
    "machine_id",
    "client",
    "before",
    "after",
];

/// A text cell a spreadsheet would run as a formula (starting with `=`, `+`, `-`, `@`,
/// a tab or a carriage return) gets a leading `'`, the usual guard; every other cell is
/// written as it is.
fn cell(s: &str) -> std::borrow::Cow<'_, str> {
    if s.starts_with(['=', '+', '-', '@', '\t', '\r']) {
        format!("'{s}").into()
    } else {
        s.into()
    }
}

/// The events as CSV (RFC 4180, the csv crate's writer): a header of [`CSV_COLUMNS`],
/// then one record per event; `before` and `after` hold the JSON text (empty: none).
pub fn to_csv(events: &[AuditEvent]) -> String {
    let mut w = csv::Writer::from_writer(Vec::new());
    let json =
        |v: &Option<serde_json::Value>| v.as_ref().map(|v| v.to_string()).unwrap_or_default();
    // Writing to memory cannot fail.
    let _ = w.write_record(CSV_COLUMNS);
    for e in events {
        let x = &e.event;
        let seq = e.seq.to_string();
        let (before, after) = (json(&x.before), json(&x.after));
        let record: [&str; 11] = [
            &seq,
            &e.at,
            &cell(&x.actor),
            &cell(&x.actor_name),
            &x.via,
            &cell(&x.action),
            &cell(&x.target),
            &cell(x.machine_id.as_deref().unwrap_or("")),
            x.client.as_deref().unwrap_or(""),
            &before,
            &after,
        ];
        let _ = w.write_record(record);
    }
    String::from_utf8(w.into_inner().unwrap_or_default()).unwrap_or_default()
}

#[cfg(test)]
mod tests {
    use super::*;
    use mtcal_store::NewAuditEvent;

    #[test]
    fn csv_reads_back_field_for_field_and_defuses_formulas() {
        let e = AuditEvent {
            seq: 7,
            at: "2026-11-25T16:10:00.500Z".into(),
            event: NewAuditEvent {
                actor: "key_1".into(),
                actor_name: "=HYPERLINK(\"x\") (mtc_abcd)".into(),
                via: "api".into(),
                action: "machine.update".into(),
                target: "VMC, \"1\"".into(),
                machine_id: Some("VMC, \"1\"".into()),
                before: Some(serde_json::json!({"name": "a,b\n"})),
                after: None,
                client: Some("127.0.0.1".into()),
            },
        };
        let text = to_csv(&[e]);
        let mut r = csv::Reader::from_reader(text.as_bytes());
        assert_eq!(r.headers().unwrap(), CSV_COLUMNS.as_slice());
        let rec = r.records().next().unwrap().unwrap();
        assert_eq!(&rec[0], "7");
        assert_eq!(&rec[3], "'=HYPERLINK(\"x\") (mtc_abcd)");
        assert_eq!(&rec[6], "VMC, \"1\"");
        assert_eq!(
            serde_json::from_str::<serde_json::Value>(&rec[9]).unwrap(),
            serde_json::json!({"name": "a,b\n"})
        );
        assert_eq!(&rec[10], "");
    }

    #[test]
    fn filter_times_are_read_as_rfc3339_and_written_as_stored() {
        let f = AuditFilter {
            since: Some("2026-11-25T18:10:00+02:00".into()),
            ..Default::default()
        };
        let q = f.query(10).unwrap();
        assert_eq!(q.since.as_deref(), Some("2026-11-25T16:10:00.000Z"));
        let bad = AuditFilter {
            until: Some("yesterday".into()),
            ..Default::default()
        };
        assert!(bad.query(10).unwrap_err().to_string().starts_with("until:"));
    }
}
