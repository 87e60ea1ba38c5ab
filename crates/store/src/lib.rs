//! # mtcal-store
//!
//! Persistence of the mtcal service behind one interface, [`Store`], so that handlers and
//! the worker never see a database: machines, datasets (raw files with checksums),
//! jobs (the durable queue, [`Queue`]), results (document + scalar columns for trend
//! queries) and API keys.
//!
//! Layout: the records ([`model`]), the queue's typed kinds and rules ([`queue`]), key
//! generation and hashing ([`keys`]) and the other backend-independent rules
//! ([`rules`]: manifest checksums, machine patches and baselines, result rows) are
//! shared; a backend module holds only SQL and its migrations
//! (`migrations/<backend>/`). Errors are [`StoreError`], which names no driver type.
//!
//! [`SqliteStore`] is the embedded default, for one process on one host (WAL mode);
//! [`PgStore`] is for several API and worker processes on several hosts sharing one
//! PostgreSQL database. Both use runtime-checked `sqlx::query` and migrations embedded
//! at build time; [`open`] picks the backend from the URL.

use std::future::Future;
use std::pin::Pin;

mod error;
pub mod keys;
pub mod limits;
mod migrations;
pub mod model;
mod postgres;
pub mod queue;
mod rows;
pub mod rules;
#[cfg(feature = "openapi")]
pub mod schemas;
mod sqlite;
pub mod testing;
pub mod text;

pub use error::{Result, StoreError};
pub use keys::{ApiKey, Scope};
pub use model::*;
pub use postgres::PgStore;
pub use queue::{Failure, Heartbeat, JobCount, Lease, Progress, Queue, QueueConfig};
pub use sqlite::SqliteStore;

/// The future every [`Store`] method returns (boxed so that `dyn Store` works).
pub type StoreFuture<'a, T> = Pin<Box<dyn Future<Output = Result<T>> + Send + 'a>>;

