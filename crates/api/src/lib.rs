//! # mtcal-api
//!
//! The request and response types of API v1, shared by the server (crates/server), which
//! answers with them, and the typed client (crates/client), which reads them: a change
//! of the API breaks its clients at compile time, and the client links neither the
//! server nor the store (no axum, no sqlx). The store keeps these records as they are
//! (re-exported by `mtcal_store`); the service's rules over them live in the domain.
//!
//! With the feature `openapi` every type derives its OpenAPI schema (utoipa, derive
//! only), for the server's API document.
//!
//! Module order (each imports only those before it): [`limits`], `schemas`,
//! [`machines`], [`datasets`], [`jobs`], [`results`], [`keys`], [`tolerances`],
//! [`fleet`], [`history`], [`trends`], [`service`].

pub mod datasets;
pub mod fleet;
pub mod history;
pub mod jobs;
pub mod keys;
pub mod limits;
pub mod machines;
pub mod results;
#[cfg(feature = "openapi")]
pub mod schemas;
pub mod service;
pub mod tolerances;
pub mod trends;

pub use datasets::{Dataset, Exclusion, FileMeta};
pub use fleet::{
    DiagnosisSummary, FleetDrift, FleetEntry, FleetList, FleetMachine, FleetParams, FleetQuery,
    LastCheck, VerdictSummary,
};
pub use history::{Reason, ResultDiff};
pub use jobs::{Job, JobKind, JobState, SubmitJob};
pub use keys::{ApiKey, CreatedKey, NewKey, Scope};
pub use machines::{Machine, MachinePatch, NewMachine};
pub use results::{
    Figure, FigurePoint, ResultMeta, ResultScalars, ResultSummary, SkippedRow, StoredResult,
};
pub use service::Health;
pub use tolerances::{Profile, ProfileRef, ResultVerdict};
pub use trends::{SummaryPoint, SummaryTrend, TermPoint, TermTrend};
