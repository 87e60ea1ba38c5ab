//! The result page, and its sections as reusable functions (the check report renders
//! the same sections in [`super::print_page`]): identification, diagnosis, cradle,
//! sensitivity, and the verdict table.

use super::{Nav, Viewer, csrf_field, machine_href, num, page, svg, verdict_badge, when, with_u};
use crate::plots;
use maud::{Markup, html};
use mtcal_solver::cradle::CradleResult;
use mtcal_solver::diagnosis::{DiagnosisResult, Finding};
use mtcal_solver::identification::IdentificationResult;
use mtcal_solver::positioning_check::DiagnosisDocument;
use mtcal_solver::residuals::ResidualSummary;
use mtcal_solver::sensitivity::SensitivityResult;
use mtcal_solver::standards::iso230_2::{FIGURES, Iso2302, run_label};
use mtcal_solver::standards::iso230_4::CirclePlot;
use mtcal_solver::tolerance::{Verdict, VerdictItem};
use serde::{Deserialize, Serialize};

/// One line of a verdict: a quantity checked against its limit by the decision rule
/// (pass when value + U ≤ limit, fail when value − U > limit, else undecided; an error
/// function's value is its range over the measured travel).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct VerdictRow {
    /// e.g. `EXX`, `EC0Y`, `iso230_2.X.E_um`.
    pub quantity: String,
    /// Where (e.g. `max over −50…50 mm`), empty when not positional.
    pub at: String,
    pub value: f64,
    /// Standard uncertainty u (U = 2u).
    pub std: Option<f64>,
    pub limit: f64,
    pub unit: String,
    /// `pass`, `fail` or `undecided`.
    pub outcome: String,
}

/// Where a verdict item's deciding value lies, in words (`at 28.54 mm of [0, 100] mm`,
/// `max at 80.00, min at 12.50 mm`, `over [0, 100] mm`), with how a per-length limit was
/// scaled to the measured length and the part of the registered travel covered; for an
/// undetermined item, why.
pub fn item_at(i: &VerdictItem) -> String {
    let over = |[lo, hi]: [f64; 2]| format!("[{}, {}] mm", num(lo), num(hi));
    let place = match (i.position_mm, i.at_mm, i.travel_mm) {
        (Some(q), _, Some(t)) => format!("at {} mm of {}", num(q), over(t)),
        (Some(q), _, None) => format!("at {} mm", num(q)),
        (None, Some([a, b]), Some(t)) => {
            format!("max at {}, min at {} mm of {}", num(a), num(b), over(t))
        }
        (None, Some([a, b]), None) => format!("max at {}, min at {} mm", num(a), num(b)),
        (None, _, Some(t)) => format!("over {}", over(t)),
        _ if i.value.is_none() => i.reason.clone(),
        _ => String::new(),
    };
    let scaled = i
        .limit_basis
        .as_ref()
        .map(|b| format!("limit {}", mtcal_solver::text::person_units(b)));
    [Some(place), scaled, i.coverage.clone()]
        .into_iter()
        .flatten()
        .filter(|s| !s.is_empty())
        .collect::<Vec<_>>()
        .join("; ")
}

/// A verdict's items as the verdict table shows them (an undetermined item shows no
/// value).
pub fn verdict_rows(v: &Verdict) -> Vec<VerdictRow> {
    v.items
        .iter()
        .map(|i| VerdictRow {
            quantity: i.item.clone(),
            at: item_at(i),
            value: i.value.unwrap_or(f64::NAN),
            std: i.u,
            limit: i.limit,
            unit: i.unit.clone(),
            outcome: i.decision.as_str().to_string(),
        })
        .collect()
}

/// Everything an identification section shows: the document, and its circle tests as
/// polar-plot traces, or why the stored ones could not be read.
pub struct IdentificationView<'a> {
    pub doc: &'a IdentificationResult,
    pub circles: Result<Vec<CirclePlot>, String>,
    /// The range limit each error function was judged against (drawn on its panel).
    pub limits: std::collections::BTreeMap<String, f64>,
}

impl<'a> IdentificationView<'a> {
    /// The view of a document, its circle tests from its `circles`.
    pub fn of(doc: &'a IdentificationResult) -> Self {
        IdentificationView {
            doc,
            circles: Ok(doc.circles.clone()),
            limits: Default::default(),
        }
    }

    /// The view with the range limits of the verdict's rows that judge an error function.
    pub fn with_limits(mut self, rows: &[VerdictRow]) -> Self {
        self.limits = rows
            .iter()
            .filter(|r| self.doc.terms.contains_key(&r.quantity))
            .map(|r| (r.quantity.clone(), r.limit))
            .collect();
        self
    }

    /// The travel of term `name`'s axis that the check measured (None: the document
    /// names none, and the reported positions are drawn as they are).
    fn travel(&self, name: &str) -> Option<[f64; 2]> {
        let t = mtcal_solver::terms::Term::parse(name)?;
        self.doc
            .model
            .measured_travel_mm
            .get(&t.axis.letter().to_string())
            .copied()
    }
}

