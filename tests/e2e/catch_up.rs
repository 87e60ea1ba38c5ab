//! The explained model after a crash: a misfit check and its diagnosis (verdict
//! `explained`) are stored as the worker stores them, but the service stopped before the
//! explained fit. When it starts, its workers' process stores the explained model, once
//! (`mtcal_server::explain::catch_up`). On SQLite, and on PostgreSQL when
//! `MTCAL_TEST_PG` names a server (`scripts/with-postgres`).

use crate::common::*;
use crate::explained::{as_worker_stores, backlash, simulated};
use mtcal_solver::identification::IdentificationResult;
use serde_json::Value;
use std::time::Duration;

async fn scenario(options: AppOptions) {
    let machine = "CATCH-1";
    // Stored without a worker, as a crash after the diagnosis landed leaves them.
    let app = spawn_app_with(AppOptions {
        run_worker: false,
        ..options
    })
    .await;
    app.machine(machine).await;
    let (dir, ds) = simulated(&app, machine, 51, &[backlash("X", 6.0)]).await;
    let d = dir.to_str().unwrap();
    let stored = |kind: &str, document: Value| as_worker_stores(&ds, kind, document);
    let ident: Value = serde_json::from_str(&mtcal(&["identify", d, "--json"])).unwrap();
    assert_eq!(ident["model_check"]["state"], "misfit");
    let original = app
        .store
        .import_result(stored("identification", ident))
        .await
        .unwrap();
    let diag: Value = serde_json::from_str(&mtcal(&["diagnose", d, "--json"])).unwrap();
    assert_eq!(diag["verdict"], "explained", "{}", diag["verdict"]);
    let diag = app
        .store
        .import_result(stored("diagnosis", diag))
        .await
        .unwrap();
    let before = app.counts().await.results;
    // The misfit's trend point says so, and why.
    let t = app.client.term_trend(machine, "EXX", &[0.0]).await.unwrap();
    let p = &t.points[0].model;
    assert!(p.misfit && p.explained_model.is_none(), "{p:?}");
    let reason = p.misfit_reason.as_deref().unwrap_or_default();
    assert!(
        reason.starts_with("the model does not explain this recording"),
        "{reason}"
    );

    // The service starts with its workers: the explained model appears.
    let worker = mtcal_server::WorkerConfig::default();
    mtcal_server::spawn_local(app.store.clone(), &worker, true)
        .await
        .unwrap();
    let mut explained = None;
    for _ in 0..1200 {
        let list = app
            .store
            .list_results(machine, "identification")
            .await
            .unwrap();
        if let [r] = list.as_slice()
            && r.id != original.id
        {
            explained = Some(r.clone());
            break;
        }
        tokio::time::sleep(Duration::from_millis(100)).await;
    }
    let explained = explained.expect("no explained model was stored at start");
    let doc: IdentificationResult =
        typed(&app.store.get_result(&explained.id).await.unwrap().document);
    let link = doc.explained.as_ref().expect("an explained model");
    assert_eq!(
        link.original_result_id.as_deref(),
        Some(original.id.as_str())
    );
    assert_eq!(link.diagnosis_result_id.as_deref(), Some(diag.id.as_str()));
    assert!(doc.model_check().decided_on_explained_model());
    let was = app.store.get_result(&original.id).await.unwrap();
    let excluded = was.meta.excluded.expect("the original is set aside");
    assert_eq!(excluded.by, mtcal_server::explain::BY);
    assert!(
        excluded.reason.contains(&explained.id),
        "{}",
        excluded.reason
    );

    // The trends now say the check is decided on the explained model: the routes'
    // points and the machine page.
    let t = app.client.term_trend(machine, "EXX", &[0.0]).await.unwrap();
    let s = app.client.summary_trend(machine).await.unwrap();
    for p in [&t.points[0].model, &s.points[0].model] {
        assert!(!p.misfit && p.misfit_reason.is_none(), "{p:?}");
        let e = p.explained_model.as_deref().unwrap_or_default();
        assert!(
            e.starts_with("decided on the explained model") && e.contains("backlash (X)"),
            "{e}"
        );
    }
    let figures = format!("/api/v1/machines/{machine}/trends/figure");
    let names = crate::explained::get_json(&app, &figures).await;
    let name = names["names"][0]
        .as_str()
        .expect("the explained model's figures");
    let f = crate::explained::get_json(&app, &format!("{figures}?name={name}")).await;
    assert_eq!(f["points"][0]["result_id"], explained.id.as_str(), "{f}");
    let e = f["points"][0]["explained_model"]
        .as_str()
        .unwrap_or_default();
    assert!(e.starts_with("decided on the explained model"), "{f}");
    let browser = app.sign_in(&app.read_key).await;
    let page = browser.get(&format!("/machines/{machine}")).await;
    let page = page.text().await.unwrap();
    let note = &page[page.find("explained-note").expect("the trends say so")..];
    assert!(
        note[..note.find("</p>").unwrap()].contains("Decided on the explained model"),
        "{note}"
    );

    // Once: started again, and caught up again by hand, nothing more is stored.
    mtcal_server::spawn_local(app.store.clone(), &worker, true)
        .await
        .unwrap();
    let limits = mtcal_server::UploadLimits::default();
    let again = mtcal_server::explain::catch_up(&app.store, limits)
        .await
        .unwrap();
    assert!(again.is_empty(), "{again:?}");
    tokio::time::sleep(Duration::from_millis(500)).await;
    assert_eq!(
        app.counts().await.results,
        before + 1,
        "one explained model"
    );
    let list = app
        .store
        .list_results(machine, "identification")
        .await
        .unwrap();
    assert_eq!(list.len(), 1);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_diagnosis_landed_before_a_crash_is_explained_at_start() {
    scenario(AppOptions::default()).await;
}

/// The same on PostgreSQL (skipped, saying so, without `MTCAL_TEST_PG`).
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_diagnosis_landed_before_a_crash_is_explained_at_start_on_postgres() {
    on_postgres("e2e::catch_up::postgres", scenario).await;
}
