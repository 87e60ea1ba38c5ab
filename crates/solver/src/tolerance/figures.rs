//! What a result offers to be judged against limits ([`Figures`]): each error function's
//! range over the measured travel, each squareness, each figure of the standards, each
//! with its fit (or sampling) uncertainty and what it spans ([`Span`], which decides its
//! uncertainty budget), and the items the result measured but could not determine.

use crate::comparison;
use crate::identification::IdentificationResult;
use crate::standards::{Iso2302, Iso2304, Standards, iso230_2};
use crate::terms::{SquarenessTerm, Term, TermKind};
use crate::uncertainty::Span;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// What is decided of a quantity.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
#[serde(rename_all = "snake_case")]
pub enum Measure {
    /// The range (max − min) of an error function over the travel (ISO 230-1).
    Range,
    /// The magnitude |value| of a single value (a squareness, a figure of a standard).
    Magnitude,
}

/// One quantity a limit can be decided against.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Quantity {
    /// `um` or `urad`.
    pub unit: String,
    pub measure: Measure,
    /// A range (≥ 0), or the signed value whose magnitude is decided.
    pub value: f64,
    /// Its standard uncertainty from the fit or the readings' scatter (None: unknown).
    pub u: Option<f64>,
    /// What it spans (the budget's contributions follow from it).
    pub span: Span,
    /// The axis and travel the quantity covers, when it is a function of position.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub axis: Option<char>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub travel_mm: Option<[f64; 2]>,
    /// Where a range has its maximum and its minimum, mm.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub at_mm: Option<[f64; 2]>,
    /// Whether it comes from the fitted model (then the misfit gate applies to it) or
    /// directly from the readings (the figures of the standards).
    pub from_model: bool,
}

impl Quantity {
    /// A single value (a squareness, a figure of a standard).
    pub fn magnitude(unit: &str, value: f64, u: Option<f64>, span: Span, from_model: bool) -> Self {
        Quantity {
            unit: unit.into(),
            measure: Measure::Magnitude,
            value,
            u,
            span,
            axis: None,
            travel_mm: None,
            at_mm: None,
            from_model,
        }
    }

    /// The length L the quantity spans along its axis, mm (a range's travel).
    pub fn length_mm(&self) -> Option<f64> {
        self.travel_mm.map(|[lo, hi]| hi - lo)
    }
}

/// The quantities of one result that limits can be decided against.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Figures {
    /// By item name: an error function (`EXX`), a squareness (`EC0Y`) or a figure of a
    /// standard (`iso230_2.X.E_um`).
    pub figures: BTreeMap<String, Quantity>,
    /// Items the result measured but could not determine, with the reason (a term that is
    /// not identifiable, a figure this plan cannot give): a limit on them is undecided.
    #[serde(default)]
    pub undetermined: BTreeMap<String, String>,
}

impl Figures {
    /// Adds figures of a standard stored by name only (value, standard uncertainty),
    /// for a result whose document does not give them: their span is unknown, so only
    /// their own uncertainty enters the budget. A name already present is kept.
    pub fn add_stored<'a>(
        &mut self,
        stored: impl IntoIterator<Item = (&'a str, f64, Option<f64>)>,
    ) {
        for (name, value, u) in stored {
            if self.figures.contains_key(name) || self.undetermined.contains_key(name) {
                continue;
            }
            if value.is_finite() && u.is_none_or(|u| u.is_finite() && u >= 0.0) {
                let unit = if name.ends_with("_urad") {
                    "urad"
                } else {
                    "um"
                };
                self.figures.insert(
                    name.to_string(),
                    Quantity::magnitude(unit, value, u, Span::Unknown, false),
                );
            } else {
                self.undetermined
                    .insert(name.to_string(), "the stored value is not finite".into());
            }
        }
    }

    /// Adds the figures of the standards of a document (ISO 230-2 per axis, ISO 230-4
    /// per plane), each with what it spans. ISO 230-2 figures of grid-encoder line passes
    /// that depend on each pass's zero are undetermined ([`iso230_2::depends_on_zero`]).
    pub fn add_standards(&mut self, st: &Standards) {
        for a in &st.iso230_2 {
            self.add_iso230_2(a);
        }
        for c in &st.iso230_4 {
            self.add_iso230_4(c);
        }
    }