/// An identification document as the service stores it (JSON), read for its page. Its
/// circle tests are read on their own: a stored shape this version does not read leaves
/// a note where their polar plots would be, instead of failing the whole page or
/// leaving the section out without a word.
pub struct StoredIdentification {
    pub doc: IdentificationResult,
    /// Why the stored circle tests could not be read (None: read, or none stored).
    pub circles_error: Option<String>,
}

impl StoredIdentification {
    /// Reads a stored document; an error when the document itself (without its circle
    /// tests) is not an identification result.
    pub fn read(mut document: serde_json::Value) -> Result<Self, serde_json::Error> {
        let circles = document.as_object_mut().and_then(|o| o.remove("circles"));
        let mut doc: IdentificationResult = serde_json::from_value(document)?;
        let circles_error = match circles.map(serde_json::from_value) {
            None => None,
            Some(Ok(c)) => {
                doc.circles = c;
                None
            }
            Some(Err(e)) => Some(format!(
                "The circle tests stored with this result could not be read ({e}); their \
                 polar plots cannot be drawn."
            )),
        };
        Ok(StoredIdentification { doc, circles_error })
    }

    /// The page's view of it.
    pub fn view(&self) -> IdentificationView<'_> {
        let mut v = IdentificationView::of(&self.doc);
        if let Some(e) = &self.circles_error {
            v.circles = Err(e.clone());
        }
        v
    }
}

/// The header facts of a stored result.
#[derive(Debug, Clone, PartialEq)]
pub struct ResultHeader {
    pub id: String,
    pub machine_id: String,
    /// `identification`, `diagnosis`, `cradle`, `sensitivity`.
    pub kind: String,
    pub measured_at: String,
    pub created_at: String,
    pub dataset_id: Option<String>,
    pub is_baseline: bool,
    /// The overall verdict, when a tolerance profile applies.
    pub verdict: Option<String>,
    /// The tolerance profile that applies to the machine (`scope target`), verdict or
    /// not.
    pub profile: Option<String>,
    /// What the diagnosis of the recording this result was computed from found, when one
    /// is stored (said in the misfit banner).
    pub diagnosis: Option<super::DiagnosisFindings>,
}

