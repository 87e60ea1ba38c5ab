//! `/api/v1/machines/{id}/datasets` (upload, list) and `/api/v1/datasets/{id}` (metadata,
//! raw files back unchanged, exclusion, deletion of the raw bytes).

use crate::AppState;
use crate::api::history::Reason;
use crate::audit::{Actor, Change, json};
use crate::auth::{AdminKey, ReadKey, WriteKey};
use crate::error::{ApiError, ApiJson, ApiQuery, ErrorBody};
use crate::ingest;
use axum::Json;
use axum::body::Bytes;
use axum::extract::{FromRequest, Multipart, Path, Request, State};
use axum::http::{HeaderMap, HeaderValue, StatusCode, header};
use axum::response::{IntoResponse, Response};
use mtcal_formats::CsvDialect;
use mtcal_store::{Dataset, Machine, NewDataset};
use serde::Deserialize;
use utoipa::{IntoParams, ToSchema};

/// Multipart form of a session upload: one part per file, the part's file name is the
/// file's name (`session.json`, `xy_L100.csv`, `xz.csv.gz`, …).
#[derive(ToSchema)]
#[serde(deny_unknown_fields)]
#[allow(dead_code)]
pub struct SessionUpload {
    #[schema(value_type = Vec<String>, format = Binary)]
    pub files: Vec<Vec<u8>>,
    /// How the CSV files are written: `plain` (default; `,` separators, `.` decimal
    /// points) or `excel` (`;` separators and decimal commas, as a spreadsheet saves CSV
    /// in many locales). A form field, not a file.
    #[schema(required = false)]
    pub csv_dialect: CsvDialectName,
}

/// The names of the CSV dialects (`mtcal_formats::CsvDialect`), as the upload's form
/// field gives them.
#[derive(ToSchema)]
#[schema(rename_all = "lowercase")]
#[allow(dead_code)]
pub enum CsvDialectName {
    Plain,
    Excel,
}

/// The name of the multipart field that gives the CSV dialect.
pub const CSV_DIALECT_FIELD: &str = "csv_dialect";

fn media(headers: &HeaderMap) -> String {
    headers
        .get(header::CONTENT_TYPE)
        .and_then(|v| v.to_str().ok())
        .unwrap_or("")
        .to_ascii_lowercase()
}

/// The Content-Encoding an upload was sent with, noted by [`note_encoding`] before the
/// decompression layer decodes the body and removes the header.
#[derive(Debug, Clone)]
struct SentEncoding(String);

/// Middleware in front of the upload route's decompression: notes the request's
/// Content-Encoding, so that a body that fails to decode is named as such
/// (`invalid_encoding`).
pub async fn note_encoding(mut req: Request, next: axum::middleware::Next) -> Response {
    let enc = req
        .headers()
        .get(header::CONTENT_ENCODING)
        .map(|v| String::from_utf8_lossy(v.as_bytes()).into_owned())
        .filter(|e| e != "identity");
    if let Some(e) = enc {
        req.extensions_mut().insert(SentEncoding(e));
    }
    next.run(req).await
}

/// The Content-Encoding the request was sent with (see [`note_encoding`]).
fn encoding(req: &Request) -> Option<String> {
    req.extensions().get::<SentEncoding>().map(|e| e.0.clone())
}

/// The files of a multipart upload and the CSV dialect its `csv_dialect` field names.
async fn read_multipart(
    req: Request,
    s: &AppState,
) -> Result<(Vec<(String, Vec<u8>)>, CsvDialect), ApiError> {
    let enc = encoding(&req);
    let rejected = |status, text| ApiError::from_body_rejection(status, text, enc.as_deref());
    let mut mp = Multipart::from_request(req, s)
        .await
        .map_err(|r| ApiError::from_rejection(r.status(), r.body_text()))?;
    let mut files = Vec::new();
    let mut dialect = CsvDialect::Plain;
    while let Some(field) = mp
        .next_field()
        .await
        .map_err(|e| rejected(e.status(), e.body_text()))?
    {
        if field.file_name().is_none() && field.name() == Some(CSV_DIALECT_FIELD) {
            let text = field
                .text()
                .await
                .map_err(|e| rejected(e.status(), e.body_text()))?;
            dialect = CsvDialect::parse(&text).ok_or_else(|| {
                ApiError::InvalidRequest(format!(
                    "{CSV_DIALECT_FIELD} {:?}: plain or excel",
                    text.chars().take(64).collect::<String>()
                ))
            })?;
            continue;
        }
        let name = field
            .file_name()
            .or(field.name())
            .unwrap_or_default()
            .to_string();
        let bytes = field
            .bytes()
            .await
            .map_err(|e| rejected(e.status(), e.body_text()))?;
        files.push((name, bytes.to_vec()));
    }
    Ok((files, dialect))
}

