//! The fleet's total (how many machines a filter keeps) and the filters' choices as a
//! process keeps them for a few seconds (`FleetCountCache`; docs/operations.md, "fleet
//! totals"): right at once after the process itself registers or moves a machine;
//! within the time they are kept after another process does; and a key of one site
//! counts only its machines, never from a count kept for another scope or filter. On
//! SQLite, and on PostgreSQL when `MTCAL_TEST_PG` names a server.

use crate::common::{request, send, state};
use axum::http::StatusCode;
use mtcal_domain::fleet::page::FleetCountCache;
use mtcal_server::{AppState, router};
use mtcal_store::{Scope, Store};
use serde_json::{Value, json};
use std::sync::Arc;
use std::time::Duration;

/// A process of the service on `store` whose counts are kept for `ttl`.
fn process(store: &Arc<dyn Store>, ttl: Duration) -> axum::Router {
    router(AppState {
        fleet_counts: Arc::new(FleetCountCache::new(ttl)),
        ..state(store.clone())
    })
}

/// `GET /api/v1/fleet?QUERY` as `key`: the total and the site choices.
async fn total(app: &axum::Router, key: &str, query: &str) -> (u64, Vec<String>) {
    let uri = format!("/api/v1/fleet?limit=1{query}");
    let (status, v) = send(app, request("GET", &uri, "", None, vec![], Some(key))).await;
    assert_eq!(status, StatusCode::OK, "{uri}: {v}");
    let sites = v["sites"].as_array().unwrap().iter();
    let sites = sites.map(|s| s.as_str().unwrap().to_string()).collect();
    (v["total"].as_u64().unwrap(), sites)
}

/// Registers machine `id` of `site` through `app`.
async fn register(app: &axum::Router, key: &str, id: &str, site: &str) {
    let body = json!({"id": id, "name": id, "site": site, "tags": ["vmc"]});
    let req = request(
        "POST",
        "/api/v1/machines",
        "application/json",
        None,
        body.to_string().into_bytes(),
        Some(key),
    );
    let (status, v): (StatusCode, Value) = send(app, req).await;
    assert_eq!(status, StatusCode::CREATED, "{v}");
}

async fn story(url: &str) {
    let store = mtcal_store::open(url).await.unwrap();
    let (_, admin) = store.create_key(Scope::Admin, "a").await.unwrap();
    let north = ["north".to_string()];
    let (_, north) = store
        .create_key_in(Scope::Read, "n", &north, &[])
        .await
        .unwrap();
    // Two processes on one database: `one` keeps its counts longer than the story
    // takes, `two` writes behind its back; `three` keeps them briefly.
    let long = Duration::from_secs(600);
    let (one, two) = (process(&store, long), process(&store, long));
    let brief = Duration::from_millis(300);
    let three = process(&store, brief);
    register(&one, &admin, "N1", "north").await;
    register(&one, &admin, "S1", "south").await;
    assert_eq!(
        total(&one, &admin, "").await,
        (2, vec!["north".into(), "south".into()])
    );
    // Scope and filter are part of what is kept: the whole group's count is not the
    // site's, nor the site's another filter's.
    assert_eq!(total(&one, &north, "").await, (1, vec!["north".into()]));
    assert_eq!(total(&one, &north, "&site=south").await.0, 0);
    assert_eq!(total(&one, &admin, "&site=south").await.0, 1);
    // This process's own registration shows at once, for every scope.
    register(&one, &admin, "N2", "north").await;
    assert_eq!(total(&one, &admin, "").await.0, 3);
    assert_eq!(total(&one, &north, "").await.0, 2);
    assert_eq!(total(&three, &north, "").await.0, 2);
    // Another process's: not before the counts kept expire (`one`), then at once
    // (`three`, after its time).
    register(&two, &admin, "N3", "north").await;
    assert_eq!(total(&two, &north, "").await.0, 3, "the writer's own");
    assert_eq!(total(&one, &north, "").await.0, 2, "kept: lags");
    tokio::time::sleep(brief).await;
    assert_eq!(total(&three, &north, "").await.0, 3, "after the time kept");
    assert_eq!(total(&three, &admin, "").await.0, 4);
    // A machine moved to another site by this process: both sites' totals at once.
    let moved = json!({"site": "south"});
    let req = request(
        "PATCH",
        "/api/v1/machines/N1",
        "application/json",
        None,
        moved.to_string().into_bytes(),
        Some(&admin),
    );
    let (status, v) = send(&one, req).await;
    assert_eq!(status, StatusCode::OK, "{v}");
    assert_eq!(total(&one, &north, "").await.0, 2);
    assert_eq!(total(&one, &admin, "&site=south").await.0, 2);
}

#[tokio::test]
async fn fleet_totals_are_kept_per_scope_and_filter_on_sqlite() {
    let dir = tempfile::tempdir().unwrap();
    story(dir.path().join("t.sqlite").to_str().unwrap()).await;
}

#[tokio::test]
async fn fleet_totals_are_kept_per_scope_and_filter_on_postgres() {
    crate::common::on_postgres("fleet_total", |url| async move { story(&url).await }).await;
}