/// Everything the service keeps: the [`Queue`] and the records around it.
/// Implementations must make each method atomic.
pub trait Store: Queue {
    // Machines.
    fn create_machine<'a>(&'a self, m: &'a Machine) -> StoreFuture<'a, Machine>;
    fn get_machine<'a>(&'a self, id: &'a str) -> StoreFuture<'a, Machine>;
    /// Applies a patch ([`rules::apply_patch`]: a baseline must be one of the machine's
    /// results).
    fn update_machine<'a>(&'a self, id: &'a str, p: &'a MachinePatch) -> StoreFuture<'a, Machine>;
    /// Machines ordered by id, after `after` (keyset pagination).
    fn list_machines<'a>(
        &'a self,
        after: Option<&'a str>,
        limit: i64,
    ) -> StoreFuture<'a, Vec<Machine>>;

    // Datasets.
    /// Stores a dataset and all its files in one transaction; an upload identical to one
    /// of the machine's datasets that is not excluded (same manifest checksum) is a
    /// [`StoreError::Conflict`] naming the earlier dataset (uploading an excluded
    /// dataset's files again stores a new dataset).
    fn insert_dataset<'a>(&'a self, d: NewDataset) -> StoreFuture<'a, Dataset>;
    fn get_dataset<'a>(&'a self, id: &'a str) -> StoreFuture<'a, Dataset>;
    /// The bytes of one file, as uploaded.
    fn dataset_file<'a>(&'a self, id: &'a str, name: &'a str) -> StoreFuture<'a, Vec<u8>>;
    /// Every file of a dataset, as uploaded.
    fn dataset_files<'a>(&'a self, id: &'a str) -> StoreFuture<'a, Vec<(String, Vec<u8>)>>;
    /// A machine's datasets in time order (measured_at, uploaded_at, id); excluded ones (deleted
    /// ones included) only when `include_excluded`.
    fn list_datasets<'a>(
        &'a self,
        machine_id: &'a str,
        include_excluded: bool,
    ) -> StoreFuture<'a, Vec<Dataset>>;
    /// Excludes a dataset (recorded with who, when and why): no new job runs on it and
    /// every result computed from it is excluded with the same record, in one
    /// transaction (results excluded before keep their own record). A result that lands
    /// later from it is excluded as it lands. Excluding an excluded dataset keeps the
    /// first record. A job on it that is queued or running: [`StoreError::Conflict`]
    /// naming the job (nothing changed).
    fn exclude_dataset<'a>(&'a self, id: &'a str, why: SetAside<'a>) -> StoreFuture<'a, Dataset>;
    /// Deletes a dataset's raw bytes: the files' content is emptied, the dataset row and
    /// its files' names, sizes and checksums stay as a tombstone recorded with who, when
    /// and why. The dataset (its results with it) is excluded first with the same record
    /// when it was not. Deleting a deleted dataset keeps the first record. A job on it
    /// that is queued or running: [`StoreError::Conflict`] naming the job.
    fn delete_dataset_files<'a>(
        &'a self,
        id: &'a str,
        why: SetAside<'a>,
    ) -> StoreFuture<'a, Dataset>;

    // Results.
    fn get_result<'a>(&'a self, id: &'a str) -> StoreFuture<'a, StoredResult>;
    /// A machine's results of `kind` in time order (measured_at, then when each landed,
    /// then id: of two checks measured at the same time the later to land is the later).
    /// A stored row that does not decode (written by an older version, a null where a
    /// number belongs) is left out; [`Store::list_results_checked`] says which.
    fn list_results<'a>(
        &'a self,
        machine_id: &'a str,
        kind: &'a str,
    ) -> StoreFuture<'a, Vec<ResultMeta>>;
    /// [`Store::list_results`] with the rows left out because they do not decode.
    fn list_results_checked<'a>(
        &'a self,
        machine_id: &'a str,
        kind: &'a str,
    ) -> StoreFuture<'a, (Vec<ResultMeta>, Vec<SkippedRow>)>;
    /// For every machine with results of `kind`: baseline, latest and count.
    fn baseline_pairs<'a>(&'a self, kind: &'a str) -> StoreFuture<'a, Vec<BaselinePair>>;
    /// The named figures of a result ([`Figure`]), by name.
    fn result_figures<'a>(&'a self, result_id: &'a str) -> StoreFuture<'a, Vec<Figure>>;
    /// One figure of a machine's results in time order (measured_at, when it landed, id),
    /// whatever the result kind (ISO 230-2 figures come from `identification` and
    /// `standards` results alike).
    fn figure_trend<'a>(
        &'a self,
        machine_id: &'a str,
        name: &'a str,
    ) -> StoreFuture<'a, Vec<FigurePoint>>;
    /// The names of every figure stored for a machine, sorted.
    fn figure_names<'a>(&'a self, machine_id: &'a str) -> StoreFuture<'a, Vec<String>>;

    /// Excludes a result from the history (kept, readable by id, recorded with who, when
    /// and why; left out of lists, trends and drift). Excluding an excluded result keeps
    /// the first record.
    fn exclude_result<'a>(&'a self, id: &'a str, why: SetAside<'a>) -> StoreFuture<'a, ResultMeta>;

    // The fleet's drift, maintained by the service.
    /// Stores a machine's drift unless the stored row was computed from a later read
    /// (`read_at_ms`); returns whether it was stored.
    fn put_fleet_drift<'a>(&'a self, row: &'a FleetDriftRow) -> StoreFuture<'a, bool>;
    /// Stores many machines' rows in one transaction, each as [`Store::put_fleet_drift`];
    /// returns how many were stored.
    fn put_fleet_drifts<'a>(&'a self, rows: &'a [FleetDriftRow]) -> StoreFuture<'a, usize>;
    /// Every stored row's machine and basis ([`FleetDriftRow::basis`]).
    fn fleet_drift_bases(&self) -> StoreFuture<'_, Vec<(String, Option<String>)>>;
    /// Removes a machine's drift (it has no result of the kind any more).
    fn delete_fleet_drift<'a>(&'a self, machine_id: &'a str) -> StoreFuture<'a, ()>;
    /// The machines' drift, largest first by `drift_um` (`by_um`) or `drift_urad`, at
    /// most `limit`, with each machine's current name and site.
    fn fleet_drift_ranked(
        &self,
        by_um: bool,
        limit: usize,
    ) -> StoreFuture<'_, Vec<(FleetDriftRow, String, Option<String>)>>;
    /// One page of the fleet ([`FleetPageQuery`]): machines with their drift rows and
    /// active alert counts, filtered, sorted and counted by the database.
    fn fleet_page<'a>(&'a self, q: &'a FleetPageQuery) -> StoreFuture<'a, FleetPage>;
    /// Inserts a result without a job run (an `import` job, born succeeded).
    fn import_result<'a>(&'a self, r: NewResult) -> StoreFuture<'a, ResultMeta>;
    /// Inserts many results (each with its `import` job) in one transaction: for seeding
    /// benchmarks and bulk imports.
    fn import_results_bulk<'a>(&'a self, results: &'a [NewResult]) -> StoreFuture<'a, ()>;

    /// Jobs newest first (created_at, then seq), of one state or all, at most `limit`.
    fn list_jobs<'a>(&'a self, state: Option<JobState>, limit: i64) -> StoreFuture<'a, Vec<Job>>;

    // Tolerance profiles.
    /// Stores a new profile; one per (scope, target): a second is a
    /// [`StoreError::Conflict`] naming the first.
    fn create_tolerance<'a>(&'a self, p: &'a ToleranceProfile)
    -> StoreFuture<'a, ToleranceProfile>;
    fn get_tolerance<'a>(&'a self, id: &'a str) -> StoreFuture<'a, ToleranceProfile>;
    /// Every profile, by scope then target (profiles are few: one per machine or tag at
    /// most).
    fn list_tolerances(&self) -> StoreFuture<'_, Vec<ToleranceProfile>>;
    /// Replaces the limits and the webhook (its URL and the key of its signatures) of the
    /// stored profile `p.id` with `p`'s; its scope, target and creation stay as stored.
    fn update_tolerance<'a>(&'a self, p: &'a ToleranceProfile)
    -> StoreFuture<'a, ToleranceProfile>;
    fn delete_tolerance<'a>(&'a self, id: &'a str) -> StoreFuture<'a, ()>;

    // Drift alerts.
    /// Stores an alert unless its result already raised one, with its webhook
    /// deliveries (`pending`, due now by the database's clock) in the same transaction;
    /// returns the stored alert (`None`: the result had one, e.g. a job run twice, and
    /// nothing is written).
    fn raise_alert<'a>(
        &'a self,
        a: &'a Alert,
        deliveries: &'a [WebhookDelivery],
    ) -> StoreFuture<'a, Option<Alert>>;

    // The webhook outbox.
    /// Claims the oldest due `pending` delivery for one try: its attempts counted and its
    /// next try moved `lease_ms` ahead (database clock), so that a try whose worker dies
    /// is made again then; `None` when none is due.
    fn claim_delivery(&self, lease_ms: i64) -> StoreFuture<'_, Option<WebhookDelivery>>;
    /// Records the outcome of the try claimed as attempt `attempt` (a stale claim,
    /// whose delivery was claimed again since, changes nothing).
    fn finish_delivery<'a>(
        &'a self,
        id: &'a str,
        attempt: i64,
        outcome: &'a DeliveryOutcome,
    ) -> StoreFuture<'a, ()>;
    /// Deliveries newest first, of one alert or all, of one state or all, at most
    /// `limit`.
    fn list_deliveries<'a>(
        &'a self,
        alert_id: Option<&'a str>,
        state: Option<&'a str>,
        limit: i64,
    ) -> StoreFuture<'a, Vec<WebhookDelivery>>;
    fn get_alert<'a>(&'a self, id: &'a str) -> StoreFuture<'a, Alert>;
    /// Alerts newest first, of one machine or all, active only (`Some(true)`),
    /// acknowledged only (`Some(false)`) or both, at most `limit`.
    fn list_alerts<'a>(
        &'a self,
        machine_id: Option<&'a str>,
        active: Option<bool>,
        limit: i64,
    ) -> StoreFuture<'a, Vec<Alert>>;
    /// Acknowledges an alert (recorded with `by`, the time and the comment given);
    /// acknowledging an acknowledged alert keeps the first record.
    fn acknowledge_alert<'a>(
        &'a self,
        id: &'a str,
        by: &'a str,
        comment: Option<&'a str>,
    ) -> StoreFuture<'a, Alert>;

    // Keys.
    /// Creates a key; returns it with the secret, which is not stored.
    fn create_key<'a>(&'a self, scope: Scope, label: &'a str) -> StoreFuture<'a, (ApiKey, String)>;
    fn key_by_secret<'a>(&'a self, secret: &'a str) -> StoreFuture<'a, Option<ApiKey>>;
    /// Every key, revoked ones included, oldest first (never a secret or a hash).
    fn list_keys(&self) -> StoreFuture<'_, Vec<ApiKey>>;
    /// Revokes key `id` (from now on it authenticates nothing, and its sign-in sessions
    /// end); revoking a revoked key keeps its first revocation time. Not found:
    /// [`StoreError::NotFound`]; the last admin key that is not revoked:
    /// [`StoreError::Conflict`] (nothing changed).
    fn revoke_key<'a>(&'a self, id: &'a str) -> StoreFuture<'a, ApiKey>;

    // Sign-in sessions (the dashboard's), kept by the database.
    /// Starts a session of key `key_id` ending `ttl_ms` from now by the database's clock;
    /// returns its token (stored as its SHA-256 only) and its CSRF token.
    fn create_session<'a>(&'a self, key_id: &'a str, ttl_ms: i64) -> StoreFuture<'a, NewSession>;
    /// The session `token` opens: None when it was ended, has expired (by the database's
    /// clock) or its key is revoked.
    fn session<'a>(&'a self, token: &'a str) -> StoreFuture<'a, Option<SessionRecord>>;
    /// Ends session `token` (signing out); ending an ended session does nothing.
    fn end_session<'a>(&'a self, token: &'a str) -> StoreFuture<'a, ()>;

    /// Migrations this build embeds that the database has not applied (empty: ready).
    /// Fails when the database cannot be reached.
    fn pending_migrations(&self) -> StoreFuture<'_, Vec<i64>>;

    fn row_counts(&self) -> StoreFuture<'_, RowCounts>;
}

