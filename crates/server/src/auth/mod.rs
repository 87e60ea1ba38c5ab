//! API-key authentication: `Authorization: Bearer <key>` (or `X-Api-Key: <key>`), scopes
//! read ⊂ write ⊂ admin; a GET or HEAD without a key may instead carry the dashboard's
//! session cookie. Health and the documentation are the only open routes.
//!
//! Two pieces:
//! * [`authenticate`], a middleware in front of every `/api/v1` route, outside the body
//!   limits, decompression and every extractor: a request without a valid key gets 401
//!   before anything looks at its body, query or content type. It puts the [`ApiKey`] in
//!   the request's extensions.
//! * the extractors [`ReadKey`], [`WriteKey`] and [`AdminKey`]: a handler names the scope
//!   it needs by taking one of them as its first argument (403 when the key's scope is
//!   lower), before any extractor that reads the request.
//!
//! The dashboard's sign-in cookie is read here too ([`session`]).

pub mod scope;
pub mod session;

use crate::AppState;
use crate::error::ApiError;
use axum::extract::{FromRequestParts, Request, State};
use axum::http::request::Parts;
use axum::http::{HeaderMap, Method};
use axum::middleware::Next;
use axum::response::{IntoResponse, Response};
use mtcal_store::{ApiKey, Scope};

/// The secret a request presents, if any: `Authorization: Bearer <key>` (the scheme's
/// name in any case, RFC 9110 section 11.1), else `X-Api-Key: <key>`.
pub(crate) fn presented(headers: &HeaderMap) -> Option<&str> {
    fn bearer(v: &str) -> Option<&str> {
        let (scheme, rest) = v.split_once(' ')?;
        scheme.eq_ignore_ascii_case("bearer").then_some(rest)
    }
    headers
        .get(axum::http::header::AUTHORIZATION)
        .and_then(|v| v.to_str().ok())
        .and_then(bearer)
        .or_else(|| headers.get("x-api-key").and_then(|v| v.to_str().ok()))
        .map(str::trim)
}

/// The stored key a request presents: 401 when missing, unknown or revoked.
pub async fn key_of(state: &AppState, headers: &HeaderMap) -> Result<ApiKey, ApiError> {
    let secret = presented(headers).ok_or_else(|| {
        ApiError::Unauthorized("missing API key (send `Authorization: Bearer <key>`)".into())
    })?;
    state
        .store
        .key_by_secret(secret)
        .await?
        .ok_or_else(|| ApiError::Unauthorized("unknown or revoked API key".into()))
}

/// The key of a request: the one it presents; a GET or HEAD that presents none may
/// come from the dashboard's page script, and is read as the key of its browser's
/// session cookie ([`session`]). Reads only: a session cannot change anything
/// through the API (forms post to the dashboard's own routes, which check a CSRF token).
async fn request_key(
    state: &AppState,
    method: &Method,
    headers: &HeaderMap,
) -> Result<ApiKey, ApiError> {
    let safe = matches!(*method, Method::GET | Method::HEAD);
    if safe && presented(headers).is_none() {
        let key = session::cookie_key();
        if let Some(s) = session::Session::from_headers(state, &key, headers).await? {
            return Ok(s.key);
        }
    }
    key_of(state, headers).await
}

/// Middleware: authenticates every request (401 first), leaving the key in the
/// request's extensions for the scope extractors.
pub async fn authenticate(State(state): State<AppState>, mut req: Request, next: Next) -> Response {
    match request_key(&state, req.method(), req.headers()).await {
        Ok(key) => {
            req.extensions_mut().insert(key);
            next.run(req).await
        }
        Err(e) => e.into_response(),
    }
}

/// Middleware for routes whose layers read the body before the handler runs (uploads:
/// decompression): the scope check of [`WriteKey`], ahead of them.
pub async fn require_write(State(state): State<AppState>, req: Request, next: Next) -> Response {
    let (mut parts, body) = req.into_parts();
    match authorize(&parts, &state, Scope::Write).await {
        Ok(key) => {
            parts.extensions.insert(key);
            next.run(Request::from_parts(parts, body)).await
        }
        Err(e) => e.into_response(),
    }
}

/// The request's key, checked against `needed` (403 when its scope is lower).
async fn authorize(parts: &Parts, state: &AppState, needed: Scope) -> Result<ApiKey, ApiError> {
    let key = match parts.extensions.get::<ApiKey>() {
        Some(k) => k.clone(),
        // A route outside the middleware still authenticates.
        None => key_of(state, &parts.headers).await?,
    };
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

macro_rules! scope_extractor {
    ($(#[$doc:meta])* $name:ident, $scope:expr) => {
        $(#[$doc])*
        #[derive(Debug, Clone)]
        pub struct $name(pub ApiKey);

        impl FromRequestParts<AppState> for $name {
            type Rejection = ApiError;

            async fn from_request_parts(
                parts: &mut Parts,
                state: &AppState,
            ) -> Result<Self, ApiError> {
                authorize(parts, state, $scope).await.map($name)
            }
        }
    };
}

scope_extractor!(
    /// A key with at least read scope.
    ReadKey,
    Scope::Read
);
scope_extractor!(
    /// A key with at least write scope.
    WriteKey,
    Scope::Write
);
scope_extractor!(
    /// A key with admin scope.
    AdminKey,
    Scope::Admin
);
