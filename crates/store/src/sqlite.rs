//! The SQLite implementation of [`Store`] (WAL mode, runtime-checked queries).

use crate::keys::{self, ApiKey, Scope};
use crate::model::*;
use crate::queue::Heartbeat;
use crate::{Result, Store, StoreError, StoreFuture, now_ms, now_rfc3339};
use sha2::{Digest, Sha256};
use sqlx::sqlite::{
    SqliteConnectOptions, SqliteJournalMode, SqlitePool, SqlitePoolOptions, SqliteRow,
    SqliteSynchronous,
};
use sqlx::{Row, Sqlite, Transaction};
use std::str::FromStr;
use std::time::Duration;

/// SQLite store. Cheap to clone (a pool handle).
#[derive(Clone)]
pub struct SqliteStore {
    pool: SqlitePool,
}

const JOB_COLUMNS: &str = "id, kind, machine_id, dataset_id, params, state, progress, \
     progress_message, attempts, max_attempts, error_code, error_message, result_id, \
     created_at, started_at, finished_at";

const RESULT_COLUMNS: &str = "id, job_id, machine_id, dataset_id, kind, measured_at, \
     created_at, residual_rms_um, condition_number, rank, ec0y_urad, eb0z_urad, ea0z_urad, \
     term_coefficients";

const MACHINE_COLUMNS: &str =
    "id, name, topology, travel_mm, site, tags, baseline_result_id, created_at, updated_at";

impl SqliteStore {
    /// Opens (creating if needed) and migrates the database at `url`.
    pub async fn open(url: &str) -> Result<SqliteStore> {
        let opts = if url.starts_with("sqlite:") {
            SqliteConnectOptions::from_str(url)?
        } else if url.contains("://") {
            return Err(StoreError::UnsupportedUrl(url.to_string()));
        } else {
            SqliteConnectOptions::new().filename(url)
        };
        let opts = opts
            .create_if_missing(true)
            .journal_mode(SqliteJournalMode::Wal)
            .synchronous(SqliteSynchronous::Normal)
            .foreign_keys(true)
            .busy_timeout(Duration::from_secs(10));
        let memory = url.contains(":memory:");
        let pool = SqlitePoolOptions::new()
            .max_connections(if memory { 1 } else { 8 })
            .connect_with(opts)
            .await?;
        sqlx::migrate!("../../migrations/sqlite").run(&pool).await?;
        Ok(SqliteStore { pool })
    }

    /// Inserts many results (each with a finished `import` job) in one transaction: for
    /// seeding benchmarks and bulk imports.
    pub async fn import_results_bulk(&self, results: &[NewResult]) -> Result<()> {
        let mut tx = self.pool.begin().await?;
        let now = now_rfc3339();
        for r in results {
            let job_id = new_id("job");
            sqlx::query(
                "INSERT INTO jobs (id, seq, kind, machine_id, dataset_id, params, state, max_attempts, \
                 run_after_ms, created_at, started_at, finished_at, progress, attempts) \
                 VALUES (?1, 0, 'import', ?2, NULL, '{}', 'succeeded', 1, 0, ?3, ?3, ?3, 1, 0)",
            )
            .bind(&job_id)
            .bind(&r.machine_id)
            .bind(&now)
            .execute(&mut *tx)
            .await?;
            insert_result(&mut tx, &job_id, r).await?;
        }
        tx.commit().await?;
        Ok(())
    }

    /// The underlying pool (tests, benchmarks).
    pub fn pool(&self) -> &SqlitePool {
        &self.pool
    }
}

fn new_id(prefix: &str) -> String {
    format!("{prefix}_{}", uuid::Uuid::new_v4().simple())
}

fn machine_from_row(r: &SqliteRow) -> Result<Machine> {
    Ok(Machine {
        id: r.try_get("id")?,
        name: r.try_get("name")?,
        topology: serde_json::from_str(r.try_get::<&str, _>("topology")?)?,
        travel_mm: serde_json::from_str(r.try_get::<&str, _>("travel_mm")?)?,
        site: r.try_get("site")?,
        tags: serde_json::from_str(r.try_get::<&str, _>("tags")?)?,
        baseline_result_id: r.try_get("baseline_result_id")?,
        created_at: r.try_get("created_at")?,
        updated_at: r.try_get("updated_at")?,
    })
}

