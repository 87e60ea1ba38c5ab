//! The whole store, [`Store`]: every resource's trait at once, behind one `dyn Store`;
//! and how a store is opened ([`open`], [`StoreOptions`]).

use crate::error::Result;
use crate::{
    Audit, Datasets, Fleet, Keys, Machines, PostgresStore, Queue, Results, SqliteStore, Tolerances,
    Webhooks,
};
use serde::{Deserialize, Serialize};
use std::future::Future;
use std::pin::Pin;
use std::sync::Arc;

/// The future every store method returns (boxed so that `dyn Store` works).
pub type StoreFuture<'a, T> = Pin<Box<dyn Future<Output = Result<T>> + Send + 'a>>;

/// Everything the service keeps: one trait per resource, all of them. Callers hold an
/// `Arc<dyn Store>` (or a `&dyn Store`) and call any resource's method on it; code that
/// calls them on a concrete store type brings the traits into scope with
/// `use mtcal_store::prelude::*`. Implemented for every type that implements them all.
pub trait Store:
    Machines
    + Datasets
    + Queue
    + Results
    + Fleet
    + Tolerances
    + Webhooks
    + Keys
    + Audit
    + Operations
    + 'static
{
}

impl<T> Store for T where
    T: Machines
        + Datasets
        + Queue
        + Results
        + Fleet
        + Tolerances
        + Webhooks
        + Keys
        + Audit
        + Operations
        + 'static
{
}

/// The database as a whole: its migrations and its tables' sizes.
pub trait Operations: Send + Sync {
    /// Migrations this build embeds that the database has not applied (empty: ready).
    /// Fails when the database cannot be reached.
    fn pending_migrations(&self) -> StoreFuture<'_, Vec<i64>>;

    fn row_counts(&self) -> StoreFuture<'_, RowCounts>;
}

/// How a store connects: the size of its connection pool and how long a statement
/// waits for a connection before the database counts as unavailable
/// ([`crate::StoreError::Unavailable`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StoreOptions {
    /// Connections of this process (`None`: [`StoreOptions::DEFAULT_PG_POOL`] on
    /// PostgreSQL, [`StoreOptions::DEFAULT_SQLITE_POOL`] on SQLite; an in-memory SQLite
    /// database has one). Sizing rule (docs/operations.md, "Operations"): the sum over every
    /// process sharing a PostgreSQL server stays below its `max_connections` less the
    /// connections reserved for administration.
    pub pool_size: Option<u32>,
    /// Longest wait for a connection, including connecting: past it the operation fails
    /// as unavailable (the service answers 503 at once instead of hanging).
    pub acquire_timeout: std::time::Duration,
}

impl StoreOptions {
    pub const DEFAULT_PG_POOL: u32 = 10;
    pub const DEFAULT_SQLITE_POOL: u32 = 8;
    /// Most connections a process may ask for.
    pub const MAX_POOL: u32 = 500;
}

impl Default for StoreOptions {
    fn default() -> Self {
        StoreOptions {
            pool_size: None,
            acquire_timeout: std::time::Duration::from_secs(3),
        }
    }
}

/// Opens the store a URL names, migrating it when needed: `postgres://…` or
/// `postgresql://…` (PostgreSQL), else SQLite (`sqlite://PATH`, `sqlite::memory:` or a
/// plain file path, created when missing).
pub async fn open(url: &str) -> Result<Arc<dyn Store>> {
    open_with(url, StoreOptions::default()).await
}

/// [`open`] with a pool of the given size and wait ([`StoreOptions`]).
pub async fn open_with(url: &str, o: StoreOptions) -> Result<Arc<dyn Store>> {
    if url.starts_with("postgres://") || url.starts_with("postgresql://") {
        return Ok(Arc::new(PostgresStore::open_with(url, o).await?));
    }
    Ok(Arc::new(SqliteStore::open_with(url, o).await?))
}

/// Row counts of every table (for tests and the admin view).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct RowCounts {
    pub machines: i64,
    pub datasets: i64,
    pub dataset_files: i64,
    pub jobs: i64,
    pub results: i64,
    pub result_figures: i64,
    pub api_keys: i64,
}
