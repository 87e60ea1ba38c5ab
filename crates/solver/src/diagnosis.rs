//! Mismatch diagnosis: locate where the model and the recordings differ, name the physics
//! the model left out, model it, and prove the fit improves on held-out data.
//!
//! This module holds the result document (docs/results.md, "Diagnosis result"),
//! common to every kind of recording; the analyses live in submodules.

use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

pub mod series;

/// Residual figures of the rigid (baseline) model.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct Baseline {
    pub residual_rms_um: f64,
    /// RMS on data not used to fit the model (whole runs, or the late part of a log).
    pub heldout_rms_um: f64,
    /// Noise floor estimated independently of the model.
    pub noise_estimate_um: f64,
}

/// Where the misfit concentrates.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct Mismatch {
    /// Human-readable place: tests, positions, angles, times, directions.
    #[serde(rename = "where")]
    pub where_: String,
    /// Identifiers of the tests concerned, e.g. `xy_L100.csv#run 3`.
    pub tests: Vec<String>,
    /// Share of the total misfit (sum of squared residuals above noise) found here.
    pub share_of_misfit: f64,
}

impl Mismatch {
    /// Whether the place is a whole file's test (`xy.csv: X line runs`): those places do
    /// not overlap, so their shares add up; the finer ones lie inside them.
    pub fn by_file_and_test(&self) -> bool {
        self.where_.ends_with(" runs")
    }
}

/// The share of the misfit the places by file and test of `places` hold together (None
/// when there are none).
pub fn listed_share(places: &[Mismatch]) -> Option<f64> {
    let parts: Vec<f64> = places
        .iter()
        .filter(|m| m.by_file_and_test())
        .map(|m| m.share_of_misfit)
        .collect();
    (!parts.is_empty()).then(|| parts.iter().sum::<f64>().min(1.0))
}

/// A before/after pair of RMS figures, µm.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct BeforeAfter {
    pub before: f64,
    pub after: f64,
}

/// One physical effect found, modelled and checked on held-out data.
///
/// Every value in `parameters` is a finite number with its `std_*` (when reported)
/// finite too: a parameter whose σ the data do not bound is in `undetermined`
/// ([`effects::classify`]). A stored document of an earlier version that wrote such a σ as
/// `null` reads back with that parameter moved to `undetermined`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
#[serde(from = "FindingDoc")]
pub struct Finding {
    /// `backlash`, `servo_lag`, `reversal_spike`, `cyclic`, `thermal_drift`,
    /// `setup_offset`, `model_order`, `vibration`, or another name (then `physics` says
    /// what it is).
    pub effect: String,
    /// The axis whose error it is: the direction the error acts along for an error that
    /// one axis's motion causes along another (`direction_coupling`,
    /// `velocity_coupling`: then `depends_on` names the moving axis); the axis itself
    /// for an error of its own motion (`backlash`, `cyclic`, a guideway's `waviness`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub axis: Option<String>,
    /// The axis whose motion (direction of travel, velocity) the error follows, when it
    /// is not `axis`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub depends_on: Option<String>,
    /// Fitted parameters with their units in the names (and `std_*` uncertainties).
    pub parameters: BTreeMap<String, f64>,
    /// One sentence: what the physics is and why the rigid-body model lacks it.
    pub physics: String,
    /// For an effect found by its signature rather than named in the catalogue: the
    /// signature in words ("a Z error that follows the Y velocity").
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub signature: Option<String>,
    pub residual_rms_um: BeforeAfter,
    pub heldout_rms_um: BeforeAfter,
    /// Why this effect was chosen (information criterion, signature counts).
    pub evidence: String,
    /// Parameters of this effect that the data do not determine, each with its value,
    /// standard uncertainty and what extra data would decide it; not in `parameters`.
    /// One shape for every kind of recording: a finding whose principal parameters are
    /// all here is listed under [`DiagnosisResult::possible`] ("possible, undetermined");
    /// a finding with a determined principal parameter may still list others here.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub undetermined: Vec<Undetermined>,
    /// Other explanations the session's plan cannot tell from this one (their data
    /// terms differ by less than Δχ² 10), each with the test that would separate them;
    /// a finding with a simpler rival is left possible (docs/diagnosis.md).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub rivals: Vec<Rival>,
}