/// How a store connects: the size of its connection pool and how long a statement
/// waits for a connection before the database counts as unavailable
/// ([`StoreError::Unavailable`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StoreOptions {
    /// Connections of this process (`None`: [`StoreOptions::DEFAULT_PG_POOL`] on
    /// PostgreSQL, [`StoreOptions::DEFAULT_SQLITE_POOL`] on SQLite; an in-memory SQLite
    /// database has one). Sizing rule (docs/api.md, "Operations"): the sum over every
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
pub async fn open(url: &str) -> Result<std::sync::Arc<dyn Store>> {
    open_with(url, StoreOptions::default()).await
}

/// [`open`] with a pool of the given size and wait ([`StoreOptions`]).
pub async fn open_with(url: &str, o: StoreOptions) -> Result<std::sync::Arc<dyn Store>> {
    if url.starts_with("postgres://") || url.starts_with("postgresql://") {
        return Ok(std::sync::Arc::new(PgStore::open_with(url, o).await?));
    }
    Ok(std::sync::Arc::new(SqliteStore::open_with(url, o).await?))
}

/// A database URL fit to print or log: the password of its user (`user:PASSWORD@`) and
/// the value of every query parameter whose name holds `password` are replaced by `***`.
/// A URL without them (a SQLite path) is returned as it is.
pub fn redacted(url: &str) -> String {
    let Some((scheme, rest)) = url.split_once("://") else {
        return url.to_string();
    };
    let (authority, tail) = rest.split_at(rest.find(['/', '?', '#']).unwrap_or(rest.len()));
    let authority = match authority.rsplit_once('@') {
        Some((userinfo, host)) => match userinfo.split_once(':') {
            Some((user, _)) => format!("{user}:***@{host}"),
            None => authority.to_string(),
        },
        None => authority.to_string(),
    };
    let tail = match tail.split_once('?') {
        Some((path, query)) => {
            let params: Vec<String> = query
                .split('&')
                .map(|p| match p.split_once('=') {
                    Some((k, _)) if k.to_ascii_lowercase().contains("password") => {
                        format!("{k}=***")
                    }
                    _ => p.to_string(),
                })
                .collect();
            format!("{path}?{}", params.join("&"))
        }
        None => tail.to_string(),
    };
    format!("{scheme}://{authority}{tail}")
}

