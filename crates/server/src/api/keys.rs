//! `/api/v1/keys` (admin): create API keys.

use crate::AppState;
use crate::auth::AdminKey;
use crate::error::{ApiError, ApiJson, ErrorBody};
use axum::Json;
use axum::extract::State;
use axum::http::StatusCode;
use mtcal_store::{ApiKey, Scope};
use serde::{Deserialize, Serialize};
use utoipa::ToSchema;

#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct NewKey {
    pub scope: Scope,
    pub label: String,
}

/// A new key: `secret` is shown this once and not stored.
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
pub struct CreatedKey {
    pub key: ApiKey,
    pub secret: String,
}

#[utoipa::path(operation_id = "keys_create", summary = "Create an API key (admin)", post, path = "/api/v1/keys", tag = "keys", request_body = NewKey,
    security(("api_key" = [])),
    responses((status = 201, body = CreatedKey), (status = 403, body = ErrorBody)))]
pub async fn create(
    _key: AdminKey,
    State(s): State<AppState>,
    ApiJson(k): ApiJson<NewKey>,
) -> Result<(StatusCode, Json<CreatedKey>), ApiError> {
    let (key, secret) = s.store.create_key(k.scope, &k.label).await?;
    Ok((StatusCode::CREATED, Json(CreatedKey { key, secret })))
}
