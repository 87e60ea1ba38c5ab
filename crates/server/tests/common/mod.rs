//! The in-process harness of the server's request tests: the router on an in-memory
//! store with a key of each scope, driven without a socket.

#![allow(dead_code)]

pub mod routes;

use axum::body::Body;
use axum::http::{Request, StatusCode, header};
use mtcal_server::{AppState, UploadLimits, router};
use mtcal_store::{NewResult, ResultScalars, Scope, Store};
use serde_json::Value;
use std::collections::BTreeMap;
use std::sync::Arc;
use tower::ServiceExt;

/// A key of each scope.
pub struct Keys {
    pub read: String,
    pub write: String,
    pub admin: String,
}

/// Upload limit of [`app`], bytes.
pub const MAX_UPLOAD: usize = 1000;

/// The API on an in-memory store (uploads limited to [`MAX_UPLOAD`] bytes).
pub async fn app() -> (axum::Router, Keys, Arc<dyn Store>) {
    app_on("sqlite::memory:").await
}

/// [`app`] on the store `url` names.
pub async fn app_on(url: &str) -> (axum::Router, Keys, Arc<dyn Store>) {
    app_with(url, MAX_UPLOAD).await
}

/// [`app_on`] with uploads limited to `max_upload` bytes.
pub async fn app_with(url: &str, max_upload: usize) -> (axum::Router, Keys, Arc<dyn Store>) {
    let store = mtcal_store::open(url).await.unwrap();
    let (_, read) = store.create_key(Scope::Read, "r").await.unwrap();
    let (_, write) = store.create_key(Scope::Write, "w").await.unwrap();
    let (_, admin) = store.create_key(Scope::Admin, "a").await.unwrap();
    let state = AppState {
        limits: UploadLimits {
            max_bytes: max_upload,
            ..UploadLimits::default()
        },
        ..state(store.clone())
    };
    (router(state), Keys { read, write, admin }, store)
}

/// The handlers' state on `store` with the default limits and settings.
pub fn state(store: Arc<dyn Store>) -> AppState {
    AppState {
        store,
        limits: UploadLimits::default(),
        max_attempts: 3,
        wake: Arc::new(tokio::sync::Notify::new()),
        settings: Arc::default(),
        database: Arc::default(),
        uploads: Default::default(),
        fleet_counts: Arc::default(),
    }
}

/// A request; empty `ct` sends no Content-Type.
pub fn request(
    method: &str,
    uri: &str,
    ct: &str,
    enc: Option<&str>,
    body: Vec<u8>,
    key: Option<&str>,
) -> Request<Body> {
    let mut r = Request::builder().method(method).uri(uri);
    if !ct.is_empty() {
        r = r.header(header::CONTENT_TYPE, ct);
    }
    if let Some(e) = enc {
        r = r.header(header::CONTENT_ENCODING, e);
    }
    if let Some(k) = key {
        r = r.header(header::AUTHORIZATION, format!("Bearer {k}"));
    }
    r.body(Body::from(body)).unwrap()
}

/// Sends a request; its status and its body when that is JSON (else null).
pub async fn send(app: &axum::Router, req: Request<Body>) -> (StatusCode, Value) {
    let resp = app.clone().oneshot(req).await.unwrap();
    let status = resp.status();
    let json = resp
        .headers()
        .get(header::CONTENT_TYPE)
        .is_some_and(|v| v.as_bytes().starts_with(b"application/json"));
    let bytes = axum::body::to_bytes(resp.into_body(), usize::MAX)
        .await
        .unwrap();
    let body = if json {
        serde_json::from_slice(&bytes).unwrap_or_default()
    } else {
        Value::Null
    };
    (status, body)
}

/// Registers machine `id` with `write_key`.
pub async fn machine(app: &axum::Router, write_key: &str, id: &str) {
    let body = serde_json::json!({"id": id, "name": id}).to_string();
    let req = request(
        "POST",
        "/api/v1/machines",
        "application/json",
        None,
        body.into_bytes(),
        Some(write_key),
    );
    let (s, b) = send(app, req).await;
    assert_eq!(s, StatusCode::CREATED, "{b}");
}

/// An identification of machine `machine` at `at` whose only term is EXX = c1·x (µm, x
/// in mm) with var(c1) = `var`, measured over x ∈ [−50, 50] mm (its document is not a
/// whole identification: no verdict reads it).
pub fn identification(machine: &str, at: &str, c1: f64, var: f64) -> NewResult {
    NewResult {
        check_model: None,
        machine_id: machine.into(),
        dataset_id: None,
        kind: "identification".into(),
        measured_at: at.into(),
        document: serde_json::json!({"kind": "identification"}),
        scalars: ResultScalars {
            term_coefficients: BTreeMap::from([("EXX".into(), vec![c1])]),
            term_covariance: BTreeMap::from([("EXX".into(), vec![vec![var]])]),
            measured_travel_mm: BTreeMap::from([("X".into(), [-50.0, 50.0])]),
            ..ResultScalars::default()
        },
        figures: vec![],
    }
}

/// The identification of a simulated machine with 6 µm of X backlash (seed plan, 10 Hz):
/// its rigid model does not explain the recording.
pub fn backlash_identification() -> mtcal_solver::identification::IdentificationResult {
    use mtcal_solver::identification::{IdentifyOptions, identify};
    use mtcal_solver::simulate::{Effect, Plan, SimOptions, random_truth, simulate};
    let sim = simulate(
        &random_truth(5),
        &SimOptions {
            plan: Plan::Seed,
            seed: 5,
            sample_rate_hz: 10.0,
            machine_id: "M1".into(),
            effects: vec![Effect::Backlash {
                axis: mtcal_solver::Axis::X,
                lost_motion_um: 6.0,
            }],
            ..Default::default()
        },
    )
    .unwrap();
    identify(&sim.session, &IdentifyOptions::default()).unwrap()
}

/// Runs `story` on the URL of a fresh PostgreSQL schema named after `test`, dropped
/// after it, when `MTCAL_TEST_PG` names a server (else skipped).
pub async fn on_postgres<F: std::future::Future<Output = ()>>(
    test: &str,
    story: impl FnOnce(String) -> F,
) {
    let Some(pg) = mtcal_store::testing::ScratchPg::create(test).await.unwrap() else {
        eprintln!("MTCAL_TEST_PG not set: skipped");
        return;
    };
    story(pg.url.clone()).await;
    pg.drop_schema().await.unwrap();
}
