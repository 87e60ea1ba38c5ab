//! What a plant's IT runs the service with: `/ready` (database reachable, migrations
//! applied) beside `/health`, and API keys listed and revoked through the admin routes.

use axum::body::Body;
use axum::http::{Request, StatusCode};
use mtcal_server::router;
use mtcal_store::{Scope, Store};
use serde_json::Value;
use std::sync::Arc;
use tower::ServiceExt;

fn app(store: Arc<dyn Store>) -> axum::Router {
    router(crate::common::state(store))
}

/// The status and body of `req`.
async fn call(app: &axum::Router, req: Request<Body>) -> (StatusCode, Vec<u8>) {
    let resp = app.clone().oneshot(req).await.unwrap();
    let status = resp.status();
    let bytes = axum::body::to_bytes(resp.into_body(), 1 << 20)
        .await
        .unwrap();
    (status, bytes.to_vec())
}

async fn send(
    app: &axum::Router,
    method: &str,
    uri: &str,
    key: Option<&str>,
) -> (StatusCode, Value) {
    let mut r = Request::builder().method(method).uri(uri);
    if let Some(k) = key {
        r = r.header("authorization", format!("Bearer {k}"));
    }
    let (status, body) = call(app, r.body(Body::empty()).unwrap()).await;
    (status, serde_json::from_slice(&body).unwrap_or(Value::Null))
}

#[tokio::test]
async fn ready_when_every_migration_is_applied_503_naming_the_missing_one_otherwise() {
    let dir = tempfile::tempdir().unwrap();
    let db = dir.path().join("r.sqlite");
    let url = db.to_str().unwrap();
    let store = mtcal_store::open(url).await.unwrap();
    let (s, b) = send(&app(store.clone()), "GET", "/ready", None).await;
    assert_eq!(
        (s, b["status"].as_str()),
        (StatusCode::OK, Some("ready")),
        "{b}"
    );
    // A database one migration behind this build (as after a restore of an old backup
    // under a newer binary that could not migrate it): not ready, and says which.
    let pool = sqlx::SqlitePool::connect(&format!("sqlite://{url}"))
        .await
        .unwrap();
    sqlx::query(
        "DELETE FROM _sqlx_migrations WHERE version = (SELECT MAX(version) FROM _sqlx_migrations)",
    )
    .execute(&pool)
    .await
    .unwrap();
    let (s, b) = send(&app(store), "GET", "/ready", None).await;
    assert_eq!(s, StatusCode::SERVICE_UNAVAILABLE, "{b}");
    assert_eq!(b["error"]["code"], "not_ready");
    let msg = b["error"]["message"].as_str().unwrap();
    assert!(msg.contains("migrations not applied"), "{msg}");
}

#[tokio::test]
async fn admin_lists_and_revokes_keys_and_a_revoked_key_is_refused_at_once() {
    let store = mtcal_store::open("sqlite::memory:").await.unwrap();
    let (_, admin) = store.create_key(Scope::Admin, "ops").await.unwrap();
    let (line, line_secret) = store.create_key(Scope::Write, "line 1").await.unwrap();
    let app = app(store);
    let (s, _) = send(&app, "GET", "/api/v1/machines", Some(&line_secret)).await;
    assert_eq!(s, StatusCode::OK);
    // Only an admin key lists or revokes.
    let (s, _) = send(&app, "GET", "/api/v1/keys", Some(&line_secret)).await;
    assert_eq!(s, StatusCode::FORBIDDEN);
    let uri = format!("/api/v1/keys/{}", line.id);
    let (s, _) = send(&app, "DELETE", &uri, Some(&line_secret)).await;
    assert_eq!(s, StatusCode::FORBIDDEN);
    let (s, list) = send(&app, "GET", "/api/v1/keys", Some(&admin)).await;
    assert_eq!(s, StatusCode::OK);
    let list = list.as_array().unwrap();
    assert_eq!(list.len(), 2);
    let text = serde_json::to_string(list).unwrap();
    assert!(
        !text.contains(&line_secret[4..]),
        "a list never shows a secret"
    );
    let (s, k) = send(&app, "DELETE", &uri, Some(&admin)).await;
    assert_eq!(s, StatusCode::OK, "{k}");
    assert!(k["revoked_at"].is_string(), "{k}");
    let (s, b) = send(&app, "GET", "/api/v1/machines", Some(&line_secret)).await;
    assert_eq!(s, StatusCode::UNAUTHORIZED, "{b}");
    let (s, _) = send(&app, "DELETE", "/api/v1/keys/key_nope", Some(&admin)).await;
    assert_eq!(s, StatusCode::NOT_FOUND);
}

/// `GET uri` with `key`: the status and the body as text.
async fn text(app: &axum::Router, uri: &str, key: &str) -> (StatusCode, String) {
    let r = Request::builder()
        .uri(uri)
        .header("authorization", format!("Bearer {key}"));
    let (status, body) = call(app, r.body(Body::empty()).unwrap()).await;
    (status, String::from_utf8(body).unwrap())
}

