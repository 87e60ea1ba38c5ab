//! The decision part of a check report (its first page): the verdict with the items that
//! do not pass, named as a person says them, whether it is decided on the explained
//! model, and the actions (the explained model's, with the numbers to set, when the
//! check has one); and the figures of the
//! standards in short (the judged ones listed, the others counted per group). The code
//! names and every row are in the appendix ([`figures_all`]).

use super::{CheckReport, ReportDiagnosis};
use crate::pages::result::item_at;
use crate::pages::{num, verdict_badge, with_u};
use crate::plots::unit_label;
use maud::{Markup, html};
use mtcal_solver::names::{group, in_words};
use mtcal_solver::tolerance::{Decision, Verdict, VerdictItem};

/// The overall decision in words, with what it rests on.
fn decision_words(v: &Verdict) -> &'static str {
    match v.decision {
        Some(Decision::Pass) => "Pass: every limit is met with its uncertainty.",
        Some(Decision::Fail) => {
            "Fail: the items below exceed their limits beyond their uncertainty."
        }
        Some(Decision::Undecided) => {
            "Undecided: the items below are within their uncertainty of their limits."
        }
        Some(Decision::Misfit) => {
            "Not decided: the model does not explain its recording (above), so no value is \
             judged; the findings below say what it leaves out."
        }
        None => "No limit of the tolerance profile applies to this check.",
    }
}

/// The verdict of page 1: the decision, every item that does not pass (named as a person
/// says it, where, value ± U, limit, outcome) and how many pass; the full table, with the
/// code names, is in the appendix.
pub(super) fn decision(r: &CheckReport) -> Markup {
    html! {
        section.card #decision {
            h2 { "Verdict" }
            @match r.verdict {
                None => {
                    p { "No tolerance profile applies to this machine: no figure is judged, and \
                         no verdict is given. The figures are in the appendix." }
                }
                Some(v) => {
                    @let open: Vec<&VerdictItem> = v.items.iter().filter(|i| i.decision != Decision::Pass).collect();
                    p.decision { (verdict_badge(v.decision.map(|d| d.as_str()))) " " (decision_words(v)) }
                    @if let Some(c) = v.model_check.as_ref().filter(|c| c.decided_on_explained_model()) {
                        p.explained #decided-on { "Decided on the explained model: " (c.explained_model.as_deref().unwrap_or_default()) " added to the 21 terms (the actions below)." }
                    }
                    @if !open.is_empty() {
                        table.items {
                            thead { tr { th { "item" } th { "where" } th.num { "value ± U" } th.num { "limit" } th { "outcome" } } }
                            tbody {
                                @for i in &open {
                                    tr data-item=(i.item) data-outcome=(i.decision.as_str()) {
                                        td { (in_words(&i.item)) } td { (item_at(i)) }
                                        td.num { (with_u(i.value, i.u, &i.unit)) }
                                        td.num { (num(i.limit)) " " (unit_label(&i.unit)) }
                                        td { (verdict_badge(Some(i.decision.as_str()))) }
                                    }
                                }
                            }
                        }
                    }
                    p.muted {
                        (v.items.len() - open.len()) " of " (v.items.len()) " limits pass"
                        @if !v.not_evaluated.is_empty() { "; " (v.not_evaluated.len()) " limit(s) of the profile have no figure in this check" }
                        "; rule ISO 14253-1 with U = 2u_c (budget below); every item by its code name in the appendix."
                    }
                }
            }
        }
    }
}

/// One thing to do after this check, and what it is about.
#[derive(Debug, Clone, PartialEq)]
pub struct ReportAction {
    /// What it acts on (`backlash (X)`, `EXX`, `identifiability`), in words.
    pub about: String,
    pub text: String,
}

/// What each kind of finding asks a technician to do, until the explained model states
/// the numbers to set.
fn finding_advice(effect: &str) -> &'static str {
    match effect {
        "backlash" | "lost_motion_profile" => {
            "set the controller's backlash compensation (or its reversal compensation per \
             position) from the lost motion found, then repeat the check"
        }
        "servo_lag" => "check the velocity feed-forward and the position-loop gain (Kv)",
        "reversal_spike" => "check the reversal-peak (friction) compensation",
        "cyclic" => "check the ball screw and the encoder for the period found",
        "thermal_drift" => "warm the machine up before a check, or compensate its thermal drift",
        "vibration" => "find and isolate the source of the vibration",
        "step" => "check the fixing of the plate and of the head, then repeat the check",
        "transient" => {
            "a one-off knock that recovered: check the plate's seat for chips and the \
             machine for a collision, then repeat the run"
        }
        "setup_offset" => "check the declared head offsets of the plane files",
        "model_order" => "identify with a higher polynomial order",
        _ => "check the guideways (gibs, preload) along the axis found",
    }
}

