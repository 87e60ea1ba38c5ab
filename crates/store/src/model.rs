//! Plain records the store reads and writes. Times are RFC 3339 UTC strings.
//!
//! Each record is kept in the file of its resource, with the trait that stores it
//! (`Machine` in `machines.rs`, `Job` in `queue.rs`, …) and re-exported here, so that
//! `use mtcal_store::model::*` names every one (the records of setting aside, shared by
//! datasets and results, are in `exclusion.rs`). Nothing inside the crate imports this
//! module: each imports a record from its own file.

pub use crate::audit::{AuditEvent, AuditQuery, NewAuditEvent};
pub use crate::datasets::{Dataset, FileMeta, NewDataset};
pub use crate::exclusion::{Exclusion, SetAside};
pub use crate::fleet::{
    EntryJson, FleetCounts, FleetDriftRow, FleetPage, FleetPageQuery, FleetPageRow, FleetSort,
    LastCheck,
};
pub use crate::keys::{NewSession, SessionRecord};
pub use crate::limits::MAX_TRAVEL_MM;
pub use crate::machines::{Machine, MachinePatch};
pub use crate::queue::{Job, JobKind, JobState, NewJob};
pub use crate::results::{
    BaselinePair, CheckModel, FIGURE_NAME_MAX, Figure, FigurePoint, NewResult, PairBatch,
    ResultMeta, ResultScalars, ResultSummary, SkippedRow, StoredResult,
};
pub use crate::store::RowCounts;
pub use crate::tolerances::{Alert, AlertRaised, ToleranceProfile};
pub use crate::webhooks::{DELIVERY_STATES, DeliveryOutcome, WebhookDelivery};
