//! The queue's statements on SQLite (semantics in [`crate::queue`]). SQLite serialises
//! writers, so the claim's `UPDATE … WHERE id = (SELECT …)` is exclusive as it stands.

use super::{SqliteStore, insert_result, row_by_id};
use crate::error::{Db, Result, StoreError, unique_conflict};
use crate::model::*;
use crate::queue::{CancelAction, Heartbeat, JobKind, Queue, lease_held};
use crate::rows::{self, Columns, JOB_COLUMNS};
use crate::{StoreFuture, now_ms, now_rfc3339, rules};
use sqlx::{Executor, Sqlite, Transaction};

/// The job `id`, read through `ex` (the pool or a transaction).
async fn job_by_id<'e>(ex: impl Executor<'e, Database = Sqlite>, id: &str) -> Result<Job> {
    let q = format!("SELECT {JOB_COLUMNS} FROM jobs WHERE id = ?1");
    rows::job(&row_by_id(ex, q, id, "job").await?)
}

/// Reads job `id` as `tx` left it, then commits.
async fn commit_with_job(mut tx: Transaction<'_, Sqlite>, id: &str) -> Result<Job> {
    let job = job_by_id(&mut *tx, id).await?;
    tx.commit().await.db()?;
    Ok(job)
}

impl SqliteStore {
    async fn job(&self, id: &str) -> Result<Job> {
        job_by_id(&self.pool, id).await
    }
}

