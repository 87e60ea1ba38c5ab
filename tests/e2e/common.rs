//! The one harness of the end-to-end tests: an in-process service on a fresh SQLite file.

#![allow(dead_code)]

use mtcal_client::{Client, ClientError};
use mtcal_server::api::jobs::SubmitJob;
use mtcal_server::api::machines::NewMachine;
use mtcal_server::jobs::JobKind;
use mtcal_server::{UploadLimits, WorkerConfig};
use mtcal_store::{Job, JobState, QueueConfig, RowCounts, Scope, Store};
use reqwest::StatusCode;
use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::Arc;
use std::time::Duration;

pub const BIN: &str = env!("CARGO_BIN_EXE_mtcal");

/// A service running in this test, with a key of each scope.
pub struct App {
    /// Client with a write key.
    pub client: Client,
    pub read_key: String,
    pub write_key: String,
    pub admin_key: String,
    pub url: String,
    pub store: Arc<dyn Store>,
    /// The database file.
    pub db: PathBuf,
    /// A folder for the test's files (removed at the end with the database).
    pub dir: tempfile::TempDir,
}

/// How to start the service.
#[derive(Debug, Clone)]
pub struct AppOptions {
    pub run_worker: bool,
    pub concurrency: usize,
    /// The readers' limits, of uploads and of the worker's reads (the service's
    /// configuration: `WorkerConfig::limits`).
    pub limits: UploadLimits,
    /// The service's settings (cookies, webhooks).
    pub settings: mtcal_server::Settings,
    /// The database: a URL the store opens (a PostgreSQL schema of its own); `None`, a
    /// fresh SQLite file.
    pub db_url: Option<String>,
}

impl Default for AppOptions {
    fn default() -> Self {
        AppOptions {
            run_worker: true,
            concurrency: 2,
            limits: UploadLimits::default(),
            settings: mtcal_server::Settings::default(),
            db_url: None,
        }
    }
}

/// Runs `scenario` with the service on a PostgreSQL schema of its own (default options
/// otherwise), then drops the schema; skipped, saying so, when `MTCAL_TEST_PG` names no
/// server (`scripts/with-postgres` starts one).
pub async fn on_postgres<F, Fut>(test: &str, scenario: F)
where
    F: FnOnce(AppOptions) -> Fut,
    Fut: std::future::Future<Output = ()>,
{
    let Some(pg) = mtcal_store::testing::ScratchPg::create(test).await.unwrap() else {
        return;
    };
    scenario(AppOptions {
        db_url: Some(pg.url.clone()),
        ..AppOptions::default()
    })
    .await;
    pg.drop_schema().await.unwrap();
}

/// The service with default options (worker on).
pub async fn spawn_app() -> App {
    spawn_app_with(AppOptions::default()).await
}

pub async fn spawn_app_with(o: AppOptions) -> App {
    let dir = tempfile::tempdir().unwrap();
    let db = dir.path().join("svc.sqlite");
    let url = o
        .db_url
        .clone()
        .unwrap_or_else(|| db.to_str().unwrap().into());
    let store = mtcal_store::open(&url).await.unwrap();
    let key = |scope| {
        let store = store.clone();
        async move { store.create_key(scope, "e2e").await.unwrap().1 }
    };
    let (read_key, write_key, admin_key) = (
        key(Scope::Read).await,
        key(Scope::Write).await,
        key(Scope::Admin).await,
    );
    let worker = WorkerConfig {
        queue: QueueConfig {
            concurrency: o.concurrency,
            ..QueueConfig::default()
        },
        limits: o.limits,
        settings: o.settings,
        ..WorkerConfig::default()
    };
    let addr = mtcal_server::spawn_local(store.clone(), &worker, o.run_worker)
        .await
        .unwrap();
    let url = format!("http://{addr}");
    App {
        client: Client::new(&url, &write_key),
        read_key,
        write_key,
        admin_key,
        url,
        store,
        db,
        dir,
    }
}