/// The actions of a check: one per finding (the explained model's, with the number to
/// set and the residual predicted once it is done; else the diagnosis's, in words), one
/// per item that fails, and what would determine what this check could not.
pub fn actions(r: &CheckReport) -> Vec<ReportAction> {
    let mut out = vec![];
    if let Some(m) = &r.doc.explained {
        for a in &m.actions {
            out.push(ReportAction {
                about: a.finding.clone(),
                text: format!(
                    "{} (residual RMS {} µm now, {} µm predicted after it)",
                    a.text,
                    num(a.predicted_rms_um.before),
                    num(a.predicted_rms_um.after)
                ),
            });
        }
    } else if let Some(ReportDiagnosis { doc: Ok(doc), .. }) = r.diagnosis {
        for f in &doc.findings {
            out.push(ReportAction {
                about: f.name_in_words(),
                text: format!(
                    "{} ({})",
                    finding_advice(&f.effect),
                    f.parameters_in_words()
                ),
            });
        }
    }
    if let Some(v) = r.verdict {
        for i in v.items.iter().filter(|i| i.decision == Decision::Fail) {
            out.push(ReportAction {
                about: in_words(&i.item),
                text: format!(
                    "exceeds its limit of {} {}: compensate or repair, then repeat the check",
                    num(i.limit),
                    unit_label(&i.unit)
                ),
            });
        }
    }
    for a in &r.doc.observability.advice {
        out.push(ReportAction {
            about: "what this check could not determine".into(),
            text: a.clone(),
        });
    }
    out
}

/// The actions of page 1 ([`actions`]).
pub(super) fn actions_section(r: &CheckReport) -> Markup {
    let list = actions(r);
    html! {
        section.card #actions {
            h2 { "Actions" }
            @if list.is_empty() {
                p { "Nothing to do: no finding, no failing item." }
            } @else {
                ol.compact {
                    @for a in &list { li { strong { (a.about) } ": " (a.text) } }
                }
            }
        }
    }
}

/// The figures of the standards in short: those a limit judged, listed, the others
/// counted per group (every one is in the appendix, [`figures_all`]).
pub(super) fn standards(r: &CheckReport) -> Markup {
    let figures = r.doc.standards.scalar_figures();
    let judged = |name: &str| {
        r.verdict
            .and_then(|v| v.items.iter().find(|i| i.item == name))
    };
    let mut counts: Vec<(String, usize)> = vec![];
    for f in figures.iter().filter(|f| judged(&f.name).is_none()) {
        let g = group(&f.name);
        match counts.iter_mut().find(|(n, _)| *n == g) {
            Some((_, c)) => *c += 1,
            None => counts.push((g, 1)),
        }
    }
    html! {
        section.card #standards {
            h2 { "Figures of the standards (ISO 230-2, ISO 230-4)" }
            @if figures.is_empty() {
                p { "No figure of ISO 230-2 or ISO 230-4 could be evaluated from this check." }
            }
            @let listed: Vec<_> = figures.iter().filter_map(|f| judged(&f.name).map(|i| (f, i))).collect();
            @if !listed.is_empty() {
                table {
                    thead { tr { th { "figure" } th.num { "value ± U" } th.num { "limit" } th { "verdict" } } }
                    tbody {
                        @for (f, i) in &listed {
                            tr data-figure=(f.name) {
                                td { (in_words(&f.name)) }
                                td.num { (with_u(Some(f.value), f.u, "um")) }
                                td.num { (num(i.limit)) " µm" }
                                td { (verdict_badge(Some(i.decision.as_str()))) }
                            }
                        }
                    }
                }
            }
            @if !counts.is_empty() {
                p.counts {
                    "Without a tolerance (value ± U of each in the appendix): "
                    @for (k, (g, n)) in counts.iter().enumerate() {
                        @if k > 0 { "; " } span.count data-group=(g) { (g) ": " (n) }
                    }
                    "."
                }
            }
        }
    }
}

/// Every figure of the standards with its code name, value ± U, limit and verdict (or
/// "no tolerance"), and the notes of ISO 230-2: the appendix's table.
pub(super) fn figures_all(r: &CheckReport) -> Markup {
    let st = &r.doc.standards;
    let figures = st.scalar_figures();
    let verdict_of = |name: &str| {
        r.verdict
            .and_then(|v| v.items.iter().find(|i| i.item == name))
            .map(|i| (i.limit, i.decision.as_str()))
    };
    html! {
        section.card #figures {
            h2 { "Figures of the standards, every one" }
            @for f in &st.iso230_2 {
                @for n in &f.notes { p.muted { "ISO 230-2, " (f.axis) ": " (n) } }
            }
            table.dense {
                thead { tr { th { "figure" } th { "code name" } th.num { "value ± U" } th.num { "limit" } th { "verdict" } } }
                tbody {
                    @for f in &figures {
                        @let v = verdict_of(&f.name);
                        tr data-figure=(f.name) {
                            td { (in_words(&f.name)) } td { code { (f.name) } }
                            td.num { (with_u(Some(f.value), f.u, "um")) }
                            td.num { @if let Some((limit, _)) = v { (num(limit)) " µm" } @else { "—" } }
                            td { (verdict_badge(v.map(|x| x.1))) }
                        }
                    }
                }
            }
        }
    }
}