fn job_from_row(r: &SqliteRow) -> Result<Job> {
    let state: String = r.try_get("state")?;
    Ok(Job {
        id: r.try_get("id")?,
        kind: r.try_get("kind")?,
        machine_id: r.try_get("machine_id")?,
        dataset_id: r.try_get("dataset_id")?,
        params: serde_json::from_str(r.try_get::<&str, _>("params")?)?,
        state: JobState::parse(&state)
            .ok_or_else(|| StoreError::Conflict(format!("unknown job state {state:?}")))?,
        progress: r.try_get("progress")?,
        progress_message: r.try_get("progress_message")?,
        attempts: r.try_get("attempts")?,
        max_attempts: r.try_get("max_attempts")?,
        error_code: r.try_get("error_code")?,
        error_message: r.try_get("error_message")?,
        result_id: r.try_get("result_id")?,
        created_at: r.try_get("created_at")?,
        started_at: r.try_get("started_at")?,
        finished_at: r.try_get("finished_at")?,
    })
}

fn result_from_row(r: &SqliteRow) -> Result<ResultMeta> {
    Ok(ResultMeta {
        id: r.try_get("id")?,
        job_id: r.try_get("job_id")?,
        machine_id: r.try_get("machine_id")?,
        dataset_id: r.try_get("dataset_id")?,
        kind: r.try_get("kind")?,
        measured_at: r.try_get("measured_at")?,
        created_at: r.try_get("created_at")?,
        scalars: ResultScalars {
            residual_rms_um: r.try_get("residual_rms_um")?,
            condition_number: r.try_get("condition_number")?,
            rank: r.try_get("rank")?,
            ec0y_urad: r.try_get("ec0y_urad")?,
            eb0z_urad: r.try_get("eb0z_urad")?,
            ea0z_urad: r.try_get("ea0z_urad")?,
            term_coefficients: serde_json::from_str(r.try_get::<&str, _>("term_coefficients")?)?,
        },
    })
}

fn key_from_row(r: &SqliteRow) -> Result<ApiKey> {
    let scope: String = r.try_get("scope")?;
    Ok(ApiKey {
        id: r.try_get("id")?,
        prefix: r.try_get("prefix")?,
        scope: Scope::parse(&scope)
            .ok_or_else(|| StoreError::Conflict(format!("unknown scope {scope:?}")))?,
        label: r.try_get("label")?,
        created_at: r.try_get("created_at")?,
    })
}

/// Maps a unique-constraint violation to a conflict naming `what`.
fn unique_conflict(e: sqlx::Error, what: impl FnOnce() -> String) -> StoreError {
    match &e {
        sqlx::Error::Database(d) if d.is_unique_violation() => StoreError::Conflict(what()),
        sqlx::Error::Database(d) if d.is_foreign_key_violation() => {
            StoreError::NotFound(format!("a record referenced by {}", what()))
        }
        _ => StoreError::Database(e),
    }
}

async fn job_in(tx: &mut Transaction<'_, Sqlite>, id: &str) -> Result<Job> {
    let q = format!("SELECT {JOB_COLUMNS} FROM jobs WHERE id = ?1");
    let row = sqlx::query(sqlx::AssertSqlSafe(q))
        .bind(id)
        .fetch_optional(&mut **tx)
        .await?
        .ok_or_else(|| StoreError::NotFound(format!("job {id}")))?;
    job_from_row(&row)
}

/// Inserts a result row inside `tx`; returns its metadata.
async fn insert_result(
    tx: &mut Transaction<'_, Sqlite>,
    job_id: &str,
    r: &NewResult,
) -> Result<ResultMeta> {
    let id = new_id("res");
    let created_at = now_rfc3339();
    let s = &r.scalars;
    sqlx::query(
        "INSERT INTO results (id, job_id, machine_id, dataset_id, kind, measured_at, created_at, \
         document, residual_rms_um, condition_number, rank, ec0y_urad, eb0z_urad, ea0z_urad, \
         term_coefficients) VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11, ?12, ?13, ?14, ?15)",
    )
    .bind(&id)
    .bind(job_id)
    .bind(&r.machine_id)
    .bind(&r.dataset_id)
    .bind(&r.kind)
    .bind(&r.measured_at)
    .bind(&created_at)
    .bind(serde_json::to_string(&r.document)?)
    .bind(s.residual_rms_um)
    .bind(s.condition_number)
    .bind(s.rank)
    .bind(s.ec0y_urad)
    .bind(s.eb0z_urad)
    .bind(s.ea0z_urad)
    .bind(serde_json::to_string(&s.term_coefficients)?)
    .execute(&mut **tx)
    .await
    .map_err(|e| unique_conflict(e, || format!("result of job {job_id}")))?;
    Ok(ResultMeta {
        id,
        job_id: job_id.to_string(),
        machine_id: r.machine_id.clone(),
        dataset_id: r.dataset_id.clone(),
        kind: r.kind.clone(),
        measured_at: r.measured_at.clone(),
        created_at,
        scalars: r.scalars.clone(),
    })
}

