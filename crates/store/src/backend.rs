//! The store's statements and their binding, written once and compiled once per backend
//! (each backend module mounts this file as its `backend` submodule and provides `Db`
//! (the sqlx database), `This` (its store type, with a `pool` field) and `dialect`
//! (the few statements whose SQL differs)). Placeholders are `$N`, which SQLite and
//! PostgreSQL both read; everything else is SQL both dialects share. Rules live in
//! [`crate::rules`] and [`crate::queue`], row decoding in `crate::rows`.

use super::{Db, This, dialect};
use crate::error::{Db as _, Result, StoreError, unique_conflict};
use crate::keys::{ApiKey, NewKey, Scope};
use crate::model::JobKind;
use crate::model::*;
use crate::queue::{Failure, Heartbeat, Lease, Progress, Queue, lease_held};
use crate::rows::{
    self, Columns, DATASET_COLUMNS, DELIVERY_COLUMNS, FLEET_DRIFT_COLUMNS, JOB_COLUMNS,
    KEY_COLUMNS, MACHINE_COLUMNS, RESULT_COLUMNS,
};
use crate::rules::{self, MachineJson, Manifest, ResultRow};
use crate::{Store, StoreFuture, now_rfc3339};
use sqlx::{Executor, Transaction};
use std::collections::HashMap;

/// A pool of at most `size` connections made with `opts` (waiting at most the options'
/// acquire timeout for one), the dialect's migrations applied: the end of every backend's
/// `open_with`.
pub(super) async fn connect(
    opts: <<Db as sqlx::Database>::Connection as sqlx::Connection>::Options,
    size: u32,
    o: &crate::StoreOptions,
) -> Result<sqlx::Pool<Db>> {
    let pool = sqlx::pool::PoolOptions::<Db>::new()
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

impl This {
    async fn machine(&self, id: &str) -> Result<Machine> {
        let q = format!("SELECT {MACHINE_COLUMNS} FROM machines WHERE id = $1");
        let row = row_by_id(&self.pool, q, id, "machine").await?;
        rows::machine(&row)
    }

    async fn dataset(&self, id: &str) -> Result<Dataset> {
        let q = format!("SELECT {DATASET_COLUMNS} FROM datasets WHERE id = $1");
        let row = row_by_id(&self.pool, q, id, "dataset").await?;
        let files = run!(
            fetch_all(&self.pool),
            "SELECT name, sha256, size FROM dataset_files WHERE dataset_id = $1 ORDER BY name",
            id
        )?
        .iter()
        .map(rows::file_meta)
        .collect::<Result<Vec<_>>>()?;
        rows::dataset(&row, files)
    }

    /// Not found, with the record, when dataset `id`'s bytes were deleted (or it is
    /// unknown).
    async fn bytes_kept(&self, id: &str) -> Result<()> {
        let row = row_by_id(
            &self.pool,
            "SELECT deleted_at, deleted_by, deleted_reason FROM datasets WHERE id = $1".into(),
            id,
            "dataset",
        )
        .await?;
        match rows::record(&row, "deleted")? {
            Some(d) => Err(StoreError::NotFound(format!(
                "the bytes of dataset {id} (deleted at {} by {}: {})",
                d.at, d.by, d.reason
            ))),
            None => Ok(()),
        }
    }

    /// Sets dataset `id` aside in one transaction: `mark` (`$1` id, `$2` now, `$3` by,
    /// `$4` reason) records it unless `done_column` is already set; the dataset's results
    /// not yet excluded are then excluded with the dataset's exclusion record, and a
    /// deleted dataset's files lose their bytes. Refused, nothing changed, while a job on
    /// it is queued or running.
    async fn set_aside(
        &self,
        id: &str,
        mark: &'static str,
        done_column: &str,
        why: SetAside<'_>,
    ) -> Result<Dataset> {
        let SetAside { by, reason } = why;
        crate::text::check_record(by, reason)?;
        let mut tx = self.pool.begin().await.db()?;
        // Written first (a read before a write in one transaction would deadlock SQLite
        // writers), guarded in the same statement against jobs that still need the data.
        let marked = run!(
            execute(&mut *tx),
            sqlx::AssertSqlSafe(format!(
                "{mark} AND NOT EXISTS (SELECT 1 FROM jobs WHERE dataset_id = $1 \
             AND state IN ('queued', 'running'))"
            )),
            id,
            now_rfc3339(),
            by,
            reason
        )?;
        if marked.rows_affected() == 0 {
            let q = format!("SELECT {done_column} AS done FROM datasets WHERE id = $1");
            let row = row_by_id(&mut *tx, q, id, "dataset").await?;
            if row.opt_text("done")?.is_none() {
                let job: String = run_scalar!(
                    fetch_optional(&mut *tx),
                    "SELECT id FROM jobs WHERE dataset_id = $1 AND state IN ('queued', 'running') \
                     ORDER BY id LIMIT 1",
                    id
                )?
                .unwrap_or_default();
                tx.rollback().await.db()?;
                return Err(StoreError::Conflict(format!(
                    "job {job} on dataset {id} is queued or running: cancel it \
                     (POST /api/v1/jobs/{job}/cancel) or wait for it to finish, then try again"
                )));
            }
        }
        run!(
            execute(&mut *tx),
            "UPDATE results SET \
             excluded_at = (SELECT excluded_at FROM datasets WHERE id = $1), \
             excluded_by = (SELECT excluded_by FROM datasets WHERE id = $1), \
             excluded_reason = (SELECT excluded_reason FROM datasets WHERE id = $1) \
             WHERE dataset_id = $1 AND excluded_at IS NULL",
            id
        )?;
        run!(
            execute(&mut *tx),
            "UPDATE dataset_files SET content = $2 WHERE dataset_id = $1 \
             AND (SELECT deleted_at FROM datasets WHERE id = $1) IS NOT NULL",
            id,
            Vec::<u8>::new()
        )?;
        tx.commit().await.db()?;
        let d = self.dataset(id).await?;
        if d.deleted.is_some() && !dialect::AFTER_BYTES_DELETED.is_empty() {
            sqlx::query(dialect::AFTER_BYTES_DELETED)
                .execute(&self.pool)
                .await
                .db()?;
        }
        Ok(d)
    }

    /// A transaction whose reads are one snapshot ([`dialect::BEGIN_SNAPSHOT`]).
    async fn read_snapshot(&self) -> Result<Transaction<'static, Db>> {
        if dialect::BEGIN_SNAPSHOT.is_empty() {
            self.pool.begin().await.db()
        } else {
            self.pool.begin_with(dialect::BEGIN_SNAPSHOT).await.db()
        }
    }

    async fn result_meta(&self, id: &str) -> Result<ResultMeta> {
        let q = format!("SELECT {RESULT_COLUMNS} FROM results WHERE id = $1");
        let row = row_by_id(&self.pool, q, id, "result").await?;
        rows::result_meta(&row)
    }
}

