//! The explained model of a check is stored once, by the store's claim
//! ([`Results::import_explained`]): a second one for the same check stores nothing and is
//! no error, and of two stores (two processes) storing one for the same check at the same
//! moment, one stores it. On a SQLite file and, when `MTCAL_TEST_PG` names a server
//! (`scripts/with-postgres`), on PostgreSQL.

use mtcal_store::*;
use serde_json::json;
use std::sync::Arc;

fn machine(id: &str) -> Machine {
    serde_json::from_value(json!({
        "id": id, "name": id, "site": null, "tags": [], "baseline_result_id": null,
        "topology": {"workpiece": ["X", "Y"], "tool": ["Z"]},
        "travel_mm": {"X": [-100.0, 100.0]}, "created_at": "", "updated_at": "",
    }))
    .unwrap()
}

fn check(machine: &str, explains: Option<&str>) -> NewResult {
    let mut document = json!({"kind": "identification"});
    if let Some(original) = explains {
        document["explained"] = json!({"original_result_id": original});
    }
    NewResult {
        check_model: None,
        machine_id: machine.into(),
        dataset_id: None,
        kind: "identification".into(),
        measured_at: "2026-01-01T00:00:00Z".into(),
        document,
        scalars: ResultScalars::default(),
        figures: vec![],
    }
}

/// `a` and `b` are two stores on one database, as two processes hold them.
async fn stored_once(a: Arc<dyn Store>, b: Arc<dyn Store>) {
    a.create_machine(&machine("M1")).await.unwrap();
    let jobs = |s: Arc<dyn Store>| async move { s.row_counts().await.unwrap().jobs };

    // One after the other: the second stores nothing, and says so without an error.
    let original = a.import_result(check("M1", None)).await.unwrap();
    let first = a
        .import_explained(&original.id, check("M1", Some(&original.id)))
        .await
        .unwrap()
        .expect("the first explained model is stored");
    let before = jobs(a.clone()).await;
    let second = b
        .import_explained(&original.id, check("M1", Some(&original.id)))
        .await
        .unwrap();
    assert!(second.is_none(), "{second:?}");
    assert_eq!(jobs(a.clone()).await, before, "no import job left behind");
    let list = a.list_results("M1", "identification").await.unwrap();
    let mut ids: Vec<_> = list.iter().map(|r| r.id.as_str()).collect();
    let mut want = [original.id.as_str(), first.id.as_str()];
    ids.sort();
    want.sort();
    assert_eq!(ids, want);

    // At the same moment, for each of several checks: one of the two is stored.
    for round in 0..8 {
        let original = a.import_result(check("M1", None)).await.unwrap();
        let land = |s: Arc<dyn Store>, id: String| async move {
            s.import_explained(&id, check("M1", Some(&id))).await
        };
        let (x, y) = tokio::join!(
            tokio::spawn(land(a.clone(), original.id.clone())),
            tokio::spawn(land(b.clone(), original.id.clone())),
        );
        let (x, y) = (x.unwrap().unwrap(), y.unwrap().unwrap());
        assert!(
            x.is_some() != y.is_some(),
            "round {round}: exactly one stored: {x:?} {y:?}"
        );
        let stored = x.or(y).unwrap();
        let doc = a.get_result(&stored.id).await.unwrap().document;
        assert_eq!(doc["explained"]["original_result_id"], original.id.as_str());
        let results = a.row_counts().await.unwrap().results;
        assert_eq!(
            results,
            2 + 2 * (round + 1),
            "round {round}: one explained model"
        );
    }
    // 1 + 1 + 8 × 2 results: each a check and its one explained model.
    assert_eq!(a.row_counts().await.unwrap().results, 18);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn an_explained_model_is_stored_once_on_sqlite() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("e.sqlite");
    let a = open(path.to_str().unwrap()).await.unwrap();
    let b = open(path.to_str().unwrap()).await.unwrap();
    stored_once(a, b).await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn an_explained_model_is_stored_once_on_postgres() {
    let test = "an_explained_model_is_stored_once_on_postgres";
    let Some(pg) = testing::ScratchPg::create(test).await.unwrap() else {
        return;
    };
    let a = open(&pg.url).await.unwrap();
    let b = open(&pg.url).await.unwrap();
    stored_once(a, b).await;
    pg.drop_schema().await.unwrap();
}

/// A check's model is kept beside the result as it lands, read back without the
/// document; one landed without it is listed as not known until it is stored.
async fn check_models_kept(s: Arc<dyn Store>) {
    s.create_machine(&machine("M2")).await.unwrap();
    let misfit = CheckModel {
        misfit: true,
        misfit_reason: Some("the residual is 9 times the noise floor".into()),
        explained_model: None,
    };
    let explained = CheckModel {
        explained_model: Some("decided on the explained model".into()),
        ..CheckModel::default()
    };
    let mut ids = vec![];
    for m in [
        Some(misfit.clone()),
        Some(explained.clone()),
        Some(CheckModel::default()),
        None,
    ] {
        let r = s
            .import_result(NewResult {
                check_model: m,
                ..check("M2", None)
            })
            .await
            .unwrap();
        ids.push(r.id);
    }
    assert_eq!(s.check_model(&ids[0]).await.unwrap(), Some(misfit.clone()));
    assert_eq!(
        s.check_model(&ids[1]).await.unwrap(),
        Some(explained.clone())
    );
    assert_eq!(
        s.check_model(&ids[2]).await.unwrap(),
        Some(CheckModel::default())
    );
    assert_eq!(s.check_model(&ids[3]).await.unwrap(), None);
    let mut listed = s.check_models("M2", "identification").await.unwrap();
    listed.sort_by(|a, b| a.0.cmp(&b.0));
    let mut want = vec![
        (ids[0].clone(), Some(misfit)),
        (ids[1].clone(), Some(explained)),
        (ids[2].clone(), Some(CheckModel::default())),
        (ids[3].clone(), None),
    ];
    want.sort_by(|a, b| a.0.cmp(&b.0));
    assert_eq!(listed, want);
    assert_eq!(
        s.unknown_check_models(10).await.unwrap(),
        vec![ids[3].clone()]
    );
    s.set_check_model(&ids[3], &CheckModel::default())
        .await
        .unwrap();
    assert!(s.unknown_check_models(10).await.unwrap().is_empty());
    assert_eq!(
        s.check_model(&ids[3]).await.unwrap(),
        Some(CheckModel::default())
    );
}

#[tokio::test]
async fn check_models_are_kept_on_sqlite() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("c.sqlite");
    check_models_kept(open(path.to_str().unwrap()).await.unwrap()).await;
}

#[tokio::test]
async fn check_models_are_kept_on_postgres() {
    let Some(pg) = testing::ScratchPg::create("check_models_are_kept")
        .await
        .unwrap()
    else {
        return;
    };
    check_models_kept(open(&pg.url).await.unwrap()).await;
    pg.drop_schema().await.unwrap();
}