impl SqliteStore {
    async fn machine(&self, id: &str) -> Result<Machine> {
        let q = format!("SELECT {MACHINE_COLUMNS} FROM machines WHERE id = ?1");
        let row = sqlx::query(sqlx::AssertSqlSafe(q))
            .bind(id)
            .fetch_optional(&self.pool)
            .await?
            .ok_or_else(|| StoreError::NotFound(format!("machine {id}")))?;
        machine_from_row(&row)
    }

    async fn job(&self, id: &str) -> Result<Job> {
        let q = format!("SELECT {JOB_COLUMNS} FROM jobs WHERE id = ?1");
        let row = sqlx::query(sqlx::AssertSqlSafe(q))
            .bind(id)
            .fetch_optional(&self.pool)
            .await?
            .ok_or_else(|| StoreError::NotFound(format!("job {id}")))?;
        job_from_row(&row)
    }

    async fn dataset(&self, id: &str) -> Result<Dataset> {
        let row = sqlx::query(
            "SELECT id, machine_id, kind, measured_at, uploaded_at, samples, total_bytes, sha256 \
             FROM datasets WHERE id = ?1",
        )
        .bind(id)
        .fetch_optional(&self.pool)
        .await?
        .ok_or_else(|| StoreError::NotFound(format!("dataset {id}")))?;
        let files = sqlx::query(
            "SELECT name, sha256, size FROM dataset_files WHERE dataset_id = ?1 ORDER BY name",
        )
        .bind(id)
        .fetch_all(&self.pool)
        .await?
        .iter()
        .map(|r| {
            Ok(FileMeta {
                name: r.try_get("name")?,
                sha256: r.try_get("sha256")?,
                size: r.try_get("size")?,
            })
        })
        .collect::<Result<Vec<_>>>()?;
        Ok(Dataset {
            id: row.try_get("id")?,
            machine_id: row.try_get("machine_id")?,
            kind: row.try_get("kind")?,
            measured_at: row.try_get("measured_at")?,
            uploaded_at: row.try_get("uploaded_at")?,
            samples: row.try_get("samples")?,
            total_bytes: row.try_get("total_bytes")?,
            sha256: row.try_get("sha256")?,
            files,
        })
    }

    async fn result_meta(&self, id: &str) -> Result<ResultMeta> {
        let q = format!("SELECT {RESULT_COLUMNS} FROM results WHERE id = ?1");
        let row = sqlx::query(sqlx::AssertSqlSafe(q))
            .bind(id)
            .fetch_optional(&self.pool)
            .await?
            .ok_or_else(|| StoreError::NotFound(format!("result {id}")))?;
        result_from_row(&row)
    }
}

impl Store for SqliteStore {
    fn create_machine<'a>(&'a self, m: &'a Machine) -> StoreFuture<'a, Machine> {
        Box::pin(async move {
            let now = now_rfc3339();
            sqlx::query(
                "INSERT INTO machines (id, name, topology, travel_mm, site, tags, \
                 baseline_result_id, created_at, updated_at) VALUES (?1, ?2, ?3, ?4, ?5, ?6, NULL, ?7, ?7)",
            )
            .bind(&m.id)
            .bind(&m.name)
            .bind(serde_json::to_string(&m.topology)?)
            .bind(serde_json::to_string(&m.travel_mm)?)
            .bind(&m.site)
            .bind(serde_json::to_string(&m.tags)?)
            .bind(&now)
            .execute(&self.pool)
            .await
            .map_err(|e| unique_conflict(e, || format!("machine {} already exists", m.id)))?;
            self.machine(&m.id).await
        })
    }

    fn get_machine<'a>(&'a self, id: &'a str) -> StoreFuture<'a, Machine> {
        Box::pin(self.machine(id))
    }

