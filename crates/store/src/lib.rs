//! # mtcal-store
//!
//! Persistence of the mtcal service behind one interface, [`Store`], so that handlers and
//! the worker never see a database: machines, datasets (raw files with checksums),
//! jobs (the durable queue, see [`queue`]), results (document + scalar columns for trend
//! queries) and API keys.
//!
//! [`SqliteStore`] is the embedded default (WAL mode, runtime-checked `sqlx::query`,
//! migrations in `migrations/sqlite` embedded at build time). A PostgreSQL backend would
//! be a second implementation of [`Store`] with its own migrations and
//! `FOR UPDATE SKIP LOCKED` in the claim query; [`open`] picks the backend from the URL.

use std::future::Future;
use std::pin::Pin;

pub mod keys;
pub mod model;
pub mod queue;
mod sqlite;

pub use keys::{ApiKey, Scope};
pub use model::*;
pub use queue::{Heartbeat, QueueConfig};
pub use sqlite::SqliteStore;

/// Why a store operation failed.
#[derive(Debug, thiserror::Error)]
pub enum StoreError {
    /// The named record does not exist.
    #[error("{0} not found")]
    NotFound(String),
    /// The operation contradicts stored state (duplicate id, job already finished, …).
    #[error("{0}")]
    Conflict(String),
    /// The worker's lease on a job was taken over (it was reaped) or the job was cancelled.
    #[error("lease on job {0} lost")]
    LeaseLost(String),
    /// The database URL names a backend this build does not have.
    #[error("unsupported database URL {0:?} (this build has SQLite: sqlite://PATH or a file path)")]
    UnsupportedUrl(String),
    #[error("database: {0}")]
    Database(#[from] sqlx::Error),
    #[error("migration: {0}")]
    Migration(#[from] sqlx::migrate::MigrateError),
    #[error("stored JSON: {0}")]
    Json(#[from] serde_json::Error),
}

pub type Result<T, E = StoreError> = std::result::Result<T, E>;

/// The future every [`Store`] method returns (boxed so that `dyn Store` works).
pub type StoreFuture<'a, T> = Pin<Box<dyn Future<Output = Result<T>> + Send + 'a>>;

/// Everything the service keeps. Implementations must make each method atomic.
pub trait Store: Send + Sync + 'static {
    // Machines.
    fn create_machine<'a>(&'a self, m: &'a Machine) -> StoreFuture<'a, Machine>;
    fn get_machine<'a>(&'a self, id: &'a str) -> StoreFuture<'a, Machine>;
    fn update_machine<'a>(&'a self, id: &'a str, p: &'a MachinePatch) -> StoreFuture<'a, Machine>;
    /// Machines ordered by id, after `after` (keyset pagination).
    fn list_machines<'a>(
        &'a self,
        after: Option<&'a str>,
        limit: i64,
    ) -> StoreFuture<'a, Vec<Machine>>;

