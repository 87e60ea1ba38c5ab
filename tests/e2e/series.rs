//! Positioning runs and drift logs upload as their kinds and are diagnosed by the series
//! diagnosis; a broken CSV is refused with the reader's file:line:column and nothing is
//! stored.

use crate::common::*;
use mtcal_server::jobs::JobKind;
use mtcal_store::JobState;

#[tokio::test]
async fn series_datasets_upload_and_diagnose_bad_ones_store_nothing() {
    let app = spawn_app().await;
    app.machine("VMC-P").await;
    // ISO 230-2 style: X axis, 5 runs each way at 11 targets, 3 µm reversal error.
    let mut text = String::from("axis,run,direction,target_mm,deviation_um\n");
    for run in 1..=5 {
        for dir in ["+", "-"] {
            for i in 0..=10 {
                let t = f64::from(i) * 10.0;
                let dev = 0.02 * t + if dir == "+" { 1.5 } else { -1.5 } + 0.01 * f64::from(run);
                text += &format!("X,{run},{dir},{t},{dev}\n");
            }
        }
    }
    let file = |name: &str, text: &str| vec![(name.to_string(), text.as_bytes().to_vec())];
    let ds = app
        .client
        .upload_files("VMC-P", &file("pos.csv", &text))
        .await
        .unwrap();
    assert_eq!((ds.kind.as_str(), ds.samples), ("positioning", 110));
    let id = submit(&app.client, JobKind::Diagnose, Some(&ds.id), None)
        .await
        .id;
    app.wait(&id, JobState::Succeeded).await;
    let doc = app.client.job_result(&id).await.unwrap();
    let runs = mtcal_formats::read_positioning(
        "pos.csv",
        text.as_bytes(),
        &mtcal_formats::Limits::default(),
    )
    .unwrap();
    let local = mtcal_solver::diagnosis::series::diagnose_positioning(
        &runs,
        "VMC-P",
        &mtcal_solver::diagnosis::series::SeriesOptions::default(),
    )
    .unwrap();
    assert_eq!(doc, serde_json::to_value(&local).unwrap());

    // Drift log: two channels over an hour.
    let mut log = String::from("t_s,x_um,t1_c\n");
    for i in 0..=60 {
        let t = f64::from(i) * 60.0;
        log += &format!(
            "{t},{},{}\n",
            5.0 * (1.0 - (-t / 1200.0).exp()),
            20.0 + t / 3600.0
        );
    }
    let ds = app
        .client
        .upload_files("VMC-P", &file("drift.csv", &log))
        .await
        .unwrap();
    assert_eq!((ds.kind.as_str(), ds.samples), ("drift_log", 61));
    // fit_fraction (drift logs): out of range refused at submission; 0.5 gives the
    // library's diagnosis fitted on the first half.
    let with_fraction = |f: f64| {
        let mut j = job(JobKind::Diagnose, Some(&ds.id), None);
        j.params = serde_json::json!({ "fit_fraction": f });
        j
    };
    let msg = refusal_message(app.client.submit(&with_fraction(0.95)).await);
    assert!(msg.contains("fit_fraction"), "{msg}");
    let id = app.client.submit(&with_fraction(0.5)).await.unwrap().id;
    app.wait(&id, JobState::Succeeded).await;
    let doc = app.client.job_result(&id).await.unwrap();
    let parsed =
        mtcal_formats::read_drift_log("drift.csv", log.as_bytes(), &Default::default()).unwrap();
    let local = mtcal_solver::diagnosis::series::diagnose_drift_log(
        &parsed,
        "VMC-P",
        &mtcal_solver::diagnosis::series::SeriesOptions {
            train_fraction: 0.5,
            ..Default::default()
        },
    )
    .unwrap();
    assert_eq!(doc, serde_json::to_value(&local).unwrap());

    // A bad value on line 3, column deviation_um: refused, nothing stored.
    let before = app.counts().await;
    let bad = text.replacen("X,1,+,10,", "X,1,+,10,abc", 1);
    let r = app
        .client
        .upload_files("VMC-P", &file("bad.csv", &bad))
        .await;
    let msg = refusal_message(r);
    assert!(msg.starts_with("bad.csv:3:deviation_um:"), "{msg}");
    assert_eq!(app.counts().await, before);
}
