//! The statements of [`crate::Results`]: results, their figures, and imports (a result
//! born with its succeeded `import` job).

use super::{Backend, Driver, row_by_id};
use crate::error::{Db as _, Result, unique_conflict};
use crate::model::*;
use crate::rows::{self, Columns, MACHINE_COLUMNS, RESULT_COLUMNS};
use crate::rules::{self, ResultRow};
use crate::{Results, StoreFuture, now_rfc3339};
use sqlx::Transaction;

impl Backend {
    pub(super) async fn result_meta(&self, id: &str) -> Result<ResultMeta> {
        let q = format!("SELECT {RESULT_COLUMNS} FROM results WHERE id = $1");
        let row = row_by_id(&self.pool, q, id, "result").await?;
        rows::result_meta(&row)
    }
}

/// Inserts a result row inside `tx`; returns its metadata.
pub(super) async fn insert_result(
    tx: &mut Transaction<'_, Driver>,
    job_id: &str,
    r: &NewResult,
) -> Result<ResultMeta> {
    let row = ResultRow::new(job_id, r)?;
    let (m, s) = (&row.meta, &row.meta.scalars);
    let (gate, statement) = r.check_model.as_ref().map(rules::check_columns).unzip();
    bound!(
        "INSERT INTO results (id, job_id, machine_id, dataset_id, kind, measured_at, created_at, \
         document, residual_rms_um, condition_number, rank, ec0y_urad, eb0z_urad, ea0z_urad, \
         term_coefficients, measured_travel, term_covariance, check_gate, check_statement, \
         excluded_at, excluded_by, excluded_reason) \
         VALUES ($1, $2, $3, $4, $5, $6, $7, $8, $9, $10, $11, $12, $13, $14, $15, $16, $17, \
         $18, $19, \
         (SELECT excluded_at FROM datasets WHERE id = $4), \
         (SELECT excluded_by FROM datasets WHERE id = $4), \
         (SELECT excluded_reason FROM datasets WHERE id = $4))",
        &m.id,
        &m.job_id,
        &m.machine_id,
        &m.dataset_id,
        &m.kind,
        &m.measured_at,
        &m.created_at,
        &row.document,
        s.summary.residual_rms_um,
        s.summary.condition_number,
        s.summary.rank,
        s.summary.ec0y_urad,
        s.summary.eb0z_urad,
        s.summary.ea0z_urad,
        &row.term_coefficients,
        &row.measured_travel,
        &row.term_covariance,
        gate,
        statement.flatten()
    )
    .execute(&mut **tx)
    .await
    .map_err(|e| unique_conflict(e, || format!("result of job {job_id}")))?;
    for f in &r.figures {
        run!(
            execute(&mut **tx),
            "INSERT INTO result_figures (result_id, machine_id, kind, measured_at, name, value, u) \
             VALUES ($1, $2, $3, $4, $5, $6, $7)",
            &m.id,
            &m.machine_id,
            &m.kind,
            &m.measured_at,
            &f.name,
            f.value,
            f.u
        )?;
    }
    if m.dataset_id.is_none() {
        return Ok(row.meta);
    }
    // A result of an excluded dataset lands excluded with the dataset's record.
    let q = format!("SELECT {RESULT_COLUMNS} FROM results WHERE id = $1");
    rows::result_meta(&row_by_id(&mut **tx, q, &m.id, "result").await?)
}

