//! The durable job queue, in the service's own `jobs` table: the jobs and queue of a
//! store ([`Queue`]), its typed [`JobKind`], and the rules every backend shares.
//!
//! * **Claim**: one `UPDATE jobs … WHERE id = (SELECT … state = 'queued' AND run_after_ms
//!   <= now AND kind IN (runnable kinds) ORDER BY seq LIMIT 1) RETURNING …`. SQLite
//!   serialises writers, so two workers never claim the same job; PostgreSQL adds
//!   `FOR UPDATE SKIP LOCKED` to the sub-select. Claiming counts an attempt and sets a
//!   lease (owner + expiry). A worker claims only the kinds its build knows
//!   ([`JobKind::RUNNABLE`]), so an older worker sharing a database with a newer API leaves
//!   new kinds to newer workers.
//! * **Lease and heartbeat**: a running worker extends its lease every few seconds and
//!   records progress; the heartbeat tells it when cancellation was requested or when its
//!   lease was lost.
//! * **Reaper**: a running job whose lease expired (its worker died) goes back to the
//!   queue, or fails with `lease_expired` when it has used all its attempts.
//! * **One clock**: every time of the queue (`run_after_ms`, `lease_expires_ms`) is the
//!   database's clock (milliseconds since the Unix epoch, computed in the statement), never
//!   a host's: workers on hosts whose clocks differ share one queue without reaping a live
//!   worker's job or keeping a dead one's.
//! * **Exactly once**: the result is written, and the job marked succeeded, in one
//!   transaction that only succeeds while the worker still holds the lease; `results.job_id`
//!   is unique.
//! * **Retries**: transient failures (database busy, worker panic) retry with exponential
//!   backoff ([`QueueConfig::backoff_ms`]); bad input never retries.

use crate::StoreFuture;
use crate::results::NewResult;
pub use mtcal_api::jobs::{Job, JobKind, JobState};
use serde::{Deserialize, Serialize};
use serde_json::Value;

/// A write guarded by `state = 'running' AND lease_owner = worker` changed `rows` rows:
/// exactly one while the worker holds the lease of job `id`, else the lease is lost.
pub(crate) fn lease_held(rows: u64, id: &str) -> crate::Result<()> {
    if rows == 1 {
        Ok(())
    } else {
        Err(crate::StoreError::LeaseLost(id.to_string()))
    }
}

/// The lease a worker holds on a running job, as the worker names it: the job and the
/// worker that claimed it. Every write only the holder may make (heartbeat, complete,
/// fail, hand back, finish cancelled) takes one, and changes the job only while the
/// stored `lease_owner` is `worker` (else [`crate::StoreError::LeaseLost`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Lease<'a> {
    /// The job's id.
    pub job: &'a str,
    /// The worker's name, as it claimed the job.
    pub worker: &'a str,
}

impl<'a> Lease<'a> {
    pub fn new(job: &'a str, worker: &'a str) -> Self {
        Lease { job, worker }
    }
}

/// What a heartbeat records: the fraction of the job done (clamped to 0 … 1) and the
/// phase it is in, shown with the job.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Progress<'a> {
    pub fraction: f64,
    pub message: &'a str,
}

/// Why a job failed, and whether it runs again.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Failure<'a> {
    /// The job's `error_code` (`bad_input`, `transient`, `timeout`, …).
    pub code: &'a str,
    /// The job's `error_message`.
    pub message: &'a str,
    /// Back to the queue after this many ms (a retry); `None`: failed for good.
    pub retry_after_ms: Option<i64>,
}

/// The jobs: the durable queue and its listing. Implementations must make each method
/// atomic.
pub trait Queue: Send + Sync {
    fn enqueue<'a>(&'a self, j: NewJob) -> StoreFuture<'a, Job>;
    fn get_job<'a>(&'a self, id: &'a str) -> StoreFuture<'a, Job>;
    /// Cancels a queued job at once; asks a running one to stop (the worker sees it at its
    /// next heartbeat). Terminal jobs are a conflict.
    fn cancel_job<'a>(&'a self, id: &'a str) -> StoreFuture<'a, Job>;
    /// Claims the oldest runnable job for `worker` with a lease of `lease_ms`, in one
    /// `UPDATE … RETURNING`; counts an attempt.
    fn claim_job<'a>(&'a self, worker: &'a str, lease_ms: i64) -> StoreFuture<'a, Option<Job>>;
    /// Extends the lease by `lease_ms` and records progress.
    fn heartbeat<'a>(
        &'a self,
        lease: Lease<'a>,
        lease_ms: i64,
        progress: Progress<'a>,
    ) -> StoreFuture<'a, Heartbeat>;
    /// Stores the result and marks the job succeeded, in one transaction, only while
    /// the lease is held: a job completes exactly once.
    fn complete_job<'a>(&'a self, lease: Lease<'a>, r: NewResult) -> StoreFuture<'a, Job>;
    /// Records a failure: back to the queue after its `retry_after_ms`, or failed for
    /// good when `None`.
    fn fail_job<'a>(&'a self, lease: Lease<'a>, f: Failure<'a>) -> StoreFuture<'a, Job>;
    /// How many jobs there are of each kind in each state (states with none are left
    /// out): the queue's gauges.
    fn job_counts(&self) -> StoreFuture<'_, Vec<JobCount>>;
    /// Hands a running job back to the queue (a worker that is stopping): queued at once,
    /// lease cleared, the attempt not counted, so another worker claims it without waiting
    /// for the lease to expire. A job whose cancellation was requested is cancelled.
    fn release_job<'a>(&'a self, lease: Lease<'a>) -> StoreFuture<'a, Job>;
    /// Marks a running job whose cancellation was requested as cancelled.
    fn finish_cancelled<'a>(&'a self, lease: Lease<'a>) -> StoreFuture<'a, Job>;
    /// Requeues (or fails, when out of attempts) running jobs whose lease has expired;
    /// returns how many.
    fn reap_expired<'a>(&'a self) -> StoreFuture<'a, u64>;

    /// Jobs newest first (created_at, then seq), of one state or all, at most `limit`.
    fn list_jobs<'a>(&'a self, state: Option<JobState>, limit: i64) -> StoreFuture<'a, Vec<Job>>;
}

