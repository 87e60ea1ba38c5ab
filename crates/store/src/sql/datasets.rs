//! The statements of [`crate::Datasets`]: a dataset and its files, set aside (excluded,
//! then its bytes deleted) with its results.

use super::{Backend, dialect, row_by_id};
use crate::error::{Db as _, Result, StoreError, unique_conflict};
use crate::model::*;
use crate::rows::{self, Columns, DATASET_COLUMNS};
use crate::rules::{self, Manifest};
use crate::{Datasets, StoreFuture, now_rfc3339};

impl Backend {
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
}

impl Datasets for Backend {
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
}
