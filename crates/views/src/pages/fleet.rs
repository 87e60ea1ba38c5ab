//! The fleet page: every machine with its last check, verdict, drift since its baseline
//! with its uncertainty and a sparkline of its worst term; machines with active alerts
//! first; filters by site and tag; the active alerts.

use super::{
    DiagnosisFindings, Nav, Viewer, machine_href, page, result_href, svg, verdict_badge, when,
};
use crate::plots;
use maud::{Markup, html};

/// Drift since the baseline: the largest change of any term over the intersection of
/// the two checks' measured travels, with its standard uncertainty.
#[derive(Debug, Clone, PartialEq)]
pub struct Drift {
    pub value: f64,
    pub std: Option<f64>,
    /// `um` or `urad`.
    pub unit: String,
    /// The term (and position, mm) where it is largest.
    pub term: Option<String>,
    pub at_mm: Option<f64>,
}

/// A check: the stored result, its kind and when it was measured.
#[derive(Debug, Clone, PartialEq)]
pub struct Check {
    pub result_id: String,
    /// `identification`, `diagnosis`, `cradle` or `sensitivity`.
    pub kind: String,
    pub measured_at: String,
}

#[derive(Debug, Clone, PartialEq)]
pub struct FleetRow {
    pub machine_id: String,
    pub name: String,
    pub site: Option<String>,
    pub tags: Vec<String>,
    /// The latest identification, else the latest check of another kind.
    pub last_check: Option<Check>,
    pub verdict: Option<String>,
    /// Limits decided, failed, undecided and not decided for a misfit (with a verdict).
    pub verdict_counts: Option<VerdictCounts>,
    /// The items behind the verdict in words, worst first.
    pub verdict_reasons: Vec<String>,
    /// The tolerance profile that applies (`tag vmc`, `machine`), verdict or not.
    pub profile: Option<String>,
    /// Its identifications (one: the baseline alone, no drift yet).
    pub results: usize,
    pub drift_um: Option<Drift>,
    pub drift_urad: Option<Drift>,
    /// Why there is no drift (shown across the drift columns instead).
    pub drift_note: Option<String>,
    /// The term of the largest drift and its value at the drift position over the
    /// machine's checks, in time order (the sparkline).
    pub worst_trend: Vec<f64>,
    pub active_alerts: usize,
    /// The latest check's misfit gate statement when its model does not explain its
    /// recording (its values are then not decided).
    pub misfit: Option<String>,
    /// When the latest check is decided on the explained model: the gate's statement
    /// (what the model adds).
    pub explained_model: Option<String>,
    /// What the diagnosis of the latest check's recording found.
    pub diagnosis: Option<DiagnosisFindings>,
}

/// How many limits a verdict decided, and how many of them failed, were undecided or
/// not decided because the model does not explain its recording.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct VerdictCounts {
    pub items: usize,
    pub failed: usize,
    pub undecided: usize,
    pub misfit: usize,
}

pub use super::alerts::AlertRow;

/// What the page shows and how it was filtered.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct FleetPage {
    /// In display order (the caller sorts: alerts first, then the chosen order).
    pub rows: Vec<FleetRow>,
    pub alerts: Vec<AlertRow>,
    pub sites: Vec<String>,
    pub tags: Vec<String>,
    pub site: Option<String>,
    pub tag: Option<String>,
    /// `drift` (default), `name` or `last_check`.
    pub sort: String,
    /// How drift is defined (from the API).
    pub definition: String,
    /// Machines matching the filters in all, this page (1-based) and the number of pages.
    pub total: usize,
    pub page: usize,
    pub pages: usize,
}

/// The fleet page's URL with these filters at page `page`.
fn page_href(f: &FleetPage, page: usize) -> String {
    let mut q = vec![format!("sort={}", super::encode(&f.sort))];
    if let Some(s) = &f.site {
        q.push(format!("site={}", super::encode(s)));
    }
    if let Some(t) = &f.tag {
        q.push(format!("tag={}", super::encode(t)));
    }
    q.push(format!("page={page}"));
    format!("/?{}", q.join("&"))
}

/// A drift cell; a `misfit` latest check's drift is not a figure: it says so, the
/// computed value only on hover.
fn drift(d: &Option<Drift>, misfit: bool) -> Markup {
    match d {
        None => html! { span.muted { "—" } },
        Some(d) if misfit => html! {
            span.badge.misfit.drift-misfit
                title={ "not decided: the latest check's model does not explain its recording (computed: "
                    (super::with_u(Some(d.value), d.std, &d.unit)) ")" } {
                "not decided: misfit"
            }
        },
        Some(d) => html! {
            span title=[d.term.as_ref().map(|t| match d.at_mm {
                Some(q) => format!("{t} at {} mm", plots::tick(&q)),
                None => t.clone(),
            })] {
                (super::with_u(Some(d.value), d.std, &d.unit))
            }
        },
    }
}