/// The value of the sample `name{labels}` in a text exposition (labels as written).
fn sample(exposition: &str, series: &str) -> Option<f64> {
    exposition
        .lines()
        .find_map(|l| l.strip_prefix(series)?.trim().parse().ok())
}

/// `/metrics` counts the whole group's jobs and requests: an admin key of the whole
/// group reads it; no key is 401, a lower role or an admin key of a site 403, and none
/// of those answers carries a metric.
#[tokio::test]
async fn metrics_need_an_admin_key_of_the_whole_group() {
    let store = mtcal_store::open("sqlite::memory:").await.unwrap();
    let app = app(store.clone());
    let (_, group) = store.create_key(Scope::Admin, "scraper").await.unwrap();
    assert_eq!(text(&app, "/metrics", &group).await.0, StatusCode::OK);
    let north = ["north".to_string()];
    let (_, site) = store
        .create_key_in(Scope::Admin, "north ops", &north, &[])
        .await
        .unwrap();
    let (_, write) = store.create_key(Scope::Write, "line").await.unwrap();
    let (s, b) = send(&app, "GET", "/metrics", None).await;
    assert_eq!(s, StatusCode::UNAUTHORIZED, "{b}");
    for (key, why) in [(&site, "limited to sites"), (&write, "scope write")] {
        let (s, b) = text(&app, "/metrics", key).await;
        assert_eq!(s, StatusCode::FORBIDDEN, "{b}");
        assert!(b.contains(why) && !b.contains("mtcal_http"), "{b}");
    }
    // The process's metrics token, where one is set: read without a key of the database.
    let token = "metrics-token-of-the-scraper-0123456789";
    let mut state = crate::common::state(store.clone());
    state.settings = Arc::new(mtcal_server::Settings {
        metrics_token: Some(token.into()),
        ..Default::default()
    });
    let with_token = router(state);
    let (s, b) = text(&with_token, "/metrics", token).await;
    assert_eq!(s, StatusCode::OK);
    assert!(b.contains("mtcal_http_requests_total"), "{b}");
    assert_eq!(
        text(&app, "/metrics", token).await.0,
        StatusCode::UNAUTHORIZED
    );
    let (s, _) = text(&with_token, "/metrics", &token[1..]).await;
    assert_eq!(s, StatusCode::UNAUTHORIZED, "a wrong token");
    assert_eq!(
        text(&with_token, "/metrics", &group).await.0,
        StatusCode::OK
    );
}

#[tokio::test]
async fn metrics_count_requests_by_route_template_and_jobs_by_state() {
    let store = mtcal_store::open("sqlite::memory:").await.unwrap();
    let (_, read) = store.create_key(Scope::Read, "r").await.unwrap();
    let (_, admin) = store.create_key(Scope::Admin, "scraper").await.unwrap();
    let app = app(store.clone());
    let series =
        r#"mtcal_http_requests_total{method="GET",route="/api/v1/machines/{id}",status="404"}"#;
    let (_, before) = text(&app, "/metrics", &admin).await;
    let n0 = sample(&before, series).unwrap_or(0.0);
    for id in ["VMC-SECRET-1", "VMC-SECRET-2"] {
        let (s, _) = send(&app, "GET", &format!("/api/v1/machines/{id}"), Some(&read)).await;
        assert_eq!(s, StatusCode::NOT_FOUND);
    }
    let (s, _) = send(&app, "GET", "/api/v1/machines/VMC-1", None).await;
    assert_eq!(s, StatusCode::UNAUTHORIZED);
    // Jobs by kind and state, from the store at the scrape.
    let m = mtcal_store::Machine {
        id: "M1".into(),
        name: "M1".into(),
        topology: Default::default(),
        travel_mm: [("X".to_string(), [-100.0, 100.0])].into(),
        site: None,
        tags: vec![],
        baseline_result_id: None,
        created_at: String::new(),
        updated_at: String::new(),
    };
    store.create_machine(&m).await.unwrap();
    for _ in 0..3 {
        store
            .enqueue(mtcal_store::NewJob {
                kind: mtcal_store::JobKind::Sensitivity,
                machine_id: Some("M1".into()),
                dataset_id: None,
                params: serde_json::json!({}),
                max_attempts: 3,
            })
            .await
            .unwrap();
    }
    let (s, after) = text(&app, "/metrics", &admin).await;
    assert_eq!(s, StatusCode::OK);
    assert_eq!(sample(&after, series), Some(n0 + 2.0), "{after}");
    assert!(
        !after.contains("VMC-SECRET"),
        "routes by template, never by id"
    );
    let unauthorized =
        r#"mtcal_http_requests_total{method="GET",route="/api/v1/machines/{id}",status="401"}"#;
    assert!(
        sample(&after, unauthorized).is_some_and(|n| n >= 1.0),
        "{after}"
    );
    assert_eq!(
        sample(&after, r#"mtcal_jobs{kind="sensitivity",state="queued"}"#),
        Some(3.0),
        "{after}"
    );
    assert!(after.contains("mtcal_http_request_duration_seconds_bucket"));
}
