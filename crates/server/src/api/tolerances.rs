//! Tolerance profiles (create, list, read, replace, delete) and the verdict of a result
//! against the profile that applies to its machine (rules: [`mtcal_domain::profiles`],
//! [`mtcal_domain::verdicts`]).

use crate::AppState;
use crate::auth::{ReadKey, WriteKey};
use crate::error::{ApiError, ApiJson, ErrorBody};
use axum::Json;
use axum::extract::{Path, State};
use axum::http::StatusCode;
use mtcal_domain::profiles;
pub use mtcal_domain::profiles::{NewProfile, Profile, ProfileUpdate, TARGET_MAX};
pub use mtcal_domain::verdicts::{ProfileRef, ResultVerdict};

/// Refreshes the fleet rows of the machines a profile applies to, in a task of its own
/// (a tag may cover many machines; the fleet page follows within moments).
pub(crate) fn refresh_targets(s: &AppState, scope: &str, target: &str) {
    let (store, scope, target) = (s.store.clone(), scope.to_string(), target.to_string());
    tokio::spawn(async move {
        if let Err(e) =
            mtcal_domain::fleet::refresh_profile_targets(store.as_ref(), &scope, &target).await
        {
            tracing::warn!(%scope, %target, %e, "fleet verdicts not refreshed");
        }
    });
}

#[utoipa::path(operation_id = "tolerances_create", summary = "Create a tolerance profile (per machine or per tag)", post, path = "/api/v1/tolerances", tag = "tolerances",
    security(("api_key" = ["write"])), request_body = NewProfile,
    responses((status = 201, body = Profile), (status = 400, body = ErrorBody, description = "names the bad field"),
              (status = 401, body = ErrorBody), (status = 403, body = ErrorBody),
              (status = 404, body = ErrorBody, description = "no such machine"),
              (status = 409, body = ErrorBody, description = "the target already has a profile")))]
pub async fn create(
    _key: WriteKey,
    State(s): State<AppState>,
    ApiJson(p): ApiJson<NewProfile>,
) -> Result<(StatusCode, Json<Profile>), ApiError> {
    let answer = profiles::create(s.store.as_ref(), &p, &s.settings.webhooks).await?;
    refresh_targets(&s, &answer.scope, &answer.target);
    Ok((StatusCode::CREATED, Json(answer)))
}

#[utoipa::path(operation_id = "tolerances_list", summary = "Every tolerance profile", get, path = "/api/v1/tolerances", tag = "tolerances",
    security(("api_key" = [])),
    responses((status = 200, body = Vec<Profile>, description = "by scope, then target"), (status = 401, body = ErrorBody)))]
pub async fn list(
    ReadKey(key): ReadKey,
    State(s): State<AppState>,
) -> Result<Json<Vec<Profile>>, ApiError> {
    let all = s.store.list_tolerances().await?;
    Ok(Json(
        all.iter()
            .map(|p| profiles::profile_of(p).map(|p| profiles::seen_by(p, key.scope)))
            .collect::<Result<_, _>>()?,
    ))
}

#[utoipa::path(operation_id = "tolerances_get", summary = "One tolerance profile", get, path = "/api/v1/tolerances/{id}", tag = "tolerances",
    security(("api_key" = [])), params(("id" = String, Path)),
    responses((status = 200, body = Profile), (status = 401, body = ErrorBody), (status = 404, body = ErrorBody)))]
pub async fn get(
    ReadKey(key): ReadKey,
    State(s): State<AppState>,
    Path(id): Path<String>,
) -> Result<Json<Profile>, ApiError> {
    let p = profiles::profile_of(&s.store.get_tolerance(&id).await?)?;
    Ok(Json(profiles::seen_by(p, key.scope)))
}

#[utoipa::path(operation_id = "tolerances_replace", summary = "Replace a tolerance profile's limits and webhook", put, path = "/api/v1/tolerances/{id}", tag = "tolerances",
    security(("api_key" = ["write"])), params(("id" = String, Path)), request_body = ProfileUpdate,
    responses((status = 200, body = Profile), (status = 400, body = ErrorBody, description = "names the bad field"),
              (status = 401, body = ErrorBody), (status = 403, body = ErrorBody), (status = 404, body = ErrorBody)))]
pub async fn replace(
    _key: WriteKey,
    State(s): State<AppState>,
    Path(id): Path<String>,
    ApiJson(u): ApiJson<ProfileUpdate>,
) -> Result<Json<Profile>, ApiError> {
    let answer = profiles::replace(s.store.as_ref(), &id, &u, &s.settings.webhooks).await?;
    refresh_targets(&s, &answer.scope, &answer.target);
    Ok(Json(answer))
}

#[utoipa::path(operation_id = "tolerances_delete", summary = "Delete a tolerance profile", delete, path = "/api/v1/tolerances/{id}", tag = "tolerances",
    security(("api_key" = ["write"])), params(("id" = String, Path)),
    responses((status = 204, description = "deleted"), (status = 401, body = ErrorBody), (status = 403, body = ErrorBody),
              (status = 404, body = ErrorBody)))]
pub async fn delete(
    _key: WriteKey,
    State(s): State<AppState>,
    Path(id): Path<String>,
) -> Result<StatusCode, ApiError> {
    let old = s.store.get_tolerance(&id).await?;
    s.store.delete_tolerance(&id).await?;
    refresh_targets(&s, &old.scope, &old.target);
    Ok(StatusCode::NO_CONTENT)
}

#[utoipa::path(operation_id = "tolerances_verdict", summary = "A result's verdict against its machine's tolerance profile", get, path = "/api/v1/results/{id}/verdict", tag = "tolerances",
    security(("api_key" = [])), params(("id" = String, Path)),
    responses((status = 200, body = ResultVerdict), (status = 401, body = ErrorBody), (status = 404, body = ErrorBody)))]
pub async fn verdict(
    _key: ReadKey,
    State(s): State<AppState>,
    Path(id): Path<String>,
) -> Result<Json<ResultVerdict>, ApiError> {
    Ok(Json(
        mtcal_domain::verdicts::result_verdict(s.store.as_ref(), &id).await?,
    ))
}
