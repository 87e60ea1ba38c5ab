//! The explained model's part of an identification result document (docs/results.md,
//! "The explained model"): the physics fitted jointly with the 21 terms, the fit's
//! figures, what each compensation is predicted to leave, and the actions.

use crate::diagnosis::{BeforeAfter, Verdict};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// The explained model: the 21 terms fitted jointly with the physics a diagnosis found.
/// The document's terms, squareness and fit are this model's; `rigid` keeps the figures of
/// the 21-term model alone.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct ExplainedModel {
    /// The diagnosis's verdict: `explained` (decisions use this model) or
    /// `partly_explained` (not decided: `remains` says what is left).
    pub verdict: Verdict,
    /// The physics of the model, one entry per finding of the diagnosis.
    pub physics: Vec<Physics>,
    /// Residual RMS of the explained model on every reading, µm.
    pub residual_rms_um: f64,
    /// RMS on whole runs held out of the fit (folds of whole runs), µm.
    pub heldout_rms_um: f64,
    /// The noise floor, estimated independently of the model, µm.
    pub noise_floor_um: f64,
    /// The 21-term model alone: its residual and held-out RMS, µm.
    pub rigid: RigidFigures,
    /// One sentence: what the model adds to the 21 terms.
    pub adds: String,
    /// What the model leaves unexplained, and where (empty when explained).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub remains: Vec<String>,
    /// Residual RMS of the 21-term model predicted once every finding is compensated
    /// in the controller, µm (`predict::after_compensation`).
    pub predicted_residual_rms_um: f64,
    /// What to do, one action per finding, in words a technician acts on.
    #[serde(default)]
    pub actions: Vec<Action>,
    /// The service's link to the check this model was fitted for: the stored result of
    /// the 21-term model alone (kept, excluded from the history as superseded by this
    /// one). Absent outside the service.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub original_result_id: Option<String>,
    /// The stored diagnosis whose findings this model adds (absent outside the service).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub diagnosis_result_id: Option<String>,
}

/// The 21-term model's figures before the physics was added.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct RigidFigures {
    pub residual_rms_um: f64,
    pub heldout_rms_um: f64,
}

/// One effect of the explained model, fitted jointly with the 21 terms.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct Physics {
    /// Effect, axis and moving axis as the diagnosis's finding names them.
    pub effect: String,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub axis: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub depends_on: Option<String>,
    /// The joint fit's parameters (`std_*`: σ conditional on `held`).
    pub parameters: BTreeMap<String, f64>,
    /// Nonlinear parameters held at the diagnosis's values (a period, a time constant,
    /// a decay length), with the diagnosis's σ where it had one.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub held: BTreeMap<String, f64>,
    /// Residual RMS of the 21-term model now and predicted after this effect alone is
    /// compensated, µm.
    pub predicted_rms_um: BeforeAfter,
}

impl Physics {
    /// `backlash (X)`, `direction coupling (Y, following X)`.
    pub fn name_in_words(&self) -> String {
        let name = self.effect.replace('_', " ");
        match (&self.axis, &self.depends_on) {
            (Some(a), Some(d)) => format!("{name} ({a}, following {d})"),
            (Some(a), None) => format!("{name} ({a})"),
            _ => name,
        }
    }

    /// A parameter and its σ, when reported.
    pub fn get(&self, name: &str) -> Option<(f64, Option<f64>)> {
        let v = self.parameters.get(name).or_else(|| self.held.get(name))?;
        let s = self
            .parameters
            .get(&format!("std_{name}"))
            .or_else(|| self.held.get(&format!("std_{name}")));
        Some((*v, s.copied()))
    }
}

/// One thing to do about a finding, with the number to set and where it comes from.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct Action {
    /// The finding it acts on, in words (`backlash (X)`).
    pub finding: String,
    /// What to do, one sentence.
    pub text: String,
    /// The value to set in the controller, when there is one.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub set: Option<SetValue>,
    /// Residual RMS of the 21-term model now and predicted once this finding is
    /// compensated (or removed), µm, from the explained model.
    pub predicted_rms_um: BeforeAfter,
}

/// A value to set, with its unit and where it comes from.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct SetValue {
    /// What is set (`X backlash compensation`).
    pub what: String,
    pub value: f64,
    /// Its standard uncertainty (k = 1).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub std: Option<f64>,
    pub unit: String,
    /// Where the number comes from, and how it relates to today's controller value.
    pub source: String,
}
