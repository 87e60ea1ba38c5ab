//! The figures of the machine-tool test standards, computed from measured data.
//!
//! * [`iso230_2`]: ISO 230-2 (accuracy and repeatability of positioning), from positioning
//!   runs and from the line passes of a session.
//! * [`iso230_4`]: ISO 230-4 (circular tests), from the circle runs of a session.
//!
//! Every figure is in µm and comes with a standard uncertainty where one is known. The
//! scalar figures are named `iso230_2.<axis>.<figure>` and
//! `iso230_4.<plane>.<cw|ccw|bi>.<figure>` ([`ScalarFigure`]): the names under which they
//! are stored, trended and given tolerances. A figure a recording cannot give is `null`,
//! its reason stated once in [`Standards::not_available`]. Formulas and readings:
//! `docs/standards.md`.

pub mod iso230_2;
pub mod iso230_4;

pub use iso230_2::{Iso2302, iso230_2};
pub use iso230_4::Iso2304;

use crate::session::Session;
use serde::{Deserialize, Serialize};

/// One scalar figure of a standard: its stored name, value and standard uncertainty.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct ScalarFigure {
    /// `iso230_2.<axis>.<figure>` or `iso230_4.<plane>.<direction>.<figure>`.
    pub name: String,
    /// µm.
    pub value: f64,
    /// Standard uncertainty (k = 1), µm, when known.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub u: Option<f64>,
}

/// Something a standard could not be evaluated for, and why.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema), schema(as = StandardsNotEvaluated))]
pub struct NotEvaluated {
    /// `iso230_2` or `iso230_4`.
    pub standard: String,
    /// The axis or plane.
    pub what: String,
    pub reason: String,
}

/// Figures the recording cannot give (each `null` where it would stand), by their scalar
/// names, and why: one reason stated once for the list of figures it applies to.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct NotAvailable {
    /// `iso230_2.<axis>.<figure>` names.
    pub figures: Vec<String>,
    pub reason: String,
}

/// The standards' figures of one session (or of positioning runs: `iso230_4` empty).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct Standards {
    pub iso230_2: Vec<Iso2302>,
    pub iso230_4: Vec<Iso2304>,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub not_evaluated: Vec<NotEvaluated>,
    /// The figures this recording cannot give, grouped by reason
    /// ([`Standards::not_available`] answers the same for a document without it).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub not_available: Vec<NotAvailable>,
}

impl Standards {
    /// The figures of `iso230_2` and `iso230_4`, with what could not be evaluated and
    /// what is not available.
    pub fn new(
        iso230_2: Vec<Iso2302>,
        iso230_4: Vec<Iso2304>,
        not_evaluated: Vec<NotEvaluated>,
    ) -> Standards {
        let mut st = Standards {
            iso230_2,
            iso230_4,
            not_evaluated,
            not_available: vec![],
        };
        st.not_available = st.not_available();
        st
    }

    /// The figures the recording cannot give, by reason, in axis and [`iso230_2::FIGURES`]
    /// order (from the axes' sources, so a document of an earlier version answers too).
    pub fn not_available(&self) -> Vec<NotAvailable> {
        let mut out: Vec<NotAvailable> = vec![];
        for f in &self.iso230_2 {
            for name in iso230_2::FIGURES {
                let Some(why) = f.not_available(name) else {
                    continue;
                };
                let figure = format!("iso230_2.{}.{name}", f.axis);
                match out.iter_mut().find(|n| n.reason == why) {
                    Some(n) => n.figures.push(figure),
                    None => out.push(NotAvailable {
                        figures: vec![figure],
                        reason: why.to_string(),
                    }),
                }
            }
        }
        out
    }

    /// Every scalar figure, ISO 230-2 first.
    pub fn scalar_figures(&self) -> Vec<ScalarFigure> {
        self.iso230_2
            .iter()
            .flat_map(Iso2302::scalar_figures)
            .chain(self.iso230_4.iter().flat_map(Iso2304::scalar_figures))
            .collect()
    }
}

/// The result document of a standards evaluation on its own (the service's `standards`
/// job, `mtcal standards --json`): the figures with what they were computed from.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct StandardsResult {
    /// Always `standards`.
    pub kind: String,
    pub machine_id: String,
    /// `session` (line passes and circles) or `positioning` (positioning runs).
    pub source: String,
    #[serde(flatten)]
    pub standards: Standards,
}

impl StandardsResult {
    pub fn new(machine_id: &str, source: &str, standards: Standards) -> StandardsResult {
        StandardsResult {
            kind: "standards".into(),
            machine_id: machine_id.into(),
            source: source.into(),
            standards,
        }
    }
}

/// ISO 230-2 from the line passes and ISO 230-4 from the circle runs of a session.
pub fn from_session(session: &Session) -> Standards {
    from_session_circles(session, &iso230_4::circle_runs(session))
}

/// [`from_session`] with the session's circle runs already reduced
/// ([`iso230_4::circle_runs`]).
pub fn from_session_circles(session: &Session, circles: &[iso230_4::CircleRun]) -> Standards {
    let (iso230_2, not_evaluated) = iso230_2::from_session(session);
    Standards::new(
        iso230_2,
        iso230_4::from_circle_runs(session, circles),
        not_evaluated,
    )
}

/// ISO 230-2 from positioning runs.
pub fn from_positioning_runs(runs: &crate::datasets::PositioningRuns) -> Standards {
    let (iso230_2, not_evaluated) = iso230_2::from_positioning_runs(runs);
    Standards::new(iso230_2, vec![], not_evaluated)
}

/// The largest and the smallest of (value, uncertainty) pairs, each with its
/// uncertainty (the first on ties).
pub(crate) fn extremes(v: impl IntoIterator<Item = (f64, f64)>) -> ((f64, f64), (f64, f64)) {
    let mut hi = (f64::NEG_INFINITY, 0.0);
    let mut lo = (f64::INFINITY, 0.0);
    for p in v {
        if p.0 > hi.0 {
            hi = p;
        }
        if p.0 < lo.0 {
            lo = p;
        }
    }
    (hi, lo)
}

/// The plane files of `files` ordered by distance of the head offset from the tool
/// reference point, then session order: the file a standard is evaluated on comes first.
pub(crate) fn nearest_first(session: &Session, files: &mut [usize]) {
    let norm = |p: usize| {
        let t = session.planes[p].head_offset_mm;
        (t[0] * t[0] + t[1] * t[1] + t[2] * t[2]).sqrt()
    };
    files.sort_by(|a, b| norm(*a).total_cmp(&norm(*b)).then(a.cmp(b)));
}
