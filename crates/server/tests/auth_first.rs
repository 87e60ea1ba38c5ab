//! Authentication comes first: without a valid key every `/api/v1` request is 401 whatever
//! is wrong with its body, query, content type or encoding; a key of too low a scope is
//! 403 before the body is read; only then do 400/413/415 apply.

use axum::body::Body;
use axum::http::{Request, StatusCode, header};
use mtcal_server::{AppState, UploadLimits, router};
use mtcal_store::Scope;
use std::sync::Arc;
use tower::ServiceExt;

async fn app() -> (axum::Router, String, String) {
    let store = mtcal_store::open("sqlite::memory:").await.unwrap();
    let (_, read) = store.create_key(Scope::Read, "r").await.unwrap();
    let (_, write) = store.create_key(Scope::Write, "w").await.unwrap();
    let state = AppState {
        store,
        limits: UploadLimits {
            max_bytes: 1000,
            ..UploadLimits::default()
        },
        max_attempts: 3,
        wake: Arc::new(tokio::sync::Notify::new()),
    };
    (router(state), read, write)
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

fn request(
    method: &str,
    uri: &str,
    ct: &str,
    enc: Option<&str>,
    body: Vec<u8>,
    key: Option<&str>,
) -> Request<Body> {
    let mut r = Request::builder().method(method).uri(uri);
    if !ct.is_empty() {
        r = r.header(header::CONTENT_TYPE, ct);
    }
    if let Some(e) = enc {
        r = r.header(header::CONTENT_ENCODING, e);
    }
    if let Some(k) = key {
        r = r.header(header::AUTHORIZATION, format!("Bearer {k}"));
    }
    r.body(Body::from(body)).unwrap()
}

async fn send(app: &axum::Router, req: Request<Body>) -> (StatusCode, serde_json::Value) {
    let resp = app.clone().oneshot(req).await.unwrap();
    let status = resp.status();
    let bytes = axum::body::to_bytes(resp.into_body(), usize::MAX)
        .await
        .unwrap();
    (status, serde_json::from_slice(&bytes).unwrap_or_default())
}

#[tokio::test]
async fn no_key_is_401_before_any_other_rejection() {
    let (app, _, write) = app().await;
    // The machine the upload routes name exists, so the write key sees the real rejection.
    let (s, _) = send(
        &app,
        request(
            "POST",
            "/api/v1/machines",
            "application/json",
            None,
            br#"{"id": "M", "name": "m"}"#.to_vec(),
            Some(&write),
        ),
    )
    .await;
    assert_eq!(s, StatusCode::CREATED);
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