/// The row `sql` selects with `$1` = `id`, or not found (`what id`). An id with a NUL
/// character names nothing (no stored text holds one; PostgreSQL would refuse the value),
/// so both backends answer it as not found without asking.
async fn row_by_id<'e>(
    ex: impl Executor<'e, Database = Db>,
    sql: String,
    id: &str,
    what: &str,
) -> Result<<Db as sqlx::Database>::Row> {
    if id.contains('\0') {
        return Err(StoreError::NotFound(format!(
            "{what} {}",
            id.escape_debug()
        )));
    }
    run!(fetch_optional(ex), sqlx::AssertSqlSafe(sql), id)?
        .ok_or_else(|| StoreError::NotFound(format!("{what} {id}")))
}

/// Stores a machine's fleet row unless the stored one was computed from a later read;
/// returns whether it was stored.
async fn upsert_fleet_drift<'e>(
    ex: impl Executor<'e, Database = Db>,
    row: &FleetDriftRow,
) -> Result<bool> {
    let done = run!(
        execute(ex),
        "INSERT INTO fleet_drift (machine_id, read_at_ms, drift_um, drift_urad, entry, \
         latest_measured_at, basis) \
         VALUES ($1, $2, $3, $4, $5, $6, $7) ON CONFLICT (machine_id) DO UPDATE SET \
         read_at_ms = EXCLUDED.read_at_ms, drift_um = EXCLUDED.drift_um, \
         drift_urad = EXCLUDED.drift_urad, entry = EXCLUDED.entry, \
         latest_measured_at = EXCLUDED.latest_measured_at, basis = EXCLUDED.basis \
         WHERE fleet_drift.read_at_ms <= EXCLUDED.read_at_ms",
        &row.machine_id,
        row.read_at_ms,
        row.drift_um,
        row.drift_urad,
        serde_json::to_string(&row.entry).db()?,
        &row.latest_measured_at,
        &row.basis
    )?;
    Ok(done.rows_affected() == 1)
}

/// The fleet page's filter on machines `m`, as SQL conditions with placeholders from `$1`
/// and their values: the site; the tag matched whole in the machine's JSON tag list
/// (the quoted tag, LIKE's wildcards escaped).
fn fleet_filter(q: &FleetPageQuery) -> Result<(String, Vec<String>)> {
    let (mut conditions, mut values) = (vec!["1 = 1".to_string()], Vec::new());
    if let Some(site) = &q.site {
        values.push(site.clone());
        conditions.push(format!("m.site = ${}", values.len()));
    }
    if let Some(tag) = &q.tag {
        let quoted = serde_json::to_string(tag).db()?;
        let escaped = quoted
            .replace('!', "!!")
            .replace('%', "!%")
            .replace('_', "!_");
        values.push(format!("%{escaped}%"));
        conditions.push(format!("m.tags LIKE ${} ESCAPE '!'", values.len()));
    }
    Ok((conditions.join(" AND "), values))
}

/// The fleet order's key in `fleet_drift` and the index that holds it in the page's
/// order (largest first, ties by machine id); None for the order by machine id.
fn fleet_key(sort: FleetSort) -> Option<(&'static str, &'static str)> {
    match sort {
        FleetSort::DriftUm => Some(("drift_um", "fleet_drift_um")),
        FleetSort::DriftUrad => Some(("drift_urad", "fleet_drift_urad")),
        FleetSort::LastCheck => Some(("latest_measured_at", "fleet_drift_last_check")),
        FleetSort::Name => None,
    }
}

/// The fleet page's machines without an active alert that the filter keeps, in the
/// page's order, as statements that walk an index and stop after the page: with a key,
/// the machines that have it (key descending, ties by id), then `unkeyed`, those that
/// do not (no drift row yet, or an older row without the key), by id; without a key
/// (the order by id), every machine by id. The order is the one of
/// `ORDER BY f.key DESC NULLS LAST, m.id` over all of them.
struct FleetWalk {
    /// `FROM … WHERE …` of the walk.
    from: String,
    /// The walk's order.
    order: String,
    /// The machines without the key, ordered (`LIMIT` and `OFFSET` to add).
    unkeyed: Option<String>,
}

impl FleetWalk {
    const NOT_ALERTED: &str = "NOT EXISTS (SELECT 1 FROM alerts al \
         WHERE al.machine_id = m.id AND al.acknowledged_at IS NULL)";

    fn new(key: Option<(&str, &str)>, filter: &str) -> FleetWalk {
        let not_alerted = Self::NOT_ALERTED;
        match key {
            Some((k, index)) => FleetWalk {
                from: format!(
                    "FROM {} JOIN machines m ON m.id = f.machine_id \
                     WHERE f.{k} IS NOT NULL AND {filter} AND {not_alerted}",
                    dialect::walk("fleet_drift f", index)
                ),
                order: format!("f.{k} DESC, f.machine_id"),
                unkeyed: Some(format!(
                    "SELECT m.id AS id FROM machines m WHERE {filter} AND {not_alerted} \
                     AND NOT EXISTS (SELECT 1 FROM fleet_drift f \
                       WHERE f.machine_id = m.id AND f.{k} IS NOT NULL) \
                     ORDER BY m.id"
                )),
            },
            None => FleetWalk {
                from: format!("FROM machines m WHERE {filter} AND {not_alerted}"),
                order: "m.id".into(),
                unkeyed: None,
            },
        }
    }

    /// The ids of `limit` machines of the walk after the first `offset`.
    fn keyed(&self, limit: usize, offset: usize) -> String {
        let (from, order) = (&self.from, &self.order);
        let id = if self.unkeyed.is_some() {
            "f.machine_id"
        } else {
            "m.id"
        };
        format!("SELECT {id} AS id {from} ORDER BY {order} LIMIT {limit} OFFSET {offset}")
    }

