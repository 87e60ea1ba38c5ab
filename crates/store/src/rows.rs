//! Reading records back from rows, written once for every backend: a backend's row type
//! only needs to decode text, integers, reals and bytes by column name ([`Columns`]).

use crate::error::{Db, Result, StoreError};
use crate::keys::{ApiKey, Scope};
use crate::model::JobKind;
use crate::model::*;
use sqlx::{ColumnIndex, Decode, Row, Type};

/// Typed access to a row's columns by name.
pub(crate) trait Columns {
    fn text(&self, c: &str) -> Result<String>;
    fn opt_text(&self, c: &str) -> Result<Option<String>>;
    fn int(&self, c: &str) -> Result<i64>;
    fn opt_int(&self, c: &str) -> Result<Option<i64>>;
    fn real(&self, c: &str) -> Result<f64>;
    fn opt_real(&self, c: &str) -> Result<Option<f64>>;
    fn bytes(&self, c: &str) -> Result<Vec<u8>>;
    /// A JSON document kept in a text column.
    fn json<T: serde::de::DeserializeOwned>(&self, c: &str) -> Result<T> {
        serde_json::from_str(&self.text(c)?).db()
    }
}

impl<R> Columns for R
where
    R: Row,
    for<'a> &'a str: ColumnIndex<R>,
    for<'r> String: Decode<'r, R::Database> + Type<R::Database>,
    for<'r> i64: Decode<'r, R::Database> + Type<R::Database>,
    for<'r> f64: Decode<'r, R::Database> + Type<R::Database>,
    for<'r> Vec<u8>: Decode<'r, R::Database> + Type<R::Database>,
{
    fn text(&self, c: &str) -> Result<String> {
        self.try_get(c).db()
    }
    fn opt_text(&self, c: &str) -> Result<Option<String>> {
        self.try_get(c).db()
    }
    fn int(&self, c: &str) -> Result<i64> {
        self.try_get(c).db()
    }
    fn opt_int(&self, c: &str) -> Result<Option<i64>> {
        self.try_get(c).db()
    }
    fn real(&self, c: &str) -> Result<f64> {
        self.try_get(c).db()
    }
    fn opt_real(&self, c: &str) -> Result<Option<f64>> {
        self.try_get(c).db()
    }
    fn bytes(&self, c: &str) -> Result<Vec<u8>> {
        self.try_get(c).db()
    }
}

/// Columns of a machine, in the order every backend selects them.
pub(crate) const MACHINE_COLUMNS: &str =
    "id, name, topology, travel_mm, site, tags, baseline_result_id, created_at, updated_at";

/// Columns of a job.
pub(crate) const JOB_COLUMNS: &str = "id, kind, machine_id, dataset_id, params, state, progress, \
     progress_message, attempts, max_attempts, error_code, error_message, result_id, \
     created_at, started_at, finished_at";

/// Columns of a result's metadata (its document apart).
pub(crate) const RESULT_COLUMNS: &str = "id, job_id, machine_id, dataset_id, kind, measured_at, \
     created_at, residual_rms_um, condition_number, rank, ec0y_urad, eb0z_urad, ea0z_urad, \
     term_coefficients, measured_travel, term_covariance, excluded_at, excluded_by, excluded_reason";

/// Columns of a dataset (its files apart).
pub(crate) const DATASET_COLUMNS: &str = "id, machine_id, kind, measured_at, uploaded_at, samples, total_bytes, sha256, \
     excluded_at, excluded_by, excluded_reason, deleted_at, deleted_by, deleted_reason";

/// Columns of an API key (never its hash).
pub(crate) const KEY_COLUMNS: &str =
    "id, prefix, scope, label, created_at, revoked_at, sites, tags";

pub(crate) fn machine(r: &impl Columns) -> Result<Machine> {
    machine_as(r, "id")
}

/// A machine from a row whose id column is named `id_column` (a join).
pub(crate) fn machine_as(r: &impl Columns, id_column: &str) -> Result<Machine> {
    Ok(Machine {
        id: r.text(id_column)?,
        name: r.text("name")?,
        topology: r.json("topology")?,
        travel_mm: r.json("travel_mm")?,
        site: r.opt_text("site")?,
        tags: r.json("tags")?,
        baseline_result_id: r.opt_text("baseline_result_id")?,
        created_at: r.text("created_at")?,
        updated_at: r.text("updated_at")?,
    })
}

