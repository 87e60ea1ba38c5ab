//! Trends over a machine's history: a term's values at given positions, and the summary
//! figures of its identifications.

use crate::results::ResultSummary;
use serde::{Deserialize, Serialize};

/// What a trend point says of its check's model: a misfit (its model does not explain
/// its recording: the values are not decided) and why, or a check decided on the
/// explained model (docs/compensation.md, "The explained model in the service").
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct CheckModel {
    /// The check's model does not explain its recording: its values are not decided
    /// (the machine page draws them as rings, without a ±2σ bar).
    #[serde(default)]
    pub misfit: bool,
    /// Why, when `misfit`: the misfit gate's statement (for a check the diagnosis
    /// explains only partly, what remains); null otherwise.
    #[serde(default)]
    pub misfit_reason: Option<String>,
    /// When the check is decided on the explained model: the gate's statement, saying
    /// what the model adds (`decided on the explained model, the 21 terms fitted jointly
    /// with backlash (X): …`); null otherwise.
    #[serde(default)]
    pub explained_model: Option<String>,
}

#[derive(Debug, Clone, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct TermPoint {
    pub result_id: String,
    pub measured_at: String,
    /// Value at each position (`um` or `urad`); null when the term was not identifiable
    /// in this check or the position lies outside the travel it measured.
    pub values: Vec<Option<f64>>,
    /// Standard uncertainty of each value (from the check's stored covariance); null
    /// where the value is null or no covariance is stored.
    pub u: Vec<Option<f64>>,
    /// A misfit, or decided on the explained model.
    #[serde(flatten)]
    pub model: CheckModel,
}

#[derive(Debug, Clone, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct TermTrend {
    pub machine_id: String,
    pub term: String,
    pub unit: String,
    pub positions_mm: Vec<f64>,
    /// In time order.
    pub points: Vec<TermPoint>,
    /// Stored results left out because their rows do not decode, one sentence each
    /// naming the result (absent when none).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub warnings: Vec<String>,
}

#[derive(Debug, Clone, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct SummaryPoint {
    pub result_id: String,
    pub measured_at: String,
    /// The result's summary figures, as stored.
    #[serde(flatten)]
    pub summary: ResultSummary,
    /// Standard uncertainties of the three squareness errors, µrad (from the check's
    /// stored covariance; null where none is stored).
    pub ec0y_u_urad: Option<f64>,
    pub eb0z_u_urad: Option<f64>,
    pub ea0z_u_urad: Option<f64>,
    /// A misfit, or decided on the explained model.
    #[serde(flatten)]
    pub model: CheckModel,
}

#[derive(Debug, Clone, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct SummaryTrend {
    pub machine_id: String,
    /// In time order.
    pub points: Vec<SummaryPoint>,
    /// Stored results left out because their rows do not decode, one sentence each
    /// naming the result (absent when none).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub warnings: Vec<String>,
}
