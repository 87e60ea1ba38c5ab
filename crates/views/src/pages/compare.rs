//! The compare page: two results of one machine side by side, and the difference
//! (b − a) of every term over the intersection of their measured travels with its ±2σ
//! band. A difference is **significant** where |b − a| exceeds its expanded uncertainty
//! U = 2u; the terms whose difference is nowhere significant are drawn on one scale per
//! unit (so that numerical noise is not blown up to fill a panel), the significant ones
//! each on its own and marked.

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
/// travels with standard uncertainties (NaN where unknown: no band, and no significance
/// decided), or why it is not compared.
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

/// Whether `|value| > 2u` (`None` when u is unknown).
fn significant_value(value: f64, u: f64) -> Option<bool> {
    (value.is_finite() && u.is_finite()).then(|| value.abs() > 2.0 * u)
}

impl TermDiff {
    /// Whether the difference exceeds its expanded uncertainty somewhere (`None`: not
    /// compared, or an uncertainty unknown).
    pub fn significant(&self) -> Option<bool> {
        if self.not_compared.is_some() || self.diff.is_empty() {
            return None;
        }
        let each: Option<Vec<bool>> = self
            .diff
            .iter()
            .zip(&self.std)
            .map(|(&v, &u)| significant_value(v, u))
            .collect();
        each.map(|e| e.into_iter().any(|s| s))
    }
}

