//! Tolerance profiles (create, list, read, replace, delete) and the verdict of a result
//! against the profile that applies to its machine (rules: [`crate::tolerances`]).

use crate::AppState;
use crate::auth::{ReadKey, WriteKey};
use crate::error::{ApiError, ApiJson, ErrorBody};
use axum::Json;
use axum::extract::{Path, State};
use axum::http::StatusCode;
use mtcal_solver::tolerance::{Limits, Verdict};
use mtcal_store::ToleranceProfile;
use serde::{Deserialize, Serialize};
use utoipa::ToSchema;

/// Longest profile target (machine id or tag), bytes.
pub const TARGET_MAX: usize = 200;

/// A tolerance profile.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct Profile {
    pub id: String,
    /// `machine` (the profile of one machine) or `tag` (of every machine with the tag).
    pub scope: String,
    /// The machine id or the tag.
    pub target: String,
    pub limits: Limits,
    /// Tag profiles only: drift alerts of the tag's machines are POSTed here.
    pub webhook_url: Option<String>,
    pub created_at: String,
    pub updated_at: String,
}

impl Profile {
    pub fn of(p: &ToleranceProfile) -> Result<Profile, ApiError> {
        Ok(Profile {
            id: p.id.clone(),
            scope: p.scope.clone(),
            target: p.target.clone(),
            limits: crate::tolerances::limits(p)?,
            webhook_url: p.webhook_url.clone(),
            created_at: p.created_at.clone(),
            updated_at: p.updated_at.clone(),
        })
    }
}

/// A new tolerance profile.
#[derive(Debug, Clone, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct NewProfile {
    /// `machine` or `tag`.
    pub scope: String,
    /// The machine id (it must exist) or the tag.
    pub target: String,
    /// At least one limit; each positive and finite, names as in docs/api.md.
    pub limits: Limits,
    /// Tag profiles only: an `http` or `https` URL receiving the drift alerts.
    #[serde(default)]
    pub webhook_url: Option<String>,
}

/// A profile's new content (replaces limits and webhook).
#[derive(Debug, Clone, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct ProfileUpdate {
    pub limits: Limits,
    #[serde(default)]
    pub webhook_url: Option<String>,
}

/// Checks a profile's content; the message names the field.
fn validate(scope: &str, limits: &Limits, webhook_url: Option<&str>) -> Result<(), ApiError> {
    let bad = |m: String| ApiError::InvalidRequest(m);
    if limits.is_empty() {
        return Err(bad(
            "limits: give at least one limit (terms, squareness, standards, drift_um or drift_urad)"
                .into(),
        ));
    }
    limits.validate().map_err(|m| bad(format!("limits.{m}")))?;
    if let Some(url) = webhook_url {
        if scope != "tag" {
            return Err(bad(
                "webhook_url: only a tag profile has a webhook (alerts go to the tags of a machine)"
                    .into(),
            ));
        }
        crate::alerts::validate_webhook_url(url).map_err(bad)?;
    }
    Ok(())
}

fn limits_json(l: &Limits) -> Result<serde_json::Value, ApiError> {
    serde_json::to_value(l).map_err(|e| ApiError::Internal(e.to_string()))
}

/// Refreshes the fleet rows of the machines a profile applies to, in a task of its own
/// (a tag may cover many machines; the fleet page follows within moments).
fn refresh_targets(s: &AppState, scope: &str, target: &str) {
    let (store, scope, target) = (s.store.clone(), scope.to_string(), target.to_string());
    tokio::spawn(async move {
        if let Err(e) = crate::fleet::refresh_profile_targets(store.as_ref(), &scope, &target).await
        {
            tracing::warn!(%scope, %target, %e, "fleet verdicts not refreshed");
        }
    });
}

#[utoipa::path(operation_id = "tolerances_create", summary = "Create a tolerance profile (per machine or per tag)", post, path = "/api/v1/tolerances", tag = "tolerances",
    security(("api_key" = [])), request_body = NewProfile,
    responses((status = 201, body = Profile), (status = 400, body = ErrorBody, description = "names the bad field"),
              (status = 401, body = ErrorBody), (status = 403, body = ErrorBody),
              (status = 404, body = ErrorBody, description = "no such machine"),
              (status = 409, body = ErrorBody, description = "the target already has a profile")))]
pub async fn create(
    _key: WriteKey,
    State(s): State<AppState>,
    ApiJson(p): ApiJson<NewProfile>,
) -> Result<(StatusCode, Json<Profile>), ApiError> {
    if !crate::tolerances::SCOPES.contains(&p.scope.as_str()) {
        return Err(ApiError::InvalidRequest(format!(
            "scope: `machine` or `tag`, got {:?}",
            p.scope
        )));
    }
    let target = p.target.trim();
    if target.is_empty() || target.len() > TARGET_MAX {
        return Err(ApiError::InvalidRequest(format!(
            "target: a machine id or a tag of 1 to {TARGET_MAX} bytes"
        )));
    }
    validate(&p.scope, &p.limits, p.webhook_url.as_deref())?;
    if p.scope == "machine" {
        s.store.get_machine(target).await?;
    }
    let stored = s
        .store
        .create_tolerance(&ToleranceProfile {
            id: mtcal_store::rules::new_id("tol"),
            scope: p.scope.clone(),
            target: target.to_string(),
            limits: limits_json(&p.limits)?,
            webhook_url: p.webhook_url.clone(),
            created_at: String::new(),
            updated_at: String::new(),
        })
        .await?;
    refresh_targets(&s, &stored.scope, &stored.target);
    Ok((StatusCode::CREATED, Json(Profile::of(&stored)?)))
}

