//! The machine page: trends of any term at chosen positions and of the squareness
//! errors (±2σ bars), the history of checks with verdicts, the baseline, the upload form
//! and the progress of its jobs.

use super::jobs::{JobRow, job_progress};
use super::result::TERM_ORDER;
use super::{Nav, Viewer, csrf_field, machine_href, page, result_href, svg, verdict_badge, when};
use crate::plots::{self, TrendSeries};
use maud::{Markup, html};

#[derive(Debug, Clone, PartialEq, Default)]
pub struct MachineInfo {
    pub id: String,
    pub name: String,
    pub site: Option<String>,
    pub tags: Vec<String>,
    /// Registered travel per axis, mm.
    pub travel_mm: Vec<(String, [f64; 2])>,
    pub baseline_result_id: Option<String>,
}

/// One stored result of the machine.
#[derive(Debug, Clone, PartialEq)]
pub struct CheckRow {
    pub result_id: String,
    /// `identification`, `diagnosis`, `cradle`, `sensitivity`.
    pub kind: String,
    pub measured_at: String,
    pub verdict: Option<String>,
    /// One line: residual, rank, findings, …
    pub summary: String,
    pub is_baseline: bool,
    /// Its model does not explain its recording (an identification's misfit gate): not
    /// decided, not offered as a baseline, a ring in the trends.
    pub misfit: bool,
}

/// The term trend asked for: a series per position, or why there is none (e.g. a
/// position outside the measured travel).
#[derive(Debug, Clone, PartialEq)]
pub struct TermTrend {
    pub term: String,
    pub unit: String,
    pub series: Vec<TrendSeries>,
}

#[derive(Debug, Clone, PartialEq, Default)]
pub struct MachinePage {
    pub machine: MachineInfo,
    /// In time order, newest first.
    pub checks: Vec<CheckRow>,
    /// The term and positions of the trend form (`at`: comma-separated mm).
    pub term: String,
    pub at: String,
    /// None before the first identification.
    pub term_trend: Option<TermTrend>,
    /// Why the trend asked for cannot be shown (e.g. a position outside the travel).
    pub trend_error: Option<String>,
    /// EC0Y, EB0Z, EA0Z over time.
    pub squareness: Vec<TrendSeries>,
    /// Jobs of this machine not yet finished, and those just submitted.
    pub jobs: Vec<JobRow>,
    /// A message after a form (e.g. "baseline set").
    pub notice: Option<String>,
    /// The machine's drift alerts, newest first (active ones shown with a way to
    /// acknowledge them).
    pub alerts: Vec<super::alerts::AlertRow>,
    /// The tolerance profile that applies (`scope target`), if any.
    pub tolerance: Option<String>,
    /// The machine's latest diagnosis, if any: its result id, when it was measured, and
    /// its document or why that does not read.
    pub diagnosis: Option<LatestDiagnosis>,
    /// The latest check verified against the predictions of the check before it: its
    /// sentence and one line per finding (`backlash (X): 5.96 → 0.40 µm after
    /// compensation (predicted 0)`); None when there is nothing to verify.
    pub verification: Option<(String, Vec<String>)>,
    /// The check the verification compares with (result id, when measured): its
    /// compensation tables are the ones set.
    pub verified_against: Option<(String, String)>,
    /// When the latest check is an explained model: its gate's statement ("decided on
    /// the explained model, … with backlash (X)", or what remains when not decided).
    pub explained_model: Option<String>,
    /// When the checks of the trends decided on the explained model were measured, in
    /// time order (the trends say so under the plots).
    pub explained_checks: Vec<String>,
}

/// A machine's latest diagnosis as the machine page shows it.
#[derive(Debug, Clone, PartialEq)]
pub struct LatestDiagnosis {
    pub result_id: String,
    pub measured_at: String,
    pub doc: Result<mtcal_solver::diagnosis::DiagnosisResult, String>,
}

/// The findings of the latest diagnosis: each effect with its axis and its parameters
/// with their standard uncertainties, the possible ones, and what is left unexplained;
/// the full diagnosis is on its result page.
fn latest_findings(d: &LatestDiagnosis) -> Markup {
    html! {
        section.card #findings {
            h2 { "Findings of the latest diagnosis" }
            p.muted { "u: standard uncertainty (k = 1)." }
            p.muted {
                a href=(result_href(&d.result_id)) { "diagnosis of " (when(&d.measured_at)) }
            }
            @match &d.doc {
                Err(e) => { div.notice.error { "The latest diagnosis (" (d.result_id) ") cannot be shown: " (e) } }
                Ok(doc) => { (super::result::findings_summary(doc)) }
            }
        }
    }
}

