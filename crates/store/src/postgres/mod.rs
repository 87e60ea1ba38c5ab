//! The PostgreSQL backend: any number of API and worker processes on any number of hosts
//! share one database. Runtime-checked queries (no database needed to build), migrations
//! in `migrations/postgres` embedded at build time and applied under the migrator's
//! advisory lock (processes starting together migrate once). The statements are the
//! shared ones of `sql/`; only the connection and the dialect live here.
//!
//! Raw dataset files are kept in `dataset_files.content` (`BYTEA`) with the upload limits
//! of the API, as on SQLite. A fleet whose raw files outgrow the database would move
//! `content` to an object store keyed by the file's SHA-256 (the column becoming the key);
//! that path is described in the README, not built.

use crate::error::{Db as _, Result};
use sqlx::postgres::PgConnectOptions;
use std::str::FromStr;

/// The sqlx database the shared statements (`sql/`) run on.
type Driver = sqlx::Postgres;
/// The store type the shared statements implement the store traits for.
type Backend = PostgresStore;

/// The statements whose SQL differs from SQLite's.
mod dialect {
    /// The migrations of `migrations/postgres`, embedded at build time.
    pub const MIGRATIONS: crate::migrations::Embedded = crate::migrations::POSTGRES;
    /// The next submission number: the identity column's sequence.
    pub const NEXT_SEQ: &str = "DEFAULT";
    /// Row locking of the claim's sub-select: concurrent claimers skip a row another
    /// claimer holds instead of waiting for it, so each claims a different job.
    pub const CLAIM_LOCK: &str = "FOR UPDATE SKIP LOCKED";
    /// How a transaction whose reads are one snapshot begins (READ COMMITTED, the
    /// default, takes a new snapshot per statement).
    pub const BEGIN_SNAPSHOT: &str = "BEGIN ISOLATION LEVEL REPEATABLE READ, READ ONLY";
    /// The database's clock, milliseconds since the Unix epoch (the time of the statement,
    /// not of its transaction's start).
    pub const NOW_MS: &str = "CAST(EXTRACT(EPOCH FROM clock_timestamp()) * 1000 AS BIGINT)";
    /// Taken before a key is revoked, so that two revocations of the last two admin keys
    /// cannot both see the other still active.
    pub const LOCK_KEYS: &str = "LOCK TABLE api_keys IN SHARE ROW EXCLUSIVE MODE";
    /// Run after a dataset's bytes were deleted: nothing; the old row versions are
    /// removed by (auto)vacuum, as for every update.
    pub const AFTER_BYTES_DELETED: &str = "";
    /// The table `table` (with its alias) for a walk of `index`: as the planner chooses
    /// (it walks the index for an `ORDER BY … LIMIT` the index holds in order).
    pub fn walk(table: &str, _index: &str) -> String {
        table.to_string()
    }
}

/// The shared statements, compiled for PostgreSQL.
#[allow(clippy::duplicate_mod)] // compiled once per backend on purpose
#[path = "../sql/mod.rs"]
mod sql;

/// PostgreSQL store. Cheap to clone (a pool handle).
#[derive(Clone)]
pub struct PostgresStore {
    pool: sqlx::PgPool,
}

impl PostgresStore {
    /// Connects to `url` (`postgres://user:password@host:port/database`, with the usual
    /// parameters: `sslmode`, `options=-c search_path=…`, …) and applies the migrations.
    pub async fn open(url: &str) -> Result<PostgresStore> {
        Self::open_with(url, crate::StoreOptions::default()).await
    }

    /// [`PostgresStore::open`] with a pool of the given size and wait ([`crate::StoreOptions`]:
    /// by default [`crate::StoreOptions::DEFAULT_PG_POOL`] connections, a server's
    /// `max_connections` (100 by default) bounds processes × this).
    pub async fn open_with(url: &str, o: crate::StoreOptions) -> Result<PostgresStore> {
        let opts = PgConnectOptions::from_str(url).db()?;
        let size = o
            .pool_size
            .unwrap_or(crate::StoreOptions::DEFAULT_PG_POOL)
            .clamp(1, crate::StoreOptions::MAX_POOL);
        let pool = sql::connect(opts, size, &o).await?;
        Ok(PostgresStore { pool })
    }
}