/// An explanation the plan cannot tell from a finding's, and the test that would.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct Rival {
    /// The rival effect's name (`servo_lag`, `backlash`, …).
    pub effect: String,
    /// Its axis (or direction), as the finding's `axis`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub axis: Option<String>,
    /// Why the plan cannot separate the two, with the figures.
    pub why: String,
    /// The test that would separate them, in words.
    pub separating_test: String,
}

impl Rival {
    /// One line: `servo lag (X) — would be told apart by lines or circles at a second
    /// feed (…); why they read alike`.
    pub fn in_words(&self) -> String {
        let name = self.effect.replace('_', " ");
        let name = match &self.axis {
            Some(a) => format!("{name} ({a})"),
            None => name,
        };
        format!(
            "{name} — would be told apart by {}; {}",
            self.separating_test, self.why
        )
    }
}

impl Finding {
    /// The finding's axis as a person reads it: `Y`, or `Y, following X` for an error
    /// along Y that follows the X motion (`depends_on`).
    pub fn axis_label(&self) -> Option<String> {
        let a = self.axis.as_deref()?;
        Some(match &self.depends_on {
            Some(d) => format!("{a}, following {d}"),
            None => a.to_string(),
        })
    }

    /// Its fitted parameters in words, in a person's units:
    /// `backlash_um = 6.01 (u = 0.02), …` (u: the standard uncertainty, k = 1, where
    /// reported).
    pub fn parameters_in_words(&self) -> String {
        use crate::text::{num, person_units};
        let list = self
            .parameters
            .iter()
            .filter(|(k, _)| !k.starts_with("std_"))
            .map(|(k, v)| match self.parameters.get(&format!("std_{k}")) {
                Some(u) => {
                    // σ to two significant digits, the value to its place (never u = 0.000).
                    let both = crate::text::with_std(*v, *u, 2, false);
                    let (v, u) = both.split_once(" ± ").unwrap_or((&both, ""));
                    format!("{k} = {v} (u = {u})")
                }
                None => format!("{k} = {}", num(*v)),
            })
            .collect::<Vec<_>>()
            .join(", ");
        person_units(&list)
    }

    /// The effect and its axis in words: `backlash (X)`, `direction coupling (Y,
    /// following X)`.
    pub fn name_in_words(&self) -> String {
        let name = self.effect.replace('_', " ");
        match self.axis_label() {
            Some(a) => format!("{name} ({a})"),
            None => name,
        }
    }

    /// One line: `backlash (X): backlash_um = 6.01 (u = 0.02)`.
    pub fn in_words(&self) -> String {
        format!("{}: {}", self.name_in_words(), self.parameters_in_words())
    }
}

/// The stored shape of a [`Finding`], whose parameters may hold `null` (an earlier
/// version's unbounded σ).
#[derive(Deserialize)]
struct FindingDoc {
    effect: String,
    #[serde(default)]
    axis: Option<String>,
    #[serde(default)]
    depends_on: Option<String>,
    parameters: BTreeMap<String, Option<f64>>,
    physics: String,
    #[serde(default)]
    signature: Option<String>,
    residual_rms_um: BeforeAfter,
    heldout_rms_um: BeforeAfter,
    evidence: String,
    #[serde(default)]
    undetermined: Vec<Undetermined>,
    #[serde(default)]
    rivals: Vec<Rival>,
}