/// The form creating a tolerance profile for the machine (its own) or for one of its
/// tags: ranges of the error functions (optionally per length, ISO 230-1's
/// proportionality), squareness and drift thresholds; every field optional, at least one.
fn profile_form(viewer: &Viewer, m: &MachineInfo, href: &str) -> Markup {
    let number = |name: &str, label: &str, unit: &str| {
        html! {
            label { (label) " (" (unit) ")"
                input type="number" name=(name) min="0" step="any" inputmode="decimal";
            }
        }
    };
    html! {
        section.card #new-profile {
            details {
                summary { "Create a tolerance profile" }
                p.muted { "Limits on the range (max − min) of each error function over the measured \
                           travel, optionally per length (the limit scales with the measured length, \
                           ISO 230-1); squareness by magnitude; drift thresholds raise alerts \
                           (docs/api.md, \"Tolerances and verdicts\"). A machine's own profile wins \
                           over its tags'." }
                form.stack.profile method="post" action={ (href) "/tolerance" } {
                    (csrf_field(&viewer.csrf))
                    label { "applies to"
                        select name="target" {
                            option value="machine" { "this machine (" (m.id) ")" }
                            @for t in &m.tags { option value={ "tag:" (t) } { "every machine tagged " (t) } }
                        }
                    }
                    (number("positioning_um", "positioning EXX, EYY, EZZ range", "µm"))
                    (number("straightness_um", "straightness range", "µm"))
                    (number("angular_urad", "angular errors range", "µrad"))
                    (number("per_length_mm", "ranges per length (empty: over the measured travel)", "mm"))
                    (number("squareness_urad", "squareness EC0Y, EB0Z, EA0Z", "µrad"))
                    (number("drift_um", "drift alert threshold", "µm"))
                    (number("drift_urad", "drift alert threshold", "µrad"))
                    button type="submit" { "Create profile" }
                }
            }
        }
    }
}