/// Number of jobs of one kind in one state.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct JobCount {
    pub kind: String,
    pub state: String,
    pub count: i64,
}

/// What a heartbeat learnt.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum Heartbeat {
    /// Lease extended; carry on.
    Continue,
    /// Cancellation was requested: stop and call `finish_cancelled`.
    CancelRequested,
    /// The job is no longer ours (reaped and claimed elsewhere, or finished).
    LeaseLost,
}

/// Tuning of the queue and its workers.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct QueueConfig {
    /// Jobs run at the same time by one process.
    pub concurrency: usize,
    /// Lease length, ms; heartbeats come every third of it.
    pub lease_ms: i64,
    /// Sleep between polls of an empty queue, ms.
    pub poll_ms: u64,
    /// Attempts a job gets (first run included).
    pub max_attempts: i64,
    /// First retry delay, ms (doubled at each further attempt).
    pub backoff_base_ms: i64,
    /// Upper bound of the retry delay, ms.
    pub backoff_max_ms: i64,
}

impl Default for QueueConfig {
    fn default() -> Self {
        QueueConfig {
            concurrency: 2,
            lease_ms: 30_000,
            poll_ms: 200,
            max_attempts: 3,
            backoff_base_ms: 1_000,
            backoff_max_ms: 60_000,
        }
    }
}

impl QueueConfig {
    /// Delay before attempt `attempts + 1`: base · 2^(attempts − 1), capped.
    pub fn backoff_ms(&self, attempts: i64) -> i64 {
        let exp = (attempts - 1).clamp(0, 30) as u32;
        self.backoff_base_ms
            .saturating_mul(1i64 << exp)
            .min(self.backoff_max_ms)
    }
}

/// A job to enqueue.
#[derive(Debug, Clone)]
pub struct NewJob {
    pub kind: JobKind,
    pub machine_id: Option<String>,
    pub dataset_id: Option<String>,
    pub params: Value,
    pub max_attempts: i64,
}

/// `'identify', 'sensitivity', …`: the runnable kinds as an SQL list (constants only,
/// never user input), for the claim query of every backend.
pub fn runnable_sql_list() -> String {
    JobKind::RUNNABLE
        .iter()
        .map(|k| format!("'{}'", k.as_str()))
        .collect::<Vec<_>>()
        .join(", ")
}

#[cfg(test)]
mod tests {
    use super::JobKind;
    use super::*;

    #[test]
    fn backoff_doubles_and_caps() {
        let c = QueueConfig {
            backoff_base_ms: 100,
            backoff_max_ms: 1_000,
            ..QueueConfig::default()
        };
        assert_eq!(c.backoff_ms(1), 100);
        assert_eq!(c.backoff_ms(2), 200);
        assert_eq!(c.backoff_ms(4), 800);
        assert_eq!(c.backoff_ms(5), 1_000);
        assert_eq!(c.backoff_ms(60), 1_000);
    }

    #[test]
    fn kinds_round_trip_and_import_is_not_runnable() {
        for k in JobKind::RUNNABLE.into_iter().chain([JobKind::Import]) {
            assert_eq!(JobKind::parse(k.as_str()), Some(k));
            assert_eq!(serde_json::to_value(k).unwrap(), k.as_str());
        }
        assert!(!JobKind::RUNNABLE.contains(&JobKind::Import));
        assert_eq!(
            runnable_sql_list(),
            "'identify', 'sensitivity', 'diagnose', 'cradle', 'standards'"
        );
        assert_eq!(JobKind::parse("nope"), None);
    }
}