/// Inserts a succeeded `import` job and its result inside `tx` (`seq` 0: an import is
/// never queued).
async fn insert_import(tx: &mut Transaction<'_, Driver>, r: &NewResult) -> Result<ResultMeta> {
    let job_id = rules::new_id("job");
    let now = now_rfc3339();
    bound!(
        "INSERT INTO jobs (id, seq, kind, machine_id, dataset_id, params, state, max_attempts, \
         run_after_ms, created_at, started_at, finished_at, progress, attempts) \
         VALUES ($1, 0, $2, $3, $4, '{}', 'succeeded', 1, 0, $5, $5, $5, 1, 0)",
        &job_id,
        crate::JobKind::Import.as_str(),
        &r.machine_id,
        &r.dataset_id,
        &now
    )
    .execute(&mut **tx)
    .await
    .map_err(|e| unique_conflict(e, || format!("import for machine {}", r.machine_id)))?;
    let meta = insert_result(tx, &job_id, r).await?;
    run!(
        execute(&mut **tx),
        "UPDATE jobs SET result_id = $2 WHERE id = $1",
        &job_id,
        &meta.id
    )?;
    Ok(meta)
}

/// The baseline pairs of the machines (all, or the first `limit` by id after `after`:
/// `batch`) and the ids of the machines read, by id, inside one read snapshot `tx`.
async fn pairs_of(
    tx: &mut Transaction<'static, Driver>,
    kind: &str,
    batch: Option<(&str, i64)>,
) -> Result<(Vec<BaselinePair>, Vec<String>)> {
    // The machines: `$2` and `$3` bound to the batch's bounds (all: none).
    let machines = "(SELECT * FROM machines WHERE id > $2 ORDER BY id LIMIT $3) m";
    let (after, limit) = batch.unwrap_or(("", i64::MAX));
    // Per machine with results of `kind`: count, baseline id (chosen, else first),
    // latest id: index seeks on results(machine_id, kind, measured_at, id).
    let with = format!(
        "WITH p AS (SELECT m.id AS mid, \
         (SELECT COUNT(*) FROM results r WHERE r.machine_id = m.id AND r.kind = $1 \
           AND r.excluded_at IS NULL) AS n, \
         COALESCE((SELECT r.id FROM results r WHERE r.id = m.baseline_result_id \
           AND r.excluded_at IS NULL), (SELECT r.id FROM results r \
           WHERE r.machine_id = m.id AND r.kind = $1 AND r.excluded_at IS NULL \
           ORDER BY r.measured_at, r.created_at, r.id LIMIT 1)) AS base_id, \
         (SELECT r.id FROM results r WHERE r.machine_id = m.id AND r.kind = $1 \
           AND r.excluded_at IS NULL ORDER BY r.measured_at DESC, r.created_at DESC, r.id DESC LIMIT 1) AS last_id \
         FROM {machines}) "
    );
    // One read snapshot for the three queries: a result landing between them must not
    // leave a pair whose result or machine is missing.
    let pairs = run!(
        fetch_all(&mut **tx),
        sqlx::AssertSqlSafe(format!(
            "{with} SELECT mid, n, base_id, last_id FROM p WHERE n > 0 ORDER BY mid"
        )),
        kind,
        after,
        limit
    )?;
    let metas = run!(
        fetch_all(&mut **tx),
        sqlx::AssertSqlSafe(format!(
            "{with} SELECT {RESULT_COLUMNS} FROM results WHERE id IN \
             (SELECT base_id FROM p WHERE n > 0 UNION SELECT last_id FROM p WHERE n > 0)"
        )),
        kind,
        after,
        limit
    )?;
    let machines = run!(
        fetch_all(&mut **tx),
        sqlx::AssertSqlSafe(format!(
            "SELECT {MACHINE_COLUMNS} FROM machines WHERE id > $1 ORDER BY id LIMIT $2"
        )),
        after,
        limit
    )?;
    let ids = machines
        .iter()
        .map(|r| r.text("id"))
        .collect::<Result<Vec<_>>>()?;
    Ok((rows::baseline_pairs(&pairs, &metas, &machines)?, ids))
}

impl Results for Backend {
    fn get_result<'a>(&'a self, id: &'a str) -> StoreFuture<'a, StoredResult> {
        Box::pin(async move {
            let q = format!("SELECT {RESULT_COLUMNS}, document FROM results WHERE id = $1");
            let row = row_by_id(&self.pool, q, id, "result").await?;
            rows::stored_result(&row)
        })
    }