#[utoipa::path(operation_id = "tolerances_list", summary = "Every tolerance profile", get, path = "/api/v1/tolerances", tag = "tolerances",
    security(("api_key" = [])),
    responses((status = 200, body = Vec<Profile>, description = "by scope, then target"), (status = 401, body = ErrorBody)))]
pub async fn list(
    _key: ReadKey,
    State(s): State<AppState>,
) -> Result<Json<Vec<Profile>>, ApiError> {
    let all = s.store.list_tolerances().await?;
    Ok(Json(all.iter().map(Profile::of).collect::<Result<_, _>>()?))
}

#[utoipa::path(operation_id = "tolerances_get", summary = "One tolerance profile", get, path = "/api/v1/tolerances/{id}", tag = "tolerances",
    security(("api_key" = [])), params(("id" = String, Path)),
    responses((status = 200, body = Profile), (status = 401, body = ErrorBody), (status = 404, body = ErrorBody)))]
pub async fn get(
    _key: ReadKey,
    State(s): State<AppState>,
    Path(id): Path<String>,
) -> Result<Json<Profile>, ApiError> {
    Ok(Json(Profile::of(&s.store.get_tolerance(&id).await?)?))
}

#[utoipa::path(operation_id = "tolerances_replace", summary = "Replace a tolerance profile's limits and webhook", put, path = "/api/v1/tolerances/{id}", tag = "tolerances",
    security(("api_key" = [])), params(("id" = String, Path)), request_body = ProfileUpdate,
    responses((status = 200, body = Profile), (status = 400, body = ErrorBody, description = "names the bad field"),
              (status = 401, body = ErrorBody), (status = 403, body = ErrorBody), (status = 404, body = ErrorBody)))]
pub async fn replace(
    _key: WriteKey,
    State(s): State<AppState>,
    Path(id): Path<String>,
    ApiJson(u): ApiJson<ProfileUpdate>,
) -> Result<Json<Profile>, ApiError> {
    let old = s.store.get_tolerance(&id).await?;
    validate(&old.scope, &u.limits, u.webhook_url.as_deref())?;
    let stored = s
        .store
        .update_tolerance(&id, &limits_json(&u.limits)?, u.webhook_url.as_deref())
        .await?;
    refresh_targets(&s, &stored.scope, &stored.target);
    Ok(Json(Profile::of(&stored)?))
}

#[utoipa::path(operation_id = "tolerances_delete", summary = "Delete a tolerance profile", delete, path = "/api/v1/tolerances/{id}", tag = "tolerances",
    security(("api_key" = [])), params(("id" = String, Path)),
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

/// The profile a verdict is against.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct ProfileRef {
    pub id: String,
    pub scope: String,
    pub target: String,
}

/// A result's verdict.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct ResultVerdict {
    pub result_id: String,
    pub machine_id: String,
    /// The profile that applies to the machine (its own, else its first tag's that has
    /// one); null when none applies.
    pub profile: Option<ProfileRef>,
    /// The decision per limit and overall; null when no profile applies.
    pub verdict: Option<Verdict>,
}

/// The verdict of result `id` (`GET /api/v1/results/{id}/verdict`; the dashboard too).
pub async fn result_verdict(s: &AppState, id: &str) -> Result<ResultVerdict, ApiError> {
    let r = s.store.get_result(id).await?;
    let m = s.store.get_machine(&r.meta.machine_id).await?;
    let profiles = s.store.list_tolerances().await?;
    let v = crate::tolerances::verdict(s.store.as_ref(), &profiles, &m, &r).await?;
    Ok(ResultVerdict {
        result_id: r.meta.id.clone(),
        machine_id: m.id.clone(),
        profile: v.as_ref().map(|(p, _)| ProfileRef {
            id: p.id.clone(),
            scope: p.scope.clone(),
            target: p.target.clone(),
        }),
        verdict: v.map(|(_, v)| v),
    })
}

#[utoipa::path(operation_id = "tolerances_verdict", summary = "A result's verdict against its machine's tolerance profile", get, path = "/api/v1/results/{id}/verdict", tag = "tolerances",
    security(("api_key" = [])), params(("id" = String, Path)),
    responses((status = 200, body = ResultVerdict), (status = 401, body = ErrorBody), (status = 404, body = ErrorBody)))]
pub async fn verdict(
    _key: ReadKey,
    State(s): State<AppState>,
    Path(id): Path<String>,
) -> Result<Json<ResultVerdict>, ApiError> {
    Ok(Json(result_verdict(&s, &id).await?))
}
