//! `/api/v1/keys` (admin): create, list and revoke API keys. Secrets are shown once, at
//! creation; a list shows prefixes and labels, never a secret or its hash.

use crate::AppState;
use crate::audit::{Actor, Change, json};
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
    AdminKey(me): AdminKey,
    who: Actor,
    State(s): State<AppState>,
    ApiJson(k): ApiJson<NewKey>,
) -> Result<(StatusCode, Json<CreatedKey>), ApiError> {
    // A key gives no more than it has: its sites and tags bound the new key's.
    if !me.contains(&k.sites, &k.tags) {
        return Err(ApiError::Forbidden(format!(
            "key {} (sites {:?}, tags {:?}) cannot create a key wider than its own scope \
             (asked: sites {:?}, tags {:?}; empty is the whole group)",
            me.prefix, me.sites, me.tags, k.sites, k.tags
        )));
    }
    let (key, secret) = s
        .store
        .create_key_in(k.scope, &k.label, &k.sites, &k.tags)
        .await?;
    // The record without the secret (shown once, never kept).
    let change = Change {
        action: "key.create",
        target: &key.id,
        machine: None,
        before: None,
        after: json(&key),
    };
    who.record(s.store.as_ref(), change).await?;
    Ok((StatusCode::CREATED, Json(CreatedKey { key, secret })))
}

#[utoipa::path(operation_id = "keys_list", summary = "List API keys, revoked ones included (admin)", get, path = "/api/v1/keys", tag = "keys",
    security(("api_key" = ["admin"])),
    responses((status = 200, body = Vec<ApiKey>), (status = 401, body = ErrorBody), (status = 403, body = ErrorBody)))]
pub async fn list(
    AdminKey(me): AdminKey,
    State(s): State<AppState>,
) -> Result<Json<Vec<ApiKey>>, ApiError> {
    let mut keys = s.store.list_keys().await?;
    // A key limited to sites or tags sees the keys within its scope only.
    keys.retain(|k| me.contains(&k.sites, &k.tags));
    Ok(Json(keys))
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
    who: Actor,
    State(s): State<AppState>,
    Path(id): Path<String>,
) -> Result<Json<ApiKey>, ApiError> {
    if id == me.id {
        return Err(ApiError::Conflict(format!(
            "key {id} is the key of this request: revoke it with another admin key"
        )));
    }
    let before = s.store.list_keys().await?.into_iter().find(|k| k.id == id);
    let after = s.store.revoke_key(&id).await?;
    let change = Change {
        action: "key.revoke",
        target: &after.id,
        machine: None,
        before: before.as_ref().and_then(json),
        after: json(&after),
    };
    who.record(s.store.as_ref(), change).await?;
    Ok(Json(after))
}