pub(crate) fn job(r: &impl Columns) -> Result<Job> {
    let state = r.text("state")?;
    let kind = r.text("kind")?;
    Ok(Job {
        id: r.text("id")?,
        kind: JobKind::parse(&kind)
            .ok_or_else(|| StoreError::Backend(format!("unknown job kind {kind:?}")))?,
        machine_id: r.opt_text("machine_id")?,
        dataset_id: r.opt_text("dataset_id")?,
        params: r.json("params")?,
        state: JobState::parse(&state)
            .ok_or_else(|| StoreError::Backend(format!("unknown job state {state:?}")))?,
        progress: r.real("progress")?,
        progress_message: r.opt_text("progress_message")?,
        attempts: r.int("attempts")?,
        max_attempts: r.int("max_attempts")?,
        error_code: r.opt_text("error_code")?,
        error_message: r.opt_text("error_message")?,
        result_id: r.opt_text("result_id")?,
        created_at: r.text("created_at")?,
        started_at: r.opt_text("started_at")?,
        finished_at: r.opt_text("finished_at")?,
    })
}

pub(crate) fn result_meta(r: &impl Columns) -> Result<ResultMeta> {
    Ok(ResultMeta {
        id: r.text("id")?,
        job_id: r.text("job_id")?,
        machine_id: r.text("machine_id")?,
        dataset_id: r.opt_text("dataset_id")?,
        kind: r.text("kind")?,
        measured_at: r.text("measured_at")?,
        created_at: r.text("created_at")?,
        scalars: ResultScalars {
            summary: ResultSummary {
                residual_rms_um: r.opt_real("residual_rms_um")?,
                condition_number: r.opt_real("condition_number")?,
                rank: r.opt_int("rank")?,
                ec0y_urad: r.opt_real("ec0y_urad")?,
                eb0z_urad: r.opt_real("eb0z_urad")?,
                ea0z_urad: r.opt_real("ea0z_urad")?,
            },
            term_coefficients: r.json("term_coefficients")?,
            measured_travel_mm: r.json("measured_travel")?,
            term_covariance: r.json("term_covariance")?,
        },
        excluded: record(r, "excluded")?,
    })
}

/// The record ([`Exclusion`]) kept in the columns `{prefix}_at`, `{prefix}_by` and
/// `{prefix}_reason`; `None` when `{prefix}_at` is null.
pub(crate) fn record(r: &impl Columns, prefix: &str) -> Result<Option<Exclusion>> {
    Ok(match r.opt_text(&format!("{prefix}_at"))? {
        Some(at) => Some(Exclusion {
            at,
            by: r.opt_text(&format!("{prefix}_by"))?.unwrap_or_default(),
            reason: r.opt_text(&format!("{prefix}_reason"))?.unwrap_or_default(),
        }),
        None => None,
    })
}

/// Rows decoded as results, those that do not decode set aside with the reason.
pub(crate) fn result_meta_checked<R: Columns>(rows: &[R]) -> (Vec<ResultMeta>, Vec<SkippedRow>) {
    let (mut ok, mut skipped) = (Vec::new(), Vec::new());
    for r in rows {
        match result_meta(r) {
            Ok(m) => ok.push(m),
            Err(e) => skipped.push(SkippedRow {
                id: r.text("id").unwrap_or_else(|_| "?".into()),
                reason: e.to_string(),
            }),
        }
    }
    (ok, skipped)
}

/// A figure trend point: `result_id`, `measured_at`, `value`, `u` columns.
pub(crate) fn figure_point(r: &impl Columns) -> Result<FigurePoint> {
    Ok(FigurePoint {
        result_id: r.text("result_id")?,
        measured_at: r.text("measured_at")?,
        value: r.real("value")?,
        u: r.opt_real("u")?,
    })
}

/// A figure: `name`, `value`, `u` columns.
pub(crate) fn figure(r: &impl Columns) -> Result<Figure> {
    Ok(Figure {
        name: r.text("name")?,
        value: r.real("value")?,
        u: r.opt_real("u")?,
    })
}

pub(crate) fn stored_result(r: &impl Columns) -> Result<StoredResult> {
    Ok(StoredResult {
        meta: result_meta(r)?,
        document: r.json("document")?,
    })
}