/// The body of a result page, by kind.
pub enum ResultBody<'a> {
    Identification(IdentificationView<'a>),
    /// A diagnosis, with the ISO 230-2 figures of a positioning-run recording.
    Diagnosis(&'a DiagnosisDocument),
    Cradle(&'a CradleResult),
    Sensitivity(&'a SensitivityResult),
}

/// The 18 functions in the ISO 230-1 table's order: per moving axis, positioning, the
/// two straightnesses, roll, then pitch and yaw.
pub const TERM_ORDER: [&str; 18] = [
    "EXX", "EYX", "EZX", "EAX", "EBX", "ECX", "EYY", "EXY", "EZY", "EBY", "EAY", "ECY", "EZZ",
    "EXZ", "EYZ", "ECZ", "EAZ", "EBZ",
];

/// The result page.
pub fn result_page(
    viewer: &Viewer,
    header: &ResultHeader,
    verdict: &[VerdictRow],
    body: &ResultBody,
) -> Markup {
    let title = format!("{} {} of {}", header.kind, header.id, header.machine_id);
    // A misfit check: no compensation table (the export refuses it) and not a baseline
    // (the API refuses it); the banner below says why.
    let misfit = matches!(body, ResultBody::Identification(v) if v.doc.model_check().is_misfit());
    page(
        &title,
        Nav::Other,
        Some(viewer),
        html! {
            h1 { (header.kind) " of " a href=(machine_href(&header.machine_id)) { (header.machine_id) }
                 " " (header_badge(header)) }
            p.lead {
                "Measured " (when(&header.measured_at)) " · computed " (when(&header.created_at))
                " · result " code { (header.id) }
                @if let Some(d) = &header.dataset_id { " · dataset " code { (d) } }
                @if header.is_baseline { " · " span.badge { "baseline" } }
                " · " a href={ "/api/v1/results/" (super::encode(&header.id)) } { "JSON" }
            }
            @if header.kind == "identification" {
                p.links #result-links {
                    a.report href={ "/api/v1/results/" (super::encode(&header.id)) "/report" } { "Check report" }
                    @if misfit {
                        " · " span.muted.no-tables { "no compensation table: its model does not explain its recording" }
                    } @else {
                        " · compensation tables: "
                        @for (k, f) in mtcal_formats::compensation::Format::ALL.iter().enumerate() {
                            @if k > 0 { ", " }
                            a.export href={ "/api/v1/results/" (super::encode(&header.id)) "/export?format=" (f.name()) } { (f.name()) }
                        }
                    }
                }
                @if !misfit { @if let ResultBody::Identification(v) = body { (reversal_table(&header.id, v.doc)) } }
            }
            @if header.kind == "identification" && viewer.can_write() && !header.is_baseline && !misfit {
                form.inline method="post" action={ (machine_href(&header.machine_id)) "/baseline" } {
                    (csrf_field(&viewer.csrf))
                    input type="hidden" name="result_id" value=(header.id);
                    button.secondary type="submit" { "Set as baseline" }
                }
            }
            @if let ResultBody::Identification(v) = body {
                (misfit_banner(v.doc, header.diagnosis.as_ref().map(|d| d.sentence())))
            }
            @if !verdict.is_empty() { (verdict_table(verdict)) }
            (sections(body))
        },
    )
}

/// The reversal the explained model found, and the LinuxCNC table that carries it (its
/// forward and reverse columns): nothing for a check without one.
fn reversal_table(id: &str, d: &IdentificationResult) -> Markup {
    let reversals: Vec<String> = d
        .explained
        .iter()
        .flat_map(|m| &m.physics)
        .filter(|p| matches!(p.effect.as_str(), "backlash" | "lost_motion_profile"))
        .map(|p| p.name_in_words())
        .collect();
    html! {
        @if !reversals.is_empty() {
            p.links #reversal-table {
                "Reversal compensation of " (reversals.join(", ")) ": "
                a.export.linuxcnc href={ "/api/v1/results/" (super::encode(id)) "/export?format=linuxcnc" } {
                    "LinuxCNC compensation table"
                }
                " (forward and reverse values per position, one COMP_FILE per joint; the actions below give the value for a controller's backlash parameter instead)"
            }
        }
    }
}

/// The header's verdict badge: the verdict; without one, that no limit of the profile
/// applies to this result, or that no profile applies to the machine.
fn header_badge(h: &ResultHeader) -> Markup {
    match (&h.verdict, &h.profile) {
        (Some(v), _) => verdict_badge(Some(v)),
        (None, Some(p)) => html! {
            span.badge.none title={ "the tolerance profile of " (p) " applies to the machine; none of its limits to this result" } {
                "no limit applies"
            }
        },
        (None, None) => verdict_badge(None),
    }
}

/// The sections of a result body (no page around them).
pub fn sections(body: &ResultBody) -> Markup {
    match body {
        ResultBody::Identification(v) => identification(v),
        ResultBody::Diagnosis(d) => html! { (diagnosis(&d.diagnosis)) (iso230_2(&d.iso230_2)) },
        ResultBody::Cradle(c) => cradle(c),
        ResultBody::Sensitivity(s) => sensitivity(s),
    }
}

/// The verdict table: each quantity, its value ± U, the limit and the outcome.
pub fn verdict_table(rows: &[VerdictRow]) -> Markup {
    html! {
        section.card #verdict {
            h2 { "Verdict" }
            p.muted { "Decision rule (ISO 14253-1): an error function is judged by its range over \
                       the measured travel, a squareness or an ISO figure by its magnitude; pass when \
                       value + U ≤ limit, fail when value − U > limit, undecided otherwise; U = 2u \
                       (docs/conventions.md, Decisions)." }
            table {
                thead { tr { th { "quantity" } th { "where" } th.num { "value ± U" } th.num { "limit" } th { "outcome" } } }
                tbody {
                    @for r in rows {
                        tr {
                            td { (r.quantity) } td { (r.at) }
                            td.num { (with_u(Some(r.value), r.std, &r.unit)) }
                            td.num { (num(r.limit)) " " (plots::unit_label(&r.unit)) }
                            td { (verdict_badge(Some(&r.outcome))) }
                        }
                    }
                }
            }
        }
    }
}

/// The misfit gate's banner of an identification whose model does not explain its
/// recording (nothing otherwise): first on its page, above the verdict, and first in its
/// check report. It states the gate's finding (the residual RMS against the noise floor
/// and the factor), that no value is judged and that the compensation table is refused
/// unless forced, and where the diagnosis of the recording is: `diagnosis` says it (the
/// report names the diagnosis it holds), else the machine's page lists the diagnoses.
pub fn misfit_banner(d: &IdentificationResult, diagnosis: Option<Markup>) -> Markup {
    let check = d.model_check();
    html! {
        @if check.is_misfit() {
            // The misfit gate: no value of this model is judged, no table made unforced.
            section.card.misfit #misfit {
                h2 { "Not decided: model misfit" }
                p { (check.statement) "." }
                p { "No value of this model is judged against a tolerance and its compensation \
                     table is refused unless forced. "
                    @match diagnosis {
                        Some(m) => { (m) }
                        None => {
                            "The diagnosis of this recording says which physics the model leaves \
                             out: see the diagnoses on "
                            a href=(machine_href(&d.machine_id)) { "the machine's page" } "."
                        }
                    }
                }
            }
        }
    }
}

