//! API-key authentication: `Authorization: Bearer <key>` (or `X-Api-Key: <key>`), scopes
//! read ⊂ write ⊂ admin. Health and the documentation are the only open routes.

use crate::AppState;
use crate::error::ApiError;
use axum::http::HeaderMap;
use mtcal_store::{ApiKey, Scope};

/// The key presented with a request, checked against `needed`.
pub async fn authorize(
    state: &AppState,
    headers: &HeaderMap,
    needed: Scope,
) -> Result<ApiKey, ApiError> {
    let secret = headers
        .get(axum::http::header::AUTHORIZATION)
        .and_then(|v| v.to_str().ok())
        .and_then(|v| v.strip_prefix("Bearer "))
        .or_else(|| headers.get("x-api-key").and_then(|v| v.to_str().ok()))
        .ok_or_else(|| {
            ApiError::Unauthorized("missing API key (send `Authorization: Bearer <key>`)".into())
        })?;
    let key = state
        .store
        .key_by_secret(secret.trim())
        .await?
        .ok_or_else(|| ApiError::Unauthorized("unknown or revoked API key".into()))?;
    if !key.scope.allows(needed) {
        return Err(ApiError::Forbidden(format!(
            "this route needs a key with scope {}; key {} has scope {}",
            needed.as_str(),
            key.prefix,
            key.scope.as_str()
        )));
    }
    Ok(key)
}