/// The verdict cell: the badge with how many limits failed (or are undecided) and the
/// items behind it; without a verdict, whether a profile applies and why nothing was
/// decided.
fn verdict_cell(r: &FleetRow) -> Markup {
    html! {
        @match (&r.verdict, &r.profile) {
            (Some(v), _) => {
                (verdict_badge(Some(v)))
                @if let Some(c) = r.verdict_counts {
                    " " span.verdict-count { @if c.failed > 0 { (c.failed) " of " (c.items) " limits fail" }
                        @else if c.misfit > 0 { "for " (c.misfit) " of " (c.items) " limits" }
                        @else if c.undecided > 0 { (c.undecided) " of " (c.items) " limits undecided" }
                        @else { "all " (c.items) " limits pass" } }
                }
                @for reason in &r.verdict_reasons { div.reason.muted { (reason) } }
            }
            (None, Some(p)) => {
                @if r.last_check.is_none() {
                    span.badge.none title={ "the " (p) " tolerance profile applies" } { "not checked yet" }
                } @else {
                    span.badge.none title="none of the profile's limits applies to this check" { "no limit applies" }
                }
                div.reason.muted { "profile: " (p) }
            }
            (None, None) => { (verdict_badge(None)) }
        }
        @if let Some(m) = &r.misfit {
            div.misfit-note {
                // The verdict's badge already says "model misfit" when a profile applies.
                @if r.verdict.as_deref() != Some("misfit") { span.badge.misfit { "model misfit" } " " }
                span.muted { (m) }
                @if r.diagnosis.is_none() { div.muted { "diagnosis queued, not landed yet" } }
            }
        }
        @if let Some(m) = &r.explained_model {
            div.explained-note { span.badge.explained { "explained model" } " " span.muted { (m) } }
        }
        @if let Some(d) = &r.diagnosis { (findings(d)) }
    }
}

/// What the diagnosis of the latest check found, linked to it.
fn findings(d: &DiagnosisFindings) -> Markup {
    html! {
        div.findings {
            a href=(result_href(&d.result_id)) {
                "diagnosis: "
                (match d.verdict.as_deref() {
                    Some("consistent") => "consistent, nothing found",
                    Some("explained") => "explained by",
                    Some("partly_explained") => "partly explained by",
                    _ => "cannot be read",
                })
            }
            @if !d.findings.is_empty() {
                ul { @for f in &d.findings { li { (f) } } }
            }
            @if d.more > 0 { div.muted { "and " (d.more) " more" } }
        }
    }
}

/// The sparkline of the worst term with its name and the range of its values, so that
/// the line can be read (it is scaled to fill its box).
fn sparkline_cell(r: &FleetRow) -> Markup {
    let known: Vec<f64> = r
        .worst_trend
        .iter()
        .copied()
        .filter(|v| v.is_finite())
        .collect();
    let (lo, hi) = known
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
            (a.min(v), b.max(v))
        });
    let term = r.drift_um.as_ref().and_then(|d| d.term.clone());
    html! {
        @if r.worst_trend.len() > 1 && !known.is_empty() {
            (svg(plots::sparkline(&r.worst_trend)))
            div.spark-scale {
                @if let Some(t) = &term { (t) " " }
                (super::num(lo)) " to " (super::num(hi)) " µm"
            }
        }
    }
}

/// The form registering a machine: id, name, site, tags and the travel of each axis.
fn machine_form(viewer: &Viewer) -> Markup {
    html! {
        section.card #new-machine {
            details {
                summary { "Register a machine" }
                form.stack method="post" action="/machines" {
                    (super::csrf_field(&viewer.csrf))
                    label { "id (letters, digits, '.', '_', '-')" input name="id" required maxlength="64"; }
                    label { "name" input name="name"; }
                    label { "site" input name="site"; }
                    label { "tags (comma-separated)" input name="tags"; }
                    @for axis in ["X", "Y", "Z"] {
                        label { (axis) " travel (mm): min "
                            input type="number" name={ (axis.to_lowercase()) "_min" } step="any";
                            " max " input type="number" name={ (axis.to_lowercase()) "_max" } step="any";
                        }
                    }
                    button type="submit" { "Register" }
                }
            }
        }
    }
}

