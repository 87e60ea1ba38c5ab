//! The check report: one self-contained HTML page per check (no external asset, the
//! stylesheet inlined, plots as inline SVG), laid out to print on A4 (`@page` and print
//! rules in the stylesheet). It reuses the result page's sections ([`super::result`])
//! and adds what a signed report needs: the check's facts (machine, date, instrument,
//! plan), the figures of the standards with their verdicts (or "no tolerance"), the
//! diagnosis findings when a diagnosis of the check exists, the compensation table's
//! summary, and what the data could not determine. A cradle (A/C) check has its own
//! report ([`cradle_report`]): facts, the result page's cradle sections (the compliance
//! against A with its bands among them) and what the ball data could not determine.

use super::result::{self, IdentificationView, VerdictRow};
use super::{num, print_page, verdict_badge, when};
use crate::plots::{tick_label, unit_label};
use maud::{Markup, html};
use mtcal_formats::compensation::{Compensation, DEFAULT_STEP_MM, ExportError, Format};
use mtcal_solver::cradle::{CradleResult, LocationErrorReport, TermSeparability};
use mtcal_solver::diagnosis::DiagnosisResult;
use mtcal_solver::identification::IdentificationResult;
use mtcal_solver::positioning_check::DiagnosisDocument;
use mtcal_solver::terms::Term;
use mtcal_solver::tolerance::{Assessment, COVERAGE_K, Figures, Verdict, identification_figures};
use mtcal_solver::uncertainty::{ItemBudget, Source};

/// Everything the report shows. `verdict` is the result's verdict against a tolerance
/// profile ([`mtcal_solver::tolerance::evaluate`]; `None`: no profile applies, and every
/// figure says "no tolerance").
pub struct CheckReport<'a> {
    pub doc: &'a IdentificationResult,
    /// The stored result's id (`None` for a result read from a file).
    pub result_id: Option<&'a str>,
    /// When the report was made (RFC 3339).
    pub generated_at: &'a str,
    pub verdict: Option<&'a Verdict>,
    /// A diagnosis of the same check, when one was run.
    pub diagnosis: Option<&'a ReportDiagnosis>,
}

/// A diagnosis of the same recording as the report shows it: its document, or why the
/// stored document does not read (said, never taken for "no diagnosis").
#[derive(Debug, Clone, PartialEq)]
pub struct ReportDiagnosis {
    /// The stored result's id, or the file the diagnosis was read from.
    pub id: String,
    /// Whether `id` is a stored result (the report links to its page).
    pub stored: bool,
    pub doc: Result<DiagnosisResult, String>,
}

/// What recorded the data of an identification: its sessions are planar grid-encoder
/// recordings (docs/datasets.md).
pub const INSTRUMENT: &str = "planar grid encoder (cross-grid plate and scanning head)";

/// The report page: the summary first (the misfit banner when the model does not
/// explain its recording, the check's facts with its conditions, the figures of the
/// standards with their verdicts, the uncertainty budget, the findings of a diagnosis,
/// what the data could not determine, the signature block), then the appendix with the
/// detail (fit, squareness, the error functions, residuals, circle tests,
/// identifiability, the whole diagnosis, the compensation table's summary).
pub fn check_report(r: &CheckReport) -> Markup {
    let d = r.doc;
    let title = format!("Check report {} {}", d.machine_id, when(&d.measured_at));
    let compensation = Compensation::from_result(d, DEFAULT_STEP_MM, false);
    let rows: Vec<VerdictRow> = r.verdict.map(verdict_rows).unwrap_or_default();
    let view = IdentificationView::of(d).with_limits(&rows);
    print_page(
        &title,
        html! {
            article.report {
                (result::misfit_banner(d, Some(misfit_diagnosis(r.diagnosis))))
                (facts(r))
                (standards(r))
                @if !rows.is_empty() { (result::verdict_table(&rows)) }
                (budget(r))
                (findings(r.diagnosis))
                (undetermined(d, &compensation))
                (signature(r))
                div.appendix #appendix {
                    h1 { "Appendix: detail" }
                    (result::identification(&view))
                    @if let Some(ReportDiagnosis { doc: Ok(doc), .. }) = r.diagnosis {
                        div #diagnosis-detail { (result::diagnosis(doc)) }
                    }
                    (compensation_summary(&compensation))
                }
            }
        },
    )
}

/// Where the misfit banner of a report sends the reader: the findings of the diagnosis
/// of the recording, why it could not be read, or that none is stored yet.
fn misfit_diagnosis(d: Option<&ReportDiagnosis>) -> Markup {
    html! {
        @match d {
            Some(ReportDiagnosis { doc: Ok(_), id, .. }) => {
                "The diagnosis of this recording (" (id) ") says which physics the model leaves out: see "
                a href="#findings" { "its findings" } " below."
            }
            Some(ReportDiagnosis { doc: Err(_), id, .. }) => {
                "The diagnosis of this recording (" (id) ") could not be read (see Findings below)."
            }
            None => {
                "No diagnosis of this recording is stored yet: the service queues one for a misfit \
                 on its own and the machine's page shows its findings (`mtcal diagnose` on the \
                 session; `mtcal report --diagnosis` puts it in this report)."
            }
        }
    }
}

/// The report of a positioning-run check (a diagnosis of positioning runs stored with
/// their ISO 230-2 figures): the facts, the figures of ISO 230-2 (the standard's, and
/// without the readings the outlier test set aside, each labelled), the diagnosis with its
/// findings and held-out figures. `measured_at` is the dataset's date.
pub struct PositioningReport<'a> {
    pub doc: &'a DiagnosisDocument,
    pub result_id: Option<&'a str>,
    pub measured_at: &'a str,
    pub generated_at: &'a str,
}

