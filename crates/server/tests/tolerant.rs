//! Readers of stored results tolerate a bad row: a result whose stored row does not
//! decode (written by an older version, a null where a number belongs) is left out of
//! lists, trends, differences and the fleet with a warning naming it, instead of failing
//! every reader of the machine (and the fleet) with a 500. Told once, run on SQLite and,
//! when `MTCAL_TEST_PG` names a server, on PostgreSQL (else that half says it skipped).

use crate::common::{app_on, machine, request, send};
use axum::http::StatusCode;
use mtcal_store::{NewResult, ResultScalars};
use serde_json::json;

fn result(measured_at: &str, exx: f64) -> NewResult {
    NewResult {
        check_model: None,
        machine_id: "M".into(),
        dataset_id: None,
        kind: "identification".into(),
        measured_at: measured_at.into(),
        document: json!({"kind": "identification"}),
        scalars: ResultScalars {
            summary: mtcal_store::ResultSummary {
                residual_rms_um: Some(0.1),
                ..Default::default()
            },
            term_coefficients: [("EXX".to_string(), vec![exx, 0.0])].into(),
            measured_travel_mm: [("X".to_string(), [-100.0, 100.0])].into(),
            ..ResultScalars::default()
        },
        figures: vec![],
    }
}

/// Runs one statement on the database `url` names, behind the store's back: how a bad
/// row gets there.
async fn raw(url: &str, sql: &str) {
    let sql = sqlx::raw_sql(sqlx::AssertSqlSafe(sql.to_string()));
    if url.starts_with("postgres") {
        let pool = sqlx::PgPool::connect(url).await.unwrap();
        sql.execute(&pool).await.unwrap();
    } else {
        let pool = sqlx::SqlitePool::connect(url).await.unwrap();
        sql.execute(&pool).await.unwrap();
    }
}

#[tokio::test]
async fn a_bad_stored_row_is_skipped_and_named_on_sqlite() {
    let dir = tempfile::tempdir().unwrap();
    let db = dir.path().join("t.sqlite");
    a_bad_stored_row_is_skipped_and_named(&format!("sqlite://{}", db.display())).await;
}

#[tokio::test]
async fn a_bad_stored_row_is_skipped_and_named_on_postgres() {
    let name = "a_bad_stored_row_is_skipped_and_named_on_postgres";
    let Some(pg) = mtcal_store::testing::ScratchPg::create(name).await.unwrap() else {
        return;
    };
    a_bad_stored_row_is_skipped_and_named(&pg.url).await;
    pg.drop_schema().await.unwrap();
}

async fn a_bad_stored_row_is_skipped_and_named(url: &str) {
    let (app, keys, store) = app_on(url).await;
    machine(&app, &keys.write, "M").await;
    let good = store
        .import_result(result("2026-01-01T00:00:00Z", 0.001))
        .await
        .unwrap();
    let other = store
        .import_result(result("2026-02-01T00:00:00Z", 0.002))
        .await
        .unwrap();
    let bad = store
        .import_result(result("2026-03-01T00:00:00Z", 0.003))
        .await
        .unwrap();
    mtcal_domain::fleet::refresh_machine(store.as_ref(), "M")
        .await
        .unwrap();
    // The bad row: a null among a term's coefficients (as NaN was once stored), written
    // directly into the database.
    raw(
        url,
        &format!(
            "UPDATE results SET term_coefficients = '{{\"EXX\": [1.0, null]}}' WHERE id = '{}'",
            bad.id
        ),
    )
    .await;
    let r = Some(keys.read.as_str());
    let get = |uri: &str| request("GET", uri, "", None, vec![], r);

    let resp = tower::ServiceExt::oneshot(app.clone(), get("/api/v1/machines/M/results"))
        .await
        .unwrap();
    assert_eq!(resp.status(), StatusCode::OK);
    let warning = resp.headers()["x-mtcal-warning"]
        .to_str()
        .unwrap()
        .to_string();
    assert!(warning.contains(&bad.id), "{warning}");
    let (_, list) = send(&app, get("/api/v1/machines/M/results")).await;
    let ids: Vec<&str> = list
        .as_array()
        .unwrap()
        .iter()
        .map(|m| m["id"].as_str().unwrap())
        .collect();
    assert_eq!(ids, [good.id.as_str(), other.id.as_str()]);

    for uri in [
        "/api/v1/machines/M/trends/summary",
        "/api/v1/machines/M/trends/term?term=EXX&at=50",
        "/api/v1/machines/M/results/diff",
    ] {
        let (s, b) = send(&app, get(uri)).await;
        assert_eq!(s, StatusCode::OK, "{uri}: {b}");
        let w = b["warnings"].to_string();
        assert!(w.contains(&bad.id), "{uri}: {b}");
    }
    // The latest readable result is the latest.
    let (s, b) = send(&app, get("/api/v1/machines/M/results/latest")).await;
    assert_eq!(s, StatusCode::OK, "{b}");
    assert_eq!(b["meta"]["id"], other.id.as_str());
    // The difference compares the readable ones.
    let (_, d) = send(&app, get("/api/v1/machines/M/results/diff")).await;
    assert_eq!(d["baseline"]["id"], good.id.as_str());
    assert_eq!(d["against"]["id"], other.id.as_str());

    // A stored fleet entry that does not decode: the fleet is served without it.
    raw(
        url,
        "UPDATE fleet_drift SET entry = '{\"machine_id\": 5}' WHERE machine_id = 'M'",
    )
    .await;
    let (s, b) = send(&app, get("/api/v1/fleet/drift")).await;
    assert_eq!(s, StatusCode::OK, "{b}");
    assert_eq!(b["machines"].as_array().unwrap().len(), 0, "{b}");
    assert!(b["warnings"].to_string().contains("machine M"), "{b}");
}

/// A result stored before check models were kept beside results (its model not known)
/// is read from its document until the fill at start stores it; a landed one is not
/// filled again.
async fn unknown_check_models_are_filled(url: &str) {
    let (app, keys, store) = app_on(url).await;
    machine(&app, &keys.write, "M").await;
    let old = store
        .import_result(result("2026-01-01T00:00:00Z", 0.001))
        .await
        .unwrap();
    let landed = store
        .import_result(NewResult {
            check_model: Some(Default::default()),
            ..result("2026-02-01T00:00:00Z", 0.002)
        })
        .await
        .unwrap();
    assert_eq!(store.check_model(&old.id).await.unwrap(), None);
    let models = mtcal_domain::trends::check_models(store.as_ref(), &[old.clone(), landed])
        .await
        .unwrap();
    assert!(
        models.is_empty(),
        "neither a misfit nor explained: {models:?}"
    );
    let filled = mtcal_domain::trends::fill_check_models(store.as_ref(), 1)
        .await
        .unwrap();
    assert_eq!(filled, 1);
    assert_eq!(
        store.check_model(&old.id).await.unwrap(),
        Some(Default::default())
    );
    assert!(store.unknown_check_models(10).await.unwrap().is_empty());
}

#[tokio::test]
async fn unknown_check_models_are_filled_on_sqlite() {
    let dir = tempfile::tempdir().unwrap();
    let db = dir.path().join("t.sqlite");
    unknown_check_models_are_filled(&format!("sqlite://{}", db.display())).await;
}

#[tokio::test]
async fn unknown_check_models_are_filled_on_postgres() {
    let name = "unknown_check_models_are_filled_on_postgres";
    let Some(pg) = mtcal_store::testing::ScratchPg::create(name).await.unwrap() else {
        return;
    };
    unknown_check_models_are_filled(&pg.url).await;
    pg.drop_schema().await.unwrap();
}
