//! The default baseline (no baseline chosen) is the machine's first check whose model
//! explains its recording, never a misfit check: the drift of the fleet row, the drift
//! alerts and the difference route are measured from it
//! (`mtcal_domain::history::baseline`). On SQLite, and on PostgreSQL when
//! `MTCAL_TEST_PG` names a server (`scripts/with-postgres`).

use crate::common::{app_on, backlash_identification, identification, machine, request, send};
use mtcal_domain::history::baseline;
use mtcal_domain::landing::result_landed;
use mtcal_store::{ResultMeta, Store};
use serde_json::{Value, json};
use std::sync::Arc;

/// `GET uri` with `key`: the body (200 asserted).
async fn get(app: &axum::Router, uri: &str, key: &str) -> Value {
    let (status, v) = send(app, request("GET", uri, "", None, vec![], Some(key))).await;
    assert!(status.is_success(), "{uri}: {status} {v}");
    v
}

/// Lands a check of M1 at `at` with EXX = c1·x (its document `document` when given) as
/// the worker does (drift row, then the alert check); its id and the alert raised.
async fn land(
    store: &Arc<dyn Store>,
    at: &str,
    c1: f64,
    document: Option<&Value>,
) -> (String, Option<String>) {
    let mut r = identification("M1", at, c1, 1e-6);
    if let Some(d) = document {
        r.document = d.clone();
    }
    let r = store.import_result(r).await.unwrap();
    let alert = result_landed(store, "M1", &r.id).await.unwrap();
    (r.id, alert.map(|a| a.raised.baseline_result_id))
}

/// M1's default baseline now.
async fn default_baseline(store: &dyn Store) -> Option<String> {
    let m = store.get_machine("M1").await.unwrap();
    let list: Vec<ResultMeta> = store.list_results("M1", "identification").await.unwrap();
    let b = baseline(store, &m, &list).await.unwrap();
    b.map(|r| r.id.clone())
}

async fn story(url: &str) {
    let (app, keys, store) = app_on(url).await;
    machine(&app, &keys.write, "M1").await;
    let profile = json!({"scope": "machine", "target": "M1", "limits": {"drift_um": 0.5}});
    let (status, b) = send(
        &app,
        request(
            "POST",
            "/api/v1/tolerances",
            "application/json",
            None,
            profile.to_string().into_bytes(),
            Some(&keys.write),
        ),
    )
    .await;
    assert!(status.is_success(), "{b}");
    let misfit = serde_json::to_value(backlash_identification()).unwrap();

    // The first check is a misfit: no baseline; the fleet row's reference is the check
    // itself (drift 0), and nothing alerts.
    let (first, alert) = land(&store, "2026-01-01T00:00:00Z", 0.02, Some(&misfit)).await;
    assert_eq!(alert, None);
    assert_eq!(default_baseline(store.as_ref()).await, None);
    let drift = get(&app, "/api/v1/fleet/drift", &keys.read).await;
    let row = &drift["machines"][0];
    assert_eq!(row["baseline_result_id"], json!(first), "{drift}");
    let req = request(
        "GET",
        "/api/v1/machines/M1/results/diff",
        "",
        None,
        vec![],
        Some(&keys.read),
    );
    let (status, b) = send(&app, req).await;
    assert_eq!(status.as_u16(), 404, "{b}");
    assert!(
        b.to_string().contains("every check of it is a misfit"),
        "{b}"
    );

    // The second explains its recording: it is the baseline, so it does not alert
    // although EXX changed by (0.10 − 0.02)·50 = 4 µm since the misfit.
    let (second, alert) = land(&store, "2026-02-01T00:00:00Z", 0.10, None).await;
    assert_eq!(alert, None, "measured from the misfit check");
    assert_eq!(default_baseline(store.as_ref()).await, Some(second.clone()));

    // The third changed by (0.12 − 0.10)·50 = 1 µm since the second: the alert, the
    // fleet row and the difference are measured from the second.
    let (third, alert) = land(&store, "2026-03-01T00:00:00Z", 0.12, None).await;
    assert_eq!(alert, Some(second.clone()));
    let drift = get(&app, "/api/v1/fleet/drift", &keys.read).await;
    let row = &drift["machines"][0];
    assert_eq!(row["baseline_result_id"], json!(second), "{drift}");
    assert!(
        (row["drift_um"].as_f64().unwrap() - 1.0).abs() < 1e-9,
        "{row}"
    );
    // The refresh at start finds the row current (its basis names the store's pair).
    let n = mtcal_domain::fleet::refresh_all(store.as_ref())
        .await
        .unwrap();
    assert_eq!(n.recomputed, 0, "{n:?}");
    let diff = get(&app, "/api/v1/machines/M1/results/diff", &keys.read).await;
    assert_eq!(diff["baseline"]["id"], json!(second));
    assert_eq!(diff["against"]["id"], json!(third));
    // A baseline chosen is kept as it is.
    let patch = json!({"baseline_result_id": third})
        .to_string()
        .into_bytes();
    let req = request(
        "PATCH",
        "/api/v1/machines/M1",
        "application/json",
        None,
        patch,
        Some(&keys.write),
    );
    assert!(send(&app, req).await.0.is_success());
    assert_eq!(default_baseline(store.as_ref()).await, Some(third));
}

#[tokio::test]
async fn the_default_baseline_is_never_a_misfit_check_on_sqlite() {
    let dir = tempfile::tempdir().unwrap();
    story(dir.path().join("t.sqlite").to_str().unwrap()).await;
}

#[tokio::test]
async fn the_default_baseline_is_never_a_misfit_check_on_postgres() {
    let Some(pg) = mtcal_store::testing::ScratchPg::create("baseline")
        .await
        .unwrap()
    else {
        return;
    };
    story(&pg.url).await;
    pg.drop_schema().await.unwrap();
}
