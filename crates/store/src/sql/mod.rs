//! The store's statements and their binding, written once and compiled once per backend:
//! each backend module (`sqlite/`, `postgres/`) mounts this directory as its `sql`
//! submodule and provides `Driver` (the sqlx database: `sqlx::Sqlite`, `sqlx::Postgres`),
//! `Backend` (its store type, with a `pool` field: [`crate::SqliteStore`],
//! [`crate::PostgresStore`]) and `dialect` (the few statements whose SQL differs).
//! Placeholders are `$N`, which SQLite and PostgreSQL both read; everything else is SQL
//! both dialects share.
//!
//! This module holds the connection setup, the statement macros and the helpers every
//! resource uses; each resource's statements are in the file of its name, implementing
//! the trait of that name (`machines.rs`: [`crate::Machines`], …). Rules live in
//! [`crate::rules`] and [`crate::queue`], row decoding in `crate::rows`.

use super::{Backend, Driver, dialect};
use crate::error::{Db as _, Result, StoreError};
use crate::model::RowCounts;
use crate::rows;
use crate::{Operations, StoreFuture};
use sqlx::{Executor, Transaction};

/// A pool of at most `size` connections made with `opts` (waiting at most the options'
/// acquire timeout for one), the dialect's migrations applied: the end of every backend's
/// `open_with`.
pub(super) async fn connect(
    opts: <<Driver as sqlx::Database>::Connection as sqlx::Connection>::Options,
    size: u32,
    o: &crate::StoreOptions,
) -> Result<sqlx::Pool<Driver>> {
    let pool = sqlx::pool::PoolOptions::<Driver>::new()
        .max_connections(size)
        .acquire_timeout(o.acquire_timeout)
        .connect_with(opts)
        .await
        .db()?;
    crate::migrations::migrator(dialect::MIGRATIONS)
        .await?
        .run(&pool)
        .await
        .db()?;
    Ok(pool)
}

/// `sqlx::query(sql)` with its arguments bound in order, to `$1`, `$2`, ...
macro_rules! bound {
    ($sql:expr $(, $arg:expr)* $(,)?) => {
        sqlx::query($sql)$(.bind($arg))*
    };
}

/// `sqlx::query_scalar(sql)` with its arguments bound in order, to `$1`, `$2`, ...
macro_rules! bound_scalar {
    ($sql:expr $(, $arg:expr)* $(,)?) => {
        sqlx::query_scalar($sql)$(.bind($arg))*
    };
}

/// `bound!(sql, args...)` run on the executor `ex` with sqlx's `method` (`execute`,
/// `fetch_one`, `fetch_optional`, `fetch_all`), its error the store's.
macro_rules! run {
    ($method:ident($ex:expr), $sql:expr $(, $arg:expr)* $(,)?) => {
        bound!($sql $(, $arg)*).$method($ex).await.db()
    };
}

/// `bound_scalar!(sql, args...)` run as [`run!`] runs `bound!`.
macro_rules! run_scalar {
    ($method:ident($ex:expr), $sql:expr $(, $arg:expr)* $(,)?) => {
        bound_scalar!($sql $(, $arg)*).$method($ex).await.db()
    };
}

mod audit;
mod datasets;
mod fleet;
mod jobs;
mod keys;
mod machines;
mod results;
mod tolerances;
mod webhooks;

impl Backend {
    /// A transaction whose reads are one snapshot ([`dialect::BEGIN_SNAPSHOT`]).
    async fn read_snapshot(&self) -> Result<Transaction<'static, Driver>> {
        if dialect::BEGIN_SNAPSHOT.is_empty() {
            self.pool.begin().await.db()
        } else {
            self.pool.begin_with(dialect::BEGIN_SNAPSHOT).await.db()
        }
    }
}

/// The row `sql` selects with `$1` = `id`, or not found (`what id`). An id with a NUL
/// character names nothing (no stored text holds one; PostgreSQL would refuse the value),
/// so both backends answer it as not found without asking.
async fn row_by_id<'e>(
    ex: impl Executor<'e, Database = Driver>,
    sql: String,
    id: &str,
    what: &str,
) -> Result<<Driver as sqlx::Database>::Row> {
    if id.contains('\0') {
        return Err(StoreError::NotFound(format!(
            "{what} {}",
            id.escape_debug()
        )));
    }
    run!(fetch_optional(ex), sqlx::AssertSqlSafe(sql), id)?
        .ok_or_else(|| StoreError::NotFound(format!("{what} {id}")))
}

/// `columns` (comma-separated) each prefixed with table alias `alias`.
fn qualified(alias: &str, columns: &str) -> String {
    columns
        .split(',')
        .map(|c| format!("{alias}.{}", c.trim()))
        .collect::<Vec<_>>()
        .join(", ")
}

impl Operations for Backend {
    fn pending_migrations(&self) -> StoreFuture<'_, Vec<i64>> {
        Box::pin(async move {
            let applied: Vec<i64> =
                sqlx::query_scalar("SELECT version FROM _sqlx_migrations WHERE success")
                    .fetch_all(&self.pool)
                    .await
                    .db()?;
            Ok(dialect::MIGRATIONS
                .iter()
                .map(|&(version, _, _)| version)
                .filter(|v| !applied.contains(v))
                .collect())
        })
    }

    fn row_counts(&self) -> StoreFuture<'_, RowCounts> {
        Box::pin(async move {
            let r = sqlx::query(rows::ROW_COUNTS)
                .fetch_one(&self.pool)
                .await
                .db()?;
            rows::row_counts(&r)
        })
    }
}
