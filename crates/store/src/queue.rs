//! The durable job queue, in the service's own `jobs` table.
//!
//! * **Claim**: one `UPDATE jobs … WHERE id = (SELECT … state = 'queued' AND run_after_ms
//!   <= now ORDER BY seq LIMIT 1) RETURNING …`. SQLite serialises writers, so two workers
//!   never claim the same job; PostgreSQL would add `FOR UPDATE SKIP LOCKED` to the
//!   sub-select. Claiming counts an attempt and sets a lease (owner + expiry).
//! * **Lease and heartbeat**: a running worker extends its lease every few seconds and
//!   records progress; the heartbeat tells it when cancellation was requested or when its
//!   lease was lost.
//! * **Reaper**: a running job whose lease expired (its worker died) goes back to the
//!   queue, or fails with `lease_expired` when it has used all its attempts.
//! * **Exactly once**: the result is written, and the job marked succeeded, in one
//!   transaction that only succeeds while the worker still holds the lease; `results.job_id`
//!   is unique.
//! * **Retries**: transient failures (database busy, worker panic) retry with exponential
//!   backoff ([`QueueConfig::backoff_ms`]); bad input never retries.

use serde::{Deserialize, Serialize};

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

#[cfg(test)]
mod tests {
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
}
