//! The one error type of the API.
//!
//! Policy: every error is JSON `{"error": {"code": "...", "message": "..."}}` with a
//! **stable** `code` (clients switch on it; the list is in docs/api.md and the OpenAPI
//! document) and a message that names the problem. A 500 never leaks internals: the cause
//! is logged, the client gets `internal`.

use axum::Json;
use axum::http::StatusCode;
use axum::response::{IntoResponse, Response};
use mtcal_store::StoreError;
use serde::{Deserialize, Serialize};
use utoipa::ToSchema;

/// What a client is told to wait before trying again after a 503.
pub const RETRY_AFTER: std::time::Duration = std::time::Duration::from_secs(5);

/// Marks a response made of an [`ApiError::Unavailable`]: the database was unreachable
/// (the outage guard marks the database down when it sees one).
#[derive(Debug, Clone, Copy)]
pub struct Unreachable;

/// Error body.
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
pub struct ErrorBody {
    pub error: ErrorDetail,
}

#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
pub struct ErrorDetail {
    /// Stable code: unauthorized, forbidden, not_found, conflict, invalid_request,
    /// invalid_encoding, invalid_dataset, payload_too_large, unsupported_media_type,
    /// job_not_finished, method_not_allowed, timeout, outside_measured_travel,
    /// not_identifiable, not_ready, unavailable, uri_too_long, headers_too_large,
    /// internal.
    pub code: String,
    pub message: String,
}

/// Everything a handler can fail with.
#[derive(Debug, thiserror::Error)]
pub enum ApiError {
    #[error("{0}")]
    Unauthorized(String),
    #[error("{0}")]
    Forbidden(String),
    #[error("{0}")]
    NotFound(String),
    #[error("{0}")]
    Conflict(String),
    #[error("{0}")]
    InvalidRequest(String),
    /// A body that cannot be decoded as its Content-Encoding says (a broken gzip stream).
    #[error("{0}")]
    InvalidEncoding(String),
    /// An upload broke a dataset rule (message: file, line, column, rule).
    #[error("{0}")]
    InvalidDataset(String),
    #[error("{0}")]
    PayloadTooLarge(String),
    #[error("{0}")]
    UnsupportedMediaType(String),
    #[error("{0}")]
    JobNotFinished(String),
    /// A position outside the travel the check measured (no figure is extrapolated).
    #[error("{0}")]
    OutsideTravel(String),
    /// Nothing of a result can be exported: no term is identifiable.
    #[error("{0}")]
    NotIdentifiable(String),
    /// The result's model does not explain its recording (the misfit gate): what would be
    /// made of it (a compensation table) is refused unless forced.
    #[error("{0}")]
    ModelMisfit(String),
    /// The request took too long (an upload below the minimum rate: the message says).
    #[error("{0}")]
    Timeout(String),
    /// The service cannot serve yet (database unreachable, migrations missing).
    #[error("{0}")]
    NotReady(String),
    /// The database cannot be reached now: 503 with Retry-After.
    #[error("{0}; try again in a few seconds")]
    Unavailable(String),
    #[error("internal error: {0}")]
    Internal(String),
}

impl ApiError {
    pub fn status(&self) -> StatusCode {
        match self {
            ApiError::Unauthorized(_) => StatusCode::UNAUTHORIZED,
            ApiError::Forbidden(_) => StatusCode::FORBIDDEN,
            ApiError::NotFound(_) => StatusCode::NOT_FOUND,
            ApiError::Conflict(_) | ApiError::JobNotFinished(_) | ApiError::ModelMisfit(_) => {
                StatusCode::CONFLICT
            }
            ApiError::InvalidRequest(_) | ApiError::InvalidEncoding(_) => StatusCode::BAD_REQUEST,
            ApiError::InvalidDataset(_) => StatusCode::UNPROCESSABLE_ENTITY,
            ApiError::PayloadTooLarge(_) => StatusCode::PAYLOAD_TOO_LARGE,
            ApiError::UnsupportedMediaType(_) => StatusCode::UNSUPPORTED_MEDIA_TYPE,
            ApiError::NotReady(_) | ApiError::Unavailable(_) => StatusCode::SERVICE_UNAVAILABLE,
            ApiError::Timeout(_) => StatusCode::REQUEST_TIMEOUT,
            ApiError::OutsideTravel(_) | ApiError::NotIdentifiable(_) => {
                StatusCode::UNPROCESSABLE_ENTITY
            }
            ApiError::Internal(_) => StatusCode::INTERNAL_SERVER_ERROR,
        }
    }

