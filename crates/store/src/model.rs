//! Plain records the store reads and writes. Times are RFC 3339 UTC strings.
//!
//! Each record is kept in the file of its resource, with the trait that stores it
//! (`Machine` in `machines.rs`, `Job` in `queue.rs`, …) and re-exported here, so that
//! `use mtcal_store::model::*` names every one; only the records of setting aside,
//! shared by datasets and results, live here.

pub use crate::datasets::{Dataset, FileMeta, NewDataset};
pub use crate::fleet::{
    FleetDriftRow, FleetPage, FleetPageQuery, FleetPageRow, FleetSort, LastCheck,
};
pub use crate::keys::{NewSession, SessionRecord};
pub use crate::limits::MAX_TRAVEL_MM;
pub use crate::machines::{Machine, MachinePatch};
pub use crate::queue::{Job, JobKind, JobState, NewJob};
pub use crate::results::{
    BaselinePair, FIGURE_NAME_MAX, Figure, FigurePoint, NewResult, ResultMeta, ResultScalars,
    ResultSummary, SkippedRow, StoredResult,
};
pub use crate::store::RowCounts;
pub use crate::tolerances::{Alert, AlertRaised, ToleranceProfile};
pub use crate::webhooks::{DELIVERY_STATES, DeliveryOutcome, WebhookDelivery};
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