    // Datasets.
    /// Stores a dataset and all its files in one transaction.
    fn insert_dataset<'a>(&'a self, d: NewDataset) -> StoreFuture<'a, Dataset>;
    fn get_dataset<'a>(&'a self, id: &'a str) -> StoreFuture<'a, Dataset>;
    /// The bytes of one file, as uploaded.
    fn dataset_file<'a>(&'a self, id: &'a str, name: &'a str) -> StoreFuture<'a, Vec<u8>>;
    /// Every file of a dataset, as uploaded.
    fn dataset_files<'a>(&'a self, id: &'a str) -> StoreFuture<'a, Vec<(String, Vec<u8>)>>;

    // Jobs (the queue).
    fn enqueue<'a>(&'a self, j: NewJob) -> StoreFuture<'a, Job>;
    fn get_job<'a>(&'a self, id: &'a str) -> StoreFuture<'a, Job>;
    /// Cancels a queued job at once; asks a running one to stop (the worker sees it at its
    /// next heartbeat). Terminal jobs are a conflict.
    fn cancel_job<'a>(&'a self, id: &'a str) -> StoreFuture<'a, Job>;
    /// Claims the oldest runnable job for `worker` with a lease of `lease_ms`, in one
    /// `UPDATE … RETURNING`; counts an attempt.
    fn claim_job<'a>(&'a self, worker: &'a str, lease_ms: i64) -> StoreFuture<'a, Option<Job>>;
    /// Extends the lease and records progress.
    fn heartbeat<'a>(
        &'a self,
        id: &'a str,
        worker: &'a str,
        lease_ms: i64,
        progress: f64,
        message: &'a str,
    ) -> StoreFuture<'a, Heartbeat>;
    /// Stores the result and marks the job succeeded, in one transaction, only while
    /// `worker` holds the lease: a job completes exactly once.
    fn complete_job<'a>(
        &'a self,
        id: &'a str,
        worker: &'a str,
        r: NewResult,
    ) -> StoreFuture<'a, Job>;
    /// Records a failure: back to the queue after `retry_after_ms`, or failed for good
    /// when `None`.
    fn fail_job<'a>(
        &'a self,
        id: &'a str,
        worker: &'a str,
        code: &'a str,
        message: &'a str,
        retry_after_ms: Option<i64>,
    ) -> StoreFuture<'a, Job>;
    /// Marks a running job whose cancellation was requested as cancelled.
    fn finish_cancelled<'a>(&'a self, id: &'a str, worker: &'a str) -> StoreFuture<'a, Job>;
    /// Requeues (or fails, when out of attempts) running jobs whose lease has expired;
    /// returns how many.
    fn reap_expired<'a>(&'a self) -> StoreFuture<'a, u64>;

    // Results.
    fn get_result<'a>(&'a self, id: &'a str) -> StoreFuture<'a, StoredResult>;
    /// A machine's results of `kind` in time order (measured_at, then id).
    fn list_results<'a>(
        &'a self,
        machine_id: &'a str,
        kind: &'a str,
    ) -> StoreFuture<'a, Vec<ResultMeta>>;
    /// For every machine with results of `kind`: baseline, latest and count.
    fn baseline_pairs<'a>(&'a self, kind: &'a str) -> StoreFuture<'a, Vec<BaselinePair>>;
    /// Inserts a result without a job run (seeding the load benchmark, imports).
    fn import_result<'a>(&'a self, r: NewResult) -> StoreFuture<'a, ResultMeta>;

    // Keys.
    /// Creates a key; returns it with the secret, which is not stored.
    fn create_key<'a>(&'a self, scope: Scope, label: &'a str) -> StoreFuture<'a, (ApiKey, String)>;
    fn key_by_secret<'a>(&'a self, secret: &'a str) -> StoreFuture<'a, Option<ApiKey>>;

    fn row_counts(&self) -> StoreFuture<'_, RowCounts>;
}

/// Opens the store a URL names (`sqlite://PATH`, `sqlite::memory:` or a plain file path),
/// creating and migrating it when needed.
pub async fn open(url: &str) -> Result<std::sync::Arc<dyn Store>> {
    if url.starts_with("postgres://") || url.starts_with("postgresql://") {
        return Err(StoreError::UnsupportedUrl(url.to_string()));
    }
    Ok(std::sync::Arc::new(SqliteStore::open(url).await?))
}

/// Current time as RFC 3339 UTC with millisecond precision.
pub fn now_rfc3339() -> String {
    let t = time::OffsetDateTime::now_utc();
    let t = t
        .replace_nanosecond(t.millisecond() as u32 * 1_000_000)
        .unwrap_or(t);
    t.format(&time::format_description::well_known::Rfc3339)
        .unwrap_or_default()
}

/// Current time in milliseconds since the Unix epoch.
pub fn now_ms() -> i64 {
    (time::OffsetDateTime::now_utc().unix_timestamp_nanos() / 1_000_000) as i64
}
