//! Tolerance profiles (create, list, read, replace, delete) and the verdict of a result
//! against the profile that applies to its machine (rules: [`mtcal_domain::profiles`],
//! [`mtcal_domain::verdicts`]).

use crate::AppState;
use crate::audit::{Actor, Change, json};
use crate::auth::scope::Within;
use crate::auth::{ReadKey, WriteKey};
use crate::error::{ApiError, ApiJson, ErrorBody};
use axum::Json;
use axum::extract::{Path, State};
use axum::http::StatusCode;
use mtcal_domain::profiles;
pub use mtcal_domain::profiles::{NewProfile, Profile, ProfileUpdate, TARGET_MAX};
pub use mtcal_domain::verdicts::{ProfileRef, ResultVerdict};
use mtcal_store::{ApiKey, ToleranceProfile};

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
    who: Actor,
    State(s): State<AppState>,
    ApiJson(p): ApiJson<NewProfile>,
) -> Result<(StatusCode, Json<Profile>), ApiError> {
    Ok((
        StatusCode::CREATED,
        Json(create_profile(&s, &p, &who).await?),
    ))
}

/// The profile as the audit trail keeps it ([`profiles::audited`]).
fn recorded(p: &Profile) -> Option<serde_json::Value> {
    json(&profiles::audited(p))
}

/// Creates a profile, records it and refreshes the verdicts of the machines it applies
/// to (`POST /api/v1/tolerances`; the dashboard's form).
pub async fn create_profile(
    s: &AppState,
    p: &NewProfile,
    who: &Actor,
) -> Result<Profile, ApiError> {
    let post = axum::http::Method::POST;
    who.within()?.profile(s, &p.scope, &p.target, &post).await?;
    let answer = profiles::create(s.store.as_ref(), p, &s.settings.webhooks).await?;
    let change = Change {
        action: "profile.create",
        target: &answer.id,
        machine: profiles::machine_of(&answer),
        before: None,
        after: recorded(&answer),
    };
    who.record(s.store.as_ref(), change).await?;
    refresh_targets(s, &answer.scope, &answer.target);
    Ok(answer)
}

/// A profile as `key` may see it: a tag's profile, the whole group's, shows a key
/// limited to sites or tags the webhook's host only, as a read key.
fn seen(p: Profile, key: &ApiKey) -> Profile {
    let scope = if key.is_group() || p.scope == "machine" {
        key.scope
    } else {
        mtcal_store::Scope::Read
    };
    profiles::seen_by(p, scope)
}

#[utoipa::path(operation_id = "tolerances_list", summary = "Every tolerance profile", get, path = "/api/v1/tolerances", tag = "tolerances",
    security(("api_key" = [])),
    responses((status = 200, body = Vec<Profile>, description = "by scope, then target"), (status = 401, body = ErrorBody)))]
pub async fn list(
    ReadKey(key): ReadKey,
    State(s): State<AppState>,
) -> Result<Json<Vec<Profile>>, ApiError> {
    let all = s.store.list_tolerances().await?;
    let ids = Within(&key).machine_ids(&s).await?;
    let shown = |p: &&ToleranceProfile| match &ids {
        Some(ids) if p.scope == "machine" => ids.contains(&p.target),
        _ => true,
    };
    Ok(Json(
        all.iter()
            .filter(shown)
            .map(|p| profiles::profile_of(p).map(|p| seen(p, &key)))
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
    Ok(Json(seen(p, &key)))
}

#[utoipa::path(operation_id = "tolerances_replace", summary = "Replace a tolerance profile's limits and webhook", put, path = "/api/v1/tolerances/{id}", tag = "tolerances",
    security(("api_key" = ["write"])), params(("id" = String, Path)), request_body = ProfileUpdate,
    responses((status = 200, body = Profile), (status = 400, body = ErrorBody, description = "names the bad field"),
              (status = 401, body = ErrorBody), (status = 403, body = ErrorBody), (status = 404, body = ErrorBody)))]
pub async fn replace(
    _key: WriteKey,
    who: Actor,
    State(s): State<AppState>,
    Path(id): Path<String>,
    ApiJson(u): ApiJson<ProfileUpdate>,
) -> Result<Json<Profile>, ApiError> {
    let before = mtcal_domain::profiles::profile_of(&s.store.get_tolerance(&id).await?)?;
    let answer = profiles::replace(s.store.as_ref(), &id, &u, &s.settings.webhooks).await?;
    let change = Change {
        action: "profile.replace",
        target: &answer.id,
        machine: profiles::machine_of(&answer),
        before: recorded(&before),
        after: recorded(&answer),
    };
    who.record(s.store.as_ref(), change).await?;
    refresh_targets(&s, &answer.scope, &answer.target);
    Ok(Json(answer))
}

#[utoipa::path(operation_id = "tolerances_delete", summary = "Delete a tolerance profile", delete, path = "/api/v1/tolerances/{id}", tag = "tolerances",
    security(("api_key" = ["write"])), params(("id" = String, Path)),
    responses((status = 204, description = "deleted"), (status = 401, body = ErrorBody), (status = 403, body = ErrorBody),
              (status = 404, body = ErrorBody)))]
pub async fn delete(
    _key: WriteKey,
    who: Actor,
    State(s): State<AppState>,
    Path(id): Path<String>,
) -> Result<StatusCode, ApiError> {
    let old = s.store.get_tolerance(&id).await?;
    let before = mtcal_domain::profiles::profile_of(&old)?;
    s.store.delete_tolerance(&id).await?;
    let change = Change {
        action: "profile.delete",
        target: &before.id,
        machine: profiles::machine_of(&before),
        before: recorded(&before),
        after: None,
    };
    who.record(s.store.as_ref(), change).await?;
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
