//! Every rejection, whoever makes it (an extractor of JSON, query, path or multipart, a
//! body limit, request decompression, routing), comes back as the JSON error body with
//! the stable code of its kind; none is empty or plain text.

use crate::common::{MAX_UPLOAD, app, machine, request, send};
use axum::http::StatusCode;
use tower::ServiceExt;

/// A gzip stream cut short: its header is right, its deflate data is not.
fn broken_gzip() -> Vec<u8> {
    let mut b = vec![0x1f, 0x8b, 8, 0, 0, 0, 0, 0, 0, 3];
    b.extend_from_slice(&[0xff; 64]);
    b
}

/// Method, URI, Content-Type, Content-Encoding, body, status, code.
type Case<'a> = (
    &'a str,
    &'a str,
    &'a str,
    Option<&'a str>,
    Vec<u8>,
    StatusCode,
    &'a str,
);

#[tokio::test]
async fn every_rejection_is_a_json_error_with_a_stable_code() {
    let (app, keys, _) = app().await;
    machine(&app, &keys.write, "M").await;
    let w = Some(keys.write.as_str());
    let json = "application/json";
    let upload = "/api/v1/machines/M/datasets";
    let multipart = "multipart/form-data; boundary=b";
    let part = b"--b\r\nContent-Disposition: form-data; name=\"f\"; filename=\"a.csv\"\r\n\r\nx\r\n--b--\r\n";
    #[rustfmt::skip]
    let cases: Vec<Case> = vec![
        // JSON bodies.
        ("POST", "/api/v1/machines", json, None, b"{not json".to_vec(), StatusCode::BAD_REQUEST, "invalid_request"),
        ("POST", "/api/v1/machines", json, None, br#"{"id": 5}"#.to_vec(), StatusCode::BAD_REQUEST, "invalid_request"),
        ("POST", "/api/v1/machines", "", None, b"{}".to_vec(), StatusCode::UNSUPPORTED_MEDIA_TYPE, "unsupported_media_type"),
        ("POST", "/api/v1/machines", "text/plain", None, b"{}".to_vec(), StatusCode::UNSUPPORTED_MEDIA_TYPE, "unsupported_media_type"),
        ("POST", "/api/v1/machines", json, None, vec![b' '; 2 << 20], StatusCode::PAYLOAD_TOO_LARGE, "payload_too_large"),
        // A JSON route reads no encoded body.
        ("POST", "/api/v1/machines", json, Some("gzip"), broken_gzip(), StatusCode::UNSUPPORTED_MEDIA_TYPE, "unsupported_media_type"),
        // Query and path.
        ("GET", "/api/v1/machines?limit=abc", "", None, vec![], StatusCode::BAD_REQUEST, "invalid_request"),
        ("GET", "/api/v1/fleet/drift?limit=-1", "", None, vec![], StatusCode::BAD_REQUEST, "invalid_request"),
        ("GET", "/api/v1/machines/%FF%FE", "", None, vec![], StatusCode::BAD_REQUEST, "invalid_request"),
        // Routing.
        ("PUT", "/api/v1/machines", json, None, b"{}".to_vec(), StatusCode::METHOD_NOT_ALLOWED, "method_not_allowed"),
        ("GET", "/api/v1/nothing", "", None, vec![], StatusCode::NOT_FOUND, "not_found"),
        // Uploads: content type, encoding, multipart, size.
        ("POST", upload, "text/csv", None, b"x".to_vec(), StatusCode::UNSUPPORTED_MEDIA_TYPE, "unsupported_media_type"),
        ("POST", upload, "application/gzip", Some("br"), b"x".to_vec(), StatusCode::UNSUPPORTED_MEDIA_TYPE, "unsupported_media_type"),
        ("POST", upload, multipart, Some("gzip"), broken_gzip(), StatusCode::BAD_REQUEST, "invalid_encoding"),
        ("POST", upload, "application/gzip", Some("gzip"), broken_gzip(), StatusCode::BAD_REQUEST, "invalid_encoding"),
        ("POST", upload, "multipart/form-data", None, part.to_vec(), StatusCode::BAD_REQUEST, "invalid_request"),
        ("POST", upload, multipart, None, b"--b\r\nbroken".to_vec(), StatusCode::BAD_REQUEST, "invalid_request"),
        ("POST", upload, multipart, None, vec![b'x'; MAX_UPLOAD * 3], StatusCode::PAYLOAD_TOO_LARGE, "payload_too_large"),
        ("POST", upload, "application/gzip", None, vec![0; MAX_UPLOAD * 3], StatusCode::PAYLOAD_TOO_LARGE, "payload_too_large"),
        // A .tar.gz body that is not gzip is a dataset error.
        ("POST", upload, "application/gzip", None, b"plain".to_vec(), StatusCode::UNPROCESSABLE_ENTITY, "invalid_dataset"),
    ];
    let mut wrong = Vec::new();
    for (method, uri, ct, enc, body, status, code) in cases {
        let (s, b) = send(&app, request(method, uri, ct, enc, body, w)).await;
        let message = b["error"]["message"].as_str().unwrap_or_default();
        if s != status || b["error"]["code"] != code || message.is_empty() || message.len() > 2000 {
            wrong.push(format!(
                "{method} {uri} ({ct}, {enc:?}): {s} {b}, not {status} {code}"
            ));
        }
    }
    assert!(wrong.is_empty(), "{}", wrong.join("\n"));
}

/// `bytes` gzip-compressed.
fn gzip(bytes: &[u8]) -> Vec<u8> {
    use std::io::Write;
    let mut z = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
    z.write_all(bytes).unwrap();
    z.finish().unwrap()
}

/// Garbage in a gzip body (a valid stream of binary junk, a broken stream, junk after
/// a gzip header) is answered with a JSON error whose message is readable text: none
/// of the junk's bytes comes back.
#[tokio::test]
async fn a_garbage_gzip_body_is_a_json_error_that_echoes_nothing_binary() {
    let (app, keys, _) = app().await;
    machine(&app, &keys.write, "M").await;
    let w = Some(keys.write.as_str());
    let upload = "/api/v1/machines/M/datasets";
    // Bytes no text holds: NUL, controls, bytes that are not UTF-8.
    let junk: Vec<u8> = (0..200u32).map(|i| (i * 37 % 256) as u8).collect();
    let mut header_then_junk = vec![0x1f, 0x8b, 8, 0, 0, 0, 0, 0, 0, 3];
    header_then_junk.extend_from_slice(&junk);
    let multipart = |file: &[u8]| {
        let mut b =
            b"--b\r\nContent-Disposition: form-data; name=\"f\"; filename=\"a.csv.gz\"\r\n\r\n"
                .to_vec();
        b.extend_from_slice(file);
        b.extend_from_slice(b"\r\n--b--\r\n");
        b
    };
    let mp = "multipart/form-data; boundary=b";
    let cases: Vec<(&str, Option<&str>, Vec<u8>)> = vec![
        ("application/gzip", None, gzip(&junk)),
        ("application/gzip", None, header_then_junk.clone()),
        ("application/gzip", Some("gzip"), gzip(&gzip(&junk))),
        ("application/gzip", Some("gzip"), gzip(&junk)),
        ("application/gzip", Some("gzip"), header_then_junk.clone()),
        (mp, None, multipart(&gzip(&junk))),
        (mp, None, multipart(&header_then_junk)),
        (mp, Some("gzip"), gzip(&multipart(&gzip(&junk)))),
        (mp, Some("gzip"), gzip(&junk)),
    ];
    let mut wrong = vec![];
    for (i, (ct, enc, body)) in cases.into_iter().enumerate() {
        let resp = app
            .clone()
            .oneshot(request("POST", upload, ct, enc, body, w))
            .await
            .unwrap();
        let (status, is_json) = (
            resp.status(),
            resp.headers()
                .get("content-type")
                .is_some_and(|v| v.as_bytes().starts_with(b"application/json")),
        );
        let bytes = axum::body::to_bytes(resp.into_body(), 1 << 20)
            .await
            .unwrap();
        let text = String::from_utf8(bytes.to_vec());
        let readable = text.as_ref().is_ok_and(|t| {
            let v: serde_json::Value = serde_json::from_str(t).unwrap_or_default();
            v["error"]["message"].as_str().is_some_and(|m| {
                !m.is_empty() && m.chars().all(|c| !c.is_control() && c != '\u{fffd}')
            })
        });
        if !status.is_client_error() || !is_json || !readable {
            wrong.push(format!("case {i} ({ct}, {enc:?}): {status} {text:?}"));
        }
    }
    assert!(wrong.is_empty(), "{}", wrong.join("\n"));
}
