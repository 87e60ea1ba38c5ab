//! Datasets excluded (their results with them) and their raw bytes deleted under a
//! tombstone, over HTTP.

use crate::common::*;
use mtcal_store::JobState;
use reqwest::StatusCode;

#[tokio::test]
async fn an_excluded_dataset_takes_its_results_out_and_deleted_bytes_leave_a_tombstone() {
    let app = spawn_app().await;
    app.machine("VMC-A").await;
    let mut datasets = Vec::new();
    for q in 0..3 {
        let dir = app.path(&format!("q{q}"));
        write_session(&dir, "VMC-A", 1, q);
        let ds = app.client.upload_path("VMC-A", &dir).await.unwrap();
        let job = app.identify(&ds.id).await;
        app.wait(&job, JobState::Succeeded).await;
        datasets.push(ds);
    }
    let hist = app.client.results("VMC-A", None).await.unwrap();
    assert_eq!(hist.len(), 3);
    let first = &datasets[0];
    assert_eq!(hist[0].dataset_id.as_deref(), Some(first.id.as_str()));

    // Who may exclude, and how.
    let read = app.with_key(&app.read_key);
    assert_eq!(
        refused(read.exclude_dataset(&first.id, "bad setup").await).0,
        StatusCode::FORBIDDEN
    );
    assert_eq!(
        refused(app.client.exclude_dataset(&first.id, " ").await).0,
        StatusCode::BAD_REQUEST
    );
    assert_eq!(
        refused(app.client.exclude_dataset("ds_unknown", "x").await).0,
        StatusCode::NOT_FOUND
    );

    // Excluding the first dataset (the machine's baseline check): recorded, shown when
    // read, and its result excluded with the same record.
    let x = app
        .client
        .exclude_dataset(&first.id, "probe loose")
        .await
        .unwrap();
    let rec = x.excluded.clone().unwrap();
    assert_eq!(rec.reason, "probe loose");
    assert!(rec.by.starts_with("key "), "{}", rec.by);
    assert_eq!(
        app.client.dataset(&first.id).await.unwrap().excluded,
        Some(rec.clone())
    );
    let r0 = app.client.result(&hist[0].id).await.unwrap();
    assert_eq!(r0.meta.excluded, Some(rec.clone()));
    // Again: the first record stays.
    let again = app
        .client
        .exclude_dataset(&first.id, "other")
        .await
        .unwrap();
    assert_eq!(again.excluded, Some(rec.clone()));

    // History, difference and fleet no longer use it: the baseline is now the second.
    let ids: Vec<String> = app
        .client
        .results("VMC-A", None)
        .await
        .unwrap()
        .into_iter()
        .map(|r| r.id)
        .collect();
    assert_eq!(ids, [hist[1].id.clone(), hist[2].id.clone()]);
    let d = app.client.diff("VMC-A", &[]).await.unwrap();
    assert_eq!(
        (d.baseline.id.as_str(), d.against.id.as_str()),
        (hist[1].id.as_str(), hist[2].id.as_str())
    );
    let fleet = app.client.fleet_drift(None, None).await.unwrap();
    let a = &fleet.machines[0];
    assert_eq!(
        (a.baseline_result_id.as_str(), a.results),
        (hist[1].id.as_str(), 2)
    );

    // Listings leave it out unless asked; a new job on it is refused.
    let c = &app.client;
    let listed = |all| async move {
        let l = c.datasets("VMC-A", all).await.unwrap();
        l.into_iter().map(|d| d.id).collect::<Vec<_>>()
    };
    assert_eq!(
        listed(false).await,
        [datasets[1].id.clone(), datasets[2].id.clone()]
    );
    assert_eq!(listed(true).await.len(), 3);
    let (status, code) = refused(
        app.client
            .submit(&job(
                mtcal_server::jobs::JobKind::Identify,
                Some(&first.id),
                None,
            ))
            .await,
    );
    assert_eq!((status, code.as_str()), (StatusCode::CONFLICT, "conflict"));

    // Deleting its bytes takes an admin key; a tombstone stays.
    assert_eq!(
        refused(
            app.client
                .delete_dataset_files(&first.id, "retention")
                .await
        )
        .0,
        StatusCode::FORBIDDEN
    );
    let admin = app.with_key(&app.admin_key);
    let t = admin
        .delete_dataset_files(&first.id, "retention period over")
        .await
        .unwrap();
    assert_eq!(t.deleted.as_ref().unwrap().reason, "retention period over");
    assert_eq!(
        t.excluded,
        Some(rec.clone()),
        "the exclusion's record is kept"
    );
    assert_eq!(
        (t.files.clone(), t.sha256.clone()),
        (first.files.clone(), first.sha256.clone())
    );
    let name = &first.files[0].name;
    let msg = refusal_message(app.client.dataset_file(&first.id, name).await);
    assert!(msg.contains("retention period over"), "{msg}");
    let again = admin
        .delete_dataset_files(&first.id, "twice")
        .await
        .unwrap();
    assert_eq!(again.deleted, t.deleted);
    // The other datasets keep their bytes.
    let kept = &datasets[1];
    let bytes = app
        .client
        .dataset_file(&kept.id, &kept.files[0].name)
        .await
        .unwrap();
    assert_eq!(bytes.len() as i64, kept.files[0].size);
}

#[tokio::test]
async fn a_dataset_with_a_queued_job_is_neither_excluded_nor_deleted() {
    let app = spawn_app_with(AppOptions {
        run_worker: false,
        ..AppOptions::default()
    })
    .await;
    app.machine("VMC-A").await;
    let dir = app.path("q0");
    write_session(&dir, "VMC-A", 1, 0);
    let ds = app.client.upload_path("VMC-A", &dir).await.unwrap();
    let job = app.identify(&ds.id).await;
    let admin = app.with_key(&app.admin_key);
    for r in [
        app.client.exclude_dataset(&ds.id, "wrong machine").await,
        admin.delete_dataset_files(&ds.id, "wrong machine").await,
    ] {
        let msg = refusal_message(r);
        assert!(msg.contains(&job), "{msg}");
    }
    let d = app.client.dataset(&ds.id).await.unwrap();
    assert_eq!((d.excluded, d.deleted), (None, None));
    // Cancelled, the job no longer holds it.
    app.client.cancel(&job).await.unwrap();
    let d = admin
        .delete_dataset_files(&ds.id, "wrong machine")
        .await
        .unwrap();
    assert_eq!(d.excluded, d.deleted);
    assert!(d.deleted.is_some());
}
