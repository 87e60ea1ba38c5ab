//! A database outage fails fast: what the process knows of its database's reachability,
//! and the middleware that answers 503 at once while the database is away.
//!
//! A store operation that cannot reach the database (connection refused or lost, no
//! connection within the pool's wait, `mtcal serve --db-timeout-ms`) fails as
//! [`mtcal_store::StoreError::Unavailable`], which every route answers as 503
//! `unavailable` with `Retry-After: 5` ([`RETRY_AFTER`]). The first such answer marks
//! the database down ([`Database`]); from then on every request that needs the database
//! is answered 503 at once, without waiting for a connection, except that one request
//! per [`PROBE_INTERVAL`] first probes the database (one cheap statement): when it
//! answers, the database is up again and requests pass. `/ready` says `database: down`
//! (503) and `/metrics` has `mtcal_database_up` 0 meanwhile (and
//! `mtcal_database_unavailable_total` counts the refused requests).

use crate::error::ApiError;
use axum::extract::{Request, State};
use axum::middleware::Next;
use axum::response::{IntoResponse, Response};
use std::sync::atomic::{AtomicBool, AtomicI64, Ordering};
use std::time::Duration;

pub use crate::error::{RETRY_AFTER, Unreachable};
/// While the database is down, one request per this interval probes it.
pub const PROBE_INTERVAL: Duration = Duration::from_secs(1);

/// The reachability of the process's database.
#[derive(Debug, Default)]
pub struct Database {
    down: AtomicBool,
    /// When the database was last tried while down (ms since the Unix epoch).
    last_probe_ms: AtomicI64,
}

impl Database {
    pub fn is_up(&self) -> bool {
        !self.down.load(Ordering::Relaxed)
    }

    /// Records that the database could not be reached.
    pub fn mark_down(&self) {
        self.last_probe_ms
            .store(mtcal_store::now_ms(), Ordering::Relaxed);
        if !self.down.swap(true, Ordering::Relaxed) {
            tracing::warn!("the database cannot be reached: answering 503 until it can");
        }
        crate::metrics::metrics().set_database_up(false);
    }

    /// Records that the database answered.
    pub fn mark_up(&self) {
        if self.down.swap(false, Ordering::Relaxed) {
            tracing::info!("the database answers again");
        }
        crate::metrics::metrics().set_database_up(true);
    }

    /// While down: whether this request should probe the database (at most one per
    /// [`PROBE_INTERVAL`]; the others are refused at once).
    fn claim_probe(&self) -> bool {
        let now = mtcal_store::now_ms();
        let last = self.last_probe_ms.load(Ordering::Relaxed);
        now - last >= PROBE_INTERVAL.as_millis() as i64
            && self
                .last_probe_ms
                .compare_exchange(last, now, Ordering::Relaxed, Ordering::Relaxed)
                .is_ok()
    }
}

/// Probes the database with one cheap statement; records the outcome.
pub async fn probe(s: &crate::AppState) -> Result<Vec<i64>, mtcal_store::StoreError> {
    let r = s.store.pending_migrations().await;
    match &r {
        Ok(_) => s.database.mark_up(),
        Err(mtcal_store::StoreError::Unavailable(_)) => s.database.mark_down(),
        Err(_) => {}
    }
    r
}

/// Middleware of every route that reads the database (the API and the dashboard, not
/// the probes): see the module documentation.
pub async fn guard(State(s): State<crate::AppState>, req: Request, next: Next) -> Response {
    if !s.database.is_up() {
        let ready = s.database.claim_probe() && probe(&s).await.is_ok();
        if !ready {
            crate::metrics::metrics().database_unavailable();
            return ApiError::Unavailable("the database cannot be reached".into()).into_response();
        }
    }
    let resp = next.run(req).await;
    if resp.extensions().get::<Unreachable>().is_some() {
        s.database.mark_down();
        crate::metrics::metrics().database_unavailable();
    }
    resp
}
