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
    // The diagnosis with the ISO 230-2 figures of the same runs beside it.
    let local = mtcal_solver::positioning_check::check_positioning(
        &runs,
        "VMC-P",
        &mtcal_solver::diagnosis::series::SeriesOptions::default(),
        &mut mtcal_solver::diagnosis::NoProgress,
    )
    .unwrap();
    assert_eq!(doc, serde_json::to_value(&local).unwrap());
    assert_eq!(doc["iso230_2"][0]["axis"], "X");

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

/// A real positioning-run file (the ESS stage of `data/ecmccfg_iso230`) uploaded and
/// diagnosed: the result page and the check report show the ISO 230-2 figures, the
/// standard's and those without cycle 1's two outlying readings, each labelled, and the
/// findings (the first-cycle transient, the lost motion along the travel) with their
/// held-out figures.
#[tokio::test]
async fn a_real_positioning_run_shows_its_figures_and_findings() {
    let app = spawn_app().await;
    app.machine("ESS-1025").await;
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/data/ecmccfg_iso230/ess_mcu1025_axis1.csv"
    );
    let bytes = std::fs::read(path).unwrap();
    let ds = app
        .client
        .upload_files("ESS-1025", &[("ess_mcu1025_axis1.csv".to_string(), bytes)])
        .await
        .unwrap();
    assert_eq!(ds.kind.as_str(), "positioning");
    let id = submit(&app.client, JobKind::Diagnose, Some(&ds.id), None)
        .await
        .id;
    let job = app.wait(&id, JobState::Succeeded).await;
    let result_id = job.result_id.expect("a result");
    let doc = app.client.job_result(&id).await.unwrap();
    assert_ne!(doc["verdict"], "consistent");
    assert!(
        doc["iso230_2"][0]["without_outlying"]["dominated"]
            .as_array()
            .unwrap()
            .iter()
            .any(|d| d == "R_um")
    );

    let b = app.sign_in(&app.read_key).await;
    let page = b.get(&format!("/results/{result_id}")).await;
    assert_eq!(page.status(), reqwest::StatusCode::OK);
    let html = page.text().await.unwrap();
    let report = app.client.report(&result_id).await.unwrap();
    assert_eq!(report.content_type, "text/html; charset=utf-8");
    for (what, text) in [("page", &html), ("report", &report.text)] {
        for needle in [
            "ISO 230-2, axis X",
            "standard (every reading)",
            "without the outlying readings (not the standard",
            "data-figure=\"R_um\"",
            "R = 204.8 µm",
            "R = 58.28 µm",
            "data-effect=\"first_cycle_transient\"",
            "data-effect=\"lost_motion_profile\"",
            "held-out RMS",
            "positioning_X_reversal",
        ] {
            assert!(text.contains(needle), "{what}: no {needle}");
        }
    }
    assert!(!report.text.contains("<script"));
}