/// Fit figures, squareness, the 18 error functions, residuals, circle tests,
/// identifiability and reporting notes of an identification.
pub fn identification(v: &IdentificationView) -> Markup {
    let d = v.doc;
    let o = &d.observability;
    html! {
        (super::explained::section(d))
        section.card #fit {
            h2 { "Fit" }
            dl.facts {
                dt { "method" } dd { (format!("{:?}", d.method).to_lowercase()) ", " (format!("{:?}", d.model.basis).to_lowercase()) " basis, order " (d.model.order) }
                dt { "samples" } dd { (d.fit.samples) }
                dt { "residual RMS" } dd { (num(d.fit.residual_rms_um)) " µm" }
                dt { "noise from repeated passes" } dd {
                    @match d.fit.noise_estimate_um { Some(n) => { (num(n)) " µm" } None => { "— (no repeated passes)" } }
                }
                dt { "identifiability" } dd { "rank " (o.rank) " of " (o.parameters) " parameters, condition number " (format!("{:.3e}", o.condition_number)) }
            }
        }
        (squareness(d))
        section.card #terms {
            h2 { "Error functions over the measured travel (±2σ)" }
            div.grid.three {
                @for name in TERM_ORDER {
                    @if let Some(t) = d.terms.get(name) {
                        figure.plot data-term=(name) data-identifiable=(t.identifiable) {
                            (svg(plots::error_function(name, t, v.travel(name), v.limits.get(name).copied())))
                        }
                    }
                }
            }
        }
        @if !d.residuals.is_empty() { (residuals(&d.residuals)) }
        @match &v.circles {
            Ok(c) => { @if !c.is_empty() { (circles(c, &d.standards.iso230_4)) } }
            Err(e) => {
                section.card #circles {
                    h2 { "Circle tests" }
                    div.notice.error.circles-error { (e) }
                }
            }
        }
        section.card #identifiability {
            h2 { "Identifiability" }
            @if o.not_identifiable.is_empty() {
                p { "Every term is separately identifiable with this plan." }
            } @else {
                p { "Not identifiable (never shown as a number of its own): " (o.not_identifiable.join(", ")) }
                ul.compact { @for c in &o.confounded { li { (c.terms.join(" + ")) " — seen as " (c.seen_as) } } }
            }
            @if !o.advice.is_empty() {
                h3 { "Advice" }
                ul.compact { @for a in &o.advice { li { (a) } } }
            }
            h3 { "Reporting conventions" }
            ul.compact { @for r in &d.reporting { li { (r) } } }
        }
    }
}

fn squareness(d: &IdentificationResult) -> Markup {
    html! {
        section.card #squareness {
            h2 { "Squareness" }
            table {
                thead { tr { th { "term" } th.num { "value ± U" } th { "angle" } th { "measured as" } } }
                tbody {
                    @for (name, s) in ["EC0Y", "EB0Z", "EA0Z"].iter().filter_map(|n| d.squareness.get(*n).map(|s| (n, s))) {
                        tr data-term=(name) {
                            td { (name) }
                            @if s.identifiable {
                                td.num { (with_u(s.value_urad, s.std_urad, "urad")) }
                                td { (angle(name, s.value_urad)) }
                                td title=[s.reported_as.as_deref()] { (reported_as_words(s.reported_as.as_deref())) }
                            } @else {
                                td.num colspan="3" { "not identifiable"
                                    @if !s.confounded_with.is_empty() { " (with " (s.confounded_with.join(", ")) ")" } }
                            }
                        }
                    }
                }
            }
        }
    }
}

/// How a squareness is reported, in words (its code name on hover).
fn reported_as_words(code: Option<&str>) -> &str {
    match code {
        Some("ls_axis_lines") => "the angle between the least-squares lines of the two axes",
        Some("model_constant") => {
            "the model's constant (the straightness slopes the axis lines need are not determined)"
        }
        Some(other) => other,
        None => "",
    }
}

/// The angle between two axes from a squareness value (docs/conventions.md: X–Y =
/// 90° + EC0Y, X–Z = 90° − EB0Z, Y–Z = 90° + EA0Z).
fn angle(name: &str, v: Option<f64>) -> String {
    let Some(v) = v else { return String::new() };
    let (axes, sign) = match name {
        "EC0Y" => ("X–Y", 1.0),
        "EB0Z" => ("X–Z", -1.0),
        "EA0Z" => ("Y–Z", 1.0),
        _ => return String::new(),
    };
    format!(
        "{axes} = 90° {} {} µrad",
        if sign * v >= 0.0 { "+" } else { "−" },
        num(v.abs())
    )
}

fn residuals(rows: &[ResidualSummary]) -> Markup {
    html! {
        section.card #residuals {
            h2 { "Residual by file and test" }
            table {
                thead { tr { th { "file" } th { "test" } th.num { "runs" } th.num { "samples" } th.num { "RMS (µm)" } } }
                tbody { @for r in rows { tr { td { (r.file) } td { (r.test) } td.num { (r.runs) } td.num { (r.samples) } td.num { (num(r.rms_um)) } } } }
            }
        }
    }
}