/// The positioning-run report page.
pub fn positioning_report(r: &PositioningReport) -> Markup {
    let d = &r.doc.diagnosis;
    let title = format!(
        "Positioning check report {} {}",
        d.machine_id,
        when(r.measured_at)
    );
    print_page(
        &title,
        html! {
            article.report {
                section.card #check {
                    h1 { "Positioning check report: " (d.machine_id) }
                    dl.facts {
                        dt { "machine" } dd { (d.machine_id) }
                        dt { "measured" } dd { (when(r.measured_at)) }
                        @if let Some(id) = r.result_id { dt { "result" } dd { code { (id) } } }
                        dt { "recording" } dd { "bidirectional positioning runs (ISO 230-2 test cycle)" }
                        dt { "axes" } dd { @for (i, f) in r.doc.iso230_2.iter().enumerate() {
                            @if i > 0 { "; " } (f.axis) ": " (f.targets) " targets, " (f.runs) " runs"
                        } }
                    }
                }
                @if r.doc.iso230_2.is_empty() {
                    section.card #standards { h2 { "ISO 230-2" } p { "No axis could be evaluated." } }
                }
                (result::iso230_2(&r.doc.iso230_2))
                @for n in &r.doc.not_evaluated { p.muted { "not evaluated: " (n.what) ": " (n.reason) } }
                div #findings { (result::diagnosis(d)) }
                p.muted.signature {
                    "Figures are value ± U, U = 2u (k = 2). Nothing is evaluated outside the travel                      the runs measured. Report made by mtcal "
                    (env!("CARGO_PKG_VERSION")) " on " (when(r.generated_at)) "."
                }
            }
        },
    )
}

/// What recorded the data of a cradle check: a ball on the C table measured by a 3-D
/// instrument (docs/cradle.md).
pub const CRADLE_INSTRUMENT: &str =
    "3-D instrument (laser tracker) on a ball on the C table, C turned at each A pose";

/// Everything a cradle check's report shows.
pub struct CradleCheckReport<'a> {
    pub doc: &'a CradleResult,
    /// The stored result's id (`None` for a result read from a file).
    pub result_id: Option<&'a str>,
    /// When the report was made (RFC 3339).
    pub generated_at: &'a str,
}

/// The report page of a cradle (A/C) check: its facts, the result page's cradle sections
/// (the model, the compliance against A with ±2σ bands, what the ball data can separate,
/// the location errors) and what the data could not determine.
pub fn cradle_report(r: &CradleCheckReport) -> Markup {
    let d = r.doc;
    let machine = d.machine_id.as_deref().unwrap_or("—");
    let measured = d.measured_at.as_deref().map(when).unwrap_or("—".into());
    let title = format!("Cradle check report {machine} {measured}");
    let (lo, hi) = d
        .poses
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| {
            (lo.min(p.a_deg), hi.max(p.a_deg))
        });
    let not_observable: Vec<&LocationErrorReport> = d
        .location_errors
        .iter()
        .filter(|e| e.value.is_none())
        .collect();
    let sep = d.kinematics.separability.as_ref();
    let inseparable: Vec<&TermSeparability> = sep
        .map(|s| {
            s.terms
                .iter()
                .filter(|t| !t.separable || !t.confounded_with.is_empty())
                .collect()
        })
        .unwrap_or_default();
    print_page(
        &title,
        html! {
            article.report {
                section.card #check {
                    h1 { "Cradle check report: " (machine) }
                    dl.facts {
                        dt { "machine" } dd { (machine) }
                        dt { "measured" } dd { (measured) }
                        @if let Some(id) = r.result_id { dt { "result" } dd { code { (id) } } }
                        dt { "instrument" } dd { (CRADLE_INSTRUMENT) }
                        dt { "plan" } dd { (d.n_points) " points at " (d.n_poses) " A poses, A from "
                                           (tick_label(lo)) "° to " (tick_label(hi)) "°" }
                        dt { "model" } dd { (d.kinematics.description) }
                        dt { "convention" } dd { (d.convention) }
                    }
                }
                (result::cradle(d))
                section.card #undetermined {
                    h2 { "What the data could not determine" }
                    ul.compact {
                        li { "Nothing is evaluated outside the measured A range [" (tick_label(lo)) "°, " (tick_label(hi)) "°]." }
                        @for e in &not_observable {
                            li { (e.name) ": no value — " (e.note.as_deref().unwrap_or("not observable from a ball on the table")) }
                        }
                        @for t in &inseparable {
                            li { (t.description) ": "
                                 @if !t.separable { "not separable" } @else { "separable only while these terms are absent" }
                                 @if !t.why.is_empty() { " — " (t.why) } }
                        }
                        @for p in d.kinematics.parameters.iter().filter(|p| !p.determined && !p.model_dependent) {
                            li { (p.name) ": possible, undetermined (|value| < 3u)" }
                        }
                        @for rival in &d.kinematics.rivals {
                            li { (rival.statement) }
                        }
                    }
                }
                p.muted.signature {
                    "Figures are value ± U, U = 2u (k = 2); plots show ±2σ. Report made by mtcal "
                    (env!("CARGO_PKG_VERSION")) " on " (when(r.generated_at)) "."
                }
            }
        },
    )
}