    fn add_iso230_2(&mut self, a: &Iso2302) {
        let travel = match (a.per_target.first(), a.per_target.last()) {
            (Some(f), Some(l)) => {
                Some([f.target_mm.min(l.target_mm), f.target_mm.max(l.target_mm)])
            }
            _ => None,
        };
        // What the recording cannot give (the zero-dependent figures of line passes) is
        // undetermined with the reason; `scalar_figures` leaves it out.
        for figure in iso230_2::FIGURES {
            if let Some(why) = a.not_available(figure) {
                self.undetermined
                    .insert(format!("iso230_2.{}.{figure}", a.axis), why.to_string());
            }
        }
        for f in a.scalar_figures() {
            let figure = f.name.rsplit('.').next().unwrap_or("");
            let span = match (iso230_2::is_local(figure), travel) {
                (true, _) => Span::Local,
                (false, Some([lo, hi])) => Span::Length { mm: hi - lo },
                (false, None) => Span::Unknown,
            };
            let mut q = Quantity::magnitude("um", f.value, f.u, span, false);
            if !iso230_2::is_local(figure) {
                q.axis = a.axis.letter().into();
                q.travel_mm = travel;
            }
            self.figures.insert(f.name, q);
        }
    }

    fn add_iso230_4(&mut self, c: &Iso2304) {
        let radius = c.diameter_mm / 2.0;
        for f in c.scalar_figures() {
            let figure = f.name.rsplit('.').next().unwrap_or("");
            let span = if matches!(figure, "G_um" | "H_um") {
                Span::Form
            } else {
                Span::Radius { mm: radius }
            };
            self.figures
                .insert(f.name, Quantity::magnitude("um", f.value, f.u, span, false));
        }
    }
}

/// The quantities of an identification result: each identifiable error function's
/// range over the measured travel of its axis ([`comparison::term_range`]: a straightness
/// about its least-squares line, as reported), each identified squareness, and the
/// figures of the standards of its session. Terms and squareness that are not
/// identifiable are listed as undetermined.
pub fn identification_figures(r: &IdentificationResult) -> Figures {
    let mut f = Figures::default();
    for term in Term::all() {
        let name = term.name();
        let Some(rep) = r.terms.get(&name) else {
            continue;
        };
        let range = rep
            .identifiable
            .then(|| comparison::term_range(r, term, None))
            .flatten()
            .filter(|g| g.range.is_finite() && g.u.is_none_or(f64::is_finite));
        match range {
            Some(g) => {
                let span = match term.kind() {
                    TermKind::Positioning => Span::Length {
                        mm: g.travel_mm[1] - g.travel_mm[0],
                    },
                    TermKind::Straightness => Span::Form,
                    TermKind::Roll | TermKind::PitchYaw => Span::Angle,
                };
                f.figures.insert(
                    name,
                    Quantity {
                        unit: term.unit().into(),
                        measure: Measure::Range,
                        value: g.range,
                        u: g.u,
                        span,
                        axis: Some(term.axis.letter()),
                        travel_mm: Some(g.travel_mm),
                        at_mm: Some([g.at_max_mm, g.at_min_mm]),
                        from_model: true,
                    },
                );
            }
            None => {
                f.undetermined
                    .insert(name, not_determined(&rep.confounded_with));
            }
        }
    }
    for s in SquarenessTerm::ALL {
        let name = s.name().to_string();
        let Some(rep) = r.squareness.get(&name) else {
            continue;
        };
        match (rep.identifiable, rep.value_urad) {
            (true, Some(v)) if v.is_finite() => {
                f.figures.insert(
                    name,
                    Quantity::magnitude(
                        "urad",
                        v,
                        rep.std_urad.filter(|u| u.is_finite()),
                        Span::Squareness,
                        true,
                    ),
                );
            }
            _ => {
                f.undetermined
                    .insert(name, not_determined(&rep.confounded_with));
            }
        }
    }
    f.add_standards(&r.standards);
    if let Some(m) = &r.explained {
        f.add_explained_lost_motion(m);
    }
    f
}

impl Figures {
    /// The explained model's lost motion as ISO 230-2's reversal value B of its axis
    /// (`iso230_2.<axis>.B_um`): a backlash's |lost motion|, a profile's largest |b(q)| at
    /// its points, with its σ. It replaces the figure the line passes cannot give (each
    /// pass is zeroed) and is judged as a model figure (not decided on a misfit).
    pub fn add_explained_lost_motion(&mut self, m: &crate::explained::doc::ExplainedModel) {
        for p in &m.physics {
            let Some(axis) = &p.axis else { continue };
            let b = match p.effect.as_str() {
                "backlash" => p.get("lost_motion_um"),
                "lost_motion_profile" => (1..=9)
                    .filter_map(|n| p.get(&format!("lost_motion_um_{n}")))
                    .max_by(|a, b| a.0.abs().total_cmp(&b.0.abs())),
                _ => None,
            };
            let Some((value, u)) = b.filter(|(v, _)| v.is_finite()) else {
                continue;
            };
            let name = format!("iso230_2.{axis}.B_um");
            self.undetermined.remove(&name);
            self.figures.insert(
                name,
                Quantity::magnitude("um", value.abs(), u, Span::Local, true),
            );
        }
    }
}

fn not_determined(confounded_with: &[String]) -> String {
    if confounded_with.is_empty() {
        "not identifiable from this check".into()
    } else {
        format!(
            "not identifiable from this check (confounded with {})",
            confounded_with.join(", ")
        )
    }
}