#[utoipa::path(operation_id = "datasets_upload", summary = "Upload a dataset (session folder as multipart or tar.gz, or one series file)", post, path = "/api/v1/machines/{id}/datasets", tag = "datasets",
    security(("api_key" = ["write"])), params(("id" = String, Path, description = "machine id")),
    request_body(content = SessionUpload, content_type = "multipart/form-data",
        description = "A session (session.json and its plane CSVs), or one rotary point-set \
                       CSV with its optional JSON sidecar <stem>.json, or one positioning-run \
                       CSV, or one drift-log CSV: as multipart parts, or as one .tar.gz with \
                       Content-Type application/gzip (application/x-tar for an uncompressed \
                       archive). Any file may be gzip-compressed. The kind is stored with the \
                       dataset (session, rotary_points, positioning, drift_log). The form \
                       field csv_dialect=excel reads CSV files written by a spreadsheet (`;` \
                       separators, decimal commas)."),
    responses((status = 201, body = Dataset),
              (status = 400, body = ErrorBody, description = "invalid_request: an unknown csv_dialect"),
              (status = 409, body = ErrorBody, description = "conflict: identical to an earlier dataset of the machine, which the message names"),
              (status = 413, body = ErrorBody, description = "payload_too_large"),
              (status = 415, body = ErrorBody, description = "unsupported_media_type"),
              (status = 422, body = ErrorBody, description = "invalid_dataset: names file, line, column and rule; nothing stored")))]
pub async fn upload(
    _key: WriteKey,
    State(s): State<AppState>,
    Path(machine_id): Path<String>,
    req: Request,
) -> Result<(StatusCode, Json<Dataset>), ApiError> {
    let machine = s.store.get_machine(&machine_id).await?;
    let ct = media(req.headers());
    let (files, dialect) = if ct.starts_with("multipart/form-data") {
        read_multipart(req, &s).await?
    } else if let Some(name) = archive_name(&ct) {
        let enc = encoding(&req);
        let body = Bytes::from_request(req, &s).await.map_err(|r| {
            ApiError::from_body_rejection(r.status(), r.body_text(), enc.as_deref())
        })?;
        // Decompressing and unpacking is blocking work, bounded like the read.
        let limits = upload_limits(&s);
        let files =
            crate::blocking::run::<_, ApiError>(move || ingest::untar(name, &body, &limits))
                .await??;
        (files, CsvDialect::Plain)
    } else {
        return Err(ApiError::UnsupportedMediaType(format!(
            "Content-Type {ct:?}: send multipart/form-data, application/gzip (a .tar.gz) \
             or application/zip (a .zip)"
        )));
    };
    Ok((
        StatusCode::CREATED,
        Json(store_upload(&s, machine, files, dialect).await?),
    ))
}

/// The readers' limits for one upload: the service's, with a deadline at the upload time
/// limit from now, so that a parsing thread stops no later than its request would.
fn upload_limits(s: &AppState) -> ingest::UploadLimits {
    s.limits.with_time_limit(s.settings.upload_slot_time)
}