/// The verdict's items as the result page's verdict table shows them.
fn verdict_rows(v: &Verdict) -> Vec<VerdictRow> {
    v.items
        .iter()
        .map(|i| VerdictRow {
            quantity: i.item.clone(),
            at: match (i.position_mm, i.travel_mm) {
                (Some(q), Some([lo, hi])) => {
                    format!("at {} mm of [{}, {}] mm", num(q), num(lo), num(hi))
                }
                (Some(q), None) => format!("at {} mm", num(q)),
                _ => String::new(),
            },
            value: i.value.unwrap_or(f64::NAN),
            std: i.u,
            limit: i.limit,
            unit: i.unit.clone(),
            outcome: i.decision.as_str().to_string(),
        })
        .collect()
}

/// The check's facts: machine, date, result, the conditions of the test (instrument
/// with its serial and calibration date, temperature, operator), plan, travel, model.
fn facts(r: &CheckReport) -> Markup {
    let d = r.doc;
    let c = &d.conditions;
    let files: Vec<&str> = {
        let mut f: Vec<&str> = d.residuals.iter().map(|x| x.file.as_str()).collect();
        f.dedup();
        f
    };
    html! {
        section.card #check {
            h1 { "Check report: " (d.machine_id) " "
                 (verdict_badge(r.verdict.and_then(|v| v.decision).map(|d| d.as_str()))) }
            dl.facts {
                dt { "machine" } dd { (d.machine_id) }
                dt { "measured" } dd { (when(&d.measured_at)) }
                @if let Some(id) = r.result_id { dt { "result" } dd { code { (id) } } }
                dt { "instrument" } dd { (INSTRUMENT) ": "
                    @match &c.instrument {
                        Some(i) => {
                            span.instrument { (i.describe()) }
                            @if let Some(n) = &i.certificate { ", certificate " (n) }
                            @if i.serial.is_none() { " (serial not stated)" }
                            @if i.calibration_date.is_none() { " (calibration date not stated)" }
                        }
                        None => { "not stated (no serial, no calibration certificate)" }
                    }
                }
                dt { "temperature" } dd {
                    @match c.temperature_c {
                        Some(t) => {
                            (format!("{t:.1}")) " °C"
                            @if let Some(u) = c.temperature_u_k { " (u = " (num(u)) " K)" }
                            @if let Some(s) = &c.temperature_source { ", " (s) }
                        }
                        None => { "not stated" }
                    }
                }
                dt { "operator" } dd { (c.operator.as_deref().unwrap_or("not stated")) }
                dt { "plan" } dd {
                    (files.len()) " plane file(s), " (d.nuisance.runs) " runs, "
                    (d.nuisance.mountings.len()) " mounting(s), " (d.fit.samples) " samples"
                    @if !files.is_empty() { ": " (files.join(", ")) }
                }
                dt { "measured travel" } dd {
                    @for (i, (axis, [lo, hi])) in d.model.measured_travel_mm.iter().enumerate() {
                        @if i > 0 { "; " } (axis) " [" (num(*lo)) ", " (num(*hi)) "] mm"
                    }
                }
                dt { "model" } dd { (format!("{:?}", d.method).to_lowercase()) " identification, "
                    (d.model.basis.name()) " basis of order " (d.model.order) }
                dt { "convention" } dd { (d.convention) }
            }
        }
    }
}

/// ISO 230-2 and ISO 230-4 figures, each with its verdict or "no tolerance".
fn standards(r: &CheckReport) -> Markup {
    let st = &r.doc.standards;
    let figures = st.scalar_figures();
    let verdict_of = |name: &str| {
        r.verdict
            .and_then(|v| v.items.iter().find(|i| i.item == name))
            .map(|i| (i.limit, i.decision.as_str()))
    };
    html! {
        section.card #standards {
            h2 { "Figures of the standards (ISO 230-2, ISO 230-4)" }
            @if r.verdict.is_none() {
                p.muted { "No tolerance profile applies to this machine: figures are reported without a verdict." }
            }
            @if figures.is_empty() {
                p { "No figure of ISO 230-2 or ISO 230-4 could be evaluated from this check." }
            } @else {
                @for f in &st.iso230_2 {
                    @for n in &f.notes { p.muted { "ISO 230-2, " (f.axis) ": " (n) } }
                }
                table {
                    thead { tr { th { "figure" } th.num { "value ± U" } th.num { "limit" } th { "verdict" } } }
                    tbody {
                        @for f in &figures {
                            @let v = verdict_of(&f.name);
                            tr data-figure=(f.name) {
                                td { (f.name) }
                                td.num { (super::with_u(Some(f.value), f.u, "um")) }
                                td.num { @if let Some((limit, _)) = v { (num(limit)) " µm" } @else { "—" } }
                                td { (verdict_badge(v.map(|x| x.1))) }
                            }
                        }
                    }
                }
            }
        }
    }
}

/// One line of the budget table: the item, its unit, the value decided and its budget.
struct BudgetRow<'a> {
    item: &'a str,
    unit: &'a str,
    value: Option<f64>,
    budget: std::borrow::Cow<'a, ItemBudget>,
}

