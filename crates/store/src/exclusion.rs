//! Who set a record aside and why: an exclusion of a result or a dataset, the deletion
//! of a dataset's bytes (shared by datasets and results).

use serde::{Deserialize, Serialize};

/// Who sets a record aside and why, as asked of the store (an exclusion of a result or a
/// dataset, the deletion of a dataset's bytes); checked by [`crate::text::check_record`].
/// The store adds the time and keeps it as an [`Exclusion`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SetAside<'a> {
    /// The API key (or the operator) that does it.
    pub by: &'a str,
    pub reason: &'a str,
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
