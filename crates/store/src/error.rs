//! [`StoreError`]: why a store operation failed, in terms that do not depend on the
//! backend (no database-driver type appears in the store's public API).

/// Why a store operation failed.
#[derive(Debug, thiserror::Error)]
pub enum StoreError {
    /// The named record does not exist.
    #[error("{0} not found")]
    NotFound(String),
    /// The operation contradicts stored state (duplicate id, job already finished, …).
    #[error("{0}")]
    Conflict(String),
    /// A record breaks a rule of the store (e.g. a non-finite figure); nothing stored.
    #[error("invalid record: {0}")]
    Invalid(String),
    /// The worker's lease on a job was taken over (it was reaped) or the job was cancelled.
    #[error("lease on job {0} lost")]
    LeaseLost(String),
    /// The database URL names a backend this build does not have.
    /// (The URL is held as [`crate::redacted`] gives it: no password.)
    #[error("unsupported database URL {0:?} (use postgres://…, sqlite://PATH or a file path)")]
    UnsupportedUrl(String),
    /// The database cannot be reached now (connection refused or lost, pool exhausted or
    /// closed): worth retrying later.
    #[error("database unavailable: {0}")]
    Unavailable(String),
    /// The database failed the operation, its migrations failed, or a stored value does
    /// not read back.
    #[error("database: {0}")]
    Backend(String),
}

pub type Result<T, E = StoreError> = std::result::Result<T, E>;

/// Maps a driver error to a [`StoreError`] (crate-private, so that the driver stays out
/// of the public API).
pub(crate) fn db_error(e: sqlx::Error) -> StoreError {
    match e {
        sqlx::Error::PoolTimedOut
        | sqlx::Error::PoolClosed
        | sqlx::Error::WorkerCrashed
        | sqlx::Error::Io(_)
        | sqlx::Error::Tls(_) => StoreError::Unavailable(e.to_string()),
        // PostgreSQL's connection exceptions (class 08) and a server shutting down or
        // starting (57P01–57P03): the database is away, not the statement wrong.
        sqlx::Error::Database(ref d)
            if d.code()
                .is_some_and(|c| c.starts_with("08") || c.starts_with("57P")) =>
        {
            StoreError::Unavailable(e.to_string())
        }
        sqlx::Error::RowNotFound => StoreError::NotFound("row".into()),
        e => StoreError::Backend(e.to_string()),
    }
}

/// Maps a unique-constraint violation to a conflict naming `what`, a foreign-key
/// violation to a missing referenced record, anything else as [`db_error`].
pub(crate) fn unique_conflict(e: sqlx::Error, what: impl FnOnce() -> String) -> StoreError {
    match &e {
        sqlx::Error::Database(d) if d.is_unique_violation() => StoreError::Conflict(what()),
        sqlx::Error::Database(d) if d.is_foreign_key_violation() => {
            StoreError::NotFound(format!("a record referenced by {}", what()))
        }
        _ => db_error(e),
    }
}

/// `?`-friendly conversion of driver, migration and JSON results (crate-private).
pub(crate) trait Db<T> {
    fn db(self) -> Result<T>;
}

impl<T> Db<T> for std::result::Result<T, sqlx::Error> {
    fn db(self) -> Result<T> {
        self.map_err(db_error)
    }
}

impl<T> Db<T> for std::result::Result<T, sqlx::migrate::MigrateError> {
    fn db(self) -> Result<T> {
        self.map_err(|e| StoreError::Backend(format!("migration: {e}")))
    }
}

impl<T> Db<T> for std::result::Result<T, serde_json::Error> {
    fn db(self) -> Result<T> {
        self.map_err(|e| StoreError::Backend(format!("stored JSON: {e}")))
    }
}
