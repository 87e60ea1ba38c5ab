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
    /// not_identifiable, not_ready, internal.
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
    /// The service cannot serve yet (database unreachable, migrations missing).
    #[error("{0}")]
    NotReady(String),
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
            ApiError::NotReady(_) => StatusCode::SERVICE_UNAVAILABLE,
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
            ApiError::OutsideTravel(_) => "outside_measured_travel",
            ApiError::NotIdentifiable(_) => "not_identifiable",
            ApiError::ModelMisfit(_) => "model_misfit",
            ApiError::Internal(_) => "internal",
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
        (self.status(), Json(body)).into_response()
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
        match Json::<T>::from_request(req, state).await {
            Ok(Json(v)) => Ok(ApiJson(v)),
            Err(r) => Err(ApiError::from_rejection(r.status(), r.body_text())),
        }
    }
}

/// Query-string extractor whose rejections are [`ApiError`]s.
pub struct ApiQuery<T>(pub T);

impl<S, T> axum::extract::FromRequestParts<S> for ApiQuery<T>
where
    S: Send + Sync,
    T: serde::de::DeserializeOwned,
{
    type Rejection = ApiError;

    async fn from_request_parts(
        parts: &mut axum::http::request::Parts,
        state: &S,
    ) -> Result<Self, ApiError> {
        match axum::extract::Query::<T>::from_request_parts(parts, state).await {
            Ok(axum::extract::Query(v)) => Ok(ApiQuery(v)),
            Err(r) => Err(ApiError::InvalidRequest(r.body_text())),
        }
    }
}