/// Circle tests grouped by file, plane and radius (both directions in one polar plot),
/// all on one radial scale ([`plots::circle_step`]), each with the ISO 230-4 figures of
/// its file and plane (`iso`): G per direction, H and the bidirectional G, and F (its
/// maximum and minimum) when the radius is traceable.
fn circles(all: &[CirclePlot], iso: &[mtcal_solver::standards::Iso2304]) -> Markup {
    let mut groups: Vec<Vec<CirclePlot>> = vec![];
    for c in all {
        match groups
            .iter_mut()
            .find(|g| g[0].file == c.file && g[0].plane == c.plane && g[0].radius_mm == c.radius_mm)
        {
            Some(g) => g.push(c.clone()),
            None => groups.push(vec![c.clone()]),
        }
    }
    let step = plots::circle_step(all);
    let figures = |c: &CirclePlot| iso.iter().find(|f| f.file == c.file && f.plane == c.plane);
    html! {
        section.card #circles {
            h2 { "Circle tests" }
            p.muted { "Radial deviation (measured − nominal radius) and the fitted model's, \
                       counter-clockwise (ccw, blue) and clockwise (cw, red), the measured trace \
                       thick; every plot on the same radial scale, rings every " (plots::tick_label(step)) " µm. \
                       ISO 230-4 figures: G circular deviation, H circular hysteresis, F radial deviation \
                       (max, min)." }
            div.grid {
                @for g in &groups {
                    figure.plot.polar data-file=(g[0].file) {
                        (svg(plots::circle_polar(g, step)))
                        figcaption {
                            (g[0].file) ", " (g[0].plane) " plane, R " (plots::nominal_mm(g[0].radius_mm)) " mm, F "
                            (num(g[0].feed_mm_min)) " mm/min, centre (" (num(g[0].centre_mm[0])) ", " (num(g[0].centre_mm[1])) ") mm"
                            @if let Some(f) = figures(&g[0]) {
                                br;
                                span.iso230-4 {
                                    "ISO 230-4: "
                                    @for (k, d) in f.directions.iter().enumerate() {
                                        @if k > 0 { "; " }
                                        "G(" (d.direction) ") " (num(d.g_um)) " µm"
                                        @if f.traceable_radius { ", F(" (d.direction) ") max " (num(d.f_max_um)) ", min " (num(d.f_min_um)) " µm" }
                                    }
                                    @if let Some(b) = &f.bidirectional {
                                        "; G(b) " (num(b.g_um)) " µm, H " (num(b.h_um)) " µm"
                                    }
                                }
                            }
                        }
                    }
                }
            }
        }
    }
}

/// A parameter's value ± u (k = 1) in one cell with its unit, u to two significant
/// digits and the value to its place (`6.004 ± 0.004 µm`); without u, the value alone.
fn value_u(key: &str, value: f64, u: Option<f64>) -> String {
    let (_, unit) = mtcal_solver::text::parameter_name(key);
    let v = match u {
        Some(u) if u.is_finite() => mtcal_solver::text::with_std(value, u, 2, false),
        _ => num(value),
    };
    format!("{v} {unit}").trim_end().to_string()
}

/// A parameter's name in words, its code name on hover.
fn parameter_cell(key: &str) -> Markup {
    html! { td title=(key) { (mtcal_solver::text::parameter_name(key).0) } }
}

/// A finding's fitted parameters, each as value ± u in one cell (its `std_*` entry is its
/// u, not a row of its own).
fn parameters(f: &Finding) -> Markup {
    html! {
        table.parameters {
            thead { tr { th { "parameter" } th.num { "value ± u (k = 1)" } } }
            tbody {
                @for (k, v) in f.parameters.iter().filter(|(k, _)| !k.starts_with("std_")) {
                    tr { (parameter_cell(k)) td.num { (value_u(k, *v, f.parameters.get(&format!("std_{k}")).copied())) } }
                }
            }
        }
    }
}

/// A finding's parameters the data leave undetermined: value ± u and what would decide
/// each (nothing when all are determined).
fn undetermined(f: &Finding) -> Markup {
    html! {
        @if !f.undetermined.is_empty() {
            h3 { "Undetermined" }
            table.undetermined {
                thead { tr { th { "parameter" } th.num { "value ± u (k = 1)" } th { "would be decided by" } } }
                tbody { @for u in &f.undetermined { tr {
                    (parameter_cell(&u.name))
                    td.num { (value_u(&u.name, u.value, u.std)) @if u.std.is_none() { " (no finite bound on u)" } }
                    td { (u.decide) }
                } } }
            }
        }
    }
}

/// How strongly the data prefer a model, from its ΔBIC (the model with the effect minus
/// the model without; negative favours the effect): the odds exp(−ΔBIC/2) and the
/// strength of evidence on Kass and Raftery's scale.
pub fn preference_in_words(dbic: f64) -> String {
    let two_ln_k = -dbic;
    if two_ln_k.is_nan() || two_ln_k <= 0.0 {
        return "the data do not prefer this model".into();
    }
    let strength = match two_ln_k {
        x if x > 10.0 => "very strong evidence",
        x if x > 6.0 => "strong evidence",
        x if x > 2.0 => "positive evidence",
        _ => "barely worth mentioning",
    };
    let odds = (two_ln_k / 2.0).exp();
    let odds = if odds > 1e6 {
        "more than a million to one".to_string()
    } else {
        format!("about {} to one", mtcal_solver::text::short(odds.round()))
    };
    format!("the data prefer this model by odds of {odds} ({strength})")
}