impl From<FindingDoc> for Finding {
    fn from(d: FindingDoc) -> Finding {
        let mut parameters = BTreeMap::new();
        let mut unbounded = Vec::new();
        for (name, v) in &d.parameters {
            match (v, name.strip_prefix("std_")) {
                (Some(v), _) => {
                    parameters.insert(name.clone(), *v);
                }
                (None, Some(base)) => unbounded.push(base.to_string()),
                (None, None) => {}
            }
        }
        let mut undetermined = d.undetermined;
        for base in unbounded {
            if let Some(v) = parameters.remove(&base) {
                undetermined.push(Undetermined::with_sentence(
                    base,
                    v,
                    f64::INFINITY,
                    "more data would decide it".into(),
                ));
            }
        }
        // An earlier version named the moving axis in `axis` for an error across it;
        // the error's own axis is the first word of its signature ("a Y error that ...").
        let (axis, depends_on) = match (d.depends_on, d.effect.as_str()) {
            (None, "direction_coupling" | "velocity_coupling") => {
                let own = d
                    .signature
                    .as_deref()
                    .and_then(|s| s.strip_prefix("a "))
                    .and_then(|s| s.split(' ').next())
                    .filter(|a| ["X", "Y", "Z"].contains(a))
                    .map(str::to_string);
                match own {
                    Some(own) => (Some(own), d.axis),
                    None => (d.axis, None),
                }
            }
            (dep, _) => (d.axis, dep),
        };
        Finding {
            effect: d.effect,
            axis,
            depends_on,
            parameters,
            physics: d.physics,
            signature: d.signature,
            residual_rms_um: d.residual_rms_um,
            heldout_rms_um: d.heldout_rms_um,
            evidence: d.evidence,
            undetermined,
            rivals: d.rivals,
        }
    }
}

/// A parameter the data leave undetermined, and what data would decide it.
///
/// Every number of the document is finite: a standard uncertainty the data do not bound
/// (the profiled sum of squares is flat or not convex there) is stated by `bounded: false`
/// with no `std`, never as `null`, NaN or infinity (docs/results.md, "Every document
/// round-trips").
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
#[serde(from = "UndeterminedDoc")]
pub struct Undetermined {
    /// Parameter name with its unit, as it would appear in `parameters`.
    pub name: String,
    pub value: f64,
    /// Standard uncertainty (k = 1) when the data bound it; absent when they do not.
    /// A stored document of an earlier version with `"std": null` reads as absent.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub std: Option<f64>,
    /// Whether the data put a finite bound on the parameter (`std` present).
    pub bounded: bool,
    /// What extra data would decide it, in a sentence.
    pub decide: String,
}

/// The stored shape of an [`Undetermined`] as every version wrote it (`bounded` absent
/// before it was added; `std` null where an unbounded σ was written as infinity).
#[derive(Deserialize)]
struct UndeterminedDoc {
    name: String,
    value: f64,
    #[serde(default)]
    std: Option<f64>,
    decide: String,
}

impl From<UndeterminedDoc> for Undetermined {
    fn from(d: UndeterminedDoc) -> Undetermined {
        Undetermined::with_sentence(d.name, d.value, d.std.unwrap_or(f64::INFINITY), d.decide)
    }
}

impl Undetermined {
    /// An undetermined parameter `name` = `value` ± `std`, decided by `data`: the sentence
    /// is "`data` would decide it". A `std` that is not finite means the data put no bound
    /// on the parameter.
    pub fn new(name: impl Into<String>, value: f64, std: f64, data: &str) -> Undetermined {
        Undetermined::with_sentence(name, value, std, format!("{data} would decide it"))
    }

    /// As [`Undetermined::new`], with the whole sentence of what would decide it.
    pub fn with_sentence(
        name: impl Into<String>,
        value: f64,
        std: f64,
        decide: String,
    ) -> Undetermined {
        let std = std.is_finite().then_some(std);
        Undetermined {
            name: name.into(),
            value,
            std,
            bounded: std.is_some(),
            decide,
        }
    }
}

/// `consistent` (no finding needed), `explained`, `partly_explained`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema), schema(as = DiagnosisVerdict))]
#[serde(rename_all = "snake_case")]
pub enum Verdict {
    Consistent,
    Explained,
    PartlyExplained,
}

impl Verdict {
    /// Its name in the document: `consistent`, `explained`, `partly_explained`.
    pub fn as_str(self) -> &'static str {
        match self {
            Verdict::Consistent => "consistent",
            Verdict::Explained => "explained",
            Verdict::PartlyExplained => "partly_explained",
        }
    }
}

