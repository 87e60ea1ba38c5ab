//! The audit trail page (admin): who changed what, before and after, when and from
//! where; filtered by machine, actor, action and time, paged, with its CSV export.

use super::{Nav, Viewer, encode, machine_href, page, when};
use maud::{Markup, html};

/// One event as the page shows it.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct AuditRow {
    pub seq: i64,
    pub at: String,
    pub actor_name: String,
    pub via: String,
    pub action: String,
    pub target: String,
    pub machine_id: Option<String>,
    pub client: Option<String>,
    /// The JSON before and after (empty: none).
    pub before: String,
    pub after: String,
}

/// The filter the page applied (empty: none), as its form fields.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct AuditFilterView {
    pub machine: String,
    pub actor: String,
    pub action: String,
    pub since: String,
    pub until: String,
}

impl AuditFilterView {
    /// The filter as a query string (`machine=…&actor=…`), without the empty fields.
    pub fn query(&self) -> String {
        [
            ("machine", &self.machine),
            ("actor", &self.actor),
            ("action", &self.action),
            ("since", &self.since),
            ("until", &self.until),
        ]
        .iter()
        .filter(|(_, v)| !v.is_empty())
        .map(|(k, v)| format!("{k}={}", encode(v)))
        .collect::<Vec<_>>()
        .join("&")
    }
}

/// A JSON cell: folded when long.
fn json_cell(text: &str) -> Markup {
    html! {
        @if text.len() > 80 {
            details { summary { code { (text.chars().take(60).collect::<String>()) "…" } } pre { (text) } }
        } @else if !text.is_empty() {
            code { (text) }
        }
    }
}

/// The page: the filter form, the events newest first, a link to the next page (the
/// events before the last one shown, when the page was full) and to the CSV export.
pub fn audit_page(viewer: &Viewer, rows: &[AuditRow], f: &AuditFilterView, full: bool) -> Markup {
    let query = f.query();
    let sep = if query.is_empty() { "" } else { "&" };
    page(
        "Audit trail",
        Nav::Other,
        Some(viewer),
        html! {
            h1 { "Audit trail" }
            form.filters method="get" action="/audit" {
                label { "machine " input type="text" name="machine" value=(f.machine); }
                label { "actor " input type="text" name="actor" value=(f.actor); }
                label { "action " input type="text" name="action" value=(f.action); }
                label { "since " input type="text" name="since" placeholder="2026-11-25T00:00:00Z" value=(f.since); }
                label { "until " input type="text" name="until" value=(f.until); }
                button type="submit" { "Apply" }
                " " a #csv href={ "/api/v1/audit/export?" (query) } { "CSV" }
            }
            table #audit {
                thead { tr { th { "#" } th { "when" } th { "who" } th { "action" } th { "target" } th { "machine" } th { "from" } th { "before" } th { "after" } } }
                tbody {
                    @for r in rows {
                        tr data-seq=(r.seq) {
                            td { (r.seq) }
                            td title=(r.at) { (when(&r.at)) }
                            td { (r.actor_name) " " span.muted { "(" (r.via) ")" } }
                            td { code { (r.action) } }
                            td { (r.target) }
                            td { @if let Some(m) = &r.machine_id { a href=(machine_href(m)) { (m) } } }
                            td { (r.client.as_deref().unwrap_or("")) }
                            td { (json_cell(&r.before)) }
                            td { (json_cell(&r.after)) }
                        }
                    }
                }
            }
            @if rows.is_empty() { p.muted { "No event." } }
            @if let (true, Some(last)) = (full, rows.last()) {
                p { a #next href={ "/audit?" (query) (sep) "before=" (last.seq) } { "Older events" } }
            }
        },
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pages::tests::viewer;

    #[test]
    fn events_show_who_what_and_the_way_to_older_ones_and_the_csv() {
        let rows = [AuditRow {
            seq: 41,
            at: "2026-11-25T16:10:00.500Z".into(),
            actor_name: "line <1> (mtc_abcd)".into(),
            via: "dashboard".into(),
            action: "baseline.set".into(),
            target: "VMC 1".into(),
            machine_id: Some("VMC 1".into()),
            client: Some("10.0.0.7".into()),
            before: r#"{"baseline_result_id":null}"#.into(),
            after: "x".repeat(100),
        }];
        let f = AuditFilterView {
            machine: "VMC 1".into(),
            ..Default::default()
        };
        let html = audit_page(&viewer("admin"), &rows, &f, true).into_string();
        assert!(html.contains("line &lt;1&gt; (mtc_abcd)"), "{html}");
        assert!(html.contains("<code>baseline.set</code>"));
        assert!(html.contains(r#"href="/machines/VMC%201""#));
        assert!(html.contains(r#"href="/audit?machine=VMC%201&amp;before=41""#));
        assert!(html.contains(r#"href="/api/v1/audit/export?machine=VMC%201""#));
        assert!(html.contains("<details>"), "a long JSON cell is folded");
        let last = audit_page(&viewer("admin"), &rows, &f, false).into_string();
        assert!(!last.contains("Older events"));
    }
}