    /// How many machines the walk holds (column `n`).
    fn count_keyed(&self) -> String {
        format!("SELECT COUNT(*) AS n {}", self.from)
    }
}

/// The distinct values of the machines' indexed column `column` (not NULL; columns `v`
/// and `col` = `name`), by a walk of its index that jumps from one value to the next: one
/// probe per value, not a read of every machine's entry.
fn distinct_machines(column: &str, name: &str) -> String {
    let d = format!("d_{name}");
    format!(
        "SELECT * FROM (WITH RECURSIVE {d}(v) AS (SELECT MIN({column}) FROM machines \
         UNION ALL SELECT (SELECT MIN({column}) FROM machines WHERE {column} > {d}.v) \
         FROM {d} WHERE {d}.v IS NOT NULL) \
         SELECT v, '{name}' AS col FROM {d} WHERE v IS NOT NULL) AS {d}_values"
    )
}

/// Statement `sql` with `values` bound to `$1`, `$2`, … in order.
fn bound(
    sql: String,
    values: &[String],
) -> sqlx::query::Query<'_, Db, <Db as sqlx::Database>::Arguments> {
    values
        .iter()
        .fold(sqlx::query(sqlx::AssertSqlSafe(sql)), |q, v| q.bind(v))
}

/// The `id` column of the rows `sql` selects with `values` bound.
async fn ids<'e>(
    sql: String,
    values: &[String],
    ex: impl Executor<'e, Database = Db>,
) -> Result<Vec<String>> {
    bound(sql, values)
        .fetch_all(ex)
        .await
        .db()?
        .iter()
        .map(|r| r.text("id"))
        .collect()
}

/// `columns` (comma-separated) each prefixed with table alias `alias`.
fn qualified(alias: &str, columns: &str) -> String {
    columns
        .split(',')
        .map(|c| format!("{alias}.{}", c.trim()))
        .collect::<Vec<_>>()
        .join(", ")
}