impl Queue for SqliteStore {
    fn enqueue<'a>(&'a self, j: NewJob) -> StoreFuture<'a, Job> {
        Box::pin(async move {
            let id = rules::new_id("job");
            sqlx::query(
                "INSERT INTO jobs (id, seq, kind, machine_id, dataset_id, params, state, max_attempts, \
                 run_after_ms, created_at) VALUES (?1, (SELECT COALESCE(MAX(seq), 0) + 1 FROM jobs), \
                 ?2, ?3, ?4, ?5, 'queued', ?6, ?7, ?8)",
            )
            .bind(&id)
            .bind(j.kind.as_str())
            .bind(&j.machine_id)
            .bind(&j.dataset_id)
            .bind(serde_json::to_string(&j.params).db()?)
            .bind(j.max_attempts.max(1))
            .bind(now_ms())
            .bind(now_rfc3339())
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
            let mut tx = self.pool.begin().await.db()?;
            let job = job_by_id(&mut *tx, id).await?;
            let q = match CancelAction::for_state(job.state) {
                CancelAction::CancelNow => {
                    "UPDATE jobs SET state = 'cancelled', finished_at = ?2 WHERE id = ?1"
                }
                CancelAction::Request => "UPDATE jobs SET cancel_requested = 1 WHERE id = ?1",
                CancelAction::Refuse => {
                    return Err(StoreError::Conflict(format!(
                        "job {id} is already {}",
                        job.state.as_str()
                    )));
                }
            };
            sqlx::query(q)
                .bind(id)
                .bind(now_rfc3339())
                .execute(&mut *tx)
                .await
                .db()?;
            commit_with_job(tx, id).await
        })
    }

    fn claim_job<'a>(&'a self, worker: &'a str, lease_ms: i64) -> StoreFuture<'a, Option<Job>> {
        Box::pin(async move {
            let now = now_ms();
            let q = format!(
                "UPDATE jobs SET state = 'running', lease_owner = ?1, lease_expires_ms = ?2, \
                 attempts = attempts + 1, started_at = COALESCE(started_at, ?3), \
                 progress = 0, progress_message = 'claimed' \
                 WHERE id = (SELECT id FROM jobs WHERE state = 'queued' AND run_after_ms <= ?4 \
                             AND kind IN ({kinds}) ORDER BY run_after_ms, seq LIMIT 1) \
                 RETURNING {JOB_COLUMNS}",
                kinds = JobKind::runnable_sql_list()
            );
            let row = sqlx::query(sqlx::AssertSqlSafe(q))
                .bind(worker)
                .bind(now + lease_ms)
                .bind(now_rfc3339())
                .bind(now)
                .fetch_optional(&self.pool)
                .await
                .db()?;
            row.as_ref().map(rows::job).transpose()
        })
    }

    fn heartbeat<'a>(
        &'a self,
        id: &'a str,
        worker: &'a str,
        lease_ms: i64,
        progress: f64,
        message: &'a str,
    ) -> StoreFuture<'a, Heartbeat> {
        Box::pin(async move {
            let row = sqlx::query(
                "UPDATE jobs SET lease_expires_ms = ?3, progress = ?4, progress_message = ?5 \
                 WHERE id = ?1 AND state = 'running' AND lease_owner = ?2 \
                 RETURNING cancel_requested",
            )
            .bind(id)
            .bind(worker)
            .bind(now_ms() + lease_ms)
            .bind(progress.clamp(0.0, 1.0))
            .bind(message)
            .fetch_optional(&self.pool)
            .await
            .db()?;
            Ok(match row {
                None => Heartbeat::LeaseLost,
                Some(r) if r.int("cancel_requested")? != 0 => Heartbeat::CancelRequested,
                Some(_) => Heartbeat::Continue,
            })
        })
    }

    fn complete_job<'a>(
        &'a self,
        id: &'a str,
        worker: &'a str,
        r: NewResult,
    ) -> StoreFuture<'a, Job> {
        Box::pin(async move {
            let mut tx = self.pool.begin().await.db()?;
            // Take the lease back first: this write makes the transaction the only writer,
            // and fails when another worker owns the job now.
            let owned = sqlx::query(
                "UPDATE jobs SET progress = 1, progress_message = 'done' \
                 WHERE id = ?1 AND state = 'running' AND lease_owner = ?2 AND cancel_requested = 0",
            )
            .bind(id)
            .bind(worker)
            .execute(&mut *tx)
            .await
            .db()?;
            lease_held(owned.rows_affected(), id)?;
            let meta = insert_result(&mut tx, id, &r).await?;
            sqlx::query(
                "UPDATE jobs SET state = 'succeeded', result_id = ?2, finished_at = ?3, \
                 lease_owner = NULL, lease_expires_ms = NULL, error_code = NULL, error_message = NULL \
                 WHERE id = ?1",
            )
            .bind(id)
            .bind(&meta.id)
            .bind(now_rfc3339())
            .execute(&mut *tx)
            .await
            .db()?;
            commit_with_job(tx, id).await
        })
    }

    fn fail_job<'a>(
        &'a self,
        id: &'a str,
        worker: &'a str,
        code: &'a str,
        message: &'a str,
        retry_after_ms: Option<i64>,
    ) -> StoreFuture<'a, Job> {
        Box::pin(async move {
            // Retry: back to the queue after the delay; else failed for good.
            let done = sqlx::query(
                "UPDATE jobs SET state = CASE WHEN ?5 IS NULL THEN 'failed' ELSE 'queued' END, \
                 run_after_ms = COALESCE(?5, run_after_ms), \
                 finished_at = CASE WHEN ?5 IS NULL THEN ?6 ELSE NULL END, \
                 lease_owner = NULL, lease_expires_ms = NULL, error_code = ?3, error_message = ?4 \
                 WHERE id = ?1 AND state = 'running' AND lease_owner = ?2",
            )
            .bind(id)
            .bind(worker)
            .bind(code)
            .bind(message)
            .bind(retry_after_ms.map(|delay| now_ms() + delay))
            .bind(now_rfc3339())
            .execute(&self.pool)
            .await
            .db()?;
            lease_held(done.rows_affected(), id)?;
            self.job(id).await
        })
    }

    fn finish_cancelled<'a>(&'a self, id: &'a str, worker: &'a str) -> StoreFuture<'a, Job> {
        Box::pin(async move {
            let done = sqlx::query(
                "UPDATE jobs SET state = 'cancelled', finished_at = ?3, lease_owner = NULL, \
                 lease_expires_ms = NULL WHERE id = ?1 AND state = 'running' AND lease_owner = ?2",
            )
            .bind(id)
            .bind(worker)
            .bind(now_rfc3339())
            .execute(&self.pool)
            .await
            .db()?;
            lease_held(done.rows_affected(), id)?;
            self.job(id).await
        })
    }

    fn reap_expired<'a>(&'a self) -> StoreFuture<'a, u64> {
        Box::pin(async move {
            let now = now_ms();
            let done = sqlx::query(
                "UPDATE jobs SET \
                   state = CASE WHEN cancel_requested = 1 THEN 'cancelled' \
                                WHEN attempts >= max_attempts THEN 'failed' ELSE 'queued' END, \
                   finished_at = CASE WHEN cancel_requested = 1 OR attempts >= max_attempts \
                                      THEN ?2 ELSE NULL END, \
                   error_code = 'lease_expired', \
                   error_message = 'the worker running this job stopped renewing its lease', \
                   lease_owner = NULL, lease_expires_ms = NULL, run_after_ms = ?1 \
                 WHERE state = 'running' AND lease_expires_ms < ?1",
            )
            .bind(now)
            .bind(now_rfc3339())
            .execute(&self.pool)
            .await
            .db()?;
            Ok(done.rows_affected())
        })
    }
}
