//! `/api/v1/jobs`: submit, status with progress, result, cancel.

use crate::AppState;
use crate::auth::scope::{Kind, Within};
use crate::auth::{ReadKey, WriteKey};
use crate::error::{ApiError, ApiJson, ErrorBody};
use crate::jobs;
use axum::Json;
use axum::extract::{Path, State};
use axum::http::StatusCode;
pub use mtcal_api::jobs::SubmitJob;
use mtcal_store::{ApiKey, Job, JobState, NewJob};
use serde::Deserialize;

#[utoipa::path(operation_id = "jobs_submit", summary = "Submit a job (identify, sensitivity, diagnose, cradle, standards)", post, path = "/api/v1/jobs", tag = "jobs", request_body = SubmitJob,
    security(("api_key" = ["write"])),
    responses((status = 202, body = Job), (status = 400, body = ErrorBody),
              (status = 404, body = ErrorBody),
              (status = 409, body = ErrorBody, description = "conflict: the dataset is excluded (the message gives its record)")))]
pub async fn submit(
    WriteKey(key): WriteKey,
    State(s): State<AppState>,
    ApiJson(j): ApiJson<SubmitJob>,
) -> Result<(StatusCode, Json<Job>), ApiError> {
    Ok((StatusCode::ACCEPTED, Json(submit_job(&s, j, &key).await?)))
}

/// Checks and enqueues a job (`POST /api/v1/jobs`; the dashboard's upload form too).
pub async fn submit_job(s: &AppState, j: SubmitJob, key: &ApiKey) -> Result<Job, ApiError> {
    let within = Within(key);
    let get = axum::http::Method::GET;
    if let Some(d) = &j.dataset_id {
        within.check(s, Kind::Dataset, d, &get).await?;
    }
    if let Some(m) = &j.machine_id {
        within.check(s, Kind::Machine, m, &get).await?;
    }
    let params = if j.params.is_null() {
        serde_json::json!({})
    } else {
        j.params
    };
    jobs::validate_params(j.kind, &params).map_err(ApiError::InvalidRequest)?;
    let machine_id = match (&j.dataset_id, j.kind.needs_dataset()) {
        (Some(d), true) => {
            let ds = s.store.get_dataset(d).await?;
            if let Some(x) = &ds.excluded {
                return Err(ApiError::Conflict(format!(
                    "dataset {d} was excluded at {} by {} ({}): it is not used for new jobs",
                    x.at, x.by, x.reason
                )));
            }
            if !j.kind.accepts(&ds.kind) {
                return Err(ApiError::InvalidRequest(format!(
                    "a {} job cannot run on dataset {d} of kind {}",
                    j.kind.as_str(),
                    ds.kind
                )));
            }
            ds.machine_id
        }
        (None, true) => {
            return Err(ApiError::InvalidRequest(format!(
                "a {} job needs dataset_id",
                j.kind.as_str()
            )));
        }
        (Some(_), false) => {
            return Err(ApiError::InvalidRequest(format!(
                "a {} job takes no dataset_id",
                j.kind.as_str()
            )));
        }
        (None, false) => {
            let m = j.machine_id.as_deref().ok_or_else(|| {
                ApiError::InvalidRequest(format!("a {} job needs machine_id", j.kind.as_str()))
            })?;
            s.store.get_machine(m).await?.id
        }
    };
    let job = s
        .store
        .enqueue(NewJob {
            kind: j.kind,
            machine_id: Some(machine_id),
            dataset_id: j.dataset_id,
            params,
            max_attempts: s.max_attempts,
        })
        .await?;
    s.wake.notify_one();
    Ok(job)
}

#[utoipa::path(operation_id = "jobs_get", summary = "A job: state, progress, error", get, path = "/api/v1/jobs/{id}", tag = "jobs",
    security(("api_key" = [])), params(("id" = String, Path)),
    responses((status = 200, body = Job), (status = 404, body = ErrorBody)))]
pub async fn get(
    _key: ReadKey,
    State(s): State<AppState>,
    Path(id): Path<String>,
) -> Result<Json<Job>, ApiError> {
    Ok(Json(s.store.get_job(&id).await?))
}