/// The diagnosis result document.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct DiagnosisResult {
    /// Always `diagnosis`.
    pub kind: String,
    pub machine_id: String,
    /// What was diagnosed: `session`, `positioning`, `drift_log`.
    pub source: String,
    pub baseline: Baseline,
    pub mismatch: Vec<Mismatch>,
    /// Effects found, modelled and determined by the data (they count for the verdict).
    pub findings: Vec<Finding>,
    /// Effects the evidence points to whose parameters the data do not determine
    /// ("possible, undetermined"), each with its `undetermined` parameters and what would
    /// decide them; not in the verdict.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub possible: Vec<Finding>,
    /// Candidates rejected as physically implausible, with the reason.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub rejected: Vec<String>,
    pub verdict: Verdict,
    /// What remains unexplained, and where (empty when explained).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub unexplained: Vec<String>,
    /// Named plot series (x, y) for before/after figures, keyed by a short id; the
    /// formats layer renders them to SVG.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub plots: Vec<PlotData>,
}

/// Data for one figure: several named series of (x, y) points.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct PlotData {
    pub id: String,
    pub title: String,
    pub x_label: String,
    pub y_label: String,
    pub kind: PlotKind,
    pub series: Vec<PlotSeries>,
}

/// How a figure's axes are drawn.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
#[serde(rename_all = "lowercase")]
pub enum PlotKind {
    /// x and y on straight axes.
    Cartesian,
    /// x is an angle in degrees, y a radial deviation drawn about a base circle.
    Polar,
    /// x and y on straight axes, each point on its own (one value per run: points of
    /// separate runs are not joined by lines).
    Points,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct PlotSeries {
    pub name: String,
    pub x: Vec<f64>,
    pub y: Vec<f64>,
}

// Grid-encoder sessions (the series of positioning runs and drift logs live in
// `series*` submodules).
pub mod band_search;
pub mod catalogue;
pub mod chebyshev;
pub mod credible;
pub mod design;
pub mod effects;
pub mod engine;
pub mod even_scan;
pub mod linalg;
pub mod local_scan;
pub(crate) mod locate;
pub mod lost_motion;
pub mod lsq;
pub mod moments;
pub mod periodic_scan;
pub mod phase_walk;
pub mod reduced;
pub mod repeatability;
pub(crate) mod search;
pub mod session;
pub mod temperature;
pub mod thermal_search;
pub mod transient;

pub use session::{DiagnoseOptions, diagnose_session, diagnose_session_with_progress};

/// Progress of a diagnosis: `report(phase, fraction)`, the phase in words and the
/// fraction of the whole work done, in [0, 1] and never decreasing. Any
/// `FnMut(&str, f64)` is one.
pub trait Progress {
    fn report(&mut self, phase: &str, fraction: f64);
}

impl<F: FnMut(&str, f64)> Progress for F {
    fn report(&mut self, phase: &str, fraction: f64) {
        self(phase, fraction)
    }
}

/// No progress reports.
pub struct NoProgress;

impl Progress for NoProgress {
    fn report(&mut self, _: &str, _: f64) {}
}

/// Holds a [`Progress`] to its contract: fractions clamped to [0, 1] and never below
/// one already reported.
pub(crate) struct Monotone<'a> {
    inner: &'a mut dyn Progress,
    last: f64,
}

impl<'a> Monotone<'a> {
    pub(crate) fn new(inner: &'a mut dyn Progress) -> Self {
        Monotone { inner, last: 0.0 }
    }

    pub(crate) fn report(&mut self, phase: &str, fraction: f64) {
        let f = if fraction.is_finite() {
            fraction.clamp(self.last, 1.0)
        } else {
            self.last
        };
        self.last = f;
        self.inner.report(phase, f);
    }

    /// Reports `phase` at `fraction` of the part `[lo, hi]` of the whole work.
    pub(crate) fn report_in(&mut self, (lo, hi): (f64, f64), phase: &str, fraction: f64) {
        self.report(phase, lo + (hi - lo) * fraction);
    }
}
