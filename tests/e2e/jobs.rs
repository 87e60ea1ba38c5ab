//! Jobs of every kind give the library's result on the same input; cancellation; a result
//! that is not finite is refused and the history stays readable.

use crate::common::*;
use mtcal_server::jobs::JobKind;
use mtcal_store::JobState;
use reqwest::StatusCode;
use serde_json::json;

#[tokio::test]
async fn queued_job_can_be_cancelled() {
    let app = spawn_app_with(AppOptions {
        run_worker: false,
        ..AppOptions::default()
    })
    .await;
    app.machine("VMC-C").await;
    let dir = app.path("s");
    write_session(&dir, "VMC-C", 5, 0);
    let ds = app.client.upload_path("VMC-C", &dir).await.unwrap();
    let job = app.identify(&ds.id).await;
    let j = app.client.cancel(&job).await.unwrap();
    assert_eq!(j.state, JobState::Cancelled);
    assert_eq!(
        refused(app.client.job_result(&job).await),
        (StatusCode::CONFLICT, "job_not_finished".into())
    );
    assert_eq!(
        refused(app.client.cancel(&job).await),
        (StatusCode::CONFLICT, "conflict".into())
    );
}

#[tokio::test]
async fn sensitivity_job_gives_the_library_result() {
    let app = spawn_app().await;
    app.machine("VMC-S").await;
    let params = json!({"machine": {"template": "vmc3"}});
    let mut j = job(JobKind::Sensitivity, None, None);
    j.params = params.clone();
    assert_eq!(
        refused(app.client.submit(&j).await),
        (StatusCode::BAD_REQUEST, "invalid_request".into())
    );
    j.machine_id = Some("VMC-S".into());
    let id = app.client.submit(&j).await.unwrap().id;
    app.wait(&id, JobState::Succeeded).await;
    // The worker recorded the job's run and queue wait in the process's metrics.
    let metrics = reqwest::Client::new()
        .get(format!("{}/metrics", app.url))
        .bearer_auth(&app.admin_key)
        .send()
        .await
        .unwrap()
        .text()
        .await
        .unwrap();
    for series in [
        r#"mtcal_job_duration_seconds_count{kind="sensitivity",outcome="succeeded"}"#,
        r#"mtcal_job_queue_wait_seconds_count{kind="sensitivity"}"#,
    ] {
        let n: f64 = metrics
            .lines()
            .find_map(|l| l.strip_prefix(series)?.trim().parse().ok())
            .unwrap_or_else(|| panic!("no {series} in {metrics}"));
        assert!(n >= 1.0, "{series} {n}");
    }
    let doc = app.client.job_result(&id).await.unwrap();
    let mut req: mtcal_solver::sensitivity::SensitivityRequest = typed(&params);
    req.machine_id = "VMC-S".into();
    let local = mtcal_solver::sensitivity::analyse(&req).unwrap();
    assert_eq!(doc, serde_json::to_value(&local).unwrap());
    // Not an identification: the machine's identification history stays empty.
    assert!(app.client.results("VMC-S", None).await.unwrap().is_empty());
}

/// A running `diagnose` job's progress field moves through the diagnosis's phases:
/// polled while it runs, it shows more than one phase with fractions between the
/// loading (0.2) and the end (1), never going back.
#[tokio::test]
async fn diagnose_job_progress_moves_through_phases() {
    use mtcal_solver::simulate::{Plan, SimOptions, random_truth, simulate};
    let app = spawn_app().await;
    app.machine("VMC-P").await;
    // Full plan at 20 Hz (about 60 000 samples): a diagnosis of a second or more.
    let sim = simulate(
        &random_truth(4),
        &SimOptions {
            plan: Plan::Full,
            seed: 4,
            sample_rate_hz: 20.0,
            machine_id: "VMC-P".into(),
            ..SimOptions::default()
        },
    )
    .unwrap();
    let dir = app.path("p");
    mtcal_formats::write_session_dir(&dir, &sim.session).unwrap();
    let ds = app.client.upload_path("VMC-P", &dir).await.unwrap();
    let id = submit(&app.client, JobKind::Diagnose, Some(&ds.id), None)
        .await
        .id;
    let mut seen: Vec<(f64, String)> = Vec::new();
    let start = std::time::Instant::now();
    loop {
        let j = app.client.job(&id).await.unwrap();
        let now = (j.progress, j.progress_message.clone().unwrap_or_default());
        if seen.last() != Some(&now) {
            seen.push(now);
        }
        if j.state.is_terminal() {
            assert_eq!(j.state, JobState::Succeeded, "{j:?}");
            break;
        }
        assert!(
            start.elapsed() < std::time::Duration::from_secs(120),
            "{seen:?}"
        );
        tokio::time::sleep(std::time::Duration::from_millis(20)).await;
    }
    assert!(seen.windows(2).all(|w| w[1].0 >= w[0].0), "{seen:?}");
    // At least two intermediate states beyond the claim (the worker writes a new phase at
    // most every 100 ms, so how many a poll sees depends on the machine's speed; which
    // phase names they carry does too).
    let intermediate: Vec<&(f64, String)> =
        seen.iter().filter(|(p, _)| *p > 0.0 && *p < 1.0).collect();
    assert!(intermediate.len() >= 2, "{seen:?}");
    assert_eq!(seen.last().unwrap().0, 1.0);
}