/// A finding's evidence in words: its `BIC ±x` said as what it means
/// ([`preference_in_words`]), the number on hover.
fn evidence(text: &str) -> Markup {
    let text = mtcal_solver::text::person_units(text).replace(" -> ", " → ");
    let parsed = text.find("BIC ").and_then(|at| {
        let rest = &text[at + 4..];
        let end = rest.find(char::is_whitespace).unwrap_or(rest.len());
        let dbic: f64 = rest[..end].parse().ok()?;
        Some((at, at + 4 + end, dbic))
    });
    match parsed {
        Some((start, end, dbic)) => html! {
            (text[..start])
            span.bic title={ "ΔBIC = " (format!("{dbic:+.1}")) " (Bayesian information criterion of the model with this effect minus the model without; −10 or below is very strong evidence)" } {
                (preference_in_words(dbic))
            }
            (text[end..])
        },
        None => html! { (text) },
    }
}

/// A diagnosis in short: its verdict in words, each finding with its axis and its
/// parameters with their standard uncertainties (`std_*`), the possible (undetermined)
/// effects, and what is left unexplained (the machine page and the check report; the
/// whole diagnosis is [`diagnosis`]).
pub fn findings_summary(doc: &DiagnosisResult) -> Markup {
    use mtcal_solver::diagnosis::Verdict;
    html! {
        p {
            (match doc.verdict {
                Verdict::Consistent => "consistent: the rigid model explains the recording to noise level",
                Verdict::Explained => "explained by the findings below",
                Verdict::PartlyExplained => "partly explained: a misfit remains (see the diagnosis)",
            })
        }
        @if !doc.findings.is_empty() || !doc.possible.is_empty() {
            ul {
                @for f in &doc.findings {
                    li data-effect=(f.effect) {
                        strong { (f.name_in_words()) }
                        ": " (f.parameters_in_words())
                    }
                }
                @for f in &doc.possible {
                    li data-effect=(f.effect) {
                        (f.name_in_words()) " — possible, undetermined"
                    }
                }
            }
        }
        @for u in &doc.unexplained { p.muted { "Unexplained: " (mtcal_solver::text::person_units(u)) } }
    }
}

/// Verdict, baseline figures, where the misfit is, the findings with their before/after
/// plots and held-out figures, the possible (undetermined) effects, the diagnosis plots and what remains unexplained.
pub fn diagnosis(d: &DiagnosisResult) -> Markup {
    let verdict = match d.verdict {
        mtcal_solver::diagnosis::Verdict::Consistent => "consistent",
        mtcal_solver::diagnosis::Verdict::Explained => "explained",
        mtcal_solver::diagnosis::Verdict::PartlyExplained => "partly explained",
    };
    html! {
        section.card #diagnosis {
            h2 { "Diagnosis of a " (d.source.replace('_', " ")) ": " (verdict) }
            dl.facts {
                dt { "rigid model, residual RMS" } dd { (num(d.baseline.residual_rms_um)) " µm" }
                dt { "rigid model, held-out RMS" } dd { (num(d.baseline.heldout_rms_um)) " µm" }
                dt { "noise floor" } dd { (num(d.baseline.noise_estimate_um)) " µm" }
            }
            @if !d.mismatch.is_empty() {
                h3 { "Where the model and the recording differ" }
                table.mismatch {
                    thead { tr { th { "where" } th.num { "share of misfit" } th { "tests" } } }
                    tbody { @for m in &d.mismatch {
                        tr.part[m.by_file_and_test()] { td { (mtcal_solver::text::person_units(&m.where_)) } td.num { (format!("{:.0} %", 100.0 * m.share_of_misfit)) } td { (m.tests.join(", ")) } }
                    } }
                }
                p.muted.mismatch-share {
                    "Share of misfit: of the squared residual above the noise floor. "
                    @match mtcal_solver::diagnosis::listed_share(&d.mismatch) {
                        Some(sum) => {
                            "The places by file and test listed (they do not overlap) carry "
                            (format!("{:.0} %", 100.0 * sum)) " of the misfit together; the finer places (angles,                             reversals, times, local anomalies) lie inside them."
                        }
                        None => { "Places may overlap: their shares do not add up." }
                    }
                }
            }
        }
        @for f in &d.findings {
            section.card.finding data-effect=(f.effect) {
                h2 { "Finding: " (f.effect.replace('_', " ")) @if let Some(a) = f.axis_label() { " (" (a) ")" } }
                div.pair {
                    div {
                        p { (mtcal_solver::text::person_units(&f.physics)) }
                        table {
                            thead { tr { th { "" } th.num { "before (µm)" } th.num { "after (µm)" } } }
                            tbody {
                                tr { td { "residual RMS (fit)" } td.num { (num(f.residual_rms_um.before)) } td.num { (num(f.residual_rms_um.after)) } }
                                tr { td { "held-out RMS" } td.num { (num(f.heldout_rms_um.before)) } td.num { (num(f.heldout_rms_um.after)) } }
                            }
                        }
                        h3 { "Parameters" }
                        (parameters(f))
                        (undetermined(f))
                        @for r in &f.rivals { p.rival { "rival: " (mtcal_solver::text::person_units(&r.in_words())) } }
                        p.muted.evidence { (evidence(&f.evidence)) }
                    }
                    figure.plot { (svg(plots::finding_bars(f, d.baseline.noise_estimate_um))) }
                }
            }
        }
        @for f in &d.possible {
            section.card.possible data-effect=(f.effect) {
                h2 { "Possible, undetermined: " (f.effect.replace('_', " ")) @if let Some(a) = f.axis_label() { " (" (a) ")" } }
                p { (mtcal_solver::text::person_units(&f.physics)) }
                (undetermined(f))
                p.muted.evidence { (evidence(&f.evidence)) }
            }
        }
        @if !d.plots.is_empty() {
            section.card #diagnosis-plots {
                h2 { "Before and after" }
                div.grid { @for (p, drawn) in d.plots.iter().zip(plots::render_svgs(&d.plots)) { figure.plot.wide[p.kind != mtcal_solver::diagnosis::PlotKind::Polar] data-plot=(p.id) { (svg(drawn)) } } }
            }
        }
        @if !d.unexplained.is_empty() {
            section.card { h2 { "Unexplained" } ul.compact { @for u in &d.unexplained { li { (u) } } } }
        }
    }
}