/// The budget lines: those of the verdict's items when a tolerance profile applies (the
/// very budgets the decisions used), else every figure the result offers to be judged
/// with the budget a verdict would use ([`Assessment::of_identification`]).
fn budget_rows<'a>(
    r: &'a CheckReport,
    figures: &'a Figures,
    how: &Assessment,
) -> Vec<BudgetRow<'a>> {
    let mut rows: Vec<BudgetRow> = match r.verdict {
        Some(v) => v
            .items
            .iter()
            .filter_map(|i| {
                Some(BudgetRow {
                    item: &i.item,
                    unit: &i.unit,
                    value: i.value,
                    budget: std::borrow::Cow::Borrowed(i.budget.as_ref()?),
                })
            })
            .collect(),
        None => figures
            .figures
            .iter()
            .map(|(name, q)| BudgetRow {
                item: name,
                unit: &q.unit,
                value: Some(q.value),
                budget: std::borrow::Cow::Owned(how.budget.item(q.span, q.u)),
            })
            .collect(),
    };
    let order = |n: &str| {
        result::TERM_ORDER
            .iter()
            .position(|t| *t == n)
            .unwrap_or(result::TERM_ORDER.len())
    };
    rows.sort_by(|a, b| (order(a.item), a.item).cmp(&(order(b.item), b.item)));
    rows
}

/// The uncertainty budget per ISO/TR 230-9 of every judged figure: the contributions of
/// the instrument's calibration, the thermal expansion, the setup and the fit (standard
/// uncertainties, k = 1), u_c and U = 2u_c; a contribution that could not be evaluated
/// says "not included", with the reason below the table (docs/conventions.md,
/// "Uncertainty budget").
fn budget(r: &CheckReport) -> Markup {
    let how = Assessment::of_identification(r.doc, Default::default());
    let figures = identification_figures(r.doc);
    let rows = budget_rows(r, &figures, &how);
    let inputs = r.verdict.map_or(&how.budget, |v| &v.budget);
    let mut reasons: Vec<(Source, &str)> = vec![];
    for row in &rows {
        for c in row.budget.contributions.iter().filter(|c| c.u.is_none()) {
            if !reasons.iter().any(|(s, b)| *s == c.source && *b == c.basis) {
                reasons.push((c.source, &c.basis));
            }
        }
    }
    let cell = |b: &ItemBudget, s: Source| -> Markup {
        match b.contributions.iter().find(|c| c.source == s) {
            Some(c) => match c.u {
                Some(u) => html! { td.num title=(c.basis) { (num(u)) } },
                None => html! { td.num.not-included title=(c.basis) { "not included" } },
            },
            None => html! { td.num { "—" } },
        }
    };
    html! {
        section.card #budget {
            h2 { "Uncertainty budget (ISO/TR 230-9)" }
            p.muted {
                "Standard uncertainties (k = 1) in the figure's unit, combined in quadrature into u_c; \
                 U = 2u_c is the U of every verdict (docs/conventions.md, \"Uncertainty budget\"). "
                @match &inputs.conditions.instrument {
                    Some(i) => { "Instrument: " (i.describe()) @if let Some(f) = &inputs.instrument_from { " (from the " (f) ")" } ". " }
                    None => { "No instrument stated. " }
                }
                @for a in &inputs.assumed { "Assumed: " (a) ". " }
            }
            @if rows.is_empty() {
                p { "No figure of this check is judged." }
            } @else {
                table.budget {
                    thead { tr {
                        th { "figure" } th.num { "value" }
                        @for s in Source::ALL { th.num { (s.as_str()) } }
                        th.num { "u_c" } th.num { "U = 2u_c" }
                    } }
                    tbody {
                        @for row in &rows {
                            tr data-item=(row.item) {
                                td { (row.item) }
                                td.num { @match row.value { Some(v) => { (num(v)) " " (unit_label(row.unit)) } None => "—" } }
                                @for s in Source::ALL { (cell(&row.budget, s)) }
                                td.num { (num(row.budget.combined_u)) }
                                td.num { (num(COVERAGE_K * row.budget.combined_u)) }
                            }
                        }
                    }
                }
                @if !reasons.is_empty() {
                    ul.compact.not-included {
                        @for (s, b) in &reasons { li { "not included, " (s.as_str()) ": " (b) } }
                    }
                }
            }
        }
    }
}

/// The findings of the diagnosis of the same recording in short (the whole diagnosis is
/// in the appendix), or why it could not be read, or that none was run.
fn findings(d: Option<&ReportDiagnosis>) -> Markup {
    html! {
        section.card #findings {
            h2 { "Findings of the diagnosis" }
            @match d {
                None => { p { "No diagnosis was run on this check: no finding to report." } }
                Some(ReportDiagnosis { id, doc: Err(e), .. }) => {
                    div.notice.error { "The diagnosis of this check (" (id) ") could not be read: " (e)
                        ". Its findings cannot be shown; that does not mean that there are none." }
                }
                Some(ReportDiagnosis { id, stored, doc: Ok(doc) }) => {
                    p.muted {
                        "Diagnosis "
                        @if *stored { a href={ "/results/" (super::encode(id)) } { (id) } } @else { (id) }
                        "; u: standard uncertainty (k = 1); the whole diagnosis is in the appendix."
                    }
                    (result::findings_summary(doc))
                }
            }
        }
    }
}

/// The signature block: who checked the report, when, and their signature.
fn signature(r: &CheckReport) -> Markup {
    html! {
        section.card #signature {
            p.muted.signature {
                "Figures are value ± U, U = 2u_c (k = 2) of the uncertainty budget; plots show ±2σ. \
                 Nothing is evaluated outside the travel the check measured. Report made by mtcal "
                (env!("CARGO_PKG_VERSION")) " on " (when(r.generated_at)) "."
            }
            table.sign {
                tbody {
                    tr { th { "Checked by" } td {} }
                    tr { th { "Date" } td {} }
                    tr { th { "Signature" } td {} }
                }
            }
        }
    }
}

