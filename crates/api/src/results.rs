//! Results: a stored result with or without its document, the scalar figures kept for
//! trends, the named figures of the standards, and a row a list left out.

use crate::datasets::Exclusion;
use serde::{Deserialize, Serialize};
use serde_json::Value;
use std::collections::BTreeMap;

/// Scalar figures of a result kept in their own columns for trend queries.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct ResultScalars {
    /// Residual, conditioning, rank and squareness (their own JSON fields).
    #[serde(flatten)]
    pub summary: ResultSummary,
    /// Monomial coefficients of the identifiable terms (element i ↔ q^(i+1)).
    pub term_coefficients: BTreeMap<String, Vec<f64>>,
    /// Travel each axis measured, [min, max] mm, by axis letter: the terms are determined
    /// there only. Empty when unknown (results stored before it was recorded).
    #[serde(default)]
    pub measured_travel_mm: BTreeMap<String, [f64; 2]>,
    /// Covariance of each identifiable term's coefficients (n × n, same order), and the
    /// variance of each squareness value as a 1 × 1 matrix under its name.
    #[serde(default)]
    pub term_covariance: BTreeMap<String, Vec<Vec<f64>>>,
}

/// The summary figures of an identification, each in its own column (absent for other
/// kinds of result): what the summary trend shows over a machine's checks.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct ResultSummary {
    /// RMS of the fit's residual, µm.
    pub residual_rms_um: Option<f64>,
    /// Condition number and rank of the identification (its observability's).
    pub condition_number: Option<f64>,
    pub rank: Option<i64>,
    /// Squareness error EC0Y, µrad.
    pub ec0y_urad: Option<f64>,
    /// Squareness error EB0Z, µrad.
    pub eb0z_urad: Option<f64>,
    /// Squareness error EA0Z, µrad.
    pub ea0z_urad: Option<f64>,
}

impl ResultSummary {
    /// The stored value of squareness `name` (`EC0Y`, `EB0Z`, `EA0Z`; `None` inside where
    /// the result has none); `None` when `name` is not one of them.
    pub fn squareness(&self, name: &str) -> Option<Option<f64>> {
        match name {
            "EC0Y" => Some(self.ec0y_urad),
            "EB0Z" => Some(self.eb0z_urad),
            "EA0Z" => Some(self.ea0z_urad),
            _ => None,
        }
    }
}

/// One named scalar figure of a result (the standards' figures, e.g. `iso230_2.X.E_um`,
/// `iso230_4.XY.bi.H_um`): stored in its own table so that it trends and takes
/// tolerances. Names: letters, digits, `_` and `.`, at most [`FIGURE_NAME_MAX`] bytes.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct Figure {
    pub name: String,
    /// Value in the unit its name ends with (`_um`: µm).
    pub value: f64,
    /// Standard uncertainty (k = 1), when known.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub u: Option<f64>,
}

/// Longest figure name accepted, bytes.
pub const FIGURE_NAME_MAX: usize = 128;

/// One result's value of a figure, for a trend.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct FigurePoint {
    pub result_id: String,
    pub measured_at: String,
    pub value: f64,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub u: Option<f64>,
}

/// A stored result, without its document.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct ResultMeta {
    pub id: String,
    pub job_id: String,
    pub machine_id: String,
    pub dataset_id: Option<String>,
    pub kind: String,
    pub measured_at: String,
    pub created_at: String,
    pub scalars: ResultScalars,
    /// Set when the result was excluded from the history (see [`Exclusion`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub excluded: Option<Exclusion>,
}

/// A stored result with its document.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct StoredResult {
    pub meta: ResultMeta,
    #[cfg_attr(feature = "openapi", schema(value_type = Object))]
    pub document: Value,
}

/// A stored row a list left out because it does not decode, and why: the rest of the
/// list is served (one bad row must not fail every reader of a machine's history).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct SkippedRow {
    /// The row's id (a result id), or `?` when even that does not read.
    pub id: String,
    pub reason: String,
}

impl SkippedRow {
    /// The warning sentence readers return with the rows they served.
    pub fn warning(&self) -> String {
        format!(
            "result {} skipped: its stored row does not decode ({})",
            self.id, self.reason
        )
    }
}