/// ISO 230-2 figures per axis (value ± U): the standard's, with every reading, and, when
/// the outlier test of the repeated readings set readings aside, the same figures without
/// them in a column of their own, labelled as not the standard's; the notes and the
/// readings set aside.
pub fn iso230_2(figs: &[Iso2302]) -> Markup {
    html! {
        @for f in figs {
            section.card.iso230-2 data-axis=(f.axis.to_string()) {
                h2 { "ISO 230-2, axis " (f.axis) }
                p.muted { (f.targets) " targets, " (f.runs) " runs (" (f.n_up) " + and " (f.n_down) " − readings per target at least); µm, U = 2u." }
                table {
                    thead { tr {
                        th { "figure" } th.num { "standard (every reading)" }
                        @if f.without_outlying.is_some() { th.num { "without the outlying readings (not the standard's)" } }
                    } }
                    tbody {
                        @for (name, v) in FIGURES.iter().zip(f.values()) {
                            tr data-figure=(name) {
                                td { (name.trim_end_matches("_um")) }
                                td.num { (with_u(v, f.u.get(*name).copied(), "um")) }
                                @if let Some(w) = &f.without_outlying {
                                    td.num {
                                        (with_u(w.figures.get(*name).copied(), w.u.get(*name).copied(), "um"))
                                        @if w.dominated.iter().any(|d| d == name) { " " span.badge { "dominated" } }
                                    }
                                }
                            }
                        }
                    }
                }
                @let unavailable: Vec<&str> = FIGURES.iter().copied().filter(|n| f.not_available(n).is_some()).collect();
                @if let Some(why) = unavailable.first().and_then(|n| f.not_available(n)) {
                    p.muted.not-available { "— " (unavailable.iter().map(|n| n.trim_end_matches("_um")).collect::<Vec<_>>().join(", ")) ": " (why) }
                }
                @if let Some(w) = &f.without_outlying {
                    h3 { "Readings set aside (outlier test, 1 % per axis, |t| > " (num(w.critical_t)) ")" }
                    table.outlying {
                        thead { tr { th.num { "run" } th { "direction" } th.num { "target (mm)" } th.num { "reading (µm)" } th.num { "off the other runs (µm)" } th.num { "t" } } }
                        tbody { @for r in &w.readings { tr {
                            td.num { (run_label(f.source, r.run)) } td { @if r.up { "+" } @else { "−" } } td.num { (num(r.target_mm)) }
                            td.num { (num(r.deviation_um)) } td.num { (num(r.off_um)) } td.num { (num(r.t)) }
                        } } }
                    }
                }
                @for n in &f.notes { p.muted { (n) } }
            }
        }
    }
}