/// Per exported term: axis, points, travel, largest |error|; the squareness values; the
/// formats and the sign convention.
fn compensation_summary(c: &Result<Compensation, ExportError>) -> Markup {
    html! {
        section.card #compensation {
            h2 { "Compensation table" }
            @match c {
                Err(e) => { p { "No compensation table: " (e.to_string()) } }
                Ok(c) => {
                    p.muted { "Errors of the identifiable terms on every " (DEFAULT_STEP_MM) " mm of the measured \
                               travel (and its end), as exported for controllers (formats: " (Format::names())
                              "); compensation = −error." }
                    table {
                        thead { tr { th { "term" } th { "axis" } th.num { "points" } th.num { "from (mm)" } th.num { "to (mm)" } th.num { "max |error|" } } }
                        tbody {
                            @for a in &c.axes {
                                @for col in &a.columns {
                                    @let angular = Term::parse(&col.term).is_some_and(Term::is_angular);
                                    @let (scale, unit) = if angular { (1e6, "urad") } else { (1e3, "um") };
                                    @let max = col.values.iter().fold(0.0f64, |m, v| m.max(v.abs())) * scale;
                                    tr data-term=(col.term) {
                                        td { (col.term) } td { (a.axis) } td.num { (a.positions_mm.len()) }
                                        td.num { (num(a.positions_mm[0])) } td.num { (num(a.positions_mm[a.positions_mm.len() - 1])) }
                                        td.num { (num(max)) " " (unit_label(unit)) }
                                    }
                                }
                            }
                            @for (n, v) in &c.squareness {
                                tr data-term=(n) { td { (n) } td { "—" } td.num { "1" } td.num { "—" } td.num { "—" } td.num { (num(v.abs() * 1e6)) " µrad" } }
                            }
                        }
                    }
                    @if !c.not_identifiable.is_empty() {
                        p { "Left out of the table (not identifiable): " (c.not_identifiable.join(", ")) }
                    }
                }
            }
        }
    }
}

