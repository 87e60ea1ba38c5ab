//! Drift alerts: the table shown on the fleet, machine and alerts pages, and the alerts
//! page (every alert, filtered by machine and state, newest first).

use super::{Nav, Viewer, csrf_field, encode, machine_href, page, result_href, when};
use maud::{Markup, html};

/// An alert as listed (raised when drift exceeds its threshold by more than the combined
/// uncertainty).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct AlertRow {
    pub id: String,
    pub machine_id: String,
    /// The landed result whose change raised it.
    pub result_id: String,
    pub raised_at: String,
    pub message: String,
    /// The comparison of the baseline with the check that raised it.
    pub compare_href: Option<String>,
    pub acknowledged: bool,
    /// When and by which key, once acknowledged, and what was written.
    pub acknowledged_at: Option<String>,
    pub acknowledged_by: Option<String>,
    pub comment: Option<String>,
}

/// The alerts page's content.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct AlertsPage {
    pub alerts: Vec<AlertRow>,
    pub machine: Option<String>,
    /// `active`, `acknowledged` or `all`.
    pub state: String,
}

/// A table of alerts, each linked to the comparison of its two checks; a write key gets
/// an acknowledge button with a comment field on each active one, which comes back to
/// `back` (a path of this site).
pub fn alert_table(viewer: &Viewer, alerts: &[AlertRow], back: &str) -> Markup {
    html! {
        table.alerts {
            thead { tr { th { "machine" } th { "raised" } th { "alert" } th { "state" } } }
            tbody {
                @for a in alerts {
                    tr.alert[!a.acknowledged] data-alert=(a.id) {
                        td { a href=(machine_href(&a.machine_id)) { (a.machine_id) } }
                        td { a href=(result_href(&a.result_id)) { (when(&a.raised_at)) } }
                        td {
                            (a.message)
                            @if let Some(href) = &a.compare_href {
                                " " a.compare href=(href) { "compare the two checks" }
                            }
                        }
                        td {
                            @if a.acknowledged {
                                span.muted {
                                    "acknowledged"
                                    @if let Some(t) = &a.acknowledged_at { " " (when(t)) }
                                    @if let Some(b) = &a.acknowledged_by { " by " (b) }
                                }
                                @if let Some(c) = &a.comment { p.ack-comment { "“" (c) "”" } }
                            } @else if viewer.can_write() {
                                form.inline method="post" action={ "/alerts/" (encode(&a.id)) "/ack" } {
                                    (csrf_field(&viewer.csrf))
                                    input type="hidden" name="next" value=(back);
                                    input type="text" name="comment" maxlength="1000" size="18"
                                        placeholder="comment (optional)" aria-label="comment";
                                    button.secondary type="submit" { "Acknowledge" }
                                }
                            } @else {
                                span.badge.alert { "active" }
                            }
                        }
                    }
                }
            }
        }
    }
}

pub fn alerts_page(viewer: &Viewer, p: &AlertsPage) -> Markup {
    let states = [
        ("active", "active"),
        ("acknowledged", "acknowledged"),
        ("all", "all"),
    ];
    let back = match &p.machine {
        Some(m) => format!("/alerts?state={}&machine={}", encode(&p.state), encode(m)),
        None => format!("/alerts?state={}", encode(&p.state)),
    };
    page(
        "Alerts",
        Nav::Alerts,
        Some(viewer),
        html! {
            h1 { "Drift alerts" }
            p.lead { "Raised when a check lands whose change since the machine's baseline exceeds \
                      the drift threshold of its tolerance profile by more than the expanded \
                      uncertainty (|change| − U > threshold, U = 2u)." }
            form.filters method="get" action="/alerts" {
                label { "state"
                    select name="state" {
                        @for (v, l) in states { option value=(v) selected[p.state == v] { (l) } }
                    }
                }
                label { "machine" input type="text" name="machine" value=[p.machine.as_deref()] size="14"; }
                button type="submit" { "Apply" }
            }
            @if p.alerts.is_empty() {
                p.muted #no-alerts { "No alert." }
            } @else {
                (alert_table(viewer, &p.alerts, &back))
            }
        },
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pages::tests::viewer;

    fn row(id: &str, acked: bool) -> AlertRow {
        AlertRow {
            id: id.into(),
            machine_id: "VMC-1".into(),
            result_id: "r9".into(),
            raised_at: "2026-04-06T09:00:00Z".into(),
            message: "EXX |change| - U = 6.1 - 0.4 > 5 um".into(),
            compare_href: Some("/compare?a=r1&b=r9".into()),
            acknowledged: acked,
            acknowledged_at: acked.then(|| "2026-04-07T10:00:00Z".into()),
            acknowledged_by: acked.then(|| "key k1 (ops)".into()),
            comment: acked.then(|| "ballscrew re-tensioned".into()),
        }
    }

    #[test]
    fn active_alerts_can_be_acknowledged_by_a_write_key_only() {
        let p = AlertsPage {
            alerts: vec![row("a1", false), row("a2", true)],
            machine: Some("VMC-1".into()),
            state: "all".into(),
        };
        let html = alerts_page(&viewer("write"), &p).into_string();
        assert!(html.contains(r#"action="/alerts/a1/ack""#), "{html}");
        assert!(
            !html.contains(r#"action="/alerts/a2/ack""#),
            "acknowledged once"
        );
        assert!(html.contains("by key k1 (ops)"));
        assert!(html.contains("“ballscrew re-tensioned”"), "{html}");
        assert!(
            html.contains(r#"name="comment""#),
            "a comment with the acknowledgement"
        );
        assert!(html.contains(r#"href="/compare?a=r1&amp;b=r9""#), "{html}");
        assert!(html.contains(r#"value="/alerts?state=all&amp;machine=VMC-1""#));
        let read = alerts_page(&viewer("read"), &p).into_string();
        assert!(!read.contains("/ack"));
        assert!(read.contains("6.1 - 0.4 &gt; 5 um"));
        let none = alerts_page(&viewer("read"), &AlertsPage::default()).into_string();
        assert!(none.contains("No alert."));
    }
}
