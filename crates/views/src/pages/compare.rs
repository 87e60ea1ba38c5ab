//! The compare page: two results of one machine side by side, and the difference
//! (b − a) of every term over the intersection of their measured travels with its
//! uncertainty.

use super::result::TERM_ORDER;
use super::{Nav, Viewer, machine_href, num, page, result_href, svg, when, with_u};
use crate::plots;
use maud::{Markup, html};

/// One side: a result and its headline figures.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Side {
    pub result_id: String,
    pub measured_at: String,
    pub residual_rms_um: Option<f64>,
    pub rank: Option<i64>,
    pub verdict: Option<String>,
}

/// The difference of one function: values b − a at positions inside both measured
/// travels with standard uncertainties (NaN where unknown: no band), or why it is not
/// compared.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct TermDiff {
    pub name: String,
    pub unit: String,
    pub positions_mm: Vec<f64>,
    pub diff: Vec<f64>,
    pub std: Vec<f64>,
    /// Set when not compared (not identifiable in either, or travels do not overlap).
    pub not_compared: Option<String>,
}

/// A squareness on both sides and its difference, each value with its standard
/// uncertainty.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct SquarenessDiff {
    pub name: String,
    pub a: (Option<f64>, Option<f64>),
    pub b: (Option<f64>, Option<f64>),
    pub diff: (Option<f64>, Option<f64>),
}

#[derive(Debug, Clone, PartialEq, Default)]
pub struct ComparePage {
    pub machine_id: String,
    pub a: Side,
    pub b: Side,
    pub terms: Vec<TermDiff>,
    pub squareness: Vec<SquarenessDiff>,
}

fn side(title: &str, s: &Side) -> Markup {
    html! {
        section.card {
            h2 { (title) ": " a href=(result_href(&s.result_id)) { (when(&s.measured_at)) } }
            dl.facts {
                dt { "residual RMS" } dd { (with_u(s.residual_rms_um, None, "um")) }
                dt { "rank" } dd { @match s.rank { Some(r) => { (r) } None => { "—" } } }
                dt { "verdict" } dd { (super::verdict_badge(s.verdict.as_deref())) }
            }
        }
    }
}

pub fn compare_page(viewer: &Viewer, p: &ComparePage) -> Markup {
    page(
        "Compare",
        Nav::Other,
        Some(viewer),
        html! {
            h1 { "Compare two checks of " a href=(machine_href(&p.machine_id)) { (p.machine_id) } }
            div.pair { (side("a", &p.a)) (side("b", &p.b)) }
            section.card #squareness-diff {
                h2 { "Squareness" }
                table {
                    thead { tr { th { "term" } th.num { "a" } th.num { "b" } th.num { "b − a" } } }
                    tbody {
                        @for s in &p.squareness {
                            tr data-term=(s.name) {
                                td { (s.name) }
                                td.num { (with_u(s.a.0, s.a.1, "urad")) }
                                td.num { (with_u(s.b.0, s.b.1, "urad")) }
                                td.num { (with_u(s.diff.0, s.diff.1, "urad")) }
                            }
                        }
                    }
                }
            }
            section.card #term-diffs {
                h2 { "Difference b − a of each function (±2σ), over both measured travels" }
                div.grid.three {
                    @for name in TERM_ORDER {
                        @if let Some(d) = p.terms.iter().find(|d| d.name == name) {
                            figure.plot data-term=(name) {
                                @let title = format!("{name} b − a ({})", plots::unit_label(&d.unit));
                                @match &d.not_compared {
                                    Some(why) => { (svg(plots::empty_panel(&title, why))) }
                                    None => {
                                        @let pts: Vec<(f64, f64, f64)> = d.positions_mm.iter().zip(&d.diff).zip(&d.std)
                                            .map(|((&q, &v), &s)| (q, v, s)).collect();
                                        (svg(plots::function_band(name, &title, &pts)))
                                        figcaption { "largest |b − a| "
                                            (num(d.diff.iter().fold(0.0f64, |m, v| m.max(v.abs())))) " " (plots::unit_label(&d.unit)) }
                                    }
                                }
                            }
                        }
                    }
                }
            }
        },
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pages::tests::viewer;

    #[test]
    fn differences_are_drawn_or_said_not_compared() {
        let p = ComparePage {
            machine_id: "VMC-1".into(),
            terms: vec![
                TermDiff {
                    name: "EXX".into(),
                    unit: "um".into(),
                    positions_mm: vec![-50.0, 0.0, 50.0],
                    diff: vec![-1.0, 0.0, 2.0],
                    std: vec![0.1, 0.0, 0.1],
                    not_compared: None,
                },
                TermDiff {
                    name: "EAX".into(),
                    unit: "urad".into(),
                    not_compared: Some("not identifiable in a".into()),
                    ..TermDiff::default()
                },
            ],
            squareness: vec![SquarenessDiff {
                name: "EC0Y".into(),
                a: (Some(10.0), Some(0.5)),
                b: (Some(12.0), Some(0.5)),
                diff: (Some(2.0), Some(0.75)),
            }],
            ..ComparePage::default()
        };
        let html = compare_page(&viewer("read"), &p).into_string();
        assert!(html.contains("largest |b − a| 2.000 µm"));
        assert!(html.contains("not identifiable in a"));
        assert!(html.contains("2.000 ± 1.500 µrad"));
        assert_eq!(html.matches("<svg").count(), 2);
    }
}