/// The value range shared by the panels of `unit` whose difference is not significant:
/// ±max(|b − a| + 2u) over them (`None` when there is none).
fn shared_range(terms: &[TermDiff], unit: &str) -> Option<(f64, f64)> {
    let m = terms
        .iter()
        .filter(|d| d.unit == unit && d.significant() == Some(false))
        .flat_map(|d| d.diff.iter().zip(&d.std).map(|(v, u)| v.abs() + 2.0 * u))
        .filter(|m| m.is_finite())
        .fold(0.0f64, f64::max);
    (m > 0.0).then_some((-m, m))
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
                    thead { tr { th { "term" } th.num { "a" } th.num { "b" } th.num { "b − a (± U)" } th { "" } } }
                    tbody {
                        @for s in &p.squareness {
                            @let sig = match s.diff { (Some(v), Some(u)) => significant_value(v, u), _ => None };
                            tr data-term=(s.name) data-significant=[sig] {
                                td { (s.name) }
                                td.num { (with_u(s.a.0, s.a.1, "urad")) }
                                td.num { (with_u(s.b.0, s.b.1, "urad")) }
                                td.num { (with_u(s.diff.0, s.diff.1, "urad")) }
                                td { @match sig {
                                    Some(true) => { span.badge.significant { "significant" } }
                                    Some(false) => { span.muted { "within U" } }
                                    None => { span.muted { "u not stored" } }
                                } }
                            }
                        }
                    }
                }
            }
            section.card #term-diffs {
                h2 { "Difference b − a of each function (±2σ), over both measured travels" }
                p.muted { "A difference is significant where |b − a| exceeds U = 2u. Functions whose \
                           difference is nowhere significant share one scale per unit; the \
                           significant ones are marked and drawn on their own scale." }
                div.grid.three {
                    @for name in TERM_ORDER {
                        @if let Some(d) = p.terms.iter().find(|d| d.name == name) {
                            @let sig = d.significant();
                            figure.plot data-term=(name) data-significant=[sig] {
                                @let title = format!("{name} b − a ({})", plots::unit_label(&d.unit));
                                @match &d.not_compared {
                                    Some(why) => { (svg(plots::empty_panel(&title, why))) }
                                    None => {
                                        @let pts: Vec<(f64, f64, f64)> = d.positions_mm.iter().zip(&d.diff).zip(&d.std)
                                            .map(|((&q, &v), &s)| (q, v, s)).collect();
                                        @let range = if sig == Some(false) { shared_range(&p.terms, &d.unit) } else { None };
                                        (svg(plots::function_band_on(name, &title, &pts, range)))
                                        figcaption {
                                            @if sig == Some(true) { span.badge.significant { "significant" } " " }
                                            "largest |b − a| "
                                            (num(d.diff.iter().fold(0.0f64, |m, v| m.max(v.abs())))) " " (plots::unit_label(&d.unit))
                                            @match sig {
                                                Some(false) => { " (within U; shared scale)" }
                                                None => { " (u not stored: significance not decided)" }
                                                Some(true) => {}
                                            }
                                        }
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
        // EXX: 2 µm at 50 mm against U = 0.2 µm is significant; EC0Y: 2 against U = 1.5 too.
        assert!(
            html.contains(r#"data-term="EXX" data-significant="true""#),
            "{html}"
        );
        assert!(
            html.contains(r#"<tr data-term="EC0Y" data-significant="true">"#),
            "{html}"
        );
    }

    /// Terms that did not change beyond U share one scale (their panels' value axes are
    /// equal, spanning the largest |b − a| + U among them), so a change of a few nm does
    /// not fill its panel; a significant change keeps its own scale.
    #[test]
    fn unchanged_terms_share_a_scale_and_changes_are_marked() {
        let flat = |name: &str, scale: f64| TermDiff {
            name: name.into(),
            unit: "um".into(),
            positions_mm: vec![-50.0, 0.0, 50.0],
            diff: vec![-0.001 * scale, 0.0, 0.002 * scale],
            std: vec![0.1, 0.1, 0.1],
            not_compared: None,
        };
        let changed = TermDiff {
            diff: vec![-3.0, 0.0, 5.0],
            ..flat("EYY", 1.0)
        };
        assert_eq!(flat("EXX", 1.0).significant(), Some(false));
        assert_eq!(changed.significant(), Some(true));
        let unknown = TermDiff {
            std: vec![f64::NAN; 3],
            ..flat("EZZ", 1.0)
        };
        assert_eq!(unknown.significant(), None);
        let p = ComparePage {
            terms: vec![flat("EXX", 1.0), flat("EXY", 10.0), changed],
            ..ComparePage::default()
        };
        assert_eq!(shared_range(&p.terms, "um"), Some((-0.22, 0.22)));
        let html = compare_page(&viewer("read"), &p).into_string();
        let panel = |name: &str| {
            let start = html.find(&format!(r#"data-term="{name}""#)).unwrap();
            let end = start + html[start..].find("</figure>").unwrap();
            let svg_start = start + html[start..].find("<svg").unwrap();
            let svg_end = svg_start + html[svg_start..].find("</svg>").unwrap() + 6;
            (
                html[start..end].to_string(),
                html[svg_start..svg_end].to_string(),
            )
        };
        let (exx, exx_svg) = panel("EXX");
        let (_, exy_svg) = panel("EXY");
        let (eyy, eyy_svg) = panel("EYY");
        assert!(
            exx.contains("shared scale") && !exx.contains("badge significant"),
            "{exx}"
        );
        assert!(
            eyy.contains("significant") && !eyy.contains("shared scale"),
            "{eyy}"
        );
        let y = |s: &str| crate::plots::inspect::parse(s).unwrap().axes().unwrap().y;
        let (a, b, c) = (y(&exx_svg), y(&exy_svg), y(&eyy_svg));
        assert!(
            (a.scale - b.scale).abs() < 1e-6 * a.scale.abs() && (a.offset - b.offset).abs() < 1e-3,
            "one scale for both unchanged terms: {a:?} {b:?}"
        );
        // The shared axis spans ±0.22 µm (+5 % padding): ±0.22 lie inside the panel and
        // apart by most of its height.
        let h = f64::from(crate::plots::PANEL.1);
        let (top, bottom) = (a.px(0.22), a.px(-0.22));
        assert!(
            top > 0.0 && bottom < h && bottom - top > 0.5 * h,
            "{a:?}: {top} {bottom} of {h}"
        );
        assert!(
            c.scale.abs() < a.scale.abs() / 10.0,
            "the change on its own, larger scale: {a:?} {c:?}"
        );
    }
}
