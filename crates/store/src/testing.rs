//! Helpers for tests that run against PostgreSQL (this crate's and the service's): the
//! server is named by `MTCAL_TEST_PG` (`postgres://user@host:port/database`); each test
//! gets a schema of its own, so tests run in parallel on one server and start empty.

use crate::error::{Db as _, Result};
use sqlx::Connection;

/// The skew of this process's [`crate::now_ms`] (tests only: a host whose clock is wrong).
pub(crate) static HOST_CLOCK_SKEW_MS: std::sync::atomic::AtomicI64 =
    std::sync::atomic::AtomicI64::new(0);

/// Makes this process's clock ([`crate::now_ms`]) run `ms` ahead (behind when negative):
/// for a test binary of its own that plays a host with a wrong clock.
pub fn skew_host_clock(ms: i64) {
    HOST_CLOCK_SKEW_MS.store(ms, std::sync::atomic::Ordering::Relaxed);
}

/// The variable naming the PostgreSQL server of the tests.
pub const TEST_PG_VAR: &str = "MTCAL_TEST_PG";

/// A schema of its own on the test server, with the URL that opens a store in it.
#[derive(Debug, Clone)]
pub struct ScratchPg {
    /// The server's URL with `search_path` set to the schema.
    pub url: String,
    /// The server's URL as given.
    pub server: String,
    pub schema: String,
}

impl ScratchPg {
    /// A new empty schema on the server `MTCAL_TEST_PG` names; `None` (and a line on
    /// stderr saying so) when the variable is not set, so tests skip visibly.
    pub async fn create(test: &str) -> Result<Option<ScratchPg>> {
        let Some(server) = std::env::var(TEST_PG_VAR).ok().filter(|s| !s.is_empty()) else {
            // In CI (.ci/run sets MTCAL_CI) the PostgreSQL half must run, never skip.
            assert!(
                std::env::var_os("MTCAL_CI").is_none(),
                "{test}: {TEST_PG_VAR} is not set under MTCAL_CI (scripts/with-postgres starts a server)"
            );
            eprintln!("{test}: PostgreSQL part skipped ({TEST_PG_VAR} is not set)");
            return Ok(None);
        };
        let schema = crate::rules::new_id("t");
        let mut c = sqlx::PgConnection::connect(&server).await.db()?;
        sqlx::query(sqlx::AssertSqlSafe(format!("CREATE SCHEMA {schema}")))
            .execute(&mut c)
            .await
            .db()?;
        c.close().await.db()?;
        let sep = if server.contains('?') { '&' } else { '?' };
        Ok(Some(ScratchPg {
            url: format!("{server}{sep}options=-c%20search_path%3D{schema}"),
            server,
            schema,
        }))
    }

    /// Drops the schema and everything in it.
    pub async fn drop_schema(&self) -> Result<()> {
        let mut c = sqlx::PgConnection::connect(&self.server).await.db()?;
        sqlx::query(sqlx::AssertSqlSafe(format!(
            "DROP SCHEMA {} CASCADE",
            self.schema
        )))
        .execute(&mut c)
        .await
        .db()?;
        c.close().await.db()
    }
}