    fn update_machine<'a>(&'a self, id: &'a str, p: &'a MachinePatch) -> StoreFuture<'a, Machine> {
        Box::pin(async move {
            let mut m = self.machine(id).await?;
            if let Some(b) = &p.baseline_result_id {
                let r = self.result_meta(b).await?;
                if r.machine_id != id {
                    return Err(StoreError::Conflict(format!(
                        "result {b} belongs to machine {}, not {id}",
                        r.machine_id
                    )));
                }
                m.baseline_result_id = Some(b.clone());
            }
            if let Some(v) = &p.name {
                m.name = v.clone();
            }
            if let Some(v) = &p.topology {
                m.topology = v.clone();
            }
            if let Some(v) = &p.travel_mm {
                m.travel_mm = v.clone();
            }
            if let Some(v) = &p.site {
                m.site = Some(v.clone());
            }
            if let Some(v) = &p.tags {
                m.tags = v.clone();
            }
            sqlx::query(
                "UPDATE machines SET name = ?2, topology = ?3, travel_mm = ?4, site = ?5, tags = ?6, \
                 baseline_result_id = ?7, updated_at = ?8 WHERE id = ?1",
            )
            .bind(id)
            .bind(&m.name)
            .bind(serde_json::to_string(&m.topology)?)
            .bind(serde_json::to_string(&m.travel_mm)?)
            .bind(&m.site)
            .bind(serde_json::to_string(&m.tags)?)
            .bind(&m.baseline_result_id)
            .bind(now_rfc3339())
            .execute(&self.pool)
            .await?;
            self.machine(id).await
        })
    }

    fn list_machines<'a>(
        &'a self,
        after: Option<&'a str>,
        limit: i64,
    ) -> StoreFuture<'a, Vec<Machine>> {
        Box::pin(async move {
            let q = format!(
                "SELECT {MACHINE_COLUMNS} FROM machines WHERE id > ?1 ORDER BY id LIMIT ?2"
            );
            sqlx::query(sqlx::AssertSqlSafe(q))
                .bind(after.unwrap_or(""))
                .bind(limit)
                .fetch_all(&self.pool)
                .await?
                .iter()
                .map(machine_from_row)
                .collect()
        })
    }

    fn insert_dataset<'a>(&'a self, d: NewDataset) -> StoreFuture<'a, Dataset> {
        Box::pin(async move {
            let id = new_id("ds");
            let mut listing: Vec<(String, String, i64)> = d
                .files
                .iter()
                .map(|(n, b)| (n.clone(), hex::encode(Sha256::digest(b)), b.len() as i64))
                .collect();
            listing.sort();
            let mut manifest = Sha256::new();
            for (n, h, _) in &listing {
                manifest.update(format!("{n}:{h}\n").as_bytes());
            }
            let total: i64 = listing.iter().map(|f| f.2).sum();
            let mut tx = self.pool.begin().await?;
            sqlx::query(
                "INSERT INTO datasets (id, machine_id, kind, measured_at, uploaded_at, samples, \
                 total_bytes, sha256) VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8)",
            )
            .bind(&id)
            .bind(&d.machine_id)
            .bind(&d.kind)
            .bind(&d.measured_at)
            .bind(now_rfc3339())
            .bind(d.samples)
            .bind(total)
            .bind(hex::encode(manifest.finalize()))
            .execute(&mut *tx)
            .await
            .map_err(|e| unique_conflict(e, || format!("dataset of machine {}", d.machine_id)))?;
            for (name, bytes) in &d.files {
                sqlx::query(
                    "INSERT INTO dataset_files (dataset_id, name, sha256, size, content) \
                     VALUES (?1, ?2, ?3, ?4, ?5)",
                )
                .bind(&id)
                .bind(name)
                .bind(hex::encode(Sha256::digest(bytes)))
                .bind(bytes.len() as i64)
                .bind(bytes.as_slice())
                .execute(&mut *tx)
                .await
                .map_err(|e| unique_conflict(e, || format!("file {name} given twice")))?;
            }
            tx.commit().await?;
            self.dataset(&id).await
        })
    }

    fn get_dataset<'a>(&'a self, id: &'a str) -> StoreFuture<'a, Dataset> {
        Box::pin(self.dataset(id))
    }

    fn dataset_file<'a>(&'a self, id: &'a str, name: &'a str) -> StoreFuture<'a, Vec<u8>> {
        Box::pin(async move {
            let row = sqlx::query(
                "SELECT content FROM dataset_files WHERE dataset_id = ?1 AND name = ?2",
            )
            .bind(id)
            .bind(name)
            .fetch_optional(&self.pool)
            .await?
            .ok_or_else(|| StoreError::NotFound(format!("file {name} of dataset {id}")))?;
            Ok(row.try_get("content")?)
        })
    }

    fn dataset_files<'a>(&'a self, id: &'a str) -> StoreFuture<'a, Vec<(String, Vec<u8>)>> {
        Box::pin(async move {
            let rows = sqlx::query(
                "SELECT name, content FROM dataset_files WHERE dataset_id = ?1 ORDER BY name",
            )
            .bind(id)
            .fetch_all(&self.pool)
            .await?;
            if rows.is_empty() {
                return Err(StoreError::NotFound(format!("dataset {id}")));
            }
            rows.iter()
                .map(|r| Ok((r.try_get("name")?, r.try_get("content")?)))
                .collect()
        })
    }

    fn enqueue<'a>(&'a self, j: NewJob) -> StoreFuture<'a, Job> {
        Box::pin(async move {
            let id = new_id("job");
            sqlx::query(
                "INSERT INTO jobs (id, seq, kind, machine_id, dataset_id, params, state, max_attempts, \
                 run_after_ms, created_at) VALUES (?1, (SELECT COALESCE(MAX(seq), 0) + 1 FROM jobs), \
                 ?2, ?3, ?4, ?5, 'queued', ?6, ?7, ?8)",
            )
            .bind(&id)
            .bind(&j.kind)
            .bind(&j.machine_id)
            .bind(&j.dataset_id)
            .bind(serde_json::to_string(&j.params)?)
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
            let mut tx = self.pool.begin().await?;
            let job = job_in(&mut tx, id).await?;
            match job.state {
                JobState::Queued => {
                    sqlx::query(
                        "UPDATE jobs SET state = 'cancelled', finished_at = ?2 WHERE id = ?1",
                    )
                    .bind(id)
                    .bind(now_rfc3339())
                    .execute(&mut *tx)
                    .await?;
                }
                JobState::Running => {
                    sqlx::query("UPDATE jobs SET cancel_requested = 1 WHERE id = ?1")
                        .bind(id)
                        .execute(&mut *tx)
                        .await?;
                }
                s => {
                    return Err(StoreError::Conflict(format!(
                        "job {id} is already {}",
                        s.as_str()
                    )));
                }
            }
            let job = job_in(&mut tx, id).await?;
            tx.commit().await?;
            Ok(job)
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
                             ORDER BY run_after_ms, seq LIMIT 1) \
                 RETURNING {JOB_COLUMNS}"
            );
            let row = sqlx::query(sqlx::AssertSqlSafe(q))
                .bind(worker)
                .bind(now + lease_ms)
                .bind(now_rfc3339())
                .bind(now)
                .fetch_optional(&self.pool)
                .await?;
            row.as_ref().map(job_from_row).transpose()
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
            .await?;
            Ok(match row {
                None => Heartbeat::LeaseLost,
                Some(r) if r.try_get::<i64, _>("cancel_requested")? != 0 => {
                    Heartbeat::CancelRequested
                }
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
            let mut tx = self.pool.begin().await?;
            // Take the lease back first: this write makes the transaction the only writer,
            // and fails when another worker owns the job now.
            let owned = sqlx::query(
                "UPDATE jobs SET progress = 1, progress_message = 'done' \
                 WHERE id = ?1 AND state = 'running' AND lease_owner = ?2 AND cancel_requested = 0",
            )
            .bind(id)
            .bind(worker)
            .execute(&mut *tx)
            .await?;
            if owned.rows_affected() != 1 {
                return Err(StoreError::LeaseLost(id.to_string()));
            }
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
            .await?;
            let job = job_in(&mut tx, id).await?;
            tx.commit().await?;
            Ok(job)
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
            let done =
                match retry_after_ms {
                    Some(delay) => sqlx::query(
                        "UPDATE jobs SET state = 'queued', run_after_ms = ?5, lease_owner = NULL, \
                     lease_expires_ms = NULL, error_code = ?3, error_message = ?4 \
                     WHERE id = ?1 AND state = 'running' AND lease_owner = ?2",
                    )
                    .bind(id)
                    .bind(worker)
                    .bind(code)
                    .bind(message)
                    .bind(now_ms() + delay)
                    .execute(&self.pool)
                    .await?,
                    None => sqlx::query(
                        "UPDATE jobs SET state = 'failed', finished_at = ?5, lease_owner = NULL, \
                     lease_expires_ms = NULL, error_code = ?3, error_message = ?4 \
                     WHERE id = ?1 AND state = 'running' AND lease_owner = ?2",
                    )
                    .bind(id)
                    .bind(worker)
                    .bind(code)
                    .bind(message)
                    .bind(now_rfc3339())
                    .execute(&self.pool)
                    .await?,
                };
            if done.rows_affected() != 1 {
                return Err(StoreError::LeaseLost(id.to_string()));
            }
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
            .await?;
            if done.rows_affected() != 1 {
                return Err(StoreError::LeaseLost(id.to_string()));
            }
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
            .await?;
            Ok(done.rows_affected())
        })
    }

    fn get_result<'a>(&'a self, id: &'a str) -> StoreFuture<'a, StoredResult> {
        Box::pin(async move {
            let q = format!("SELECT {RESULT_COLUMNS}, document FROM results WHERE id = ?1");
            let row = sqlx::query(sqlx::AssertSqlSafe(q))
                .bind(id)
                .fetch_optional(&self.pool)
                .await?
                .ok_or_else(|| StoreError::NotFound(format!("result {id}")))?;
            Ok(StoredResult {
                meta: result_from_row(&row)?,
                document: serde_json::from_str(row.try_get::<&str, _>("document")?)?,
            })
        })
    }

    fn list_results<'a>(
        &'a self,
        machine_id: &'a str,
        kind: &'a str,
    ) -> StoreFuture<'a, Vec<ResultMeta>> {
        Box::pin(async move {
            let q = format!(
                "SELECT {RESULT_COLUMNS} FROM results WHERE machine_id = ?1 AND kind = ?2 \
                 ORDER BY measured_at, id"
            );
            sqlx::query(sqlx::AssertSqlSafe(q))
                .bind(machine_id)
                .bind(kind)
                .fetch_all(&self.pool)
                .await?
                .iter()
                .map(result_from_row)
                .collect()
        })
    }

    fn baseline_pairs<'a>(&'a self, kind: &'a str) -> StoreFuture<'a, Vec<BaselinePair>> {
        Box::pin(async move {
            // Per machine with results of `kind`: count, baseline id (chosen, else first),
            // latest id: index seeks on results(machine_id, kind, measured_at, id).
            const PAIRS: &str = "WITH p AS (SELECT m.id AS mid, \
                 (SELECT COUNT(*) FROM results r WHERE r.machine_id = m.id AND r.kind = ?1) AS n, \
                 COALESCE(m.baseline_result_id, (SELECT r.id FROM results r \
                   WHERE r.machine_id = m.id AND r.kind = ?1 ORDER BY r.measured_at, r.id LIMIT 1)) AS base_id, \
                 (SELECT r.id FROM results r WHERE r.machine_id = m.id AND r.kind = ?1 \
                   ORDER BY r.measured_at DESC, r.id DESC LIMIT 1) AS last_id \
                 FROM machines m) ";
            let pairs = sqlx::query(sqlx::AssertSqlSafe(format!(
                "{PAIRS} SELECT mid, n, base_id, last_id FROM p WHERE n > 0 ORDER BY mid"
            )))
            .bind(kind)
            .fetch_all(&self.pool)
            .await?;
            let metas: std::collections::HashMap<String, ResultMeta> =
                sqlx::query(sqlx::AssertSqlSafe(format!(
                    "{PAIRS} SELECT {RESULT_COLUMNS} FROM results WHERE id IN \
                     (SELECT base_id FROM p WHERE n > 0 UNION SELECT last_id FROM p WHERE n > 0)"
                )))
                .bind(kind)
                .fetch_all(&self.pool)
                .await?
                .iter()
                .map(|r| result_from_row(r).map(|m| (m.id.clone(), m)))
                .collect::<Result<_>>()?;
            let mut machines: std::collections::HashMap<String, Machine> = sqlx::query(
                sqlx::AssertSqlSafe(format!("SELECT {MACHINE_COLUMNS} FROM machines")),
            )
            .fetch_all(&self.pool)
            .await?
            .iter()
            .map(|r| machine_from_row(r).map(|m| (m.id.clone(), m)))
            .collect::<Result<_>>()?;
            let mut out = Vec::with_capacity(pairs.len());
            for row in pairs {
                let mid: String = row.try_get("mid")?;
                let base: String = row.try_get("base_id")?;
                let last: String = row.try_get("last_id")?;
                let get = |id: &str| {
                    metas
                        .get(id)
                        .cloned()
                        .ok_or_else(|| StoreError::NotFound(format!("result {id}")))
                };
                out.push(BaselinePair {
                    baseline: get(&base)?,
                    latest: get(&last)?,
                    results: row.try_get("n")?,
                    machine: machines
                        .remove(&mid)
                        .ok_or_else(|| StoreError::NotFound(format!("machine {mid}")))?,
                });
            }
            Ok(out)
        })
    }

    fn import_result<'a>(&'a self, r: NewResult) -> StoreFuture<'a, ResultMeta> {
        Box::pin(async move {
            let mut tx = self.pool.begin().await?;
            let job_id = new_id("job");
            let now = now_rfc3339();
            sqlx::query(
                "INSERT INTO jobs (id, seq, kind, machine_id, dataset_id, params, state, max_attempts, \
                 run_after_ms, created_at, started_at, finished_at, progress, attempts) \
                 VALUES (?1, (SELECT COALESCE(MAX(seq), 0) + 1 FROM jobs), 'import', ?2, ?3, '{}', \
                 'succeeded', 1, 0, ?4, ?4, ?4, 1, 0)",
            )
            .bind(&job_id)
            .bind(&r.machine_id)
            .bind(&r.dataset_id)
            .bind(&now)
            .execute(&mut *tx)
            .await
            .map_err(|e| unique_conflict(e, || format!("import for machine {}", r.machine_id)))?;
            let meta = insert_result(&mut tx, &job_id, &r).await?;
            sqlx::query("UPDATE jobs SET result_id = ?2 WHERE id = ?1")
                .bind(&job_id)
                .bind(&meta.id)
                .execute(&mut *tx)
                .await?;
            tx.commit().await?;
            Ok(meta)
        })
    }

    fn create_key<'a>(&'a self, scope: Scope, label: &'a str) -> StoreFuture<'a, (ApiKey, String)> {
        Box::pin(async move {
            let secret = keys::generate_secret();
            let key = ApiKey {
                id: new_id("key"),
                prefix: secret[..8].to_string(),
                scope,
                label: label.to_string(),
                created_at: now_rfc3339(),
            };
            sqlx::query(
                "INSERT INTO api_keys (id, hash, prefix, scope, label, created_at) \
                 VALUES (?1, ?2, ?3, ?4, ?5, ?6)",
            )
            .bind(&key.id)
            .bind(keys::hash_secret(&secret))
            .bind(&key.prefix)
            .bind(scope.as_str())
            .bind(&key.label)
            .bind(&key.created_at)
            .execute(&self.pool)
            .await?;
            Ok((key, secret))
        })
    }

    fn key_by_secret<'a>(&'a self, secret: &'a str) -> StoreFuture<'a, Option<ApiKey>> {
        Box::pin(async move {
            let row = sqlx::query(
                "SELECT id, prefix, scope, label, created_at FROM api_keys \
                 WHERE hash = ?1 AND revoked_at IS NULL",
            )
            .bind(keys::hash_secret(secret))
            .fetch_optional(&self.pool)
            .await?;
            row.as_ref().map(key_from_row).transpose()
        })
    }

    fn row_counts(&self) -> StoreFuture<'_, RowCounts> {
        Box::pin(async move {
            let r = sqlx::query(
                "SELECT (SELECT COUNT(*) FROM machines) AS machines, \
                        (SELECT COUNT(*) FROM datasets) AS datasets, \
                        (SELECT COUNT(*) FROM dataset_files) AS dataset_files, \
                        (SELECT COUNT(*) FROM jobs) AS jobs, \
                        (SELECT COUNT(*) FROM results) AS results, \
                        (SELECT COUNT(*) FROM api_keys) AS api_keys",
            )
            .fetch_one(&self.pool)
            .await?;
            Ok(RowCounts {
                machines: r.try_get("machines")?,
                datasets: r.try_get("datasets")?,
                dataset_files: r.try_get("dataset_files")?,
                jobs: r.try_get("jobs")?,
                results: r.try_get("results")?,
                api_keys: r.try_get("api_keys")?,
            })
        })
    }
}
