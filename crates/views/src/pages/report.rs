//! The check report: one self-contained HTML page per check (no external asset, the
//! stylesheet inlined, plots as inline SVG), laid out to print on A4 (`@page` and print
//! rules in the stylesheet). It reuses the result page's sections ([`super::result`])
//! and adds what a signed report needs: the check's facts (machine, date, instrument,
//! plan), the figures of the standards with their verdicts (or "no tolerance"), the
//! diagnosis findings when a diagnosis of the check exists, the compensation table's
//! summary, and what the data could not determine. A cradle (A/C) check has its own
//! report ([`cradle_report`]): facts, the result page's cradle sections (the compliance
//! against A with its bands among them) and what the ball data could not determine.

use super::result::{self, IdentificationView, VerdictRow, verdict_rows};
use super::{num, print_page, verdict_badge, when};
use crate::plots::{tick_label, unit_label};
use maud::{Markup, html};
use mtcal_formats::compensation::{Compensation, DEFAULT_STEP_MM, ExportError, Format};
use mtcal_solver::cradle::{CradleResult, LocationErrorReport, TermSeparability};
use mtcal_solver::diagnosis::{DiagnosisResult, Verdict as DiagnosisVerdict};
use mtcal_solver::explained::ExplainedModel;
use mtcal_solver::identification::IdentificationResult;
use mtcal_solver::positioning_check::DiagnosisDocument;
use mtcal_solver::terms::Term;
use mtcal_solver::tolerance::{Assessment, COVERAGE_K, Figures, Verdict, identification_figures};
use mtcal_solver::uncertainty::{ItemBudget, Source};

mod summary;
pub use summary::{ReportAction, actions};

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
                (result::misfit_banner(d, Some(misfit_diagnosis(r.diagnosis, d.explained.as_ref()))))
                (facts(r))
                (summary::decision(r))
                (findings(r.diagnosis, d))
                (summary::actions_section(r))
                (summary::standards(r))
                @if r.verdict.is_some() { (budget(r)) }
                (undetermined(d, &compensation))
                (signature(r))
                div.appendix #appendix {
                    h1 { "Appendix: detail" }
                    (summary::figures_all(r))
                    @if !rows.is_empty() { (result::verdict_table(&rows)) }
                    @if r.verdict.is_none() { (budget(r)) }
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
/// of the recording, why it could not be read, the physics the document's explained
/// model adds (and what remains), or that none is stored yet.
fn misfit_diagnosis(d: Option<&ReportDiagnosis>, explained: Option<&ExplainedModel>) -> Markup {
    html! {
        @match d {
            None if explained.is_some() => {
                "The diagnosis of this recording found physics the 21 terms leave out; the \
                 explained model adds it and still leaves a misfit: see "
                a href="#findings" { "its findings" } " below."
            }
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
                dt { "instrument" } dd.wide { (INSTRUMENT) ": "
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
                dt { "plan" } dd.wide {
                    (files.len()) " plane file(s), " (d.nuisance.runs) " runs, "
                    (d.nuisance.mountings.len()) " mounting(s), " (d.fit.samples) " samples"
                    @if !files.is_empty() { ": " (files.join(", ")) }
                }
                dt { "measured travel" } dd.wide {
                    @for (i, (axis, [lo, hi])) in d.model.measured_travel_mm.iter().enumerate() {
                        @if i > 0 { "; " } (axis) " [" (num(*lo)) ", " (num(*hi)) "] mm"
                    }
                }
                dt { "model" } dd.wide { (format!("{:?}", d.method).to_lowercase()) " identification, "
                    (d.model.basis.name()) " basis of order " (d.model.order) }
                dt { "convention" } dd.wide { (d.convention) }
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
                                td { (mtcal_solver::names::in_words(row.item)) }
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
/// in the appendix): the physics of the document's explained model (the check decided on
/// it, or partly explained), the diagnosis's findings or why it could not be read, or
/// that none was run.
fn findings(d: Option<&ReportDiagnosis>, doc: &IdentificationResult) -> Markup {
    html! {
        section.card #findings {
            h2 { "Findings of the diagnosis" }
            @if let Some(m) = &doc.explained { (explained_findings(m, doc)) }
            @match d {
                None if doc.explained.is_some() => {}
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

/// What the document's explained model says of the check: decided on it, or partly
/// explained (with what remains), and the physics it adds to the 21 terms as fitted.
fn explained_findings(m: &ExplainedModel, doc: &IdentificationResult) -> Markup {
    let check = doc.model_check();
    let decided = m.verdict == DiagnosisVerdict::Explained && check.decided_on_explained_model();
    html! {
        div #explained-findings data-decided=(decided) {
            p {
                @if decided {
                    "This check was decided on the explained model: the 21 terms fitted jointly with "
                    (m.adds) ", the physics the diagnosis"
                } @else if m.verdict == DiagnosisVerdict::PartlyExplained {
                    "This check is partly explained by the explained model (the 21 terms fitted \
                     jointly with " (m.adds) ") and is not decided on it; the physics the diagnosis"
                } @else {
                    "This check is not decided on the explained model (the 21 terms fitted jointly \
                     with " (m.adds) "): " (check.statement) ". The physics the diagnosis"
                }
                @if let Some(id) = &m.diagnosis_result_id { " (" (id) ")" }
                " found, as the model fits it (u: standard uncertainty, k = 1):"
            }
            ul.compact.physics {
                @for p in &m.physics {
                    li data-effect=(p.effect) { (p.name_in_words()) ": " (super::explained::parameters(p)) }
                }
            }
            @if !m.remains.is_empty() {
                p { "What remains unexplained: " (mtcal_solver::misfit::remains_in_short(&m.remains)) "." }
            }
            p.muted { "The explained model's figures are in the appendix." }
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
        && d.standards.not_available().is_empty()
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
                    @if !o.confounded.is_empty() {
                        li { (o.confounded.len()) " group(s) of terms cannot be separated (appendix, Identifiability)" }
                    }
                    @if !not_moved.is_empty() {
                        li { "Axes that did not move (nothing is known of them): " (not_moved.join(", ")) }
                    }
                    @for n in &d.standards.not_evaluated {
                        li { (n.standard) " " (n.what) ": " (n.reason) }
                    }
                    @for n in &d.standards.not_available() {
                        li.not-available { (mtcal_solver::names::figures_in_words(&n.figures)) ": — (" (n.reason) ")" }
                    }
                    @if !left_out.is_empty() { li { "Left out of the compensation table: " (left_out.join(", ")) } }
                    li { "Nothing outside the measured travel: "
                        @for (i, (axis, [lo, hi])) in d.model.measured_travel_mm.iter().enumerate() {
                            @if i > 0 { "; " } (axis) " [" (num(*lo)) ", " (num(*hi)) "] mm"
                        }
                    }
                }
                @if !o.advice.is_empty() {
                    p.muted { "What would determine them: see Actions." }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests;
