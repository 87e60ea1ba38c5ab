//! The SQLite backend (the embedded default; single host): WAL mode, runtime-checked
//! queries, migrations in `migrations/sqlite` embedded at build time. The statements are
//! the shared ones of `sql/`; only the connection and the dialect live here.
//!
//! SQLite serialises writers, so the claim's `UPDATE … WHERE id = (SELECT …)` is
//! exclusive as it stands.

use crate::error::{Db as _, Result, StoreError};
use sqlx::sqlite::{SqliteConnectOptions, SqliteJournalMode, SqliteSynchronous};
use std::str::FromStr;
use std::time::Duration;

/// The sqlx database the shared statements (`sql/`) run on.
type Driver = sqlx::Sqlite;
/// The store type the shared statements implement the store traits for.
type Backend = SqliteStore;

/// The statements whose SQL differs from PostgreSQL's.
mod dialect {
    /// The migrations of `migrations/sqlite`, embedded at build time.
    pub const MIGRATIONS: crate::migrations::Embedded = crate::migrations::SQLITE;
    /// The next submission number of `jobs.seq` (writers are serialised, so no race).
    pub const NEXT_SEQ: &str = "(SELECT COALESCE(MAX(seq), 0) + 1 FROM jobs)";
    /// Row locking of the claim's sub-select: none needed.
    pub const CLAIM_LOCK: &str = "";
    /// How a transaction whose reads are one snapshot begins: as any (in WAL mode a
    /// transaction reads one snapshot from its first read on).
    pub const BEGIN_SNAPSHOT: &str = "";
    /// The database's clock, milliseconds since the Unix epoch (SQLite's `now` has
    /// millisecond resolution).
    pub const NOW_MS: &str = "CAST(ROUND((julianday('now') - 2440587.5) * 86400000.0) AS INTEGER)";
    /// Taken before a key is revoked: nothing (writers are serialised).
    pub const LOCK_KEYS: &str = "";
    /// Run after a dataset's bytes were deleted: copies the write-ahead log into the
    /// database file and empties it, so that (with `secure_delete`, which zeroes freed
    /// content) the deleted bytes leave the disk at once, not at the next checkpoint.
    pub const AFTER_BYTES_DELETED: &str = "PRAGMA wal_checkpoint(TRUNCATE)";
    /// The table `table` (with its alias) read through `index`: the fleet page walks an
    /// index in order (without statistics the planner may drive the walk from the
    /// machines and sort every one).
    pub fn walk(table: &str, index: &str) -> String {
        format!("{table} INDEXED BY {index}")
    }
}

/// The shared statements, compiled for SQLite.
#[allow(clippy::duplicate_mod)] // compiled once per backend on purpose
#[path = "../sql/mod.rs"]
mod sql;

/// SQLite store. Cheap to clone (a pool handle).
#[derive(Clone)]
pub struct SqliteStore {
    pool: sqlx::SqlitePool,
}

impl SqliteStore {
    /// Opens (creating if needed) and migrates the database at `url` (`sqlite://PATH`,
    /// `sqlite::memory:` or a plain file path).
    pub async fn open(url: &str) -> Result<SqliteStore> {
        Self::open_with(url, crate::StoreOptions::default()).await
    }

    /// [`SqliteStore::open`] with a pool of the given size and wait.
    pub async fn open_with(url: &str, o: crate::StoreOptions) -> Result<SqliteStore> {
        let opts = if url.starts_with("sqlite:") {
            SqliteConnectOptions::from_str(url).db()?
        } else if url.contains("://") {
            return Err(StoreError::UnsupportedUrl(crate::redacted(url)));
        } else {
            SqliteConnectOptions::new().filename(url)
        };
        let opts = opts
            .create_if_missing(true)
            .journal_mode(SqliteJournalMode::Wal)
            .synchronous(SqliteSynchronous::Normal)
            .foreign_keys(true)
            // Freed content is overwritten with zeros: deleted dataset bytes do not stay
            // readable in free pages.
            .pragma("secure_delete", "ON")
            .busy_timeout(Duration::from_secs(10));
        let memory = url.contains(":memory:");
        let size = o
            .pool_size
            .unwrap_or(crate::StoreOptions::DEFAULT_SQLITE_POOL)
            .clamp(1, crate::StoreOptions::MAX_POOL);
        let pool = sql::connect(opts, if memory { 1 } else { size }, &o).await?;
        Ok(SqliteStore { pool })
    }
}
