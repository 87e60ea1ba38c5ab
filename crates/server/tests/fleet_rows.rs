//! The fleet rows the service maintains (drift, verdict's profile, sparkline, basis) equal
//! a computation from scratch after every change they follow: results landing, the
//! baseline chosen, a machine's tags, tolerance profiles created and replaced; and the
//! start-up refresh recomputes exactly the rows whose basis changed behind the service's
//! back. On SQLite, and on PostgreSQL when `MTCAL_TEST_PG` names a server
//! (`scripts/with-postgres`).

mod common;

use common::identification;
use mtcal_server::fleet::{Refreshed, refresh_all, result_landed};
use mtcal_store::{FleetDriftRow, Store};
use serde_json::{Value, json};
use std::time::Duration;

/// Sends `body` as JSON with `key`; the response's body (a success asserted).
async fn call(app: &axum::Router, method: &str, uri: &str, key: &str, body: Value) -> Value {
    let req = common::request(
        method,
        uri,
        "application/json",
        None,
        body.to_string().into_bytes(),
        Some(key),
    );
    let (status, v) = common::send(app, req).await;
    assert!(status.is_success(), "{method} {uri}: {status} {v}");
    v
}

/// The stored rows by machine, without their read times (when is not what).
async fn stored(store: &dyn Store) -> Vec<FleetDriftRow> {
    let mut rows: Vec<FleetDriftRow> = store
        .fleet_drift_ranked(true, usize::MAX)
        .await
        .unwrap()
        .into_iter()
        .map(|(r, _, _)| FleetDriftRow { read_at_ms: 0, ..r })
        .collect();
    rows.sort_by(|a, b| a.machine_id.cmp(&b.machine_id));
    rows
}

/// The maintained rows equal the rows computed from scratch (every row removed, then
/// the whole fleet refreshed, which recomputes them all).
async fn assert_maintained(store: &dyn Store, when: &str) -> Vec<FleetDriftRow> {
    let maintained = stored(store).await;
    for r in &maintained {
        store.delete_fleet_drift(&r.machine_id).await.unwrap();
    }
    let n = refresh_all(store).await.unwrap();
    assert_eq!(n.recomputed, n.machines, "{when}: all recomputed");
    let scratch = stored(store).await;
    assert_eq!(maintained, scratch, "{when}");
    scratch
}

/// Waits for the refresh a profile change starts in the background: until machine
/// `id`'s row is computed against `profile` (its id and revision).
async fn until_against(store: &dyn Store, id: &str, profile: &Value) {
    let want = format!(
        "{}@{}",
        profile["id"].as_str().unwrap(),
        profile["updated_at"].as_str().unwrap()
    );
    for _ in 0..500 {
        let rows = stored(store).await;
        let row = rows.iter().find(|r| r.machine_id == id).unwrap();
        if row.basis.as_deref().unwrap().ends_with(&want) {
            return;
        }
        tokio::time::sleep(Duration::from_millis(10)).await;
    }
    panic!("the row of {id} was not refreshed against {want}");
}