/// Inserts a result row inside `tx`; returns its metadata.
async fn insert_result(
    tx: &mut Transaction<'_, Db>,
    job_id: &str,
    r: &NewResult,
) -> Result<ResultMeta> {
    let row = ResultRow::new(job_id, r)?;
    let (m, s) = (&row.meta, &row.meta.scalars);
    bound!(
        "INSERT INTO results (id, job_id, machine_id, dataset_id, kind, measured_at, created_at, \
         document, residual_rms_um, condition_number, rank, ec0y_urad, eb0z_urad, ea0z_urad, \
         term_coefficients, measured_travel, term_covariance, \
         excluded_at, excluded_by, excluded_reason) \
         VALUES ($1, $2, $3, $4, $5, $6, $7, $8, $9, $10, $11, $12, $13, $14, $15, $16, $17, \
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
        &row.term_covariance
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
async fn insert_import(tx: &mut Transaction<'_, Db>, r: &NewResult) -> Result<ResultMeta> {
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

impl Store for This {
    fn create_machine<'a>(&'a self, m: &'a Machine) -> StoreFuture<'a, Machine> {
        Box::pin(async move {
            crate::text::check_machine(m)?;
            let now = now_rfc3339();
            let json = MachineJson::of(m)?;
            bound!("INSERT INTO machines (id, name, topology, travel_mm, site, tags, \
                 baseline_result_id, created_at, updated_at) VALUES ($1, $2, $3, $4, $5, $6, NULL, $7, $7)", &m.id, &m.name, &json.topology, &json.travel_mm, &m.site, &json.tags, &now)
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
            let baseline = match &p.baseline_result_id {
                Some(b) => Some(self.result_meta(b).await?),
                None => None,
            };
            rules::apply_patch(&mut m, p, baseline.as_ref())?;
            crate::text::check_machine(&m)?;
            let json = MachineJson::of(&m)?;
            run!(
                execute(&self.pool),
                "UPDATE machines SET name = $2, topology = $3, travel_mm = $4, site = $5, tags = $6, \
                 baseline_result_id = $7, updated_at = $8 WHERE id = $1",
                id,
                &m.name,
                &json.topology,
                &json.travel_mm,
                &m.site,
                &json.tags,
                &m.baseline_result_id,
                now_rfc3339()
            )?;
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
                "SELECT {MACHINE_COLUMNS} FROM machines WHERE id > $1 ORDER BY id LIMIT $2"
            );
            run!(
                fetch_all(&self.pool),
                sqlx::AssertSqlSafe(q),
                after.unwrap_or(""),
                limit
            )?
            .iter()
            .map(rows::machine)
            .collect()
        })
    }

    fn insert_dataset<'a>(&'a self, d: NewDataset) -> StoreFuture<'a, Dataset> {
        Box::pin(async move {
            let id = rules::new_id("ds");
            let manifest = Manifest::of(&d.files);
            let mut tx = self.pool.begin().await.db()?;
            // The same files with the same bytes for the same machine: a repeated upload,
            // whose second copy would count the check twice in every trend. One statement
            // (a read followed by a write in one transaction would deadlock SQLite writers).
            let inserted = bound!(
                "INSERT INTO datasets (id, machine_id, kind, measured_at, uploaded_at, samples, \
                 total_bytes, sha256) SELECT $1, $2, $3, $4, $5, $6, $7, $8 WHERE NOT EXISTS \
                 (SELECT 1 FROM datasets WHERE machine_id = $2 AND sha256 = $8 \
                 AND excluded_at IS NULL)",
                &id,
                &d.machine_id,
                &d.kind,
                &d.measured_at,
                now_rfc3339(),
                d.samples,
                manifest.total_bytes,
                &manifest.sha256
            )
            .execute(&mut *tx)
            .await
            .map_err(|e| unique_conflict(e, || format!("dataset of machine {}", d.machine_id)))?;
            if inserted.rows_affected() == 0 {
                tx.rollback().await.db()?;
                let e: String = run_scalar!(
                    fetch_one(&self.pool),
                    "SELECT id FROM datasets WHERE machine_id = $1 AND sha256 = $2 \
                     AND excluded_at IS NULL ORDER BY id LIMIT 1",
                    &d.machine_id,
                    &manifest.sha256
                )?;
                return Err(StoreError::Conflict(format!(
                    "this upload is identical to dataset {e} of machine {} (the same files with \
                     the same bytes): submit a new job on {e} instead of uploading it again",
                    d.machine_id
                )));
            }
            for (name, bytes) in &d.files {
                let meta = manifest
                    .files
                    .iter()
                    .find(|f| &f.name == name)
                    .ok_or_else(|| StoreError::Backend(format!("file {name} not in manifest")))?;
                bound!(
                    "INSERT INTO dataset_files (dataset_id, name, sha256, size, content) \
                     VALUES ($1, $2, $3, $4, $5)",
                    &id,
                    name,
                    &meta.sha256,
                    meta.size,
                    bytes.as_slice()
                )
                .execute(&mut *tx)
                .await
                .map_err(|e| unique_conflict(e, || format!("file {name} given twice")))?;
            }
            tx.commit().await.db()?;
            self.dataset(&id).await
        })
    }

    fn get_dataset<'a>(&'a self, id: &'a str) -> StoreFuture<'a, Dataset> {
        Box::pin(self.dataset(id))
    }

    fn dataset_file<'a>(&'a self, id: &'a str, name: &'a str) -> StoreFuture<'a, Vec<u8>> {
        Box::pin(async move {
            self.bytes_kept(id).await?;
            let row = run!(
                fetch_optional(&self.pool),
                "SELECT content FROM dataset_files WHERE dataset_id = $1 AND name = $2",
                id,
                name
            )?
            .ok_or_else(|| StoreError::NotFound(format!("file {name} of dataset {id}")))?;
            rows::Columns::bytes(&row, "content")
        })
    }

    fn dataset_files<'a>(&'a self, id: &'a str) -> StoreFuture<'a, Vec<(String, Vec<u8>)>> {
        Box::pin(async move {
            self.bytes_kept(id).await?;
            let rows = run!(
                fetch_all(&self.pool),
                "SELECT name, content FROM dataset_files WHERE dataset_id = $1 ORDER BY name",
                id
            )?;
            if rows.is_empty() {
                return Err(StoreError::NotFound(format!("dataset {id}")));
            }
            rows.iter().map(rows::name_and_content).collect()
        })
    }

    fn list_datasets<'a>(
        &'a self,
        machine_id: &'a str,
        include_excluded: bool,
    ) -> StoreFuture<'a, Vec<Dataset>> {
        Box::pin(async move {
            let shown = if include_excluded {
                ""
            } else {
                " AND excluded_at IS NULL"
            };
            let q = format!(
                "SELECT {DATASET_COLUMNS} FROM datasets WHERE machine_id = $1{shown} \
                 ORDER BY measured_at, uploaded_at, id"
            );
            let found = run!(fetch_all(&self.pool), sqlx::AssertSqlSafe(q), machine_id)?;
            let q = format!(
                "SELECT dataset_id, name, sha256, size FROM dataset_files WHERE dataset_id IN \
                 (SELECT id FROM datasets WHERE machine_id = $1{shown}) ORDER BY dataset_id, name"
            );
            let mut files: std::collections::HashMap<String, Vec<FileMeta>> = Default::default();
            for r in run!(fetch_all(&self.pool), sqlx::AssertSqlSafe(q), machine_id)? {
                files
                    .entry(r.text("dataset_id")?)
                    .or_default()
                    .push(rows::file_meta(&r)?);
            }
            found
                .iter()
                .map(|r| rows::dataset(r, files.remove(&r.text("id")?).unwrap_or_default()))
                .collect()
        })
    }

    fn exclude_dataset<'a>(&'a self, id: &'a str, why: SetAside<'a>) -> StoreFuture<'a, Dataset> {
        Box::pin(self.set_aside(
            id,
            "UPDATE datasets SET excluded_at = $2, excluded_by = $3, excluded_reason = $4 \
             WHERE id = $1 AND excluded_at IS NULL",
            "excluded_at",
            why,
        ))
    }

    fn delete_dataset_files<'a>(
        &'a self,
        id: &'a str,
        why: SetAside<'a>,
    ) -> StoreFuture<'a, Dataset> {
        // Every right-hand side reads the row as it was: an earlier exclusion is kept.
        Box::pin(self.set_aside(
            id,
            "UPDATE datasets SET deleted_at = $2, deleted_by = $3, deleted_reason = $4, \
             excluded_at = COALESCE(excluded_at, $2), \
             excluded_by = CASE WHEN excluded_at IS NULL THEN $3 ELSE excluded_by END, \
             excluded_reason = CASE WHEN excluded_at IS NULL THEN $4 ELSE excluded_reason END \
             WHERE id = $1 AND deleted_at IS NULL",
            "deleted_at",
            why,
        ))
    }

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
            // Per machine with results of `kind`: count, baseline id (chosen, else first),
            // latest id: index seeks on results(machine_id, kind, measured_at, id).
            const PAIRS: &str = "WITH p AS (SELECT m.id AS mid, \
                 (SELECT COUNT(*) FROM results r WHERE r.machine_id = m.id AND r.kind = $1 \
                   AND r.excluded_at IS NULL) AS n, \
                 COALESCE((SELECT r.id FROM results r WHERE r.id = m.baseline_result_id \
                   AND r.excluded_at IS NULL), (SELECT r.id FROM results r \
                   WHERE r.machine_id = m.id AND r.kind = $1 AND r.excluded_at IS NULL \
                   ORDER BY r.measured_at, r.created_at, r.id LIMIT 1)) AS base_id, \
                 (SELECT r.id FROM results r WHERE r.machine_id = m.id AND r.kind = $1 \
                   AND r.excluded_at IS NULL ORDER BY r.measured_at DESC, r.created_at DESC, r.id DESC LIMIT 1) AS last_id \
                 FROM machines m) ";
            // One read snapshot for the three queries: a result landing between them
            // must not leave a pair whose result or machine is missing.
            let mut tx = self.read_snapshot().await?;
            let pairs = run!(
                fetch_all(&mut *tx),
                sqlx::AssertSqlSafe(format!(
                    "{PAIRS} SELECT mid, n, base_id, last_id FROM p WHERE n > 0 ORDER BY mid"
                )),
                kind
            )?;
            let metas = run!(
                fetch_all(&mut *tx),
                sqlx::AssertSqlSafe(format!(
                    "{PAIRS} SELECT {RESULT_COLUMNS} FROM results WHERE id IN \
                 (SELECT base_id FROM p WHERE n > 0 UNION SELECT last_id FROM p WHERE n > 0)"
                )),
                kind
            )?;
            let machines = sqlx::query(sqlx::AssertSqlSafe(format!(
                "SELECT {MACHINE_COLUMNS} FROM machines"
            )))
            .fetch_all(&mut *tx)
            .await
            .db()?;
            tx.commit().await.db()?;
            rows::baseline_pairs(&pairs, &metas, &machines)
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

    fn put_fleet_drift<'a>(&'a self, row: &'a FleetDriftRow) -> StoreFuture<'a, bool> {
        Box::pin(async move { upsert_fleet_drift(&self.pool, row).await })
    }

    fn put_fleet_drifts<'a>(&'a self, rows: &'a [FleetDriftRow]) -> StoreFuture<'a, usize> {
        Box::pin(async move {
            let mut tx = self.pool.begin().await.db()?;
            let mut stored = 0;
            for row in rows {
                stored += usize::from(upsert_fleet_drift(&mut *tx, row).await?);
            }
            tx.commit().await.db()?;
            Ok(stored)
        })
    }

    fn fleet_drift_bases(&self) -> StoreFuture<'_, Vec<(String, Option<String>)>> {
        Box::pin(async move {
            sqlx::query("SELECT machine_id, basis FROM fleet_drift")
                .fetch_all(&self.pool)
                .await
                .db()?
                .iter()
                .map(|r| Ok((r.text("machine_id")?, r.opt_text("basis")?)))
                .collect()
        })
    }

    fn delete_fleet_drift<'a>(&'a self, machine_id: &'a str) -> StoreFuture<'a, ()> {
        Box::pin(async move {
            run!(
                execute(&self.pool),
                "DELETE FROM fleet_drift WHERE machine_id = $1",
                machine_id
            )?;
            Ok(())
        })
    }

    fn fleet_drift_ranked(
        &self,
        by_um: bool,
        limit: usize,
    ) -> StoreFuture<'_, Vec<(FleetDriftRow, String, Option<String>)>> {
        Box::pin(async move {
            let order = if by_um { "drift_um" } else { "drift_urad" };
            let q = format!(
                "SELECT {}, m.name, m.site \
                 FROM fleet_drift f JOIN machines m ON m.id = f.machine_id \
                 ORDER BY f.{order} DESC, f.machine_id LIMIT $1",
                qualified("f", FLEET_DRIFT_COLUMNS)
            );
            let rows = run!(
                fetch_all(&self.pool),
                sqlx::AssertSqlSafe(q),
                i64::try_from(limit).unwrap_or(i64::MAX)
            )?;
            rows.iter()
                .map(|r| Ok((rows::fleet_drift(r)?, r.text("name")?, r.opt_text("site")?)))
                .collect()
        })
    }

    fn fleet_page<'a>(&'a self, q: &'a FleetPageQuery) -> StoreFuture<'a, FleetPage> {
        Box::pin(async move {
            let (filter, binds) = fleet_filter(q)?;
            let key = fleet_key(q.sort);
            let offset = usize::try_from(q.offset).unwrap_or(0);
            let limit = usize::try_from(q.limit).unwrap_or(0);
            // One read snapshot: an alert raised or acknowledged between the statements
            // must not show a machine twice or leave it out.
            let mut tx = self.read_snapshot().await?;
            // 1. The machines with active alerts (few: alerts are acknowledged), all of
            //    those the filter keeps, in the page's order: they come first.
            let order = match key {
                Some((k, _)) => format!("f.{k} DESC NULLS LAST, m.id"),
                None => "m.id".into(),
            };
            let alerted = bound(
                format!(
                    "SELECT m.id AS id, a.n AS n FROM (SELECT machine_id, COUNT(*) AS n \
                     FROM alerts WHERE acknowledged_at IS NULL GROUP BY machine_id) a \
                     JOIN machines m ON m.id = a.machine_id \
                     LEFT JOIN fleet_drift f ON f.machine_id = m.id \
                     WHERE {filter} ORDER BY {order}"
                ),
                &binds,
            )
            .fetch_all(&mut *tx)
            .await
            .db()?
            .iter()
            .map(|r| Ok((r.text("id")?, r.int("n")?)))
            .collect::<Result<Vec<_>>>()?;
            let mut page: Vec<(String, i64)> =
                alerted.iter().skip(offset).take(limit).cloned().collect();
            // 2. The others, walked in the order of an index and stopped once the page
            //    is full (no sort of the whole fleet): those with the sort key, then
            //    (sorts by a key some machines lack) those without it, by id.
            let skip = offset.saturating_sub(alerted.len());
            let need = limit - page.len();
            if need > 0 {
                let walk = FleetWalk::new(key, &filter);
                let keyed = ids(walk.keyed(need, skip), &binds, &mut *tx).await?;
                let got = keyed.len();
                page.extend(keyed.into_iter().map(|id| (id, 0)));
                if let Some(unkeyed) = &walk.unkeyed
                    && got < need
                {
                    // The walk ran out: it held `skip + got` machines unless it started
                    // past its end.
                    let walked = if got == 0 && skip > 0 {
                        let n: i64 = bound(walk.count_keyed(), &binds)
                            .fetch_one(&mut *tx)
                            .await
                            .db()?
                            .int("n")?;
                        usize::try_from(n).unwrap_or(0)
                    } else {
                        skip + got
                    };
                    let sql = format!(
                        "{unkeyed} LIMIT {} OFFSET {}",
                        need - got,
                        skip.saturating_sub(walked)
                    );
                    page.extend(
                        ids(sql, &binds, &mut *tx)
                            .await?
                            .into_iter()
                            .map(|id| (id, 0)),
                    );
                }
            }
            // 3. Only the page's rows are read whole (a machine's entry is kilobytes), by
            //    id from each table (a join would let a planner scan the drift rows).
            let page_ids: Vec<String> = page.iter().map(|(id, _)| id.clone()).collect();
            let list = (1..=page.len())
                .map(|i| format!("${i}"))
                .collect::<Vec<_>>()
                .join(", ");
            let (mut machines, mut drifts) = (HashMap::new(), HashMap::new());
            if !page.is_empty() {
                let sql = format!("SELECT {MACHINE_COLUMNS} FROM machines WHERE id IN ({list})");
                for r in bound(sql, &page_ids).fetch_all(&mut *tx).await.db()? {
                    let m = rows::machine(&r)?;
                    machines.insert(m.id.clone(), m);
                }
                let sql = format!(
                    "SELECT {FLEET_DRIFT_COLUMNS} FROM fleet_drift WHERE machine_id IN ({list})"
                );
                for r in bound(sql, &page_ids).fetch_all(&mut *tx).await.db()? {
                    let d = rows::fleet_drift(&r)?;
                    drifts.insert(d.machine_id.clone(), d);
                }
            }
            // 4. The machines without a drift row (no identification): each one's latest
            //    result of another kind, one index seek each, in one statement.
            let lacking: Vec<String> = page_ids
                .iter()
                .filter(|id| !drifts.contains_key(*id))
                .cloned()
                .collect();
            let mut others = HashMap::new();
            if !lacking.is_empty() {
                let sql = (1..=lacking.len())
                    .map(|i| {
                        format!(
                            "SELECT * FROM (SELECT id, machine_id, kind, measured_at FROM results \
                             WHERE machine_id = ${i} AND excluded_at IS NULL \
                             ORDER BY measured_at DESC, created_at DESC, id DESC LIMIT 1) AS r{i}"
                        )
                    })
                    .collect::<Vec<_>>()
                    .join(" UNION ALL ");
                for r in bound(sql, &lacking).fetch_all(&mut *tx).await.db()? {
                    others.insert(
                        r.text("machine_id")?,
                        LastCheck {
                            result_id: r.text("id")?,
                            kind: r.text("kind")?,
                            measured_at: r.text("measured_at")?,
                        },
                    );
                }
            }
            let rows = page
                .into_iter()
                .filter_map(|(id, active_alerts)| {
                    Some(FleetPageRow {
                        drift: drifts.remove(&id),
                        other_check: others.remove(&id),
                        machine: machines.remove(&id)?,
                        active_alerts,
                    })
                })
                .collect();
            let total = bound(
                format!("SELECT COUNT(*) AS n FROM machines m WHERE {filter}"),
                &binds,
            )
            .fetch_one(&mut *tx)
            .await
            .db()?
            .int("n")?;
            let (mut sites, mut tag_lists) = (Vec::new(), Vec::new());
            let sql = format!(
                "{} UNION ALL {}",
                distinct_machines("site", "site"),
                distinct_machines("tags", "tags")
            );
            for r in sqlx::query(sqlx::AssertSqlSafe(sql))
                .fetch_all(&mut *tx)
                .await
                .db()?
            {
                match r.text("col")?.as_str() {
                    "site" => sites.push(r.text("v")?),
                    _ => tag_lists.push(r.text("v")?),
                }
            }
            sites.sort();
            tx.commit().await.db()?;
            let mut tags = Vec::new();
            for t in &tag_lists {
                tags.extend(serde_json::from_str::<Vec<String>>(t).db()?);
            }
            tags.sort();
            tags.dedup();
            Ok(FleetPage {
                rows,
                total,
                sites,
                tags,
            })
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

    fn import_results_bulk<'a>(&'a self, results: &'a [NewResult]) -> StoreFuture<'a, ()> {
        Box::pin(async move {
            let mut tx = self.pool.begin().await.db()?;
            for r in results {
                insert_import(&mut tx, r).await?;
            }
            tx.commit().await.db()
        })
    }

    fn create_key<'a>(&'a self, scope: Scope, label: &'a str) -> StoreFuture<'a, (ApiKey, String)> {
        Box::pin(async move {
            crate::text::check_line("label", label, crate::text::LABEL_MAX)?;
            let k = NewKey::generate(scope, label);
            run!(
                execute(&self.pool),
                "INSERT INTO api_keys (id, hash, prefix, scope, label, created_at) \
                 VALUES ($1, $2, $3, $4, $5, $6)",
                &k.key.id,
                &k.hash,
                &k.key.prefix,
                scope.as_str(),
                &k.key.label,
                &k.key.created_at
            )?;
            Ok((k.key, k.secret))
        })
    }

    fn key_by_secret<'a>(&'a self, secret: &'a str) -> StoreFuture<'a, Option<ApiKey>> {
        Box::pin(async move {
            let q = format!(
                "SELECT {KEY_COLUMNS} FROM api_keys WHERE hash = $1 AND revoked_at IS NULL"
            );
            let row = run!(
                fetch_optional(&self.pool),
                sqlx::AssertSqlSafe(q),
                crate::keys::hash_secret(secret)
            )?;
            row.as_ref().map(rows::api_key).transpose()
        })
    }

    fn list_keys(&self) -> StoreFuture<'_, Vec<ApiKey>> {
        Box::pin(async move {
            let q = format!("SELECT {KEY_COLUMNS} FROM api_keys ORDER BY created_at, id");
            sqlx::query(sqlx::AssertSqlSafe(q))
                .fetch_all(&self.pool)
                .await
                .db()?
                .iter()
                .map(rows::api_key)
                .collect()
        })
    }

    fn revoke_key<'a>(&'a self, id: &'a str) -> StoreFuture<'a, ApiKey> {
        Box::pin(async move {
            let mut tx = self.pool.begin().await.db()?;
            if !dialect::LOCK_KEYS.is_empty() {
                sqlx::query(dialect::LOCK_KEYS)
                    .execute(&mut *tx)
                    .await
                    .db()?;
            }
            // One statement: the last admin key that is not revoked stays.
            let done = run!(
                execute(&mut *tx),
                "UPDATE api_keys SET revoked_at = $2 WHERE id = $1 AND revoked_at IS NULL \
                 AND (scope <> 'admin' OR (SELECT COUNT(*) FROM api_keys \
                      WHERE scope = 'admin' AND revoked_at IS NULL) > 1)",
                id,
                now_rfc3339()
            )?;
            let q = format!("SELECT {KEY_COLUMNS} FROM api_keys WHERE id = $1");
            let key = rows::api_key(&row_by_id(&mut *tx, q, id, "key").await?)?;
            // Its sign-in sessions end with it.
            run!(
                execute(&mut *tx),
                "DELETE FROM sessions WHERE key_id = $1 AND $2 = 1",
                id,
                i64::from(key.revoked_at.is_some())
            )?;
            if done.rows_affected() == 0 && key.revoked_at.is_none() {
                tx.rollback().await.db()?;
                return Err(StoreError::Conflict(format!(
                    "key {id} is the last admin key: create another admin key before revoking it"
                )));
            }
            tx.commit().await.db()?;
            Ok(key)
        })
    }

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

    fn create_tolerance<'a>(
        &'a self,
        p: &'a ToleranceProfile,
    ) -> StoreFuture<'a, ToleranceProfile> {
        Box::pin(async move {
            crate::text::check_line("target", &p.target, crate::text::TARGET_MAX)?;
            let now = now_rfc3339();
            bound!(
                "INSERT INTO tolerance_profiles (id, scope, target, limits, webhook_url, \
                 webhook_secret, created_at, updated_at) VALUES ($1, $2, $3, $4, $5, $6, $7, $7)",
                &p.id,
                &p.scope,
                &p.target,
                serde_json::to_string(&p.limits).db()?,
                &p.webhook_url,
                &p.webhook_secret,
                &now
            )
            .execute(&self.pool)
            .await
            .map_err(|e| {
                unique_conflict(e, || {
                    format!("{} {} already has a tolerance profile", p.scope, p.target)
                })
            })?;
            self.get_tolerance(&p.id).await
        })
    }

    fn get_tolerance<'a>(&'a self, id: &'a str) -> StoreFuture<'a, ToleranceProfile> {
        Box::pin(async move {
            let q = format!(
                "SELECT {} FROM tolerance_profiles WHERE id = $1",
                rows::TOLERANCE_COLUMNS
            );
            rows::tolerance(&row_by_id(&self.pool, q, id, "tolerance profile").await?)
        })
    }

    fn list_tolerances(&self) -> StoreFuture<'_, Vec<ToleranceProfile>> {
        Box::pin(async move {
            let q = format!(
                "SELECT {} FROM tolerance_profiles ORDER BY scope, target",
                rows::TOLERANCE_COLUMNS
            );
            sqlx::query(sqlx::AssertSqlSafe(q))
                .fetch_all(&self.pool)
                .await
                .db()?
                .iter()
                .map(rows::tolerance)
                .collect()
        })
    }

    fn update_tolerance<'a>(
        &'a self,
        p: &'a ToleranceProfile,
    ) -> StoreFuture<'a, ToleranceProfile> {
        Box::pin(async move {
            let done = run!(
                execute(&self.pool),
                "UPDATE tolerance_profiles SET limits = $2, webhook_url = $3, updated_at = $4, \
                 webhook_secret = $5 WHERE id = $1",
                &p.id,
                serde_json::to_string(&p.limits).db()?,
                &p.webhook_url,
                now_rfc3339(),
                &p.webhook_secret
            )?;
            if done.rows_affected() == 0 {
                return Err(StoreError::NotFound(format!("tolerance profile {}", p.id)));
            }
            self.get_tolerance(&p.id).await
        })
    }

    fn delete_tolerance<'a>(&'a self, id: &'a str) -> StoreFuture<'a, ()> {
        Box::pin(async move {
            let done = run!(
                execute(&self.pool),
                "DELETE FROM tolerance_profiles WHERE id = $1",
                id
            )?;
            if done.rows_affected() == 0 {
                return Err(StoreError::NotFound(format!("tolerance profile {id}")));
            }
            Ok(())
        })
    }

    fn raise_alert<'a>(
        &'a self,
        a: &'a Alert,
        deliveries: &'a [WebhookDelivery],
    ) -> StoreFuture<'a, Option<Alert>> {
        Box::pin(async move {
            let mut tx = self.pool.begin().await.db()?;
            let done = run!(
                execute(&mut *tx),
                "INSERT INTO alerts (id, machine_id, result_id, baseline_result_id, profile_id, \
                 raised_at, message, items, details, acknowledged_at, acknowledged_by, \
                 acknowledgement_comment) \
                 VALUES ($1, $2, $3, $4, $5, $6, $7, $8, $9, NULL, NULL, NULL) \
                 ON CONFLICT (result_id) DO NOTHING",
                &a.raised.id,
                &a.raised.machine_id,
                &a.raised.result_id,
                &a.raised.baseline_result_id,
                &a.raised.profile_id,
                &a.raised.raised_at,
                &a.raised.message,
                serde_json::to_string(&a.items).db()?,
                match &a.details {
                    Some(d) => Some(serde_json::to_string(d).db()?),
                    None => None,
                }
            )?;
            if done.rows_affected() == 0 {
                tx.rollback().await.db()?;
                return Ok(None);
            }
            let now = now_rfc3339();
            for d in deliveries {
                let q = format!(
                    "INSERT INTO webhook_deliveries (id, alert_id, profile_id, url, body, state, \
                     attempts, next_attempt_ms, last_error, created_at, updated_at) \
                     VALUES ($1, $2, $3, $4, $5, 'pending', 0, {}, NULL, $6, $6)",
                    dialect::NOW_MS
                );
                run!(
                    execute(&mut *tx),
                    sqlx::AssertSqlSafe(q),
                    &d.id,
                    &a.raised.id,
                    &d.profile_id,
                    &d.url,
                    &d.body,
                    &now
                )?;
            }
            tx.commit().await.db()?;
            self.get_alert(&a.raised.id).await.map(Some)
        })
    }

    fn claim_delivery(&self, lease_ms: i64) -> StoreFuture<'_, Option<WebhookDelivery>> {
        Box::pin(async move {
            let q = format!(
                "UPDATE webhook_deliveries SET attempts = attempts + 1, \
                 next_attempt_ms = {now} + $1, updated_at = $2 \
                 WHERE id = (SELECT id FROM webhook_deliveries WHERE state = 'pending' \
                             AND next_attempt_ms <= {now} ORDER BY next_attempt_ms, id \
                             LIMIT 1 {lock}) \
                 AND state = 'pending' RETURNING {DELIVERY_COLUMNS}",
                now = dialect::NOW_MS,
                lock = dialect::CLAIM_LOCK
            );
            let row = run!(
                fetch_optional(&self.pool),
                sqlx::AssertSqlSafe(q),
                lease_ms,
                now_rfc3339()
            )?;
            row.as_ref().map(rows::delivery).transpose()
        })
    }

    fn finish_delivery<'a>(
        &'a self,
        id: &'a str,
        attempt: i64,
        outcome: &'a DeliveryOutcome,
    ) -> StoreFuture<'a, ()> {
        Box::pin(async move {
            let (state, after_ms, error) = match outcome {
                DeliveryOutcome::Delivered => ("delivered", 0, None),
                DeliveryOutcome::Retry { after_ms, error } => ("pending", *after_ms, Some(error)),
                DeliveryOutcome::Failed { error } => ("failed", 0, Some(error)),
            };
            let q = format!(
                "UPDATE webhook_deliveries SET state = $3, next_attempt_ms = {} + $4, \
                 last_error = COALESCE($5, last_error), updated_at = $6 \
                 WHERE id = $1 AND attempts = $2 AND state = 'pending'",
                dialect::NOW_MS
            );
            run!(
                execute(&self.pool),
                sqlx::AssertSqlSafe(q),
                id,
                attempt,
                state,
                after_ms,
                error,
                now_rfc3339()
            )?;
            Ok(())
        })
    }

    fn list_deliveries<'a>(
        &'a self,
        alert_id: Option<&'a str>,
        state: Option<&'a str>,
        limit: i64,
    ) -> StoreFuture<'a, Vec<WebhookDelivery>> {
        Box::pin(async move {
            let q = format!(
                "SELECT {DELIVERY_COLUMNS} FROM webhook_deliveries \
                 WHERE ($1 IS NULL OR alert_id = $1) AND ($2 IS NULL OR state = $2) \
                 ORDER BY created_at DESC, id DESC LIMIT $3"
            );
            run!(
                fetch_all(&self.pool),
                sqlx::AssertSqlSafe(q),
                alert_id,
                state,
                limit
            )?
            .iter()
            .map(rows::delivery)
            .collect()
        })
    }

    fn get_alert<'a>(&'a self, id: &'a str) -> StoreFuture<'a, Alert> {
        Box::pin(async move {
            let q = format!("SELECT {} FROM alerts WHERE id = $1", rows::ALERT_COLUMNS);
            rows::alert(&row_by_id(&self.pool, q, id, "alert").await?)
        })
    }

    fn list_alerts<'a>(
        &'a self,
        machine_id: Option<&'a str>,
        active: Option<bool>,
        limit: i64,
    ) -> StoreFuture<'a, Vec<Alert>> {
        Box::pin(async move {
            let state = match active {
                Some(true) => " AND acknowledged_at IS NULL",
                Some(false) => " AND acknowledged_at IS NOT NULL",
                None => "",
            };
            let q = format!(
                "SELECT {} FROM alerts WHERE ($1 IS NULL OR machine_id = $1){state} \
                 ORDER BY raised_at DESC, id DESC LIMIT $2",
                rows::ALERT_COLUMNS
            );
            run!(
                fetch_all(&self.pool),
                sqlx::AssertSqlSafe(q),
                machine_id,
                limit
            )?
            .iter()
            .map(rows::alert)
            .collect()
        })
    }

    fn acknowledge_alert<'a>(
        &'a self,
        id: &'a str,
        by: &'a str,
        comment: Option<&'a str>,
    ) -> StoreFuture<'a, Alert> {
        Box::pin(async move {
            crate::text::check_line("by", by, crate::text::BY_MAX)?;
            run!(
                execute(&self.pool),
                "UPDATE alerts SET acknowledged_at = $2, acknowledged_by = $3, \
                 acknowledgement_comment = $4 WHERE id = $1 AND acknowledged_at IS NULL",
                id,
                now_rfc3339(),
                by,
                comment
            )?;
            self.get_alert(id).await
        })
    }

    fn create_session<'a>(&'a self, key_id: &'a str, ttl_ms: i64) -> StoreFuture<'a, NewSession> {
        Box::pin(async move {
            let now = dialect::NOW_MS;
            let s = NewSession {
                token: crate::keys::generate_token(),
                csrf: crate::keys::generate_token(),
            };
            // Expired sessions go as new ones come (an index range at the table's start).
            let q = format!("DELETE FROM sessions WHERE expires_ms < {now}");
            sqlx::query(sqlx::AssertSqlSafe(q))
                .execute(&self.pool)
                .await
                .db()?;
            let q = format!(
                "INSERT INTO sessions (token_hash, key_id, csrf, created_ms, expires_ms) \
                 SELECT $1, id, $3, {now}, {now} + $4 FROM api_keys \
                 WHERE id = $2 AND revoked_at IS NULL"
            );
            let done = run!(
                execute(&self.pool),
                sqlx::AssertSqlSafe(q),
                crate::keys::hash_secret(&s.token),
                key_id,
                &s.csrf,
                ttl_ms
            )?;
            if done.rows_affected() == 0 {
                return Err(StoreError::NotFound(format!(
                    "key {key_id} (or it is revoked)"
                )));
            }
            Ok(s)
        })
    }

    fn session<'a>(&'a self, token: &'a str) -> StoreFuture<'a, Option<SessionRecord>> {
        Box::pin(async move {
            let q = format!(
                "SELECT {}, s.csrf AS csrf FROM sessions s JOIN api_keys k ON k.id = s.key_id \
                 WHERE s.token_hash = $1 AND s.expires_ms > {} AND k.revoked_at IS NULL",
                qualified("k", KEY_COLUMNS),
                dialect::NOW_MS
            );
            let row = run!(
                fetch_optional(&self.pool),
                sqlx::AssertSqlSafe(q),
                crate::keys::hash_secret(token)
            )?;
            row.map(|r| {
                Ok(SessionRecord {
                    key: rows::api_key(&r)?,
                    csrf: r.text("csrf")?,
                })
            })
            .transpose()
        })
    }

    fn end_session<'a>(&'a self, token: &'a str) -> StoreFuture<'a, ()> {
        Box::pin(async move {
            run!(
                execute(&self.pool),
                "DELETE FROM sessions WHERE token_hash = $1",
                crate::keys::hash_secret(token)
            )?;
            Ok(())
        })
    }

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

/// The job `id`, read through `ex` (the pool or a transaction).
async fn job_by_id<'e>(ex: impl Executor<'e, Database = Db>, id: &str) -> Result<Job> {
    let q = format!("SELECT {JOB_COLUMNS} FROM jobs WHERE id = $1");
    rows::job(&row_by_id(ex, q, id, "job").await?)
}

/// Reads job `id` as `tx` left it, then commits.
async fn commit_with_job(mut tx: Transaction<'_, Db>, id: &str) -> Result<Job> {
    let job = job_by_id(&mut *tx, id).await?;
    tx.commit().await.db()?;
    Ok(job)
}

impl This {
    async fn job(&self, id: &str) -> Result<Job> {
        job_by_id(&self.pool, id).await
    }
}

impl Queue for This {
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
                kinds = JobKind::runnable_sql_list(),
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