pub fn machine_page(viewer: &Viewer, p: &MachinePage) -> Markup {
    let m = &p.machine;
    let href = machine_href(&m.id);
    page(
        &m.id,
        Nav::Other,
        Some(viewer),
        html! {
            h1 { (m.id) @if m.name != m.id { " " span.muted { (m.name) } } }
            p.lead {
                @if let Some(s) = &m.site { "site " (s) " · " }
                @for t in &m.tags { span.tag { (t) } }
                " travel "
                @for (axis, [lo, hi]) in &m.travel_mm { (axis) " " (lo) "…" (hi) " mm  " }
                " · " a href={ "/api/v1/machines/" (super::encode(&m.id)) } { "JSON" }
            }
            @if let Some(n) = &p.notice { div.notice { (n) } }
            @if let Some(d) = &p.diagnosis { (latest_findings(d)) }
            @if let Some((statement, lines)) = &p.verification {
                section.card #verification {
                    h2 { "Verification of the compensation" }
                    p { (statement) }
                    ul { @for l in lines { li { (l) } } }
                    @if let Some((id, at)) = &p.verified_against {
                        p.links #verified-table {
                            "Compensation set from the check of " a href=(result_href(id)) { (when(at)) } ": "
                            a.export.linuxcnc href={ "/api/v1/results/" (super::encode(id)) "/export?format=linuxcnc" } {
                                "LinuxCNC compensation table"
                            }
                        }
                    }
                }
            }
            @if !p.alerts.is_empty() {
                section.card #alerts {
                    h2 { "Drift alerts " span.badge.alert { (p.alerts.iter().filter(|a| !a.acknowledged).count()) " active" } }
                    (super::alerts::alert_table(viewer, &p.alerts, &href))
                }
            }
            div.pair {
                section.card #trend {
                    h2 { "Trend of a term" }
                    form.filters method="get" action=(href) {
                        label { "term"
                            select name="term" {
                                @for t in TERM_ORDER { option value=(t) selected[p.term == t] { (t) } }
                            }
                        }
                        label { "at positions (mm)" input type="text" name="at" value=(p.at) size="18"; }
                        button type="submit" { "Show" }
                    }
                    @match (&p.trend_error, &p.term_trend) {
                        (Some(e), _) => { div.notice.error { (e) } }
                        (None, None) => { p.muted { "No identification yet." } }
                        (None, Some(t)) => {
                            (trend_notes(&t.series, &p.explained_checks))
                            figure.plot #term-trend data-term=(t.term) {
                                (svg(plots::trend(&format!("{} over time (±2σ)", t.term),
                                    &format!("{} ({})", t.term, plots::unit_label(&t.unit)), &t.series)))
                            }
                        }
                    }
                }
                section.card #squareness-trend {
                    h2 { "Squareness over time (±2σ)" }
                    (explained_note(&p.explained_checks))
                    figure.plot { (svg(plots::trend("EC0Y, EB0Z, EA0Z over time", "squareness (µrad)", &p.squareness))) }
                }
            }
            section.card #checks {
                h2 { "Checks" }
                p.muted #tolerance {
                    @match &p.tolerance {
                        Some(t) => { "Verdicts against the tolerance profile of " (t) " (error functions by their range over the measured travel, squareness and ISO figures by magnitude; pass when value + U ≤ limit, fail when value − U > limit, U = 2u; a misfit model is not decided)." }
                        None => { "No tolerance profile applies to this machine (docs/api.md: tolerances)." }
                    }
                }
                @if let Some(e) = &p.explained_model {
                    p #explained-model { span.badge.explained { "explained model" } " latest check: " (e) }
                }
                table {
                    thead { tr { th { "measured" } th { "kind" } th { "verdict" } th { "summary" } th {} } }
                    tbody {
                        @for c in &p.checks {
                            tr data-result=(c.result_id) data-kind=(c.kind) {
                                td { a href=(result_href(&c.result_id)) { (when(&c.measured_at)) } }
                                td { (c.kind) }
                                td {
                                    @if c.kind == "identification" { (verdict_badge(c.verdict.as_deref())) }
                                    // The verdict's badge already says it when a profile applies.
                                    @if c.misfit && c.verdict.as_deref() != Some("misfit") { " " span.badge.misfit { "model misfit" } }
                                }
                                td { (c.summary) }
                                td {
                                    @if c.is_baseline { span.badge { "baseline" } }
                                    @else if c.misfit {
                                        span.muted.not-baseline title="its model does not explain its recording: nothing measured against it would be decided" { "not a baseline (model misfit)" }
                                    }
                                    @else if c.kind == "identification" && viewer.can_write() {
                                        form.inline method="post" action={ (href) "/baseline" } {
                                            (csrf_field(&viewer.csrf))
                                            input type="hidden" name="result_id" value=(c.result_id);
                                            button.secondary type="submit" { "Set as baseline" }
                                        }
                                    }
                                    @if c.kind == "identification" && !c.is_baseline {
                                        @if let Some(b) = &m.baseline_result_id {
                                            " " a href={ "/compare?a=" (super::encode(b)) "&b=" (super::encode(&c.result_id)) } { "compare with baseline" }
                                        }
                                    }
                                }
                            }
                        }
                    }
                }
            }
            @if !p.jobs.is_empty() {
                section.card #jobs {
                    h2 { "Jobs" }
                    @for j in &p.jobs { (job_progress(j, true)) }
                }
            }
            @if viewer.can_write() { (profile_form(viewer, m, &href)) }
            @if viewer.can_write() {
                section.card #upload {
                    h2 { "Upload a check" }
                    p.muted { "A session (session.json and its plane CSVs, or one .tar.gz), a rotary point set, \
                               a positioning-run or drift-log CSV (docs/datasets.md). The job is chosen by the \
                               dataset's kind: identification for a session, a cradle check for a point set, a \
                               diagnosis for a positioning run or a drift log." }
                    form.upload.stack method="post" action={ (href) "/upload" } enctype="multipart/form-data" {
                        (csrf_field(&viewer.csrf))
                        label { "files" input type="file" name="files" multiple required; }
                        span.files.muted {}
                        label {
                            "CSV written by"
                            select name="csv_dialect" {
                                option value="plain" selected { "a program: commas, decimal point" }
                                option value="excel" { "a spreadsheet: semicolons, decimal comma" }
                            }
                        }
                        label.check { input type="checkbox" name="diagnose" value="1"; "also diagnose a session" }
                        button type="submit" { "Upload and run" }
                    }
                }
            }
        },
    )
}

/// Above the term trend: what its rings are (when it has a misfit point), and which of
/// its checks are decided on the explained model.
fn trend_notes(series: &[TrendSeries], explained: &[String]) -> Markup {
    let misfit = series
        .iter()
        .any(|s| s.points.iter().any(|p| p.misfit && p.value.is_some()));
    html! {
        @if misfit {
            p.muted.misfit-note { "A ring is a misfit check: its model does not explain its recording, so its value is not decided (no ±2σ bar, off the line)." }
        }
        (explained_note(explained))
    }
}