/// Current time as a stored time ([`rfc3339_millis`]).
pub fn now_rfc3339() -> String {
    rfc3339_millis(time::OffsetDateTime::now_utc())
}

/// A time as RFC 3339 UTC with exactly three fraction digits
/// (`2026-11-25T16:10:00.500Z`, truncated to the millisecond), so that the stored times
/// (created, started, finished) sort as text in time order. (The well-known RFC 3339
/// format drops trailing zeros and a zero fraction: `…:00.5Z` sorted after `…:00.12Z`,
/// and `…:00Z` after both.)
pub fn rfc3339_millis(t: time::OffsetDateTime) -> String {
    const MILLIS_UTC: &[time::format_description::BorrowedFormatItem<'_>] = time::macros::format_description!(
        "[year]-[month]-[day]T[hour]:[minute]:[second].[subsecond digits:3]Z"
    );
    t.to_offset(time::UtcOffset::UTC)
        .format(MILLIS_UTC)
        .unwrap_or_default()
}

/// This host's time in milliseconds since the Unix epoch (plus the skew a test may set,
/// [`testing::skew_host_clock`]). The queue's leases and the sessions' expiry do not use
/// it: they are kept by the database's clock, the one clock every host shares.
pub fn now_ms() -> i64 {
    (time::OffsetDateTime::now_utc().unix_timestamp_nanos() / 1_000_000) as i64
        + testing::HOST_CLOCK_SKEW_MS.load(std::sync::atomic::Ordering::Relaxed)
}