impl App {
    /// A client of this service with `key`.
    pub fn with_key(&self, key: &str) -> Client {
        self.client.with_key(key)
    }

    pub async fn counts(&self) -> RowCounts {
        self.store.row_counts().await.unwrap()
    }

    /// A path inside the test's folder.
    pub fn path(&self, name: &str) -> PathBuf {
        self.dir.path().join(name)
    }

    /// Registers machine `id` with ±100 mm of travel on every axis.
    pub async fn machine(&self, id: &str) {
        register(&self.client, id).await;
    }

    /// Submits an `identify` job on a dataset; returns the job id.
    pub async fn identify(&self, dataset_id: &str) -> String {
        submit(&self.client, JobKind::Identify, Some(dataset_id), None)
            .await
            .id
    }

    /// Waits for a job to reach `want` (failing at once if it ends otherwise).
    pub async fn wait(&self, job: &str, want: JobState) -> Job {
        wait(&self.client, job, want).await
    }
}

pub async fn register(c: &Client, id: &str) {
    let travel = [-100.0, 100.0];
    c.create_machine(&NewMachine {
        id: id.into(),
        name: id.into(),
        topology: None,
        travel_mm: ["X", "Y", "Z"].map(|a| (a.to_string(), travel)).into(),
        site: Some("test".into()),
        tags: vec![],
    })
    .await
    .unwrap();
}

pub fn job(kind: JobKind, dataset_id: Option<&str>, machine_id: Option<&str>) -> SubmitJob {
    SubmitJob {
        kind,
        dataset_id: dataset_id.map(String::from),
        machine_id: machine_id.map(String::from),
        params: serde_json::json!({}),
    }
}

pub async fn submit(
    c: &Client,
    kind: JobKind,
    dataset_id: Option<&str>,
    machine_id: Option<&str>,
) -> Job {
    c.submit(&job(kind, dataset_id, machine_id)).await.unwrap()
}