/// Everything the check's data could not determine, in one place.
fn undetermined(d: &IdentificationResult, c: &Result<Compensation, ExportError>) -> Markup {
    let o = &d.observability;
    let not_moved: Vec<&str> = ["X", "Y", "Z"]
        .into_iter()
        .filter(|a| !d.model.measured_travel_mm.contains_key(*a))
        .collect();
    let left_out = c
        .as_ref()
        .map(|c| c.not_identifiable.clone())
        .unwrap_or_default();
    let nothing = o.not_identifiable.is_empty()
        && not_moved.is_empty()
        && d.standards.not_evaluated.is_empty()
        && left_out.is_empty();
    html! {
        section.card #undetermined {
            h2 { "What the data could not determine" }
            @if nothing {
                p { "Every term of the model is determined by this check, and every standard's figure could be evaluated." }
            } @else {
                ul.compact {
                    @if !o.not_identifiable.is_empty() {
                        li { "Terms not identifiable with this plan: " (o.not_identifiable.join(", ")) }
                    }
                    @for g in &o.confounded { li { (g.terms.join(" + ")) " cannot be separated (seen as " (g.seen_as) ")" } }
                    @if !not_moved.is_empty() {
                        li { "Axes that did not move (nothing is known of them): " (not_moved.join(", ")) }
                    }
                    @for n in &d.standards.not_evaluated {
                        li { (n.standard) " " (n.what) ": " (n.reason) }
                    }
                    @if !left_out.is_empty() { li { "Left out of the compensation table: " (left_out.join(", ")) } }
                    li { "Nothing outside the measured travel: "
                        @for (i, (axis, [lo, hi])) in d.model.measured_travel_mm.iter().enumerate() {
                            @if i > 0 { "; " } (axis) " [" (num(*lo)) ", " (num(*hi)) "] mm"
                        }
                    }
                }
                @if !o.advice.is_empty() {
                    h3 { "What would determine them" }
                    ul.compact { @for a in &o.advice { li { (a) } } }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use mtcal_solver::diagnosis::{Baseline, BeforeAfter, Finding, Verdict};
    use mtcal_solver::identification::{IdentifyOptions, identify};
    use mtcal_solver::simulate::{Plan, SimOptions, random_truth, simulate};

    /// The seed plan (rank 34 of 51: some terms not identifiable) at 10 Hz.
    fn simulated_check() -> IdentificationResult {
        let out = simulate(
            &random_truth(7),
            &SimOptions {
                plan: Plan::Seed,
                seed: 7,
                sample_rate_hz: 10.0,
                ..Default::default()
            },
        )
        .unwrap();
        identify(&out.session, &IdentifyOptions::default()).unwrap()
    }

    fn finding() -> DiagnosisResult {
        DiagnosisResult {
            kind: "diagnosis".into(),
            machine_id: "SIM-0007".into(),
            source: "session".into(),
            baseline: Baseline {
                residual_rms_um: 1.2,
                heldout_rms_um: 1.3,
                noise_estimate_um: 0.15,
            },
            mismatch: vec![],
            findings: vec![Finding {
                effect: "backlash".into(),
                axis: Some("X".into()),
                depends_on: None,
                parameters: [("backlash_um".to_string(), 4.0)].into(),
                physics: "lost motion at reversal".into(),
                signature: None,
                residual_rms_um: BeforeAfter {
                    before: 1.2,
                    after: 0.2,
                },
                heldout_rms_um: BeforeAfter {
                    before: 1.3,
                    after: 0.2,
                },
                evidence: "BIC".into(),
                undetermined: vec![],
            }],
            possible: vec![],
            rejected: vec![],
            verdict: Verdict::Explained,
            unexplained: vec![],
            plots: vec![],
        }
    }

    /// The `<section …id="…"…>` of the page, or a panic naming it.
    fn section<'a>(html: &'a str, id: &str) -> &'a str {
        let start = html
            .find(&format!("id=\"{id}\""))
            .unwrap_or_else(|| panic!("no section {id}"));
        let end = html[start..]
            .find("</section>")
            .map_or(html.len(), |e| start + e);
        &html[start..end]
    }

    /// Every section is there, the page is self-contained and printable on A4, and what
    /// is not determined is said.
    #[test]
    fn report_of_a_simulated_check_holds_every_section() {
        let doc = simulated_check();
        let html = check_report(&CheckReport {
            doc: &doc,
            result_id: Some("r-42"),
            generated_at: "2026-11-25T09:00:00Z",
            verdict: None,
            diagnosis: None,
        })
        .into_string();
        // Self-contained: no external stylesheet, script, image or font.
        for bad in [
            "<link",
            "<script",
            "src=\"http",
            "href=\"http",
            "url(http",
            "@import",
        ] {
            assert!(!html.contains(bad), "external asset: {bad}");
        }
        assert!(html.contains("@page { size: A4"), "A4 print rule");
        let facts = section(&html, "check");
        for want in [
            doc.machine_id.as_str(),
            "r-42",
            INSTRUMENT,
            "plan",
            "measured travel",
        ] {
            assert!(facts.contains(want), "facts lack {want}");
        }
        assert!(facts.contains(&when(&doc.measured_at)));
        // Standards: every scalar figure has a row, with "no tolerance".
        let st = section(&html, "standards");
        let figures = doc.standards.scalar_figures();
        assert!(!figures.is_empty());
        for f in &figures {
            assert!(
                st.contains(&format!("data-figure=\"{}\"", f.name)),
                "{}",
                f.name
            );
        }
        assert_eq!(st.matches("no tolerance</span>").count(), figures.len());
        // The 18 functions drawn or labelled, squareness, identifiability, circles.
        let terms = section(&html, "terms");
        assert_eq!(terms.matches("<svg").count(), 18);
        assert!(terms.contains("data-identifiable=\"false\""));
        assert!(terms.contains("2σ"));
        for id in ["fit", "squareness", "identifiability"] {
            section(&html, id);
        }
        let circles = section(&html, "circles");
        assert!(
            circles.matches("<svg").count() >= 1,
            "polar plots of the circles"
        );
        assert!(section(&html, "findings").contains("No diagnosis was run"));
        // Compensation: a row per exported term, and the terms left out named.
        let comp = section(&html, "compensation");
        let c = Compensation::from_result(&doc, DEFAULT_STEP_MM, false).unwrap();
        for a in &c.axes {
            for col in &a.columns {
                assert!(
                    comp.contains(&format!("data-term=\"{}\"", col.term)),
                    "{}",
                    col.term
                );
            }
        }
        assert!(!c.not_identifiable.is_empty());
        for n in &doc.observability.not_identifiable {
            assert!(comp.contains(n.as_str()), "{n} not said to be left out");
            assert!(section(&html, "undetermined").contains(n.as_str()), "{n}");
        }
        // No verdict table without a tolerance profile.
        assert!(!html.contains("id=\"verdict\""));
    }

    /// With a tolerance profile's decisions the figures carry their verdicts and the
    /// verdict table appears; a diagnosis's findings are shown.
    #[test]
    fn verdicts_and_findings_are_shown_when_given() {
        let doc = simulated_check();
        let figures = mtcal_solver::tolerance::identification_figures(&doc);
        // A figure of the standards that line passes give (not one depending on the
        // passes' zeros, which is undetermined).
        let figure = doc
            .standards
            .scalar_figures()
            .into_iter()
            .find(|f| figures.figures.contains_key(&f.name))
            .unwrap();
        let limits = mtcal_solver::tolerance::Limits {
            standards: [(figure.name.clone(), figure.value.abs() + 100.0)].into(),
            ..Default::default()
        };
        let how = mtcal_solver::tolerance::Assessment::of_identification(&doc, Default::default());
        let verdict = mtcal_solver::tolerance::evaluate(&limits, &figures, &how);
        let diag = ReportDiagnosis {
            id: "diagnosis.json".into(),
            stored: false,
            doc: Ok(finding()),
        };
        let html = check_report(&CheckReport {
            doc: &doc,
            result_id: None,
            generated_at: "2026-11-25T09:00:00Z",
            verdict: Some(&verdict),
            diagnosis: Some(&diag),
        })
        .into_string();
        let st = section(&html, "standards");
        let row_start = st
            .find(&format!("data-figure=\"{}\"", figure.name))
            .unwrap();
        let row = &st[row_start..row_start + st[row_start..].find("</tr>").unwrap()];
        assert!(row.contains("badge verdict pass"), "{row}");
        assert!(!st.contains("No tolerance profile applies"));
        section(&html, "verdict");
        assert!(html.contains("Finding: backlash (X)"));
        assert!(section(&html, "check").contains("badge verdict pass"));
    }

    /// The `<tr data-item="…">` row of the budget table.
    fn budget_row<'a>(html: &'a str, item: &str) -> &'a str {
        let b = section(html, "budget");
        let start = b
            .find(&format!("data-item=\"{item}\""))
            .unwrap_or_else(|| panic!("no budget row {item}"));
        &b[start..start + b[start..].find("</tr>").unwrap()]
    }

    /// The backlash machine's figures (a residual of 0.976 µm against a noise floor of
    /// 0.149 µm): the report opens with the misfit banner, which states the residual,
    /// the floor and the gate's factor and sends the reader to the findings of the
    /// diagnosis, named by its id; the findings are in the summary, the whole diagnosis
    /// in the appendix.
    #[test]
    fn a_misfit_report_opens_with_the_banner_and_its_diagnosis() {
        let mut doc = simulated_check();
        doc.fit.residual_rms_um = 0.976;
        doc.fit.noise_estimate_um = Some(0.149);
        doc.model_check = None;
        let diag = ReportDiagnosis {
            id: "res_diag7".into(),
            stored: true,
            doc: Ok(finding()),
        };
        let html = check_report(&CheckReport {
            doc: &doc,
            result_id: Some("r-42"),
            generated_at: "2026-11-25T09:00:00Z",
            verdict: None,
            diagnosis: Some(&diag),
        })
        .into_string();
        let article = &html[html.find("<article").unwrap()..];
        let first = &article[article.find("<section").unwrap()..];
        assert!(
            first[..first.find('>').unwrap()].contains("id=\"misfit\""),
            "the first section is the banner: {}",
            &first[..200]
        );
        let banner = section(&html, "misfit");
        for want in [
            "the model does not explain this recording",
            "0.976 µm",
            "6.6 ×",
            "0.149 µm",
            "1.2 ×",
            "res_diag7",
            "href=\"#findings\"",
        ] {
            assert!(banner.contains(want), "the banner lacks {want}: {banner}");
        }
        let f = section(&html, "findings");
        assert!(
            f.contains("data-effect=\"backlash\"") && f.contains("backlash_um = 4.000"),
            "{f}"
        );
        assert!(f.contains("href=\"/results/res_diag7\""), "{f}");
        let appendix = html.find("id=\"appendix\"").unwrap();
        assert!(html.find("id=\"findings\"").unwrap() < appendix);
        assert!(html.find("Finding: backlash (X)").unwrap() > appendix);
        // The same check at noise level has no banner.
        let clean = simulated_check();
        let html = check_report(&CheckReport {
            doc: &clean,
            result_id: None,
            generated_at: "2026-11-25T09:00:00Z",
            verdict: None,
            diagnosis: None,
        })
        .into_string();
        assert!(!clean.model_check().is_misfit());
        assert!(!html.contains("id=\"misfit\""));
    }

    /// A stored diagnosis whose document does not read is said to be unreadable, with its
    /// id, in the findings and in the misfit banner: never "No diagnosis was run".
    #[test]
    fn an_unreadable_diagnosis_is_said_with_its_id() {
        let mut doc = simulated_check();
        doc.fit.residual_rms_um = 0.976;
        doc.fit.noise_estimate_um = Some(0.149);
        doc.model_check = None;
        let diag = ReportDiagnosis {
            id: "res_bad3".into(),
            stored: true,
            doc: Err("its document does not read: missing field `baseline`".into()),
        };
        let html = check_report(&CheckReport {
            doc: &doc,
            result_id: None,
            generated_at: "2026-11-25T09:00:00Z",
            verdict: None,
            diagnosis: Some(&diag),
        })
        .into_string();
        assert!(!html.contains("No diagnosis was run"));
        let f = section(&html, "findings");
        assert!(
            f.contains("could not be read") && f.contains("res_bad3") && f.contains("`baseline`"),
            "{f}"
        );
        let banner = section(&html, "misfit");
        assert!(
            banner.contains("res_bad3") && banner.contains("could not be read"),
            "{banner}"
        );
        assert!(!html.contains("id=\"diagnosis-detail\""));
    }

    /// The budget table against docs/conventions.md's worked example, computed here from
    /// its formulas: EXX's positioning range over L = the measured X travel takes the
    /// certificate's (a + b·L)/k, the differential expansion's u_th and the cosine error's
    /// L·ϑ²/(4√3) beside its fit u; an angular term takes no instrument contribution
    /// ("not included", with the reason); with a verdict every row carries the very u_c
    /// the decision used. The header names the operator, the instrument with its serial
    /// and calibration date and the temperature; the signature block follows.
    #[test]
    fn the_budget_table_and_the_conditions_are_the_verdicts() {
        let mut doc = simulated_check();
        doc.conditions = mtcal_solver::uncertainty::Conditions::worked_example();
        let html = check_report(&CheckReport {
            doc: &doc,
            result_id: None,
            generated_at: "2026-11-25T09:00:00Z",
            verdict: None,
            diagnosis: None,
        })
        .into_string();
        let [lo, hi] = doc.model.measured_travel_mm["X"];
        let l = (hi - lo) / 1000.0; // m
        let instrument = (0.5 + 1.0 * l) / 2.0;
        let e_nde = (11.5 - 8.0) * (22.0 - 20.0) * l;
        let thermal = ((e_nde / 3f64.sqrt()).powi(2)
            + (2.0 * l * (1.0f64 + 0.25).sqrt()).powi(2)
            + (3.5 * 0.2 * l).powi(2))
        .sqrt();
        let setup = (hi - lo) * 1000.0 * 500e-6f64.powi(2) / (4.0 * 3f64.sqrt());
        let figures = identification_figures(&doc);
        let fit = figures.figures["EXX"].u.unwrap();
        let u_c = (instrument.powi(2) + thermal.powi(2) + setup.powi(2) + fit.powi(2)).sqrt();
        let row = budget_row(&html, "EXX");
        for (what, v) in [
            ("instrument", instrument),
            ("thermal", thermal),
            ("setup", setup),
            ("fit", fit),
            ("u_c", u_c),
            ("U", 2.0 * u_c),
        ] {
            assert!(
                row.contains(&format!(">{}<", num(v))),
                "EXX {what} {}: {row}",
                num(v)
            );
        }
        if l == 0.1 {
            // The worked example's own numbers.
            assert!(row.contains(">0.300<") && row.contains(">0.467<"), "{row}");
        }
        let angular = ["EAX", "EBX", "ECX", "EAY", "EBY", "ECY"]
            .into_iter()
            .find(|t| figures.figures.contains_key(*t))
            .expect("an identifiable angular term");
        assert!(budget_row(&html, angular).contains("not included"));
        assert!(section(&html, "budget").contains("the certificate states no angular uncertainty"));
        let facts = section(&html, "check");
        for want in [
            "A. Keller",
            "grid encoder s/n 1234, calibrated 2026-03-01",
            "C-77",
            "22.0 °C",
            "0.200 K",
        ] {
            assert!(facts.contains(want), "the facts lack {want}: {facts}");
        }
        let sign = section(&html, "signature");
        for want in ["Checked by", "Date", "Signature"] {
            assert!(sign.contains(want), "{sign}");
        }
        // Without conditions the instrument is not included anywhere, and said so.
        let plain = simulated_check();
        let html = check_report(&CheckReport {
            doc: &plain,
            result_id: None,
            generated_at: "2026-11-25T09:00:00Z",
            verdict: None,
            diagnosis: None,
        })
        .into_string();
        let b = section(&html, "budget");
        assert_eq!(
            b.matches("<tr data-item=").count(),
            identification_figures(&plain).figures.len()
        );
        assert!(budget_row(&html, "EXX").contains("not included"));
        assert!(b.contains("no calibration certificate stated"), "{b}");
        assert!(section(&html, "check").contains("operator</dt><dd>not stated"));
        // With a verdict: its items' budgets, u_c as the decisions used them.
        let limits = mtcal_solver::tolerance::Limits {
            terms: [(
                "EXX".to_string(),
                mtcal_solver::tolerance::TermLimit::range(4.0),
            )]
            .into(),
            ..Default::default()
        };
        let how = Assessment::of_identification(&doc, Default::default());
        let verdict = mtcal_solver::tolerance::evaluate(&limits, &figures, &how);
        let html = check_report(&CheckReport {
            doc: &doc,
            result_id: None,
            generated_at: "2026-11-25T09:00:00Z",
            verdict: Some(&verdict),
            diagnosis: None,
        })
        .into_string();
        let item = &verdict.items[0];
        assert_eq!(item.item, "EXX");
        let row = budget_row(&html, "EXX");
        assert!(
            row.contains(&format!(">{}<", num(item.u.unwrap()))),
            "{row}"
        );
        assert!(
            row.contains(&format!(">{}<", num(item.expanded_u.unwrap()))),
            "{row}"
        );
        assert_eq!(
            section(&html, "budget").matches("<tr data-item=").count(),
            1
        );
    }

    /// The report of a cradle check whose C table tilts about its mount: facts, the
    /// compliance against A (one plot per term of the chosen model, each with its band),
    /// what the ball data can separate, and the undetermined: the location errors with
    /// no value and the terms the data cannot tell apart, named.
    #[test]
    fn cradle_report_draws_the_compliance_and_names_what_is_undetermined() {
        use mtcal_solver::cradle::{
            CradleOptions, CradleSimulation, Deflection, check_cradle, simulate_cradle,
        };
        let points = simulate_cradle(&CradleSimulation::example_with(Deflection::Mount, 1));
        let doc = check_cradle(&points, &CradleOptions::default()).unwrap();
        let html = cradle_report(&CradleCheckReport {
            doc: &doc,
            result_id: Some("r-7"),
            generated_at: "2026-11-25T09:00:00Z",
        })
        .into_string();
        for bad in ["<link", "<script", "src=\"http", "href=\"http"] {
            assert!(!html.contains(bad), "external asset: {bad}");
        }
        let facts = section(&html, "check");
        for want in [
            "SIM-CRADLE",
            "r-7",
            CRADLE_INSTRUMENT,
            "234 points at 13 A poses",
        ] {
            assert!(facts.contains(want), "facts lack {want}");
        }
        let compliance = section(&html, "compliance");
        let curves = &doc.kinematics.curves;
        assert!(curves.len() >= 2, "{:?}", doc.kinematics.description);
        assert_eq!(compliance.matches("<svg").count(), curves.len());
        assert!(compliance.contains("tilt about the mount, X") && compliance.contains("A (°)"));
        assert!(
            compliance.matches("<polygon").count() >= curves.len(),
            "a band per curve"
        );
        let sep = section(&html, "separability");
        assert!(sep.contains("sideways shift"));
        let und = section(&html, "undetermined");
        for e in doc.location_errors.iter().filter(|e| e.value.is_none()) {
            assert!(und.contains(e.name.as_str()), "{}", e.name);
        }
        assert!(und.contains("-90°, 90°"), "the measured A range");
        assert!(und.contains("tilt of the C table about its mount, about X"));
    }
}