/// Reads the uploaded files as one dataset of `machine` with the strict reader of its
/// kind and stores it (the upload route; the dashboard's upload form too). Nothing is
/// stored when a file breaks a rule. CSV files are read in `dialect` (stored as sent).
pub async fn store_upload(
    s: &AppState,
    machine: Machine,
    files: Vec<(String, Vec<u8>)>,
    dialect: CsvDialect,
) -> Result<Dataset, ApiError> {
    let limits = upload_limits(s).with_dialect(dialect);
    let (data, mut files) = crate::blocking::run::<_, ApiError>(move || {
        // One archive sent as a file (a multipart part, the dashboard's form) is read as
        // its files, as when it is the request's body.
        let files = mtcal_formats::unpack_single_archive(files, &limits)?;
        ingest::read_dataset(&files, &limits).map(|d| (d, files))
    })
    .await??;
    data.check_machine(&machine.id)?;
    data.check_travel(&machine.travel_mm)?;
    let measured_at = data
        .measured_at_utc()?
        .unwrap_or_else(mtcal_store::now_rfc3339);
    // Only the files read are stored (files beside a session that it does not use are
    // ignored), in the order read.
    files.retain(|(n, _)| data.files.contains(n));
    files.sort_by_key(|(n, _)| data.files.iter().position(|f| f == n));
    let d = s
        .store
        .insert_dataset(NewDataset {
            machine_id: machine.id,
            kind: data.kind().into(),
            measured_at,
            samples: data.samples() as i64,
            files,
        })
        .await?;
    Ok(d)
}

/// The archive name a body of this media type is read as (its gzip-ness is checked
/// against the content, as for any `.gz` file name).
fn archive_name(media_type: &str) -> Option<&'static str> {
    if media_type.starts_with("application/gzip") || media_type.starts_with("application/x-gzip") {
        Some("upload.tar.gz")
    } else if media_type.starts_with("application/zip")
        || media_type.starts_with("application/x-zip-compressed")
    {
        Some("upload.zip")
    } else if media_type.starts_with("application/x-tar")
        || media_type.starts_with("application/octet-stream")
    {
        // A zip sent as octet-stream is read as one: read_archive goes by the content.
        Some("upload.tar")
    } else {
        None
    }
}

#[utoipa::path(operation_id = "datasets_get", summary = "A dataset: its kind, samples, files and checksums", get, path = "/api/v1/datasets/{id}", tag = "datasets",
    security(("api_key" = [])), params(("id" = String, Path)),
    responses((status = 200, body = Dataset), (status = 404, body = ErrorBody)))]
pub async fn get(
    _key: ReadKey,
    State(s): State<AppState>,
    Path(id): Path<String>,
) -> Result<Json<Dataset>, ApiError> {
    Ok(Json(s.store.get_dataset(&id).await?))
}

#[utoipa::path(operation_id = "datasets_file", summary = "One raw file of a dataset, unchanged as uploaded", get, path = "/api/v1/datasets/{id}/files/{name}", tag = "datasets",
    security(("api_key" = [])), params(("id" = String, Path), ("name" = String, Path)),
    responses((status = 200, description = "the file's bytes as uploaded; header x-checksum-sha256",
               content_type = "application/octet-stream", body = crate::contract::FileBytes),
              (status = 404, body = ErrorBody)))]
pub async fn file(
    _key: ReadKey,
    State(s): State<AppState>,
    Path((id, name)): Path<(String, String)>,
) -> Result<Response, ApiError> {
    let meta = s.store.get_dataset(&id).await?;
    let f = meta
        .files
        .iter()
        .find(|f| f.name == name)
        .ok_or_else(|| ApiError::NotFound(format!("file {name} of dataset {id} not found")))?;
    let bytes = s.store.dataset_file(&id, &name).await?;
    let mut resp = bytes.into_response();
    let h = resp.headers_mut();
    h.insert(
        header::CONTENT_TYPE,
        HeaderValue::from_static("application/octet-stream"),
    );
    if let Ok(v) = HeaderValue::from_str(&f.sha256) {
        h.insert("x-checksum-sha256", v);
    }
    Ok(resp)
}

#[derive(Debug, Deserialize, IntoParams)]
#[into_params(parameter_in = Query)]
pub struct ListQuery {
    /// `true`: excluded datasets (and those whose bytes were deleted) too, each with its
    /// record; default `false`.
    pub include_excluded: Option<bool>,
}

#[utoipa::path(operation_id = "datasets_list", summary = "A machine's datasets in time order (excluded ones on request)", get, path = "/api/v1/machines/{id}/datasets", tag = "datasets",
    security(("api_key" = [])), params(("id" = String, Path, description = "machine id"), ListQuery),
    responses((status = 200, body = Vec<Dataset>, description = "in time order (measured_at, then id)"),
              (status = 400, body = ErrorBody), (status = 404, body = ErrorBody)))]