/// Under a trend: which of its checks are decided on the explained model (nothing when
/// none is).
fn explained_note(measured: &[String]) -> Markup {
    html! {
        @if !measured.is_empty() {
            p.muted.explained-note {
                "Decided on the explained model (the 21 terms fitted jointly with the physics the diagnosis of its recording found): the check"
                @if measured.len() > 1 { "s" }
                " of "
                @for (i, m) in measured.iter().enumerate() {
                    @if i > 0 { ", " }
                    (when(m))
                }
                "."
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pages::tests::viewer;
    use crate::plots::TrendPoint;

    fn page() -> MachinePage {
        MachinePage {
            machine: MachineInfo {
                id: "VMC-1".into(),
                name: "VMC-1".into(),
                baseline_result_id: Some("r1".into()),
                ..MachineInfo::default()
            },
            checks: vec![
                CheckRow {
                    result_id: "r2".into(),
                    kind: "identification".into(),
                    measured_at: "2026-04-06T08:00:00Z".into(),
                    verdict: Some("pass".into()),
                    summary: "residual 0.150 µm".into(),
                    is_baseline: false,
                    misfit: false,
                },
                CheckRow {
                    result_id: "r1".into(),
                    kind: "identification".into(),
                    measured_at: "2026-01-05T08:00:00Z".into(),
                    verdict: None,
                    summary: "residual 0.140 µm".into(),
                    is_baseline: true,
                    misfit: false,
                },
                CheckRow {
                    result_id: "r3".into(),
                    kind: "identification".into(),
                    measured_at: "2026-07-06T08:00:00Z".into(),
                    verdict: None,
                    summary: "residual 0.980 µm".into(),
                    is_baseline: false,
                    misfit: true,
                },
            ],
            term: "EXX".into(),
            at: "50".into(),
            term_trend: Some(TermTrend {
                term: "EXX".into(),
                unit: "um".into(),
                series: vec![TrendSeries {
                    name: "EXX at 50 mm".into(),
                    points: vec![TrendPoint {
                        measured_at: "2026-01-05T08:00:00Z".into(),
                        value: Some(1.0),
                        std: Some(0.1),
                        misfit: false,
                    }],
                }],
            }),
            ..MachinePage::default()
        }
    }

    #[test]
    fn write_key_gets_forms_read_key_does_not() {
        let html = machine_page(&viewer("write"), &page()).into_string();
        assert!(html.contains(r#"action="/machines/VMC-1/upload""#));
        assert!(html.contains(r#"enctype="multipart/form-data""#));
        assert!(html.contains(r#"action="/machines/VMC-1/baseline""#));
        assert!(html.contains(r#"href="/compare?a=r1&amp;b=r2""#));
        assert!(html.contains(r#"id="term-trend""#));
        assert!(html.contains(r#"action="/machines/VMC-1/tolerance""#));
        assert_eq!(
            html.matches(r#"name="csrf""#).count(),
            4,
            "sign-out, baseline, tolerance profile, upload"
        );
        let read = machine_page(&viewer("read"), &page()).into_string();
        assert!(!read.contains("/upload") && !read.contains("/baseline"));
        assert!(!read.contains("/tolerance"));
    }

    /// A misfit check is marked and not offered as a baseline; the others are.
    #[test]
    fn a_misfit_check_is_not_offered_as_baseline() {
        let html = machine_page(&viewer("write"), &page()).into_string();
        let row = |id: &str| {
            let at = html.find(&format!(r#"data-result="{id}""#)).unwrap();
            let end = html[at..].find("</tr>").unwrap();
            html[at..at + end].to_string()
        };
        assert!(row("r2").contains("Set as baseline"), "{}", row("r2"));
        assert!(!row("r3").contains("Set as baseline"), "{}", row("r3"));
        assert!(!row("r3").contains(r#"name="result_id""#));
        assert!(row("r3").contains("model misfit"));
        assert!(row("r3").contains("not a baseline (model misfit)"));
        assert!(!row("r2").contains("model misfit"));
    }

    #[test]
    fn a_refused_trend_says_why() {
        let mut p = page();
        p.trend_error = Some("position 300 mm is outside the measured travel −50…50 mm".into());
        let html = machine_page(&viewer("read"), &p).into_string();
        assert!(html.contains("outside the measured travel"));
        assert!(!html.contains(r#"id="term-trend""#));
    }

    /// The verification card links the LinuxCNC table of the check it verifies against.
    #[test]
    fn the_verification_links_the_table_set() {
        let mut p = page();
        p.verification = Some((
            "verified against the check of 2026-07-05: 1 of 1 as predicted".into(),
            vec!["backlash (X): 6.00 → 0.40 µm after compensation (predicted 0)".into()],
        ));
        p.verified_against = Some(("r1".into(), "2026-07-05T08:00:00Z".into()));
        let html = machine_page(&viewer("read"), &p).into_string();
        let card = &html[html.find(r#"id="verification""#).unwrap()..];
        assert!(card.contains("6.00 → 0.40 µm after compensation (predicted 0)"));
        assert!(card.contains(r#"href="/api/v1/results/r1/export?format=linuxcnc""#));
        p.verified_against = None;
        let html = machine_page(&viewer("read"), &p).into_string();
        assert!(!html.contains("verified-table"));
    }
}