#[utoipa::path(operation_id = "jobs_result", summary = "The result document of a succeeded job", get, path = "/api/v1/jobs/{id}/result", tag = "jobs",
    security(("api_key" = [])), params(("id" = String, Path)),
    responses((status = 200, description = "the result document (results contract)", body = crate::contract::ResultDocument),
              (status = 409, body = ErrorBody, description = "job_not_finished, or the job failed"),
              (status = 404, body = ErrorBody)))]
pub async fn result(
    _key: ReadKey,
    State(s): State<AppState>,
    Path(id): Path<String>,
) -> Result<Json<serde_json::Value>, ApiError> {
    let job = s.store.get_job(&id).await?;
    match (job.state, &job.result_id) {
        (JobState::Succeeded, Some(r)) => Ok(Json(s.store.get_result(r).await?.document)),
        (JobState::Failed, _) => Err(ApiError::Conflict(format!(
            "job {id} failed ({}): {}",
            job.error_code.unwrap_or_default(),
            job.error_message.unwrap_or_default()
        ))),
        (state, _) => Err(ApiError::JobNotFinished(format!(
            "job {id} is {}",
            state.as_str()
        ))),
    }
}

#[utoipa::path(operation_id = "jobs_cancel", summary = "Cancel a queued or running job", post, path = "/api/v1/jobs/{id}/cancel", tag = "jobs",
    security(("api_key" = ["write"])), params(("id" = String, Path)),
    responses((status = 200, body = Job, description = "cancelled, or cancellation requested of a running job"),
              (status = 409, body = ErrorBody, description = "the job already finished")))]
pub async fn cancel(
    _key: WriteKey,
    State(s): State<AppState>,
    Path(id): Path<String>,
) -> Result<Json<Job>, ApiError> {
    Ok(Json(s.store.cancel_job(&id).await?))
}

/// Most jobs one list returns.
pub const MAX_JOBS: usize = 1000;

#[derive(Debug, Default, Deserialize, utoipa::IntoParams)]
#[into_params(parameter_in = Query)]
pub struct JobListQuery {
    /// Only jobs in this state: `queued`, `running`, `succeeded`, `failed`, `cancelled`
    /// (empty: all).
    #[param(pattern = "^(|queued|running|succeeded|failed|cancelled)$")]
    pub state: Option<String>,
    /// At most this many, newest first (default 100, at most 1000).
    #[param(minimum = 1, maximum = 1000)]
    pub limit: Option<usize>,
}

/// Jobs newest first (`GET /api/v1/jobs`; the dashboard's jobs page too).
pub async fn list_jobs(s: &AppState, q: &JobListQuery, key: &ApiKey) -> Result<Vec<Job>, ApiError> {
    let state = match q.state.as_deref().filter(|v| !v.is_empty()) {
        None => None,
        Some(v) => Some(JobState::parse(v).ok_or_else(|| {
            ApiError::InvalidRequest(format!(
                "state: queued, running, succeeded, failed or cancelled, got {v:?}"
            ))
        })?),
    };
    let limit = mtcal_domain::paging::limit(q.limit, 100, MAX_JOBS)?;
    let Some(ids) = Within(key).machine_ids(s).await? else {
        return Ok(s.store.list_jobs(state, limit as i64).await?);
    };
    // A scoped key: the newest jobs of its machines among the newest of all.
    let mut jobs = s.store.list_jobs(state, MAX_JOBS as i64).await?;
    jobs.retain(|j| j.machine_id.as_ref().is_some_and(|m| ids.contains(m)));
    jobs.truncate(limit);
    Ok(jobs)
}

#[utoipa::path(operation_id = "jobs_list", summary = "Jobs, newest first (by state)", get, path = "/api/v1/jobs", tag = "jobs",
    security(("api_key" = [])), params(JobListQuery),
    responses((status = 200, body = Vec<Job>), (status = 400, body = ErrorBody), (status = 401, body = ErrorBody)))]
pub async fn list(
    ReadKey(key): ReadKey,
    State(s): State<AppState>,
    crate::error::ApiQuery(q): crate::error::ApiQuery<JobListQuery>,
) -> Result<Json<Vec<Job>>, ApiError> {
    Ok(Json(list_jobs(&s, &q, &key).await?))
}