    pub fn code(&self) -> &'static str {
        match self {
            ApiError::Unauthorized(_) => "unauthorized",
            ApiError::Forbidden(_) => "forbidden",
            ApiError::NotFound(_) => "not_found",
            ApiError::Conflict(_) => "conflict",
            ApiError::InvalidRequest(_) => "invalid_request",
            ApiError::InvalidEncoding(_) => "invalid_encoding",
            ApiError::InvalidDataset(_) => "invalid_dataset",
            ApiError::PayloadTooLarge(_) => "payload_too_large",
            ApiError::UnsupportedMediaType(_) => "unsupported_media_type",
            ApiError::JobNotFinished(_) => "job_not_finished",
            ApiError::NotReady(_) => "not_ready",
            ApiError::Unavailable(_) => "unavailable",
            ApiError::Timeout(_) => "timeout",
            ApiError::OutsideTravel(_) => "outside_measured_travel",
            ApiError::NotIdentifiable(_) => "not_identifiable",
            ApiError::ModelMisfit(_) => "model_misfit",
            ApiError::Internal(_) => "internal",
        }
    }

    /// Marks a response made of this error: a 503 says when to try again
    /// (`Retry-After`), and an unreachable database is noted ([`Unreachable`], read by
    /// the outage guard).
    pub fn mark(&self, resp: &mut Response) {
        if matches!(self, ApiError::NotReady(_) | ApiError::Unavailable(_)) {
            resp.headers_mut().insert(
                axum::http::header::RETRY_AFTER,
                axum::http::HeaderValue::from(RETRY_AFTER.as_secs()),
            );
        }
        if matches!(self, ApiError::Unavailable(_)) {
            resp.extensions_mut().insert(Unreachable);
        }
    }

    /// Maps an extractor rejection (body too large, bad JSON, bad multipart) by status.
    pub fn from_rejection(status: StatusCode, text: String) -> ApiError {
        match status {
            StatusCode::PAYLOAD_TOO_LARGE => {
                ApiError::PayloadTooLarge(format!("request body too large: {text}"))
            }
            StatusCode::UNSUPPORTED_MEDIA_TYPE => ApiError::UnsupportedMediaType(text),
            _ => ApiError::InvalidRequest(text),
        }
    }

    /// Maps a rejection met while reading a body sent with Content-Encoding `encoding`
    /// (decoded by the route's decompression layer): any failure but its size is the
    /// encoding's (`invalid_encoding`).
    pub fn from_body_rejection(
        status: StatusCode,
        text: String,
        encoding: Option<&str>,
    ) -> ApiError {
        match encoding {
            Some(enc) if status != StatusCode::PAYLOAD_TOO_LARGE => ApiError::InvalidEncoding(
                format!("the body cannot be decoded as Content-Encoding {enc}: {text}"),
            ),
            _ => ApiError::from_rejection(status, text),
        }
    }
}

impl From<StoreError> for ApiError {
    fn from(e: StoreError) -> Self {
        match e {
            StoreError::NotFound(w) => ApiError::NotFound(format!("{w} not found")),
            StoreError::Conflict(m) => ApiError::Conflict(m),
            // A field the store's rules refuse (mtcal_store::text), named in the message.
            StoreError::Invalid(m) => ApiError::InvalidRequest(m),
            StoreError::Unavailable(m) => {
                ApiError::Unavailable(format!("the database cannot be reached ({m})"))
            }
            other => ApiError::Internal(other.to_string()),
        }
    }
}

/// The one place the domain's refusals become API errors.
impl From<mtcal_domain::DomainError> for ApiError {
    fn from(e: mtcal_domain::DomainError) -> Self {
        use mtcal_domain::DomainError as D;
        match e {
            D::Store(e) => e.into(),
            D::Invalid(m) => ApiError::InvalidRequest(m),
            D::NotFound(m) => ApiError::NotFound(m),
            D::Conflict(m) => ApiError::Conflict(m),
            D::OutsideTravel(m) => ApiError::OutsideTravel(m),
            D::Internal(m) => ApiError::Internal(m),
        }
    }
}

impl IntoResponse for ApiError {
    fn into_response(self) -> Response {
        let message = match &self {
            ApiError::Internal(cause) => {
                tracing::error!(%cause, "internal error");
                "internal error (logged on the server)".to_string()
            }
            other => other.to_string(),
        };
        let body = ErrorBody {
            error: ErrorDetail {
                code: self.code().to_string(),
                message,
            },
        };
        let mut resp = (self.status(), Json(body)).into_response();
        self.mark(&mut resp);
        resp
    }
}

/// Stable code of an error status produced outside the handlers (layers, routing).
fn code_of(status: StatusCode) -> &'static str {
    match status {
        StatusCode::BAD_REQUEST => "invalid_request",
        StatusCode::UNAUTHORIZED => "unauthorized",
        StatusCode::FORBIDDEN => "forbidden",
        StatusCode::NOT_FOUND => "not_found",
        StatusCode::METHOD_NOT_ALLOWED => "method_not_allowed",
        StatusCode::REQUEST_TIMEOUT => "timeout",
        StatusCode::CONFLICT => "conflict",
        StatusCode::PAYLOAD_TOO_LARGE => "payload_too_large",
        StatusCode::UNSUPPORTED_MEDIA_TYPE => "unsupported_media_type",
        StatusCode::UNPROCESSABLE_ENTITY => "invalid_dataset",
        StatusCode::SERVICE_UNAVAILABLE => "not_ready",
        _ => "internal",
    }
}

