//! # mtcal-store
//!
//! Persistence of the mtcal service behind one interface, [`Store`], so that handlers and
//! the worker never see a database. [`Store`] is one trait per resource, each in the file
//! of its name with the records it reads and writes (all re-exported by [`model`]):
//!
//! | trait | file | what it keeps |
//! |---|---|---|
//! | [`Machines`] | `machines.rs` | the machines |
//! | [`Datasets`] | `datasets.rs` | datasets: raw files with checksums, excluded or deleted with a record |
//! | [`Queue`] | `queue.rs` | jobs: the durable queue |
//! | [`Results`] | `results.rs` | results (document + scalar columns for trend queries) and their figures |
//! | [`Fleet`] | `fleet.rs` | the fleet's drift rows and the fleet page |
//! | [`Tolerances`] | `tolerances.rs` | tolerance profiles and the drift alerts they raise |
//! | [`Webhooks`] | `webhooks.rs` | the outbox of webhook deliveries |
//! | [`Keys`] | `keys.rs` | API keys and the dashboard's sign-in sessions |
//! | [`Audit`] | `audit.rs` | the audit trail: every change of state a person made (append-only) |
//! | [`Operations`] | `store.rs` | the database as a whole: migrations, row counts |
//!
//! Callers hold an `Arc<dyn Store>` and call any of these methods on it; code that calls
//! them on a concrete store type adds `use mtcal_store::prelude::*`.
//!
//! Layout: the records, the queue's typed kinds and rules ([`queue`]), key
//! generation and hashing ([`keys`]) and the other backend-independent rules
//! ([`rules`]: manifest checksums, machine patches and baselines, result rows) are
//! shared; so are the statements (`sql/`, one file per resource, compiled once per
//! backend). A backend module holds only its connection and its dialect, with its
//! migrations in `migrations/<backend>/`. Errors are [`StoreError`], which names no
//! driver type.
//!
//! [`SqliteStore`] is the embedded default, for one process on one host (WAL mode);
//! [`PostgresStore`] is for several API and worker processes on several hosts sharing one
//! PostgreSQL database. Both use runtime-checked `sqlx::query` and migrations embedded
//! at build time; [`open`] picks the backend from the URL.

pub mod audit;
mod clock;
mod datasets;
mod error;
mod exclusion;
mod fleet;
pub mod keys;
pub mod limits;
mod machines;
mod migrations;
pub mod model;
mod postgres;
pub mod queue;
mod results;
mod rows;
pub mod rules;
#[cfg(feature = "openapi")]
pub mod schemas;
mod sqlite;
mod store;
pub mod testing;
pub mod text;
mod tolerances;
mod url;
mod webhooks;

pub use audit::Audit;
pub use clock::{now_ms, now_rfc3339, rfc3339_millis};
pub use datasets::Datasets;
pub use error::{Result, StoreError};
pub use fleet::Fleet;
pub use keys::{ApiKey, Keys, Scope};
pub use machines::Machines;
pub use model::*;
pub use postgres::PostgresStore;
pub use queue::{Failure, Heartbeat, JobCount, Lease, Progress, Queue, QueueConfig};
pub use results::Results;
pub use sqlite::SqliteStore;
pub use store::{Operations, Store, StoreFuture, StoreOptions, open, open_with};
pub use tolerances::Tolerances;
pub use url::redacted;
pub use webhooks::Webhooks;

/// Every store trait, for code that calls store methods on a concrete store type
/// (`SqliteStore`, `PostgresStore`) or a generic one: `use mtcal_store::prelude::*`.
/// (Through a `dyn Store` every method is callable without it.)
pub mod prelude {
    pub use crate::{
        Audit, Datasets, Fleet, Keys, Machines, Operations, Queue, Results, Store, Tolerances,
        Webhooks,
    };
}
