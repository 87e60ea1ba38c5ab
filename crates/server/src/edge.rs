//! What every request and response passes first and last, whatever the route (API,
//! dashboard, documentation, probes):
//!
//! * **Request line and headers**: a target longer than [`MAX_URI_BYTES`] is answered
//!   414, a head of more than [`MAX_HEADERS`] headers or [`MAX_HEADER_BYTES`] bytes 431,
//!   a path or query that decodes to a control character 400, each with the JSON error
//!   body, before any route looks at the request (PostgreSQL refuses a NUL byte in a
//!   text value: a lookup with one would fail there and not on SQLite). hyper's own
//!   limits lie beyond these ([`HYPER_MAX_HEADERS`]; a target over 64 KiB or a head over
//!   its buffer): a request past them is closed by hyper with an empty 414 or 431.
//! * **Security headers** on every response: `X-Content-Type-Options: nosniff`,
//!   `X-Frame-Options: DENY`, `Referrer-Policy: same-origin`, and on HTML a
//!   `Content-Security-Policy` ([`PAGE_CSP`]: scripts, styles and images from this
//!   service only, no frames, forms posting here only) unless the handler set its own
//!   (the check report's inline style; the API documentation, [`DOCS_CSP`]).

use crate::error::{ErrorBody, ErrorDetail};
use axum::Json;
use axum::extract::Request;
use axum::http::{HeaderValue, StatusCode, header};
use axum::middleware::Next;
use axum::response::{IntoResponse, Response};

/// Longest request target (path and query), bytes.
pub const MAX_URI_BYTES: usize = 8 * 1024;
/// Most headers in a request.
pub const MAX_HEADERS: usize = 100;
/// Most bytes of header names and values in a request.
pub const MAX_HEADER_BYTES: usize = 32 * 1024;
/// Headers hyper parses before it refuses a request itself (above [`MAX_HEADERS`], so
/// that a request with a few too many gets the JSON answer).
pub const HYPER_MAX_HEADERS: usize = 2 * MAX_HEADERS;

/// The Content-Security-Policy of the dashboard's pages.
pub const PAGE_CSP: &str = "default-src 'none'; script-src 'self'; style-src 'self'; \
     img-src 'self' data:; connect-src 'self'; form-action 'self'; frame-ancestors 'none'; \
     base-uri 'none'";
/// The Content-Security-Policy of the API documentation (Swagger UI sets styles inline).
pub const DOCS_CSP: &str = "default-src 'none'; script-src 'self'; \
     style-src 'self' 'unsafe-inline'; img-src 'self' data:; connect-src 'self'; \
     form-action 'self'; frame-ancestors 'none'; base-uri 'none'";
/// The Content-Security-Policy of a self-contained printable page (one inline style
/// sheet, no script, no external asset).
pub const PRINT_CSP: &str = "default-src 'none'; style-src 'unsafe-inline'; img-src data:; \
     form-action 'none'; frame-ancestors 'none'; base-uri 'none'";

fn refuse(status: StatusCode, code: &str, message: String) -> Response {
    let body = ErrorBody {
        error: ErrorDetail {
            code: code.into(),
            message,
        },
    };
    (status, Json(body)).into_response()
}

/// The first control character that `text` holds once percent-decoded, as `U+XXXX`.
fn control_in(text: &str) -> Option<String> {
    let bytes: Vec<u8> = percent_encoding::percent_decode_str(text).collect();
    String::from_utf8_lossy(&bytes)
        .chars()
        .find(|c| c.is_control())
        .map(|c| format!("U+{:04X}", c as u32))
}

/// Why the request's line or head is refused, if it is.
pub fn refusal(req: &Request) -> Option<Response> {
    let uri = req.uri();
    let target = uri.path_and_query().map_or(0, |p| p.as_str().len());
    if target > MAX_URI_BYTES {
        return Some(refuse(
            StatusCode::URI_TOO_LONG,
            "uri_too_long",
            format!("the request target is {target} bytes; at most {MAX_URI_BYTES}"),
        ));
    }
    let headers = req.headers();
    let bytes: usize = headers
        .iter()
        .map(|(n, v)| n.as_str().len() + v.len())
        .sum();
    if headers.len() > MAX_HEADERS || bytes > MAX_HEADER_BYTES {
        return Some(refuse(
            StatusCode::REQUEST_HEADER_FIELDS_TOO_LARGE,
            "headers_too_large",
            format!(
                "{} headers of {bytes} bytes; at most {MAX_HEADERS} headers and \
                 {MAX_HEADER_BYTES} bytes",
                headers.len()
            ),
        ));
    }
    for (part, text) in [("path", uri.path()), ("query", uri.query().unwrap_or(""))] {
        if let Some(c) = control_in(text) {
            return Some(refuse(
                StatusCode::BAD_REQUEST,
                "invalid_request",
                format!("the request's {part} holds the control character {c}"),
            ));
        }
    }
    None
}

/// Middleware, outermost: refuses what [`refusal`] refuses, and sets the security
/// headers on every answer (see the module documentation).
pub async fn guard(req: Request, next: Next) -> Response {
    let docs = req.uri().path().starts_with("/docs");
    let mut resp = match refusal(&req) {
        Some(r) => r,
        None => next.run(req).await,
    };
    let h = resp.headers_mut();
    h.insert(
        header::X_CONTENT_TYPE_OPTIONS,
        HeaderValue::from_static("nosniff"),
    );
    h.insert(header::X_FRAME_OPTIONS, HeaderValue::from_static("DENY"));
    h.insert(
        header::REFERRER_POLICY,
        HeaderValue::from_static("same-origin"),
    );
    let html = h
        .get(header::CONTENT_TYPE)
        .is_some_and(|v| v.as_bytes().starts_with(b"text/html"));
    if html && !h.contains_key(header::CONTENT_SECURITY_POLICY) {
        let csp = if docs { DOCS_CSP } else { PAGE_CSP };
        h.insert(
            header::CONTENT_SECURITY_POLICY,
            HeaderValue::from_static(csp),
        );
    }
    resp
}

#[cfg(test)]
mod tests {
    use super::control_in;

    #[test]
    fn control_characters_are_found_after_decoding() {
        assert_eq!(
            control_in("/api/v1/machines/a%00b").as_deref(),
            Some("U+0000")
        );
        assert_eq!(
            control_in("next=/%09/evil.example/").as_deref(),
            Some("U+0009")
        );
        assert_eq!(control_in("x=%C2%85").as_deref(), Some("U+0085"));
        assert_eq!(control_in("site=Halle%20S%C3%BCd&tag=a+b"), None);
    }
}
