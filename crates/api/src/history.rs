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
