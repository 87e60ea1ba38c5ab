//! `/api/v1/keys` (admin): create, list and revoke API keys. Secrets are shown once, at
//! creation; a list shows prefixes and labels, never a secret or its hash.

use crate::AppState;
use crate::auth::AdminKey;
use crate::error::{ApiError, ApiJson, ErrorBody};
use axum::Json;
use axum::extract::{Path, State};
use axum::http::StatusCode;
pub use mtcal_api::keys::{CreatedKey, NewKey};
use mtcal_store::ApiKey;

#[utoipa::path(operation_id = "keys_create", summary = "Create an API key (admin)", post, path = "/api/v1/keys", tag = "keys", request_body = NewKey,
    security(("api_key" = ["admin"])),
    responses((status = 201, body = CreatedKey), (status = 403, body = ErrorBody)))]
pub async fn create(
    _key: AdminKey,
    State(s): State<AppState>,
    ApiJson(k): ApiJson<NewKey>,
) -> Result<(StatusCode, Json<CreatedKey>), ApiError> {
    let (key, secret) = s.store.create_key(k.scope, &k.label).await?;
    Ok((StatusCode::CREATED, Json(CreatedKey { key, secret })))
}

#[utoipa::path(operation_id = "keys_list", summary = "List API keys, revoked ones included (admin)", get, path = "/api/v1/keys", tag = "keys",
    security(("api_key" = ["admin"])),
    responses((status = 200, body = Vec<ApiKey>), (status = 401, body = ErrorBody), (status = 403, body = ErrorBody)))]
pub async fn list(
    _key: AdminKey,
    State(s): State<AppState>,
) -> Result<Json<Vec<ApiKey>>, ApiError> {
    Ok(Json(s.store.list_keys().await?))
}

/// Revokes a key: from the next request on it authenticates nothing (401) and its
/// sign-in sessions end. Revoking a revoked key changes nothing and answers the key as it
/// is. A key cannot revoke itself, and the last admin key cannot be revoked (409).
#[utoipa::path(operation_id = "keys_revoke", summary = "Revoke an API key (admin)", delete, path = "/api/v1/keys/{id}", tag = "keys",
    params(("id" = String, Path, description = "Key id (`key_…`)")),
    security(("api_key" = ["admin"])),
    responses((status = 200, body = ApiKey), (status = 401, body = ErrorBody), (status = 403, body = ErrorBody), (status = 404, body = ErrorBody),
              (status = 409, body = ErrorBody, description = "the key is the one making the request, or the last admin key")))]
pub async fn revoke(
    AdminKey(me): AdminKey,
    State(s): State<AppState>,
    Path(id): Path<String>,
) -> Result<Json<ApiKey>, ApiError> {
    if id == me.id {
        return Err(ApiError::Conflict(format!(
            "key {id} is the key of this request: revoke it with another admin key"
        )));
    }
    Ok(Json(s.store.revoke_key(&id).await?))
}