fn select(name: &str, label: &str, options: &[String], chosen: &Option<String>) -> Markup {
    html! {
        label { (label)
            select name=(name) {
                option value="" { "all" }
                @for o in options { option value=(o) selected[chosen.as_deref() == Some(o.as_str())] { (o) } }
            }
        }
    }
}

pub fn fleet_page(viewer: &Viewer, f: &FleetPage) -> Markup {
    let sorts = [
        ("drift", "drift (µm)"),
        ("drift_urad", "drift (µrad)"),
        ("name", "name"),
        ("last_check", "last check"),
    ];
    let active: Vec<AlertRow> = f
        .alerts
        .iter()
        .filter(|a| !a.acknowledged)
        .cloned()
        .collect();
    page(
        "Fleet",
        Nav::Fleet,
        Some(viewer),
        html! {
            h1 { "Fleet" }
            p.lead { (f.total) " machine(s). Drift: " (f.definition) ", shown as ± U = 2u." }
            @if !active.is_empty() {
                section.card #alerts {
                    h2 { "Active alerts " span.badge.alert { (active.len()) } }
                    (super::alerts::alert_table(viewer, &active, "/"))
                }
            }
            form.filters method="get" action="/" {
                (select("site", "site", &f.sites, &f.site))
                (select("tag", "tag", &f.tags, &f.tag))
                label { "sort by"
                    select name="sort" {
                        @for (v, l) in sorts { option value=(v) selected[f.sort == v] { (l) } }
                    }
                }
                button type="submit" { "Apply" }
            }
            table #fleet {
                thead { tr {
                    th { "machine" } th { "site" } th { "tags" } th { "last check" } th { "verdict" }
                    th.num { "drift since baseline (µm)" } th.num { "drift (µrad)" } th { "worst term" }
                } }
                tbody {
                    @for r in &f.rows {
                        tr.alerted[r.active_alerts > 0] data-machine=(r.machine_id) {
                            td {
                                a href=(machine_href(&r.machine_id)) { (r.machine_id) }
                                @if r.name != r.machine_id { br; span.muted { (r.name) } }
                                @if r.active_alerts > 0 { " " span.badge.alert title="active alerts" { (r.active_alerts) } }
                            }
                            td { (r.site.as_deref().unwrap_or("")) }
                            td { @for t in &r.tags { span.tag { (t) } } }
                            td.last-check { @match &r.last_check {
                                Some(c) => {
                                    a href=(result_href(&c.result_id)) { (when(&c.measured_at)) }
                                    @if c.kind != "identification" { " " span.muted.kind { "(" (c.kind) ")" } }
                                }
                                None => { span.muted { "no check yet" } }
                            } }
                            td.verdict { (verdict_cell(r)) }
                            @if let (None, Some(note)) = (&r.drift_um, &r.drift_note) {
                                td.muted.drift-note colspan="3" { (note) }
                            } @else if r.results == 1 {
                                td.muted.drift-note colspan="3" { "no drift yet: one check, the baseline" }
                            } @else {
                                td.num { (drift(&r.drift_um, r.misfit.is_some())) }
                                td.num { (drift(&r.drift_urad, r.misfit.is_some())) }
                                td.spark title=[r.drift_um.as_ref().and_then(|d| d.term.clone())] {
                                    (sparkline_cell(r))
                                }
                            }
                        }
                    }
                }
            }
            @if viewer.can_write() { (machine_form(viewer)) }
            @if f.pages > 1 {
                nav.pager {
                    @if f.page > 1 { a href=(page_href(f, f.page - 1)) rel="prev" { "← previous" } " " }
                    "page " (f.page) " of " (f.pages)
                    @if f.page < f.pages { " " a href=(page_href(f, f.page + 1)) rel="next" { "next →" } }
                }
            }
        },
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pages::tests::viewer;

    /// The `<tr>` of machine `id` in a fleet page's HTML.
    fn row_html(html: &str, id: &str) -> String {
        let start = html.find(&format!(r#"data-machine="{id}""#)).unwrap();
        html[start..start + html[start..].find("</tr>").unwrap()].to_string()
    }

    fn row(id: &str, alerts: usize) -> FleetRow {
        FleetRow {
            machine_id: id.into(),
            name: format!("{id} name"),
            site: Some("north".into()),
            tags: vec!["5-axis".into()],
            last_check: Some(Check {
                result_id: "r1".into(),
                kind: "identification".into(),
                measured_at: "2026-04-06T08:00:00Z".into(),
            }),
            verdict: Some("fail".into()),
            verdict_counts: Some(VerdictCounts {
                items: 24,
                failed: 2,
                undecided: 1,
                misfit: 0,
            }),
            verdict_reasons: vec![
                "EXX 12.30 ± 0.400 µm at 50.00 mm (limit 10.00 µm)".into(),
                "EC0Y 31.00 ± 0.200 µrad (limit 30.00 µrad)".into(),
            ],
            profile: Some("tag 5-axis".into()),
            results: 3,
            drift_um: Some(Drift {
                value: 4.2,
                std: Some(0.3),
                unit: "um".into(),
                term: Some("EXX".into()),
                at_mm: Some(50.0),
            }),
            drift_urad: None,
            drift_note: None,
            worst_trend: vec![0.0, 1.0, 4.2],
            active_alerts: alerts,
            misfit: None,
            explained_model: None,
            diagnosis: None,
        }
    }

    #[test]
    fn a_misfit_row_says_so_with_the_findings_of_its_diagnosis() {
        let misfit = FleetRow {
            verdict: Some("misfit".into()),
            verdict_counts: Some(VerdictCounts {
                items: 12,
                misfit: 10,
                ..VerdictCounts::default()
            }),
            verdict_reasons: vec![],
            misfit: Some(
                "the model does not explain this recording: the residual RMS 0.976 µm is \
                 6.5 × the noise floor 0.149 µm (the gate is 1.2 ×)"
                    .into(),
            ),
            diagnosis: Some(DiagnosisFindings {
                result_id: "res_d1".into(),
                verdict: Some("explained".into()),
                findings: vec!["backlash (X): backlash_µm = 6.01 (u = 0.02)".into()],
                more: 2,
            }),
            ..row("VMC-8", 0)
        };
        let queued = FleetRow {
            misfit: misfit.misfit.clone(),
            diagnosis: None,
            ..row("VMC-9", 0)
        };
        let page = FleetPage {
            rows: vec![misfit, queued, row("VMC-1", 0)],
            sort: "drift".into(),
            total: 3,
            page: 1,
            pages: 1,
            ..FleetPage::default()
        };
        let html = fleet_page(&viewer("read"), &page).into_string();
        let found = row_html(&html, "VMC-8");
        assert!(found.contains("model misfit") && found.contains("6.5 × the noise floor"));
        assert!(found.contains("for 10 of 12 limits"), "{found}");
        assert!(found.contains("href=\"/results/res_d1\""), "{found}");
        assert!(
            found.contains("explained by") && found.contains("backlash (X): backlash_µm = 6.01")
        );
        assert!(found.contains("and 2 more"));
        let waiting = row_html(&html, "VMC-9");
        assert!(
            waiting.contains(">model misfit<") && waiting.contains("diagnosis queued"),
            "the row without a profile's misfit verdict says it: {waiting}"
        );
        let clean = row_html(&html, "VMC-1");
        assert!(!clean.contains("model misfit") && !clean.contains("diagnosis"));
        // A misfit's drift is not a figure; a decided one's is.
        let drift_cells = |row: &str| {
            row.split(r#"<td class="num">"#)
                .skip(1)
                .map(|c| c[..c.find("</td>").unwrap()].to_string())
                .collect::<Vec<_>>()
        };
        for id in ["VMC-8", "VMC-9"] {
            let cells = drift_cells(&row_html(&html, id));
            assert_eq!(cells.len(), 2, "{cells:?}");
            assert!(cells[0].contains(">not decided: misfit<"), "{cells:?}");
            assert!(!cells[0].contains(">4."), "no figure shown: {cells:?}");
        }
        let decided = &drift_cells(&clean)[0];
        assert!(
            decided.contains(">4.") && decided.contains(" ± "),
            "{decided}"
        );
    }

    #[test]
    fn fleet_rows_alerts_and_filters() {
        let page = FleetPage {
            rows: vec![row("VMC-1", 1), row("VMC-2", 0)],
            alerts: vec![AlertRow {
                id: "a1".into(),
                machine_id: "VMC-1".into(),
                raised_at: "2026-04-06T09:00:00Z".into(),
                message: "EXX drift 4.2 µm > 3 µm".into(),
                ..AlertRow::default()
            }],
            sites: vec!["north".into(), "south".into()],
            tags: vec!["5-axis".into()],
            site: Some("north".into()),
            tag: None,
            sort: "drift".into(),
            definition: "largest change".into(),
            total: 250,
            page: 2,
            pages: 3,
        };
        let html = fleet_page(&viewer("write"), &page).into_string();
        assert!(
            html.contains(r#"<tr class="alerted" data-machine="VMC-1">"#),
            "{html}"
        );
        assert!(
            html.contains(r#"data-machine="VMC-2">"#)
                && !html.contains(r#"<tr class="alerted" data-machine="VMC-2">"#),
            "{html}"
        );
        assert!(html.contains("4.200 ± 0.600 µm"), "drift with U = 2u");
        assert!(html.contains(r#"title="EXX at 50 mm""#));
        assert!(html.contains(r#"<option value="north" selected>north</option>"#));
        assert!(html.contains(r#"action="/alerts/a1/ack""#));
        assert!(html.contains("<svg"), "sparkline");
        assert!(
            html.contains("EXX 0.000 to 4.200 µm"),
            "the sparkline's scale"
        );
        assert!(html.contains("2 of 24 limits fail"), "{html}");
        assert!(html.contains("EXX 12.30 ± 0.400 µm at 50.00 mm (limit 10.00 µm)"));
        assert!(html.contains("250 machine(s)"));
        assert!(
            html.contains(r#"href="/?sort=drift&amp;site=north&amp;page=3""#),
            "{html}"
        );
        assert!(html.contains(r#"href="/?sort=drift&amp;site=north&amp;page=1""#));
        let read = fleet_page(&viewer("read"), &page).into_string();
        assert!(!read.contains("/ack"), "a read key cannot acknowledge");
        assert!(read.contains("EXX drift 4.2 µm"), "but sees the alert");
    }

    /// A machine whose only check is not an identification (a 5-axis machine's cradle
    /// check) shows that check, and says why it has no drift, instead of "no check yet".
    #[test]
    fn a_check_of_another_kind_is_shown_with_why_there_is_no_drift() {
        let cradle = FleetRow {
            last_check: Some(Check {
                result_id: "r9".into(),
                kind: "cradle".into(),
                measured_at: "2026-04-07T08:00:00Z".into(),
            }),
            verdict: None,
            drift_um: None,
            drift_note: Some("not applicable to cradle checks".into()),
            worst_trend: vec![],
            ..row("5AX-1", 0)
        };
        let none = FleetRow {
            last_check: None,
            verdict: None,
            drift_um: None,
            drift_note: None,
            results: 0,
            ..row("VMC-9", 0)
        };
        let page = FleetPage {
            rows: vec![cradle, none],
            sort: "drift".into(),
            total: 2,
            page: 1,
            pages: 1,
            ..FleetPage::default()
        };
        let html = fleet_page(&viewer("read"), &page).into_string();
        let row_of = |id: &str| row_html(&html, id);
        let cradle = row_of("5AX-1");
        assert!(cradle.contains(r#"href="/results/r9""#), "{cradle}");
        assert!(cradle.contains("(cradle)"), "{cradle}");
        assert!(
            cradle.contains("not applicable to cradle checks"),
            "{cradle}"
        );
        assert!(!cradle.contains("no check yet"), "{cradle}");
        assert!(row_of("VMC-9").contains("no check yet"));
    }

    /// A machine with no check under a tag's profile says the profile applies and that it
    /// is not checked yet (not "no tolerance"); a machine with one check has no drift yet
    /// (not a drift of 0 ± U); a machine without a profile has no tolerance.
    #[test]
    fn unchecked_one_check_and_unprofiled_machines_say_so() {
        let unchecked = FleetRow {
            last_check: None,
            verdict: None,
            verdict_counts: None,
            verdict_reasons: vec![],
            drift_um: None,
            results: 0,
            worst_trend: vec![],
            ..row("VMC-7", 0)
        };
        let one = FleetRow {
            results: 1,
            worst_trend: vec![0.0],
            drift_um: Some(Drift {
                value: 0.0,
                std: Some(0.007),
                unit: "um".into(),
                term: Some("EXX".into()),
                at_mm: Some(50.0),
            }),
            ..row("VMC-8", 0)
        };
        let none = FleetRow {
            verdict: None,
            profile: None,
            ..row("VMC-6", 0)
        };
        let page = FleetPage {
            rows: vec![unchecked, one, none],
            sort: "drift".into(),
            total: 3,
            page: 1,
            pages: 1,
            ..FleetPage::default()
        };
        let html = fleet_page(&viewer("read"), &page).into_string();
        let row_of = |id: &str| row_html(&html, id);
        let unchecked = row_of("VMC-7");
        assert!(
            unchecked.contains("not checked yet") && unchecked.contains("profile: tag 5-axis"),
            "{unchecked}"
        );
        assert!(!unchecked.contains("no tolerance"), "{unchecked}");
        let one = row_of("VMC-8");
        assert!(one.contains("no drift yet"), "{one}");
        assert!(!one.contains("0.000 ± 0.014"), "{one}");
        assert!(row_of("VMC-6").contains("no tolerance"));
    }
}
