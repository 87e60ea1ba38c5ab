//! The statements of [`crate::Queue`]: the durable job queue (its rules in
//! [`crate::queue`]).

use super::{Backend, Driver, dialect, results::insert_result, row_by_id};
use crate::error::{Db as _, Result, StoreError, unique_conflict};
use crate::model::*;
use crate::queue::{Failure, Heartbeat, Lease, Progress, Queue, lease_held};
use crate::rows::{self, Columns, JOB_COLUMNS};
use crate::rules;
use crate::{StoreFuture, now_rfc3339};
use sqlx::{Executor, Transaction};

/// The job `id`, read through `ex` (the pool or a transaction).
async fn job_by_id<'e>(ex: impl Executor<'e, Database = Driver>, id: &str) -> Result<Job> {
    let q = format!("SELECT {JOB_COLUMNS} FROM jobs WHERE id = $1");
    rows::job(&row_by_id(ex, q, id, "job").await?)
}

/// Reads job `id` as `tx` left it, then commits.
async fn commit_with_job(mut tx: Transaction<'_, Driver>, id: &str) -> Result<Job> {
    let job = job_by_id(&mut *tx, id).await?;
    tx.commit().await.db()?;
    Ok(job)
}

impl Backend {
    async fn job(&self, id: &str) -> Result<Job> {
        job_by_id(&self.pool, id).await
    }
}
impl Queue for Backend {
    fn list_jobs<'a>(&'a self, state: Option<JobState>, limit: i64) -> StoreFuture<'a, Vec<Job>> {
        Box::pin(async move {
            let q = format!(
                "SELECT {JOB_COLUMNS} FROM jobs WHERE ($1 IS NULL OR state = $1) \
                 ORDER BY created_at DESC, seq DESC LIMIT $2"
            );
            run!(
                fetch_all(&self.pool),
                sqlx::AssertSqlSafe(q),
                state.map(|s| s.as_str()),
                limit
            )?
            .iter()
            .map(rows::job)
            .collect()
        })
    }

    fn enqueue<'a>(&'a self, j: NewJob) -> StoreFuture<'a, Job> {
        Box::pin(async move {
            let id = rules::new_id("job");
            let q = format!(
                "INSERT INTO jobs (id, seq, kind, machine_id, dataset_id, params, state, max_attempts, \
                 run_after_ms, created_at) VALUES ($1, {seq}, $2, $3, $4, $5, 'queued', $6, {now}, $7)",
                seq = dialect::NEXT_SEQ,
                now = dialect::NOW_MS
            );
            bound!(
                sqlx::AssertSqlSafe(q),
                &id,
                j.kind.as_str(),
                &j.machine_id,
                &j.dataset_id,
                serde_json::to_string(&j.params).db()?,
                j.max_attempts.max(1),
                now_rfc3339()
            )
            .execute(&self.pool)
            .await
            .map_err(|e| unique_conflict(e, || format!("job {id}")))?;
            self.job(&id).await
        })
    }

    fn get_job<'a>(&'a self, id: &'a str) -> StoreFuture<'a, Job> {
        Box::pin(self.job(id))
    }

    fn cancel_job<'a>(&'a self, id: &'a str) -> StoreFuture<'a, Job> {
        Box::pin(async move {
            // One statement (atomic in every backend), reading the state before the update:
            // queued → cancelled now; running → cancellation requested; else untouched.
            let q = format!(
                "UPDATE jobs SET \
                   state = CASE WHEN state = 'queued' THEN 'cancelled' ELSE state END, \
                   finished_at = CASE WHEN state = 'queued' THEN $2 ELSE finished_at END, \
                   cancel_requested = CASE WHEN state = 'running' THEN 1 ELSE cancel_requested END \
                 WHERE id = $1 AND state IN ('queued', 'running') RETURNING {JOB_COLUMNS}"
            );
            let row = run!(
                fetch_optional(&self.pool),
                sqlx::AssertSqlSafe(q),
                id,
                now_rfc3339()
            )?;
            match row {
                Some(row) => rows::job(&row),
                None => Err(StoreError::Conflict(format!(
                    "job {id} is already {}",
                    self.job(id).await?.state.as_str()
                ))),
            }
        })
    }

    fn claim_job<'a>(&'a self, worker: &'a str, lease_ms: i64) -> StoreFuture<'a, Option<Job>> {
        Box::pin(async move {
            let q = format!(
                "UPDATE jobs SET state = 'running', lease_owner = $1, \
                 lease_expires_ms = {now} + $2, \
                 attempts = attempts + 1, started_at = COALESCE(started_at, $3), \
                 progress = 0, progress_message = 'claimed' \
                 WHERE id = (SELECT id FROM jobs WHERE state = 'queued' AND run_after_ms <= {now} \
                             AND kind IN ({kinds}) ORDER BY run_after_ms, seq LIMIT 1 {lock}) \
                 RETURNING {JOB_COLUMNS}",
                now = dialect::NOW_MS,
                kinds = crate::queue::runnable_sql_list(),
                lock = dialect::CLAIM_LOCK
            );
            let row = run!(
                fetch_optional(&self.pool),
                sqlx::AssertSqlSafe(q),
                worker,
                lease_ms,
                now_rfc3339()
            )?;
            row.as_ref().map(rows::job).transpose()
        })
    }

    fn heartbeat<'a>(
        &'a self,
        lease: Lease<'a>,
        lease_ms: i64,
        progress: Progress<'a>,
    ) -> StoreFuture<'a, Heartbeat> {
        Box::pin(async move {
            let q = format!(
                "UPDATE jobs SET lease_expires_ms = {} + $3, progress = $4, progress_message = $5 \
                 WHERE id = $1 AND state = 'running' AND lease_owner = $2 \
                 RETURNING cancel_requested",
                dialect::NOW_MS
            );
            let row = run!(
                fetch_optional(&self.pool),
                sqlx::AssertSqlSafe(q),
                lease.job,
                lease.worker,
                lease_ms,
                progress.fraction.clamp(0.0, 1.0),
                progress.message
            )?;
            Ok(match row {
                None => Heartbeat::LeaseLost,
                Some(r) if r.int("cancel_requested")? != 0 => Heartbeat::CancelRequested,
                Some(_) => Heartbeat::Continue,
            })
        })
    }

    fn complete_job<'a>(&'a self, lease: Lease<'a>, r: NewResult) -> StoreFuture<'a, Job> {
        Box::pin(async move {
            let Lease { job: id, worker } = lease;
            let mut tx = self.pool.begin().await.db()?;
            // Take the lease back first: this write makes the transaction the only writer,
            // and fails when another worker owns the job now.
            let owned = run!(
                execute(&mut *tx),
                "UPDATE jobs SET progress = 1, progress_message = 'done' \
                 WHERE id = $1 AND state = 'running' AND lease_owner = $2 AND cancel_requested = 0",
                id,
                worker
            )?;
            lease_held(owned.rows_affected(), id)?;
            let meta = insert_result(&mut tx, id, &r).await?;
            run!(
                execute(&mut *tx),
                "UPDATE jobs SET state = 'succeeded', result_id = $2, finished_at = $3, \
                 lease_owner = NULL, lease_expires_ms = NULL, error_code = NULL, error_message = NULL \
                 WHERE id = $1",
                id,
                &meta.id,
                now_rfc3339()
            )?;
            commit_with_job(tx, id).await
        })
    }

    fn fail_job<'a>(&'a self, lease: Lease<'a>, f: Failure<'a>) -> StoreFuture<'a, Job> {
        Box::pin(async move {
            let Lease { job: id, worker } = lease;
            // Retry: back to the queue after the delay; else failed for good.
            let q = format!(
                "UPDATE jobs SET state = CASE WHEN $5 IS NULL THEN 'failed' ELSE 'queued' END, \
                 run_after_ms = COALESCE({} + $5, run_after_ms), \
                 finished_at = CASE WHEN $5 IS NULL THEN $6 ELSE NULL END, \
                 lease_owner = NULL, lease_expires_ms = NULL, error_code = $3, error_message = $4 \
                 WHERE id = $1 AND state = 'running' AND lease_owner = $2",
                dialect::NOW_MS
            );
            let done = run!(
                execute(&self.pool),
                sqlx::AssertSqlSafe(q),
                id,
                worker,
                f.code,
                f.message,
                f.retry_after_ms,
                now_rfc3339()
            )?;
            lease_held(done.rows_affected(), id)?;
            self.job(id).await
        })
    }

    fn job_counts(&self) -> StoreFuture<'_, Vec<crate::queue::JobCount>> {
        Box::pin(async move {
            let rows = sqlx::query(
                "SELECT kind, state, COUNT(*) AS n FROM jobs GROUP BY kind, state ORDER BY kind, state",
            )
            .fetch_all(&self.pool)
            .await
            .db()?;
            rows.iter()
                .map(|r| {
                    Ok(crate::queue::JobCount {
                        kind: r.text("kind")?,
                        state: r.text("state")?,
                        count: r.int("n")?,
                    })
                })
                .collect()
        })
    }

    fn release_job<'a>(&'a self, lease: Lease<'a>) -> StoreFuture<'a, Job> {
        Box::pin(async move {
            let Lease { job: id, worker } = lease;
            let q = format!(
                "UPDATE jobs SET \
                   state = CASE WHEN cancel_requested = 1 THEN 'cancelled' ELSE 'queued' END, \
                   finished_at = CASE WHEN cancel_requested = 1 THEN $3 ELSE NULL END, \
                   attempts = CASE WHEN attempts > 0 THEN attempts - 1 ELSE 0 END, \
                   run_after_ms = {}, lease_owner = NULL, lease_expires_ms = NULL, \
                   progress = 0, progress_message = 'handed back by a stopping worker' \
                 WHERE id = $1 AND state = 'running' AND lease_owner = $2",
                dialect::NOW_MS
            );
            let done = run!(
                execute(&self.pool),
                sqlx::AssertSqlSafe(q),
                id,
                worker,
                now_rfc3339()
            )?;
            lease_held(done.rows_affected(), id)?;
            self.job(id).await
        })
    }

    fn finish_cancelled<'a>(&'a self, lease: Lease<'a>) -> StoreFuture<'a, Job> {
        Box::pin(async move {
            let Lease { job: id, worker } = lease;
            let done = run!(
                execute(&self.pool),
                "UPDATE jobs SET state = 'cancelled', finished_at = $3, lease_owner = NULL, \
                 lease_expires_ms = NULL WHERE id = $1 AND state = 'running' AND lease_owner = $2",
                id,
                worker,
                now_rfc3339()
            )?;
            lease_held(done.rows_affected(), id)?;
            self.job(id).await
        })
    }

    fn reap_expired<'a>(&'a self) -> StoreFuture<'a, u64> {
        Box::pin(async move {
            let q = format!(
                "UPDATE jobs SET \
                   state = CASE WHEN cancel_requested = 1 THEN 'cancelled' \
                                WHEN attempts >= max_attempts THEN 'failed' ELSE 'queued' END, \
                   finished_at = CASE WHEN cancel_requested = 1 OR attempts >= max_attempts \
                                      THEN $1 ELSE NULL END, \
                   error_code = 'lease_expired', \
                   error_message = 'the worker running this job stopped renewing its lease', \
                   lease_owner = NULL, lease_expires_ms = NULL, run_after_ms = {now} \
                 WHERE state = 'running' AND lease_expires_ms < {now}",
                now = dialect::NOW_MS
            );
            let done = run!(execute(&self.pool), sqlx::AssertSqlSafe(q), now_rfc3339())?;
            Ok(done.rows_affected())
        })
    }
}