/// Waits (up to 60 s) for a job to reach `want`; a job that ends in another state fails
/// the test with its error.
pub async fn wait(c: &Client, job: &str, want: JobState) -> Job {
    let start = std::time::Instant::now();
    loop {
        let j = c.job(job).await.unwrap();
        if j.state == want {
            return j;
        }
        assert!(
            !j.state.is_terminal(),
            "job {job} ended {j:?}, not {want:?}"
        );
        assert!(start.elapsed() < Duration::from_secs(60), "job still {j:?}");
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
}

/// The status and code of a refused call (panics on success).
#[track_caller]
pub fn refused<T: std::fmt::Debug>(r: Result<T, ClientError>) -> (StatusCode, String) {
    match r {
        Err(ClientError::Api { status, code, .. }) => (status, code),
        other => panic!("expected a refusal, got {other:?}"),
    }
}

/// The message of a refused call.
#[track_caller]
pub fn refusal_message<T: std::fmt::Debug>(r: Result<T, ClientError>) -> String {
    match r {
        Err(ClientError::Api { message, .. }) => message,
        other => panic!("expected a refusal, got {other:?}"),
    }
}

/// Runs the `mtcal` binary; its stdout (the command must succeed).
pub fn mtcal(args: &[&str]) -> String {
    let out = Command::new(BIN).args(args).output().unwrap();
    assert!(
        out.status.success(),
        "mtcal {args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).unwrap()
}

/// Writes the demo session of machine `machine` (drift seed `seed`, check `quarter`).
pub fn write_session(dir: &Path, machine: &str, seed: u64, quarter: usize) {
    mtcal(&[
        "demo",
        "--write-session",
        dir.to_str().unwrap(),
        "--machine",
        machine,
        "--seed",
        &seed.to_string(),
        "--quarter",
        &quarter.to_string(),
    ]);
}

/// Sets the cell of column `column` on line `line` (the header is line 1) of a plane file
/// of session folder `dir` to `value`; returns the file's path.
pub fn set_plane_cell(dir: &Path, column: &str, line: usize, value: &str) -> PathBuf {
    let csv = dir.join(&csv_names(dir)[0]);
    let text = std::fs::read_to_string(&csv).unwrap();
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    let header: Vec<&str> = lines[0].split(',').collect();
    let col = header.iter().position(|c| *c == column).unwrap();
    let mut cells: Vec<String> = lines[line - 1].split(',').map(str::to_string).collect();
    cells[col] = value.into();
    lines[line - 1] = cells.join(",");
    std::fs::write(&csv, lines.join("\n") + "\n").unwrap();
    csv
}

/// Every file of a folder (name, bytes), sorted by name.
pub fn folder_files(dir: &Path) -> Vec<(String, Vec<u8>)> {
    let mut files: Vec<(String, Vec<u8>)> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| {
            let p = e.unwrap().path();
            (
                p.file_name().unwrap().to_string_lossy().into_owned(),
                std::fs::read(&p).unwrap(),
            )
        })
        .collect();
    files.sort();
    files
}

/// The plane files (`.csv`) of a session folder, sorted.
pub fn csv_names(dir: &Path) -> Vec<String> {
    folder_files(dir)
        .into_iter()
        .map(|(n, _)| n)
        .filter(|n| n.ends_with(".csv"))
        .collect()
}

/// A JSON value as a typed one (documents of results).
pub fn typed<T: serde::de::DeserializeOwned>(v: &Value) -> T {
    serde_json::from_value(v.clone()).unwrap()
}

/// Writes the simulated cradle point set of machine `machine` (example 1, measured
/// 2026-11-02T08:30:00Z) to `dir` as `cradle.csv` and its sidecar `cradle.json`; returns
/// the set and both files' bytes.
pub fn write_cradle_set(
    dir: &Path,
    machine: &str,
) -> (mtcal_solver::datasets::RotaryPointSet, Vec<u8>, Vec<u8>) {
    use mtcal_solver::cradle::simulate::{CradleSimulation, simulate_cradle};
    let mut set = simulate_cradle(&CradleSimulation::example(false, 1));
    set.machine_id = Some(machine.into());
    set.measured_at = Some("2026-11-02T08:30:00Z".into());
    std::fs::create_dir_all(dir).unwrap();
    let mut csv = Vec::new();
    mtcal_formats::write_rotary_points(&mut csv, &set).unwrap();
    std::fs::write(dir.join("cradle.csv"), &csv).unwrap();
    let mut side = Vec::new();
    mtcal_formats::write_rotary_sidecar(&mut side, &set).unwrap();
    std::fs::write(dir.join("cradle.json"), &side).unwrap();
    (set, csv, side)
}

/// A browser of the dashboard without a script: its session cookie and the CSRF token of
/// its pages, over plain HTTP (redirects are not followed, so that each answer is seen).
pub struct Browser {
    pub http: reqwest::Client,
    pub base: String,
    /// `mtcal_session=…`, as the browser sends it back.
    pub cookie: String,
    /// The `Set-Cookie` header that started the session, as the service sent it.
    pub set_cookie: String,
    /// The session's CSRF token, read from a page's form.
    pub csrf: String,
}

/// The value of the first `name="csrf"` field of a page.
pub fn csrf_of(html: &str) -> String {
    let at = html
        .find(r#"name="csrf" value=""#)
        .expect("a form with a CSRF token")
        + 19;
    html[at..at + html[at..].find('"').unwrap()].to_string()
}

/// The `name=value` pair of the `Set-Cookie` header of `r` that sets cookie `name`, and
/// the whole header.
pub fn set_cookie(r: &reqwest::Response, name: &str) -> (String, String) {
    let header = r
        .headers()
        .get_all(reqwest::header::SET_COOKIE)
        .iter()
        .map(|v| v.to_str().unwrap().to_string())
        .find(|v| v.starts_with(&format!("{name}=")))
        .unwrap_or_else(|| panic!("no cookie {name} set"));
    (header.split(';').next().unwrap().to_string(), header)
}

impl App {
    /// Sends the sign-in form with `key` from a browser of its own (`http`, which follows
    /// no redirect); the answer.
    pub async fn post_sign_in(&self, http: &reqwest::Client, key: &str) -> reqwest::Response {
        let r = http
            .get(format!("{}/signin", self.url))
            .send()
            .await
            .unwrap();
        let (pre, _) = set_cookie(&r, "mtcal_signin");
        let token = csrf_of(&r.text().await.unwrap());
        http.post(format!("{}/signin", self.url))
            .header(reqwest::header::COOKIE, pre)
            .form(&[("csrf", token.as_str()), ("key", key), ("next", "/")])
            .send()
            .await
            .unwrap()
    }

    /// Signs a browser in with `key` through the sign-in form.
    pub async fn sign_in(&self, key: &str) -> Browser {
        let http = reqwest::Client::builder()
            .redirect(reqwest::redirect::Policy::none())
            .build()
            .unwrap();
        let r = self.post_sign_in(&http, key).await;
        assert_eq!(r.status(), StatusCode::SEE_OTHER, "signed in");
        let (cookie, set_cookie) = set_cookie(&r, "mtcal_session");
        let mut b = Browser {
            http,
            base: self.url.clone(),
            cookie,
            set_cookie,
            csrf: String::new(),
        };
        let page = b.get("/alerts").await;
        assert_eq!(page.status(), StatusCode::OK);
        b.csrf = csrf_of(&page.text().await.unwrap());
        b
    }
}

impl Browser {
    pub async fn get(&self, path: &str) -> reqwest::Response {
        self.http
            .get(format!("{}{path}", self.base))
            .header(reqwest::header::COOKIE, &self.cookie)
            .send()
            .await
            .unwrap()
    }

    /// Posts a form (`application/x-www-form-urlencoded`).
    pub async fn post(&self, path: &str, fields: &[(&str, &str)]) -> reqwest::Response {
        self.http
            .post(format!("{}{path}", self.base))
            .header(reqwest::header::COOKIE, &self.cookie)
            .form(fields)
            .send()
            .await
            .unwrap()
    }

    /// Posts a multipart form.
    pub async fn post_multipart(
        &self,
        path: &str,
        form: reqwest::multipart::Form,
    ) -> reqwest::Response {
        self.http
            .post(format!("{}{path}", self.base))
            .header(reqwest::header::COOKIE, &self.cookie)
            .multipart(form)
            .send()
            .await
            .unwrap()
    }
}

/// A check of `machine` at `at` of kind `kind`; an identification's only term is
/// EXX = c1·x (µm, x in mm, var(c1) = 1e-6) measured over x ∈ [−50, 50] mm.
pub fn check(machine: &str, kind: &str, at: &str, c1: f64) -> mtcal_store::NewResult {
    mtcal_store::NewResult {
        check_model: None,
        machine_id: machine.into(),
        dataset_id: None,
        kind: kind.into(),
        measured_at: at.into(),
        document: serde_json::json!({ "kind": kind }),
        scalars: mtcal_store::ResultScalars {
            term_coefficients: std::collections::BTreeMap::from([("EXX".into(), vec![c1])]),
            term_covariance: std::collections::BTreeMap::from([("EXX".into(), vec![vec![1e-6]])]),
            measured_travel_mm: std::collections::BTreeMap::from([("X".into(), [-50.0, 50.0])]),
            ..mtcal_store::ResultScalars::default()
        },
        figures: vec![],
    }
}

/// An active drift alert of `machine` raised by its result `result_id`.
pub fn alert(id: &str, machine: &str, result_id: &str) -> mtcal_store::Alert {
    mtcal_store::Alert {
        raised: mtcal_store::AlertRaised {
            id: id.into(),
            machine_id: machine.into(),
            result_id: result_id.into(),
            baseline_result_id: result_id.into(),
            profile_id: "p".into(),
            raised_at: "2026-04-06T09:00:00Z".into(),
            message: format!("{machine} drifted"),
        },
        items: serde_json::json!([]),
        details: None,
        acknowledged_at: None,
        acknowledged_by: None,
        acknowledgement_comment: None,
    }
}
