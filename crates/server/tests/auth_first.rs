//! Authentication comes first: without a valid key every `/api/v1` request is 401 whatever
//! is wrong with its body, query, content type or encoding; a key of too low a scope is
//! 403 before the body is read; only then do 400/413/415 apply.

use crate::common::{request, send};
use axum::body::Body;
use axum::http::{Request, StatusCode};

async fn app() -> (axum::Router, String, String) {
    let (app, keys, _) = crate::common::app().await;
    (app, keys.read, keys.write)
}

/// A request that is wrong in some way other than its key.
struct Broken {
    method: &'static str,
    uri: &'static str,
    content_type: &'static str,
    encoding: Option<&'static str>,
    body: Vec<u8>,
    /// The status it gets with a write key.
    with_key: StatusCode,
}

fn broken() -> Vec<Broken> {
    let b = |method, uri, content_type, encoding, body: &[u8], with_key| Broken {
        method,
        uri,
        content_type,
        encoding,
        body: body.to_vec(),
        with_key,
    };
    let json = "application/json";
    let gzip = "application/gzip";
    let upload = "/api/v1/machines/M/datasets";
    vec![
        b(
            "POST",
            "/api/v1/machines",
            json,
            None,
            b"{not json",
            StatusCode::BAD_REQUEST,
        ),
        b(
            "POST",
            "/api/v1/machines",
            "text/plain",
            None,
            b"{}",
            StatusCode::UNSUPPORTED_MEDIA_TYPE,
        ),
        b(
            "POST",
            "/api/v1/machines",
            json,
            None,
            &[b' '; 2 << 20],
            StatusCode::PAYLOAD_TOO_LARGE,
        ),
        b(
            "GET",
            "/api/v1/machines?limit=abc",
            "",
            None,
            b"",
            StatusCode::BAD_REQUEST,
        ),
        b(
            "GET",
            "/api/v1/machines/M/trends/term",
            "",
            None,
            b"",
            StatusCode::BAD_REQUEST,
        ),
        b(
            "POST",
            upload,
            "text/plain",
            None,
            b"x",
            StatusCode::UNSUPPORTED_MEDIA_TYPE,
        ),
        b(
            "POST",
            upload,
            gzip,
            Some("br"),
            b"x",
            StatusCode::UNSUPPORTED_MEDIA_TYPE,
        ),
        b(
            "POST",
            upload,
            gzip,
            None,
            &[0; 5000],
            StatusCode::PAYLOAD_TOO_LARGE,
        ),
        b(
            "POST",
            "/api/v1/jobs",
            json,
            None,
            b"[]",
            StatusCode::BAD_REQUEST,
        ),
    ]
}

impl Broken {
    fn request(&self, key: Option<&str>) -> Request<Body> {
        request(
            self.method,
            self.uri,
            self.content_type,
            self.encoding,
            self.body.clone(),
            key,
        )
    }
}

#[tokio::test]
async fn no_key_is_401_before_any_other_rejection() {
    let (app, _, write) = app().await;
    // The machine the upload routes name exists, so the write key sees the real rejection.
    crate::common::machine(&app, &write, "M").await;
    for r in broken() {
        let (m, uri, ct) = (r.method, r.uri, r.content_type);
        for key in [None, Some("mtk_00000000000000000000000000000000")] {
            let (s, b) = send(&app, r.request(key)).await;
            assert_eq!(
                s,
                StatusCode::UNAUTHORIZED,
                "{m} {uri} {ct} key {key:?}: {b}"
            );
            assert_eq!(b["error"]["code"], "unauthorized");
        }
        // The same request with a valid key gets the rejection it deserves (so the test
        // above could fail), with a JSON error body.
        let (s, b) = send(&app, r.request(Some(&write))).await;
        assert_eq!(s, r.with_key, "{m} {uri} {ct}: {b}");
        assert!(b["error"]["code"].is_string(), "{m} {uri} {ct}: {b}");
    }
}

#[tokio::test]
async fn too_weak_a_key_is_403_before_the_body_is_read() {
    let (app, read, _) = app().await;
    for r in broken().into_iter().filter(|r| r.method != "GET") {
        let (s, b) = send(&app, r.request(Some(&read))).await;
        assert_eq!(s, StatusCode::FORBIDDEN, "{} {}: {b}", r.method, r.uri);
        assert_eq!(b["error"]["code"], "forbidden");
    }
}

#[tokio::test]
async fn health_and_documentation_need_no_key() {
    let (app, _, _) = app().await;
    for uri in ["/health", "/api-docs/openapi.json"] {
        let (s, _) = send(&app, request("GET", uri, "", None, vec![], None)).await;
        assert_eq!(s, StatusCode::OK, "{uri}");
    }
}
