//! The check of a positioning-run file as one document: its diagnosis
//! ([`crate::diagnosis::series::positioning`]) with the ISO 230-2 figures of the same runs
//! beside it ([`crate::standards::iso230_2`], with and without outlying readings). The
//! service stores a positioning-run diagnosis in this shape, and the result page and the
//! check report show both; `mtcal diagnose --json` prints it.
//!
//! The document is the diagnosis result with one more key, `iso230_2` (the objects of the
//! standards document's `iso230_2`), absent for other recordings: a reader of the
//! diagnosis result reads it unchanged.

use crate::datasets::PositioningRuns;
use crate::diagnosis::series::{SeriesOptions, diagnose_positioning_with_progress};
use crate::diagnosis::{DiagnosisResult, Progress};
use crate::error::SolverError;
use crate::standards::NotEvaluated;
use crate::standards::iso230_2::{self, Iso2302};
use serde::{Deserialize, Serialize};

/// A diagnosis result with the ISO 230-2 figures of the same recording (module docs).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DiagnosisDocument {
    #[serde(flatten)]
    pub diagnosis: DiagnosisResult,
    /// ISO 230-2 figures per axis of the same positioning runs (empty for other
    /// recordings).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub iso230_2: Vec<Iso2302>,
    /// Axes whose ISO 230-2 figures could not be evaluated, with the reason.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub not_evaluated: Vec<NotEvaluated>,
}

impl From<DiagnosisResult> for DiagnosisDocument {
    /// A diagnosis of another recording: no ISO 230-2 figures.
    fn from(diagnosis: DiagnosisResult) -> Self {
        DiagnosisDocument {
            diagnosis,
            iso230_2: vec![],
            not_evaluated: vec![],
        }
    }
}

/// The diagnosis of positioning runs with their ISO 230-2 figures; `progress` as
/// [`diagnose_positioning_with_progress`].
pub fn check_positioning(
    runs: &PositioningRuns,
    machine_id: &str,
    opts: &SeriesOptions,
    progress: &mut dyn Progress,
) -> Result<DiagnosisDocument, SolverError> {
    let (iso230_2, not_evaluated) = iso230_2::from_positioning_runs(runs);
    Ok(DiagnosisDocument {
        diagnosis: diagnose_positioning_with_progress(runs, machine_id, opts, progress)?,
        iso230_2,
        not_evaluated,
    })
}