/// A `diagnose` job on an uploaded session gives the library's diagnosis of the same
/// files, filed under the machine as kind `diagnosis`. The session (seed plan, 5 Hz,
/// σ = 0.15 µm) carries 4 µm of X backlash, far above the noise: the diagnosis must name
/// it.
#[tokio::test]
async fn diagnose_job_gives_the_library_diagnosis() {
    use mtcal_solver::simulate::{Effect, Plan, SimOptions, random_truth, simulate};
    let app = spawn_app().await;
    app.machine("VMC-D").await;
    let sim = simulate(
        &random_truth(3),
        &SimOptions {
            plan: Plan::Seed,
            seed: 3,
            sample_rate_hz: 5.0,
            machine_id: "VMC-D".into(),
            effects: vec![Effect::Backlash {
                axis: mtcal_solver::axis::Axis::X,
                lost_motion_um: 4.0,
            }],
            ..SimOptions::default()
        },
    )
    .unwrap();
    let dir = app.path("s");
    mtcal_formats::write_session_dir(&dir, &sim.session).unwrap();
    let ds = app.client.upload_path("VMC-D", &dir).await.unwrap();
    let mut j = job(JobKind::Diagnose, Some(&ds.id), None);
    j.params = json!({"order": 2});
    assert_eq!(
        refused(app.client.submit(&j).await),
        (StatusCode::BAD_REQUEST, "invalid_request".into())
    );
    let id = submit(&app.client, JobKind::Diagnose, Some(&ds.id), None)
        .await
        .id;
    let done = app.wait(&id, JobState::Succeeded).await;
    let doc = app.client.job_result(&id).await.unwrap();

    let session = mtcal_formats::read_session_dir(&dir, &mtcal_formats::Limits::default()).unwrap();
    let local = mtcal_solver::diagnosis::diagnose_session(
        &session,
        &mtcal_solver::diagnosis::DiagnoseOptions::default(),
    )
    .unwrap();
    assert_eq!(doc, serde_json::to_value(&local).unwrap());
    let effects: Vec<&str> = doc["findings"]
        .as_array()
        .unwrap()
        .iter()
        .map(|f| f["effect"].as_str().unwrap())
        .collect();
    assert!(effects.contains(&"backlash"), "findings {effects:?}");

    // Stored under the machine with its kind and the baseline residual as scalar.
    let result_id = done.result_id.unwrap();
    let stored = app.client.result(&result_id).await.unwrap();
    assert_eq!(stored.meta.kind, "diagnosis");
    assert_eq!(stored.meta.machine_id, "VMC-D");
    assert_eq!(stored.document, doc);
    assert_eq!(
        stored.meta.scalars.summary.residual_rms_um,
        Some(local.baseline.residual_rms_um)
    );
    // In the machine's history of that kind, not among its identifications.
    let hist = app
        .client
        .results("VMC-D", Some("diagnosis"))
        .await
        .unwrap();
    assert_eq!(hist.len(), 1);
    assert_eq!(hist[0].id, result_id);
    assert!(app.client.results("VMC-D", None).await.unwrap().is_empty());
    let last = app.client.latest("VMC-D", Some("diagnosis")).await.unwrap();
    assert_eq!(last.document, doc);
}