/// The A axis, the per-pose table, the rotation vectors per A pose, the model chosen with
/// its parameters, the compliance against A with ±2σ bands, what the ball data can
/// separate, the location errors and the held-out compensation.
pub fn cradle(c: &CradleResult) -> Markup {
    let k = &c.kinematics;
    html! {
        section.card #cradle {
            h2 { "Cradle (A/C) check" }
            dl.facts {
                dt { "points / A poses" } dd { (c.n_points) " / " (c.n_poses) }
                dt { "instrument frame" } dd { @if c.registered_frame { "registered to the machine axes" } @else { "unregistered (intrinsic figures only)" } }
                dt { "A axis direction" } dd { (format!("({:.6}, {:.6}, {:.6})", c.a_axis.direction[0], c.a_axis.direction[1], c.a_axis.direction[2])) }
                dt { "model chosen (held-out poses)" } dd { (format!("{:?}", k.chosen).to_lowercase()) }
                dt { "compensation, held out" } dd { (num(c.compensation.before_rms_um)) " µm → " (num(c.compensation.after_rms_um)) " µm RMS" }
            }
        }
        section.card #rotation-vectors {
            h2 { "Rotation vector per A pose" }
            figure.plot { (svg(plots::rotation_vectors(&c.poses))) }
            table {
                thead { tr { th.num { "A (deg)" } th.num { "points" } th.num { "circle RMS (µm)" } th.num { "|r| pooled ± U" } th.num { "|r| patent ± U" } } }
                tbody {
                    @for p in &c.poses {
                        tr {
                            td.num { (num(p.a_deg)) } td.num { (p.n_points) } td.num { (num(p.circle_rms_um)) }
                            td.num { (with_u(Some(p.rotation_pooled.norm_urad), Some(p.rotation_pooled.std_urad), "urad")) }
                            td.num { (with_u(Some(p.rotation_point.norm_urad), Some(p.rotation_point.std_urad), "urad")) }
                        }
                    }
                }
            }
        }
        section.card #cradle-model {
            h2 { "Model of the deflection with A" }
            p { (k.description) " — chosen among the model family on A poses left out of the fit." }
            @if let Some(f) = &c.floor { p.muted { (f.statement) } }
            @if !k.parameters.is_empty() {
                table {
                    thead { tr { th { "parameter" } th.num { "value ± U" } th { "" } } }
                    tbody {
                        @for p in &k.parameters {
                            tr { td { (p.name) } td.num { (with_u(Some(p.value), Some(p.std), &p.unit)) }
                                 td { @if p.model_dependent { "not determined: another model explains the data as well" }
                                      @else if !p.determined { "undetermined (|value| < 3u)" } } }
                        }
                    }
                }
                @for rival in &k.rivals { p.muted { (rival.statement) } }
            }
        }
        section.card #compliance {
            h2 { "Compliance against A (±2σ)" }
            @if k.curves.is_empty() {
                p.muted { "Rigid: nothing in the chosen model depends on A." }
            } @else {
                p.muted { "The chosen model's terms over the measured A range; the mount's tilts in the A body frame, the pivot's in the machine frame." }
                div.grid {
                    @for cv in &k.curves {
                        figure.plot data-term=(format!("{:?}", cv.term)) { (svg(plots::compliance_curve(cv))) }
                    }
                }
            }
        }
        @if let Some(sep) = &k.separability {
            section.card #separability {
                h2 { "What the ball data can separate" }
                p.muted { "First-order Jacobian of the chosen model: rank " (sep.rank) " of " (sep.n_params)
                          ". Method: " (sep.method) "." }
                table {
                    thead { tr { th { "term" } th { "in the model" } th { "separable" } th { "not separable with" } th { "why" } } }
                    tbody {
                        @for t in &sep.terms {
                            tr {
                                td { (t.description) }
                                td { @if t.in_model { "yes" } @else { "no" } }
                                td { @if t.separable { "yes" } @else { "no" } }
                                td { (confounders(&t.confounded_with)) }
                                td { (t.why) }
                            }
                        }
                    }
                }
            }
        }
        section.card #location-errors {
            h2 { "Location errors (ISO 230-7)" }
            table {
                thead { tr { th { "error" } th.num { "value ± U" } th { "observable" } th { "note" } } }
                tbody {
                    @for e in &c.location_errors {
                        tr { td { (e.name) } td.num { (with_u(e.value, e.std, &e.unit)) }
                             td { (observable(&e.observability)) } td { (e.note.as_deref().unwrap_or("")) } }
                    }
                }
            }
        }
        @if !c.notes.is_empty() { section.card { h2 { "Notes" } ul.compact { @for n in &c.notes { li { (n) } } } } }
    }
}

/// Sets of terms, `a + b; c`.
fn confounders(sets: &[Vec<mtcal_solver::cradle::Term>]) -> String {
    sets.iter()
        .map(|set| {
            set.iter()
                .map(|t| t.describe())
                .collect::<Vec<_>>()
                .join(" + ")
        })
        .collect::<Vec<_>>()
        .join("; ")
}

fn observable(o: &mtcal_solver::cradle::Observability) -> &'static str {
    use mtcal_solver::cradle::Observability::*;
    match o {
        Intrinsic => "from ball data",
        RegisteredFrame => "with the frame registered",
        NotObservable => "not observable",
    }
}

/// Each component's ranking (bars of the first 12 and the key errors), the volumetric
/// error and the machine evaluated.
pub fn sensitivity(s: &SensitivityResult) -> Markup {
    html! {
        section.card #sensitivity {
            h2 { "Sensitivity of " (s.machine.name) }
            p.muted { (s.machine.description) " — evaluated at " (s.evaluation.poses) " pose(s) (" (s.evaluation.kind) "), key errors cover "
                      (format!("{:.0} %", 100.0 * s.share)) " of each component." }
            @if let Some(v) = &s.volumetric_error_um {
                table {
                    thead { tr { th { "component" } th.num { "RMS (µm)" } th.num { "max (µm)" } } }
                    tbody { @for (k, e) in v { tr { td { (k) } td.num { (num(e.rms_um)) } td.num { (num(e.max_um)) } } } }
                }
            }
        }
        div.grid {
            @for (name, r) in &s.components {
                figure.plot data-component=(name) {
                    (svg(plots::ranking_bars(name, r, 12)))
                    figcaption { "key errors: " (r.key_errors.join(", ")) }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests;