pub(crate) fn file_meta(r: &impl Columns) -> Result<FileMeta> {
    Ok(FileMeta {
        name: r.text("name")?,
        sha256: r.text("sha256")?,
        size: r.int("size")?,
    })
}

pub(crate) fn dataset(r: &impl Columns, files: Vec<FileMeta>) -> Result<Dataset> {
    Ok(Dataset {
        id: r.text("id")?,
        machine_id: r.text("machine_id")?,
        kind: r.text("kind")?,
        measured_at: r.text("measured_at")?,
        uploaded_at: r.text("uploaded_at")?,
        samples: r.int("samples")?,
        total_bytes: r.int("total_bytes")?,
        sha256: r.text("sha256")?,
        files,
        excluded: record(r, "excluded")?,
        deleted: record(r, "deleted")?,
    })
}

pub(crate) fn api_key(r: &impl Columns) -> Result<ApiKey> {
    let scope = r.text("scope")?;
    Ok(ApiKey {
        id: r.text("id")?,
        prefix: r.text("prefix")?,
        scope: Scope::parse(&scope)
            .ok_or_else(|| StoreError::Backend(format!("unknown scope {scope:?}")))?,
        label: r.text("label")?,
        created_at: r.text("created_at")?,
        revoked_at: r.opt_text("revoked_at")?,
        sites: r.json("sites")?,
        tags: r.json("tags")?,
    })
}

/// The columns of an audit event, in [`audit_event`]'s order.
pub(crate) const AUDIT_COLUMNS: &str = "seq, at, actor, actor_name, via, action, target, \
     machine_id, before_json, after_json, client";

pub(crate) fn audit_event(r: &impl Columns) -> Result<crate::audit::AuditEvent> {
    let json = |c: &str| -> Result<Option<serde_json::Value>> {
        r.opt_text(c)?
            .map(|t| serde_json::from_str(&t).db())
            .transpose()
    };
    Ok(crate::audit::AuditEvent {
        seq: r.int("seq")?,
        at: r.text("at")?,
        event: crate::audit::NewAuditEvent {
            actor: r.text("actor")?,
            actor_name: r.text("actor_name")?,
            via: r.text("via")?,
            action: r.text("action")?,
            target: r.text("target")?,
            machine_id: r.opt_text("machine_id")?,
            before: json("before_json")?,
            after: json("after_json")?,
            client: r.opt_text("client")?,
        },
    })
}

/// The columns of a fleet drift row, in [`fleet_drift`]'s order.
pub(crate) const FLEET_DRIFT_COLUMNS: &str =
    "machine_id, read_at_ms, drift_um, drift_urad, entry, latest_measured_at, basis";

/// A fleet drift row ([`FLEET_DRIFT_COLUMNS`]).
pub(crate) fn fleet_drift(r: &impl Columns) -> Result<FleetDriftRow> {
    Ok(FleetDriftRow {
        machine_id: r.text("machine_id")?,
        read_at_ms: r.int("read_at_ms")?,
        drift_um: r.real("drift_um")?,
        drift_urad: r.real("drift_urad")?,
        entry: crate::fleet::EntryJson::stored(r.text("entry")?),
        latest_measured_at: r.opt_text("latest_measured_at")?,
        basis: r.opt_text("basis")?,
    })
}

/// The columns of a tolerance profile, in [`tolerance`]'s order.
pub(crate) const TOLERANCE_COLUMNS: &str =
    "id, scope, target, limits, webhook_url, webhook_secret, created_at, updated_at";

pub(crate) fn tolerance(r: &impl Columns) -> Result<ToleranceProfile> {
    Ok(ToleranceProfile {
        id: r.text("id")?,
        scope: r.text("scope")?,
        target: r.text("target")?,
        limits: r.json("limits")?,
        webhook_url: r.opt_text("webhook_url")?,
        webhook_secret: r.opt_text("webhook_secret")?,
        created_at: r.text("created_at")?,
        updated_at: r.text("updated_at")?,
    })
}

/// The columns of a webhook delivery, in [`delivery`]'s order (`attempts` is a 32-bit
/// INTEGER in PostgreSQL's table: read as 64 bits like every count).
pub(crate) const DELIVERY_COLUMNS: &str = "id, alert_id, profile_id, url, body, state, \
     CAST(attempts AS BIGINT) AS attempts, next_attempt_ms, last_error, created_at, updated_at";

