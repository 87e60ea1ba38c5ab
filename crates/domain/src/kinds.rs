//! The kinds of stored results (one per runnable job kind, [`mtcal_store::JobKind`]).

use crate::error::DomainError;
use mtcal_store::JobKind;

/// The kind of identification results: the only kind history differences, trends,
/// drift, verdicts of terms and alerts are computed on.
pub const IDENTIFICATION: &str = "identification";
/// The result kind of a diagnosis.
pub const DIAGNOSIS: &str = "diagnosis";

/// The result kind a query names (default [`IDENTIFICATION`]); an unknown kind is
/// refused with a message that lists the kinds.
pub fn result_kind(kind: Option<&str>) -> Result<&str, DomainError> {
    let Some(kind) = kind else {
        return Ok(IDENTIFICATION);
    };
    let kinds = JobKind::RUNNABLE.map(JobKind::result_kind);
    if kinds.contains(&kind) {
        Ok(kind)
    } else {
        Err(DomainError::Invalid(format!(
            "kind {kind:?}: one of {}",
            kinds.join(", ")
        )))
    }
}