#[cfg(test)]
mod url_tests {
    #[test]
    fn passwords_never_print() {
        for (url, shown) in [
            (
                "postgres://mtcal:S3cr:et@db.example:5432/mtcal",
                "postgres://mtcal:***@db.example:5432/mtcal",
            ),
            (
                "postgresql://u:p%40ss@[::1]/db?sslmode=require&password=x&sslpassword=y",
                "postgresql://u:***@[::1]/db?sslmode=require&password=***&sslpassword=***",
            ),
            ("postgres://mtcal@db/mtcal", "postgres://mtcal@db/mtcal"),
            ("mysql://root:hunter2@h", "mysql://root:***@h"),
            ("/var/lib/mtcal/mtcal.sqlite", "/var/lib/mtcal/mtcal.sqlite"),
            ("sqlite://data/m.sqlite", "sqlite://data/m.sqlite"),
        ] {
            assert_eq!(super::redacted(url), shown);
        }
    }
}

#[cfg(test)]
mod time_tests {
    use time::macros::datetime;

    /// Hand-written times: a zero fraction, trailing zeros and a non-UTC offset keep the
    /// fixed width, and the text order is the time order.
    #[test]
    fn stored_times_have_a_fixed_width_and_sort_as_text() {
        let times = [
            datetime!(2026-11-25 16:10:00 UTC),
            datetime!(2026-11-25 16:10:00.12 UTC),
            datetime!(2026-11-25 16:10:00.5 UTC),
            datetime!(2026-11-25 18:10:00.5009 +02:00),
            datetime!(2026-11-25 16:10:01 UTC),
        ];
        let text: Vec<String> = times.iter().map(|t| super::rfc3339_millis(*t)).collect();
        assert_eq!(
            text,
            [
                "2026-11-25T16:10:00.000Z",
                "2026-11-25T16:10:00.120Z",
                "2026-11-25T16:10:00.500Z",
                "2026-11-25T16:10:00.500Z",
                "2026-11-25T16:10:01.000Z",
            ]
        );
        assert!(text.windows(2).all(|w| w[0] <= w[1]), "{text:?}");
        let now = super::now_rfc3339();
        assert_eq!(now.len(), 24, "{now}");
        time::OffsetDateTime::parse(&now, &time::format_description::well_known::Rfc3339).unwrap();
    }
}