async fn story(url: &str) {
    let (app, keys, store) = common::app_on(url).await;
    let write = keys.write;
    common::machine(&app, &write, "M1").await;
    common::machine(&app, &write, "M2").await;
    let tags = json!({"tags": ["vmc"]});
    call(&app, "PATCH", "/api/v1/machines/M1", &write, tags).await;
    let land = |m: &'static str, at: &'static str, c1: f64| {
        let store = store.clone();
        async move {
            let r = store
                .import_result(identification(m, at, c1, 1e-6))
                .await
                .unwrap();
            result_landed(&store, m, &r.id).await.unwrap();
            r.id
        }
    };

    // Results land.
    let first = land("M1", "2026-01-01T00:00:00Z", 0.02).await;
    let second = land("M1", "2026-02-01T00:00:00Z", 0.05).await;
    land("M1", "2026-03-01T00:00:00Z", 0.10).await;
    land("M2", "2026-01-15T00:00:00Z", 0.01).await;
    let rows = assert_maintained(store.as_ref(), "after results landed").await;
    // Hand-worked: EXX changed by (0.10 − 0.02)·50 = 4 µm at either end of the travel;
    // the sparkline is EXX at one end in each check: ±(1, 2.5, 5) µm.
    let m1 = &rows[0];
    assert_eq!(m1.entry["baseline_result_id"], json!(first));
    assert!((m1.drift_um - 4.0).abs() < 1e-9, "{}", m1.drift_um);
    let spark: Vec<f64> = m1.entry["sparkline"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_f64().unwrap().abs())
        .collect();
    assert_eq!(spark.len(), 3);
    for (got, want) in spark.iter().zip([1.0, 2.5, 5.0]) {
        assert!((got - want).abs() < 1e-9, "{spark:?}");
    }

    // The baseline is chosen: drift (0.10 − 0.05)·50 = 2.5 µm.
    call(
        &app,
        "PATCH",
        "/api/v1/machines/M1",
        &write,
        json!({"baseline_result_id": second}),
    )
    .await;
    let rows = assert_maintained(store.as_ref(), "after the baseline changed").await;
    assert!(
        (rows[0].drift_um - 2.5).abs() < 1e-9,
        "{}",
        rows[0].drift_um
    );

    // A tag profile is created, then replaced: M1's row follows, M2's does not change.
    let before_m2 = rows[1].clone();
    let p = call(
        &app,
        "POST",
        "/api/v1/tolerances",
        &write,
        json!({"scope": "tag", "target": "vmc", "limits": {"drift_um": 5.0}}),
    )
    .await;
    until_against(store.as_ref(), "M1", &p).await;
    let rows = assert_maintained(store.as_ref(), "after a profile was created").await;
    assert_eq!(rows[1], before_m2);
    let uri = format!("/api/v1/tolerances/{}", p["id"].as_str().unwrap());
    let p = call(
        &app,
        "PUT",
        &uri,
        &write,
        json!({"limits": {"drift_um": 1.0}}),
    )
    .await;
    until_against(store.as_ref(), "M1", &p).await;
    assert_maintained(store.as_ref(), "after a profile was replaced").await;

    // M2 is given the tag: its row is computed against the tag's profile.
    call(
        &app,
        "PATCH",
        "/api/v1/machines/M2",
        &write,
        json!({"tags": ["vmc"]}),
    )
    .await;
    let rows = assert_maintained(store.as_ref(), "after a machine's tags changed").await;
    assert!(
        rows[1]
            .basis
            .as_deref()
            .unwrap()
            .contains(p["id"].as_str().unwrap())
    );

    // Behind the service's back (a bulk import; a profile written in the store alone),
    // the refresh at start recomputes exactly the rows whose basis changed.
    assert_eq!(
        refresh_all(store.as_ref()).await.unwrap(),
        Refreshed {
            machines: 2,
            recomputed: 0
        }
    );
    store
        .import_results_bulk(&[identification("M2", "2026-04-01T00:00:00Z", 0.03, 1e-6)])
        .await
        .unwrap();
    let before = stored(store.as_ref()).await;
    assert_eq!(
        refresh_all(store.as_ref()).await.unwrap(),
        Refreshed {
            machines: 2,
            recomputed: 1
        }
    );
    let after = stored(store.as_ref()).await;
    assert_eq!(after[0], before[0], "M1 kept");
    assert!(
        (after[1].drift_um - 1.0).abs() < 1e-9,
        "M2: (0.03 − 0.01)·50"
    );
    assert_maintained(store.as_ref(), "after a bulk import and a refresh").await;
    store
        .update_tolerance(p["id"].as_str().unwrap(), &json!({"drift_um": 2.0}), None)
        .await
        .unwrap();
    assert_eq!(
        refresh_all(store.as_ref()).await.unwrap().recomputed,
        2,
        "both machines of the tag"
    );
    assert_maintained(store.as_ref(), "after a profile changed in the store").await;
}

#[tokio::test]
async fn maintained_fleet_rows_equal_a_recomputation_on_sqlite() {
    let dir = tempfile::tempdir().unwrap();
    story(dir.path().join("t.sqlite").to_str().unwrap()).await;
}

#[tokio::test]
async fn maintained_fleet_rows_equal_a_recomputation_on_postgres() {
    let Some(pg) = mtcal_store::testing::ScratchPg::create("fleet_rows")
        .await
        .unwrap()
    else {
        eprintln!("MTCAL_TEST_PG not set: skipped");
        return;
    };
    story(&pg.url).await;
    pg.drop_schema().await.unwrap();
}
