//! Datasets: a dataset's metadata and its files, and the record of who set a record aside
//! and why (an exclusion of a dataset or a result, the deletion of a dataset's bytes).

use serde::{Deserialize, Serialize};

/// One stored file of a dataset, as uploaded.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct FileMeta {
    pub name: String,
    pub sha256: String,
    pub size: i64,
}

/// A dataset's metadata (its bytes: `GET /api/v1/datasets/{id}/files/{name}`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct Dataset {
    pub id: String,
    pub machine_id: String,
    /// `session`, `rotary_points`, `positioning` or `drift_log` (datasets contract).
    pub kind: String,
    pub measured_at: String,
    pub uploaded_at: String,
    pub samples: i64,
    pub total_bytes: i64,
    /// SHA-256 over the sorted list of `name:sha256` lines of its files.
    pub sha256: String,
    pub files: Vec<FileMeta>,
    /// Set when the dataset was excluded ([`Exclusion`]): no new job runs on it, default
    /// listings leave it out, and the results computed from it are excluded with this
    /// same record.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub excluded: Option<Exclusion>,
    /// Set when the dataset's raw bytes were deleted (who, when, why: the same record
    /// shape as an exclusion). The files' names, sizes and checksums stay; their bytes are
    /// gone. A deleted dataset is always excluded too.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub deleted: Option<Exclusion>,
}

/// Why and by whom a record was set aside: a result excluded from the history (it stays
/// stored and readable by id, but no list, trend, difference, drift or figure trend uses
/// it), a dataset excluded (its results with it, same record) or a dataset's bytes
/// deleted.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct Exclusion {
    /// RFC 3339.
    pub at: String,
    /// The API key (or the operator) that did it.
    pub by: String,
    pub reason: String,
}
