//! A machine's history: the difference of two results, and why a record is set aside.

use crate::results::ResultMeta;
use mtcal_solver::comparison::{Drift, TermDiff};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// Difference between two results of one machine (against − baseline).
#[derive(Debug, Clone, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct ResultDiff {
    pub machine_id: String,
    pub baseline: ResultMeta,
    pub against: ResultMeta,
    pub terms: BTreeMap<String, TermDiff>,
    /// µrad; null when not identifiable in one of them.
    pub squareness: BTreeMap<String, Option<f64>>,
    pub drift: Drift,
    /// Stored results left out because their rows do not decode, one sentence each
    /// naming the result (absent when none).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub warnings: Vec<String>,
}

/// Why a record is set aside: a result or a dataset excluded, a dataset's bytes deleted.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
#[serde(deny_unknown_fields)]
pub struct Reason {
    /// Why (recorded with the key and the time): not blank, at most 1000 characters, no
    /// control character but line feeds and tabs.
    #[cfg_attr(
        feature = "openapi",
        schema(
            max_length = 1000,
            pattern = "^[^\\u0000-\\u0008\\u000b-\\u001f\\u007f-\\u009f]*[^\\s\\u0000-\\u001f\\u007f-\\u009f][^\\u0000-\\u0008\\u000b-\\u001f\\u007f-\\u009f]*$"
        )
    )]
    pub reason: String,
}

impl Reason {
    /// A reason in words.
    pub fn of(reason: &str) -> Reason {
        Reason {
            reason: reason.into(),
        }
    }
}

/// One finding of the earlier check, verified at the later one.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct VerifiedFinding {
    /// The effect (`backlash`, `lost_motion_profile`) and its axis.
    pub effect: String,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub axis: Option<String>,
    /// The parameter compared, with its unit in the name (`lost_motion_um`).
    pub parameter: String,
    /// Its value at the earlier check.
    pub before: f64,
    /// The value predicted once the action is taken (a compensated backlash: 0).
    pub predicted: f64,
    /// Its value at the later check; absent when the later check no longer shows it
    /// (`gone`) or its diagnosis has not landed (`pending`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub measured: Option<f64>,
    /// `gone`, `still_present` or `pending`.
    pub state: String,
    /// Whether the later check agrees with the prediction (module docs); absent while
    /// `pending`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub as_predicted: Option<bool>,
    /// In words: `backlash X: 5.96 → 0.40 µm after compensation (predicted 0)`.
    pub statement: String,
}

/// A check verified against the prediction of the check before it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct Verification {
    pub machine_id: String,
    /// The check verified.
    pub result_id: String,
    pub measured_at: String,
    /// The check before it whose predictions are verified (absent: none before it).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub previous_result_id: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub previous_measured_at: Option<String>,
    /// One per finding of the earlier check with a prediction (empty: nothing to verify).
    pub findings: Vec<VerifiedFinding>,
    /// One sentence: what was verified, or why nothing was.
    pub statement: String,
}