/// Middleware: every error response is the JSON error body, also those made by layers
/// (timeouts, decompression, routing) that know nothing of it: a 4xx/5xx response that
/// is not JSON gets `{"error": {"code", "message"}}` with the code of its status and its
/// text (bounded) as the message.
pub async fn json_errors(req: axum::extract::Request, next: axum::middleware::Next) -> Response {
    let resp = next.run(req).await;
    let status = resp.status();
    let is_json = resp
        .headers()
        .get(axum::http::header::CONTENT_TYPE)
        .and_then(|v| v.to_str().ok())
        .is_some_and(|v| v.starts_with("application/json"));
    if !(status.is_client_error() || status.is_server_error()) || is_json {
        return resp;
    }
    let (parts, body) = resp.into_parts();
    let text = axum::body::to_bytes(body, 4096).await.unwrap_or_default();
    let text = String::from_utf8_lossy(&text).trim().to_string();
    let message = if text.is_empty() || status.is_server_error() {
        status
            .canonical_reason()
            .unwrap_or("request refused")
            .to_string()
    } else {
        text
    };
    let body = ErrorBody {
        error: ErrorDetail {
            code: code_of(status).to_string(),
            message,
        },
    };
    let mut out = (status, Json(body)).into_response();
    for (name, value) in parts.headers.iter() {
        if name != axum::http::header::CONTENT_TYPE && name != axum::http::header::CONTENT_LENGTH {
            out.headers_mut().insert(name.clone(), value.clone());
        }
    }
    out
}

/// JSON body extractor whose rejections are [`ApiError`]s.
pub struct ApiJson<T>(pub T);

impl<S, T> axum::extract::FromRequest<S> for ApiJson<T>
where
    S: Send + Sync,
    T: serde::de::DeserializeOwned,
{
    type Rejection = ApiError;

    async fn from_request(req: axum::extract::Request, state: &S) -> Result<Self, ApiError> {
        let content_type = req
            .headers()
            .get(axum::http::header::CONTENT_TYPE)
            .cloned()
            .unwrap_or(axum::http::HeaderValue::from_static(""));
        if let Some(enc) = req
            .headers()
            .get(axum::http::header::CONTENT_ENCODING)
            .filter(|e| e.as_bytes() != b"identity")
        {
            return Err(ApiError::UnsupportedMediaType(format!(
                "Content-Encoding {:?}: this route reads an unencoded JSON body",
                String::from_utf8_lossy(enc.as_bytes())
            )));
        }
        let bytes = axum::body::Bytes::from_request(req, state)
            .await
            .map_err(|r| ApiError::from_rejection(r.status(), r.body_text()))?;
        let req = axum::extract::Request::builder()
            .header(axum::http::header::CONTENT_TYPE, content_type)
            .body(axum::body::Body::from(bytes.clone()))
            .map_err(|e| ApiError::Internal(e.to_string()))?;
        let v = match Json::<T>::from_request(req, state).await {
            Ok(Json(v)) => v,
            Err(r) => return Err(ApiError::from_rejection(r.status(), r.body_text())),
        };
        if let Some(at) = nul_in_json(&bytes) {
            return Err(ApiError::InvalidRequest(format!(
                "{at}: a string holds the control character U+0000"
            )));
        }
        Ok(ApiJson(v))
    }
}

/// Where a JSON document (valid) holds a string or key with a NUL character (`\u0000`),
/// as a JSON pointer: no stored text may hold one (PostgreSQL refuses it), whatever the
/// field. Only a body whose text has the escape is read a second time.
fn nul_in_json(bytes: &[u8]) -> Option<String> {
    fn walk(v: &serde_json::Value, at: &mut String) -> bool {
        use serde_json::Value;
        let len = at.len();
        let found = match v {
            Value::String(s) => s.contains('\0'),
            Value::Array(a) => a.iter().enumerate().any(|(i, x)| {
                at.truncate(len);
                at.push_str(&format!("/{i}"));
                walk(x, at)
            }),
            Value::Object(o) => o.iter().any(|(k, x)| {
                at.truncate(len);
                at.push('/');
                at.push_str(&k.replace('\0', "\\u0000"));
                k.contains('\0') || walk(x, at)
            }),
            _ => false,
        };
        if !found {
            at.truncate(len);
        }
        found
    }
    let escaped = bytes
        .windows(6)
        .any(|w| w[0] == b'\\' && w[1] == b'u' && w[2..6].iter().all(|&b| b == b'0'));
    if !escaped {
        return None;
    }
    let v: serde_json::Value = serde_json::from_slice(bytes).ok()?;
    let mut at = String::new();
    walk(&v, &mut at).then(|| if at.is_empty() { "/".into() } else { at })
}

/// Query-string extractor whose rejections are [`ApiError`]s: axum's `Query`, its
/// rejection turned into an `invalid_request` naming what the query got wrong.
#[derive(axum::extract::FromRequestParts)]
#[from_request(via(axum::extract::Query), rejection(ApiError))]
pub struct ApiQuery<T>(pub T);

impl From<axum::extract::rejection::QueryRejection> for ApiError {
    fn from(r: axum::extract::rejection::QueryRejection) -> Self {
        ApiError::InvalidRequest(r.body_text())
    }
}