pub(crate) fn delivery(r: &impl Columns) -> Result<WebhookDelivery> {
    Ok(WebhookDelivery {
        id: r.text("id")?,
        alert_id: r.text("alert_id")?,
        profile_id: r.text("profile_id")?,
        url: r.text("url")?,
        body: r.text("body")?,
        state: r.text("state")?,
        attempts: r.int("attempts")?,
        next_attempt_ms: r.int("next_attempt_ms")?,
        last_error: r.opt_text("last_error")?,
        created_at: r.text("created_at")?,
        updated_at: r.text("updated_at")?,
    })
}

/// The columns of an alert.
pub(crate) const ALERT_COLUMNS: &str = "id, machine_id, result_id, baseline_result_id, \
     profile_id, raised_at, message, items, details, acknowledged_at, acknowledged_by, \
     acknowledgement_comment";

pub(crate) fn alert(r: &impl Columns) -> Result<Alert> {
    Ok(Alert {
        raised: AlertRaised {
            id: r.text("id")?,
            machine_id: r.text("machine_id")?,
            result_id: r.text("result_id")?,
            baseline_result_id: r.text("baseline_result_id")?,
            profile_id: r.text("profile_id")?,
            raised_at: r.text("raised_at")?,
            message: r.text("message")?,
        },
        items: r.json("items")?,
        details: match r.opt_text("details")? {
            Some(t) => Some(serde_json::from_str(&t).db()?),
            None => None,
        },
        acknowledged_at: r.opt_text("acknowledged_at")?,
        acknowledged_by: r.opt_text("acknowledged_by")?,
        acknowledgement_comment: r.opt_text("acknowledgement_comment")?,
    })
}

/// The row counts of [`RowCounts`], from columns named after its fields.
pub(crate) fn row_counts(r: &impl Columns) -> Result<RowCounts> {
    Ok(RowCounts {
        machines: r.int("machines")?,
        datasets: r.int("datasets")?,
        dataset_files: r.int("dataset_files")?,
        jobs: r.int("jobs")?,
        results: r.int("results")?,
        result_figures: r.int("result_figures")?,
        api_keys: r.int("api_keys")?,
    })
}

/// Counts every table, in columns named after the fields of [`RowCounts`] (portable SQL).
pub(crate) const ROW_COUNTS: &str = "SELECT (SELECT COUNT(*) FROM machines) AS machines, \
     (SELECT COUNT(*) FROM datasets) AS datasets, \
     (SELECT COUNT(*) FROM dataset_files) AS dataset_files, \
     (SELECT COUNT(*) FROM jobs) AS jobs, \
     (SELECT COUNT(*) FROM results) AS results, \
     (SELECT COUNT(*) FROM result_figures) AS result_figures, \
     (SELECT COUNT(*) FROM api_keys) AS api_keys";

/// A stored file: `name` and `content` columns.
pub(crate) fn name_and_content(r: &impl Columns) -> Result<(String, Vec<u8>)> {
    Ok((r.text("name")?, r.bytes("content")?))
}

/// Assembles [`BaselinePair`]s from three row sets: `pairs` (columns `mid`, `n`,
/// `base_id`, `last_id`, one per machine with results), the result metadata they name,
/// and the machines.
pub(crate) fn baseline_pairs<R: Columns>(
    pairs: &[R],
    metas: &[R],
    machines: &[R],
) -> Result<Vec<BaselinePair>> {
    use std::collections::HashMap;
    let metas: HashMap<String, ResultMeta> = metas
        .iter()
        .map(|r| result_meta(r).map(|m| (m.id.clone(), m)))
        .collect::<Result<_>>()?;
    let mut machines: HashMap<String, Machine> = machines
        .iter()
        .map(|r| machine(r).map(|m| (m.id.clone(), m)))
        .collect::<Result<_>>()?;
    let get = |id: &str| {
        metas
            .get(id)
            .cloned()
            .ok_or_else(|| StoreError::NotFound(format!("result {id}")))
    };
    pairs
        .iter()
        .map(|row| {
            let mid = row.text("mid")?;
            Ok(BaselinePair {
                baseline: get(&row.text("base_id")?)?,
                latest: get(&row.text("last_id")?)?,
                results: row.int("n")?,
                machine: machines
                    .remove(&mid)
                    .ok_or_else(|| StoreError::NotFound(format!("machine {mid}")))?,
            })
        })
        .collect()
}