pub async fn list(
    _key: ReadKey,
    State(s): State<AppState>,
    Path(machine_id): Path<String>,
    ApiQuery(q): ApiQuery<ListQuery>,
) -> Result<Json<Vec<Dataset>>, ApiError> {
    s.store.get_machine(&machine_id).await?;
    let all = q.include_excluded.unwrap_or(false);
    Ok(Json(s.store.list_datasets(&machine_id, all).await?))
}

/// Excludes a dataset (a wrong setup, the wrong machine, poisoned input): it stays stored
/// and readable by id with who excluded it, when and why; no new job runs on it (409),
/// the default listing leaves it out, and every result computed from it is excluded with
/// the same record, so that no list, trend, difference, drift, fleet row or alert
/// baseline uses them (the machine's fleet row is recomputed at once). Excluding an
/// excluded dataset keeps the first record.
#[utoipa::path(operation_id = "datasets_exclude", summary = "Exclude a dataset and its results (recorded)", post, path = "/api/v1/datasets/{id}/exclude", tag = "datasets",
    security(("api_key" = ["write"])), params(("id" = String, Path)), request_body = Reason,
    responses((status = 200, body = Dataset), (status = 400, body = ErrorBody), (status = 401, body = ErrorBody),
              (status = 403, body = ErrorBody), (status = 404, body = ErrorBody),
              (status = 409, body = ErrorBody, description = "conflict: a job on the dataset is queued or running (the message names it); nothing changed")))]
pub async fn exclude(
    WriteKey(key): WriteKey,
    who: Actor,
    State(s): State<AppState>,
    Path(id): Path<String>,
    ApiJson(body): ApiJson<Reason>,
) -> Result<Json<Dataset>, ApiError> {
    let why = super::history::recorded(&body, &key)?;
    let before = s.store.get_dataset(&id).await?;
    let after = s.store.exclude_dataset(&id, why.set_aside()).await?;
    set_aside(&s, "dataset.exclude", before, after, &who).await
}

/// Deletes a dataset's raw bytes (admin: irreversible, unlike an exclusion). The dataset
/// stays as a tombstone: its metadata, its files' names, sizes and checksums, and the
/// record of who deleted the bytes, when and why; reading a file is then 404 naming that
/// record. The dataset is excluded with the same record first when it was not (its
/// results with it). Deleting again keeps the first record.
#[utoipa::path(operation_id = "datasets_delete_files", summary = "Delete a dataset's raw bytes, keeping a tombstone (recorded)", post, path = "/api/v1/datasets/{id}/delete-files", tag = "datasets",
    security(("api_key" = ["admin"])), params(("id" = String, Path)), request_body = Reason,
    responses((status = 200, body = Dataset), (status = 400, body = ErrorBody), (status = 401, body = ErrorBody),
              (status = 403, body = ErrorBody), (status = 404, body = ErrorBody),
              (status = 409, body = ErrorBody, description = "conflict: a job on the dataset is queued or running (the message names it); nothing changed")))]
pub async fn delete_files(
    AdminKey(key): AdminKey,
    who: Actor,
    State(s): State<AppState>,
    Path(id): Path<String>,
    ApiJson(body): ApiJson<Reason>,
) -> Result<Json<Dataset>, ApiError> {
    let why = super::history::recorded(&body, &key)?;
    let before = s.store.get_dataset(&id).await?;
    let after = s.store.delete_dataset_files(&id, why.set_aside()).await?;
    set_aside(&s, "dataset.delete_files", before, after, &who).await
}

/// The answer to a dataset set aside (`action`: excluded, or its bytes deleted), once it
/// is recorded and its machine's fleet row refreshed: the dataset's results no longer
/// count for the drift.
async fn set_aside(
    s: &AppState,
    action: &str,
    before: Dataset,
    d: Dataset,
    who: &Actor,
) -> Result<Json<Dataset>, ApiError> {
    let change = Change {
        action,
        target: &d.id,
        machine: Some(&d.machine_id),
        before: json(&before),
        after: json(&d),
    };
    who.record(s.store.as_ref(), change).await?;
    mtcal_domain::fleet::refresh_machine(s.store.as_ref(), &d.machine_id).await?;
    Ok(Json(d))
}