    fn list_results<'a>(
        &'a self,
        machine_id: &'a str,
        kind: &'a str,
    ) -> StoreFuture<'a, Vec<ResultMeta>> {
        Box::pin(async move { Ok(self.list_results_checked(machine_id, kind).await?.0) })
    }

    fn list_results_checked<'a>(
        &'a self,
        machine_id: &'a str,
        kind: &'a str,
    ) -> StoreFuture<'a, (Vec<ResultMeta>, Vec<SkippedRow>)> {
        Box::pin(async move {
            let q = format!(
                "SELECT {RESULT_COLUMNS} FROM results WHERE machine_id = $1 AND kind = $2 \
                 AND excluded_at IS NULL ORDER BY measured_at, created_at, id"
            );
            let rows = run!(
                fetch_all(&self.pool),
                sqlx::AssertSqlSafe(q),
                machine_id,
                kind
            )?;
            Ok(rows::result_meta_checked(&rows))
        })
    }

    fn baseline_pairs<'a>(&'a self, kind: &'a str) -> StoreFuture<'a, Vec<BaselinePair>> {
        Box::pin(async move {
            let mut tx = self.read_snapshot().await?;
            let (pairs, _) = pairs_of(&mut tx, kind, None).await?;
            tx.commit().await.db()?;
            Ok(pairs)
        })
    }

    fn baseline_pairs_after<'a>(
        &'a self,
        kind: &'a str,
        after: Option<&'a str>,
        limit: usize,
    ) -> StoreFuture<'a, PairBatch> {
        Box::pin(async move {
            let limit = i64::try_from(limit).unwrap_or(i64::MAX);
            let mut tx = self.read_snapshot().await?;
            let (pairs, machines) =
                pairs_of(&mut tx, kind, Some((after.unwrap_or(""), limit))).await?;
            tx.commit().await.db()?;
            Ok(PairBatch {
                pairs,
                machines: machines.len(),
                last: machines.last().cloned(),
            })
        })
    }

    fn result_figures<'a>(&'a self, result_id: &'a str) -> StoreFuture<'a, Vec<Figure>> {
        Box::pin(async move {
            self.result_meta(result_id).await?;
            run!(
                fetch_all(&self.pool),
                "SELECT name, value, u FROM result_figures WHERE result_id = $1 ORDER BY name",
                result_id
            )?
            .iter()
            .map(rows::figure)
            .collect()
        })
    }

    fn figure_trend<'a>(
        &'a self,
        machine_id: &'a str,
        name: &'a str,
    ) -> StoreFuture<'a, Vec<FigurePoint>> {
        Box::pin(async move {
            run!(
                fetch_all(&self.pool),
                "SELECT result_id, measured_at, value, u FROM result_figures \
                 WHERE machine_id = $1 AND name = $2 AND result_id NOT IN \
                 (SELECT id FROM results WHERE machine_id = $1 AND excluded_at IS NOT NULL) \
                 ORDER BY measured_at, (SELECT created_at FROM results WHERE id = result_id), \
                 result_id",
                machine_id,
                name
            )?
            .iter()
            .map(rows::figure_point)
            .collect()
        })
    }

    fn figure_names<'a>(&'a self, machine_id: &'a str) -> StoreFuture<'a, Vec<String>> {
        Box::pin(async move {
            run!(
                fetch_all(&self.pool),
                "SELECT DISTINCT name FROM result_figures WHERE machine_id = $1 ORDER BY name",
                machine_id
            )?
            .iter()
            .map(|r| r.text("name"))
            .collect()
        })
    }

    fn exclude_result<'a>(&'a self, id: &'a str, why: SetAside<'a>) -> StoreFuture<'a, ResultMeta> {
        Box::pin(async move {
            let SetAside { by, reason } = why;
            crate::text::check_record(by, reason)?;
            run!(
                execute(&self.pool),
                "UPDATE results SET excluded_at = $2, excluded_by = $3, excluded_reason = $4 \
                 WHERE id = $1 AND excluded_at IS NULL",
                id,
                now_rfc3339(),
                by,
                reason
            )?;
            self.result_meta(id).await
        })
    }

    fn import_result<'a>(&'a self, r: NewResult) -> StoreFuture<'a, ResultMeta> {
        Box::pin(async move {
            let mut tx = self.pool.begin().await.db()?;
            let meta = insert_import(&mut tx, &r).await?;
            tx.commit().await.db()?;
            Ok(meta)
        })
    }

    fn import_explained<'a>(
        &'a self,
        original_id: &'a str,
        r: NewResult,
    ) -> StoreFuture<'a, Option<ResultMeta>> {
        Box::pin(async move {
            let mut tx = self.pool.begin().await.db()?;
            let meta = insert_import(&mut tx, &r).await?;
            // The claim: the unique index on `explains_result_id` refuses a second one
            // (on PostgreSQL a concurrent one waits for the first to commit, then fails).
            let claim = bound!(
                "UPDATE results SET explains_result_id = $2 WHERE id = $1",
                &meta.id,
                original_id
            )
            .execute(&mut *tx)
            .await;
            match claim {
                Ok(_) => {
                    tx.commit().await.db()?;
                    Ok(Some(meta))
                }
                Err(sqlx::Error::Database(d)) if d.is_unique_violation() => {
                    tx.rollback().await.db()?;
                    Ok(None)
                }
                Err(e) => Err(crate::error::db_error(e)),
            }
        })
    }

    fn import_results_bulk<'a>(&'a self, results: &'a [NewResult]) -> StoreFuture<'a, ()> {
        Box::pin(async move {
            let mut tx = self.pool.begin().await.db()?;
            for r in results {
                insert_import(&mut tx, r).await?;
            }
            tx.commit().await.db()
        })
    }

    fn check_models<'a>(
        &'a self,
        machine_id: &'a str,
        kind: &'a str,
    ) -> StoreFuture<'a, Vec<(String, Option<CheckModel>)>> {
        Box::pin(async move {
            run!(
                fetch_all(&self.pool),
                "SELECT id, check_gate, check_statement FROM results \
                 WHERE machine_id = $1 AND kind = $2 AND excluded_at IS NULL",
                machine_id,
                kind
            )?
            .iter()
            .map(|r| Ok((r.text("id")?, stored_check_model(r)?)))
            .collect()
        })
    }

    fn check_model<'a>(&'a self, id: &'a str) -> StoreFuture<'a, Option<CheckModel>> {
        Box::pin(async move {
            let q = "SELECT check_gate, check_statement FROM results WHERE id = $1";
            stored_check_model(&row_by_id(&self.pool, q.into(), id, "result").await?)
        })
    }

    fn unknown_check_models<'a>(&'a self, limit: i64) -> StoreFuture<'a, Vec<String>> {
        Box::pin(async move {
            run!(
                fetch_all(&self.pool),
                "SELECT id FROM results WHERE check_gate IS NULL AND kind = 'identification' \
                 ORDER BY id LIMIT $1",
                limit
            )?
            .iter()
            .map(|r| r.text("id"))
            .collect()
        })
    }

    fn set_check_model<'a>(&'a self, id: &'a str, model: &'a CheckModel) -> StoreFuture<'a, ()> {
        Box::pin(async move {
            let (gate, statement) = rules::check_columns(model);
            run!(
                execute(&self.pool),
                "UPDATE results SET check_gate = $2, check_statement = $3 WHERE id = $1",
                id,
                gate,
                statement
            )?;
            Ok(())
        })
    }
}

/// The check model in a row's `check_gate` and `check_statement` (`None`: not known).
fn stored_check_model(r: &impl Columns) -> Result<Option<CheckModel>> {
    let gate = r.opt_text("check_gate")?;
    Ok(rules::check_model(
        gate.as_deref(),
        r.opt_text("check_statement")?,
    ))
}