/// A rotary point set (CSV + sidecar) is stored as kind `rotary_points` with its raw bytes,
/// and a `cradle` job gives the library's check of the same files, filed as kind `cradle`.
/// Wrong pairings of job and dataset kind are refused at submission.
#[tokio::test]
async fn cradle_job_on_an_uploaded_point_set_gives_the_library_result() {
    let app = spawn_app().await;
    app.machine("VMC-C").await;
    let dir = app.path("c");
    let (set, csv, side) = write_cradle_set(&dir, "VMC-C");

    let ds = app.client.upload_path("VMC-C", &dir).await.unwrap();
    assert_eq!(ds.kind, "rotary_points");
    assert_eq!(ds.samples, set.points.len() as i64);
    assert_eq!(ds.measured_at, "2026-11-02T08:30:00Z");
    assert_eq!(
        app.client.dataset_file(&ds.id, "cradle.csv").await.unwrap(),
        csv
    );

    for kind in [JobKind::Identify, JobKind::Diagnose] {
        assert_eq!(
            refused(app.client.submit(&job(kind, Some(&ds.id), None)).await),
            (StatusCode::BAD_REQUEST, "invalid_request".into()),
            "{kind:?}"
        );
    }
    let id = submit(&app.client, JobKind::Cradle, Some(&ds.id), None)
        .await
        .id;
    let done = app.wait(&id, JobState::Succeeded).await;
    let doc = app.client.job_result(&id).await.unwrap();
    let read = mtcal_formats::read_rotary_points(
        "cradle.csv",
        &csv,
        Some(&side),
        &mtcal_formats::Limits::default(),
    )
    .unwrap();
    let local =
        mtcal_solver::cradle::check_cradle(&read, &mtcal_solver::cradle::CradleOptions::default())
            .unwrap();
    assert_eq!(doc, serde_json::to_value(&local).unwrap());
    let stored = app.client.result(&done.result_id.unwrap()).await.unwrap();
    assert_eq!(stored.meta.kind, "cradle");
    assert_eq!(stored.meta.machine_id, "VMC-C");
    // Its report: the cradle check's own page, with what the ball data can separate and
    // one compliance plot per A-dependent term of the chosen model (none: rigid here).
    let page = app.client.report(&stored.meta.id).await.unwrap();
    assert_eq!(page.content_type, "text/html; charset=utf-8");
    let page = page.text;
    assert!(
        page.contains("Cradle check report: VMC-C"),
        "{}",
        &page[..page.len().min(500)]
    );
    assert!(page.contains("id=\"separability\"") && page.contains("id=\"undetermined\""));
    assert_eq!(
        page.matches("data-term=").count(),
        local.kinematics.curves.len()
    );
}

/// A job whose result holds a number that is not finite ends `bad_input` with nothing
/// stored, and the machine's results, latest, trends, difference and the fleet's drift
/// still answer from the checks before it. The service is configured with the readers'
/// bound on deviations lifted (`WorkerConfig::limits`), so that a plane file with one
/// deviation of 1e308 µm (finite) is accepted and its identification's residual
/// overflows (refused because the document does not read back as stored,
/// `crates/server/src/jobs.rs`, before the store's rule for a result's scalars,
/// `crates/store/src/rules.rs`).
#[tokio::test]
async fn a_result_that_is_not_finite_is_refused_and_the_history_stays_readable() {
    let app = spawn_app_with(AppOptions {
        limits: mtcal_server::UploadLimits {
            max_abs_deviation_um: f64::MAX,
            ..Default::default()
        },
        ..AppOptions::default()
    })
    .await;
    let m = "VMC-N";
    app.machine(m).await;
    for quarter in 0..2 {
        let dir = app.path(&format!("q{quarter}"));
        write_session(&dir, m, 6, quarter);
        let ds = app.client.upload_path(m, &dir).await.unwrap();
        let job = app.identify(&ds.id).await;
        app.wait(&job, JobState::Succeeded).await;
    }
    let before = app.counts().await;
    let dir = app.path("absurd");
    write_session(&dir, m, 6, 2);
    // A cross deviation (dv) of the first plane: the standards' figures stay finite,
    // the fit's residual does not.
    set_plane_cell(&dir, "dv_um", 4, "1e308");
    // Sent as files: the client's own read of a folder keeps the default limits.
    let ds = app
        .client
        .upload_files(m, &folder_files(&dir))
        .await
        .unwrap();
    let job = app.identify(&ds.id).await;
    let failed = app.wait(&job, JobState::Failed).await;
    let message = failed.error_message.unwrap_or_default();
    assert_eq!(failed.error_code.as_deref(), Some("bad_input"), "{message}");
    // Refused before the store's own rule for a result's scalars: the document does
    // not read back as stored.
    assert!(
        message.contains("does not read back") && message.contains("not a finite number"),
        "{message}"
    );
    assert!(failed.result_id.is_none());
    let after = app.counts().await;
    assert_eq!(
        (after.results, after.result_figures),
        (before.results, before.result_figures),
        "nothing stored"
    );

    let read = app.with_key(&app.read_key);
    let results = read.results(m, None).await.unwrap();
    assert_eq!(results.len(), 2);
    let latest = read.latest(m, None).await.unwrap();
    assert_eq!(latest.meta.id, results[1].id);
    let trend = read.term_trend(m, "EXX", &[-50.0, 50.0]).await.unwrap();
    assert_eq!(trend.points.len(), 2);
    assert!(
        trend
            .points
            .iter()
            .all(|p| p.values.iter().all(Option::is_some))
    );
    assert_eq!(read.summary_trend(m).await.unwrap().points.len(), 2);
    let diff = read.diff(m, &[]).await.unwrap();
    assert_eq!(diff.against.id, results[1].id);
    let fleet = read.fleet_drift(None, None).await.unwrap();
    let entry = fleet.machines.iter().find(|e| e.machine_id == m).unwrap();
    assert_eq!(entry.latest_result_id, results[1].id);
    assert!(entry.drift.drift_um.is_finite() && fleet.warnings.is_empty());
}
