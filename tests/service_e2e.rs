//! End-to-end tests of the service: a real `mtcal serve` process on a temporary SQLite
//! file, driven over HTTP. Sessions come from `mtcal demo --write-session` (known
//! polynomial errors simulated by `mtcal_solver::simulate`, full plan, noise σ = 0.1 µm).

use mtcal_store::{RowCounts, SqliteStore, Store};
use reqwest::StatusCode;
use serde_json::{Value, json};
use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

const BIN: &str = env!("CARGO_BIN_EXE_mtcal");

/// A running `mtcal serve`; killed (SIGKILL) on drop.
struct Server {
    child: Child,
    url: String,
}

impl Server {
    fn start(db: &Path, extra: &[&str]) -> Server {
        let mut child = Command::new(BIN)
            .args([
                "serve",
                "--db",
                db.to_str().unwrap(),
                "--listen",
                "127.0.0.1:0",
            ])
            .args(extra)
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .spawn()
            .expect("mtcal serve starts");
        let mut line = String::new();
        BufReader::new(child.stdout.take().unwrap())
            .read_line(&mut line)
            .unwrap();
        let url = line
            .split_whitespace()
            .find(|w| w.starts_with("http://"))
            .unwrap_or_else(|| panic!("no URL in {line:?}"))
            .to_string();
        Server { child, url }
    }

    /// SIGKILL: no graceful stop.
    fn kill(mut self) {
        self.child.kill().unwrap();
        self.child.wait().unwrap();
    }
}

impl Drop for Server {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

fn mtcal(args: &[&str]) -> String {
    let out = Command::new(BIN).args(args).output().unwrap();
    assert!(
        out.status.success(),
        "mtcal {args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).unwrap()
}

fn create_key(db: &Path, scope: &str) -> String {
    mtcal(&[
        "admin",
        "create-key",
        "--db",
        db.to_str().unwrap(),
        "--scope",
        scope,
    ])
    .trim()
    .to_string()
}

fn write_session(dir: &Path, machine: &str, seed: u64, quarter: usize) {
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

async fn counts(db: &Path) -> RowCounts {
    SqliteStore::open(db.to_str().unwrap())
        .await
        .unwrap()
        .row_counts()
        .await
        .unwrap()
}

struct Api {
    http: reqwest::Client,
    url: String,
    key: String,
}

impl Api {
    fn new(s: &Server, key: &str) -> Api {
        Api {
            http: reqwest::Client::new(),
            url: s.url.clone(),
            key: key.into(),
        }
    }

    async fn send(&self, rb: reqwest::RequestBuilder) -> (StatusCode, Value) {
        let r = rb.bearer_auth(&self.key).send().await.unwrap();
        let status = r.status();
        (status, r.json().await.unwrap_or(Value::Null))
    }

    async fn get(&self, path: &str) -> (StatusCode, Value) {
        self.send(self.http.get(format!("{}{path}", self.url)))
            .await
    }

    async fn post(&self, path: &str, body: Value) -> (StatusCode, Value) {
        self.send(self.http.post(format!("{}{path}", self.url)).json(&body))
            .await
    }

    async fn machine(&self, id: &str) {
        let (s, b) = self
            .post(
                "/api/v1/machines",
                json!({"id": id, "name": id, "site": "test",
                   "travel_mm": {"X": [-100, 100], "Y": [-100, 100], "Z": [-100, 100]}}),
            )
            .await;
        assert_eq!(s, StatusCode::CREATED, "{b}");
    }

    async fn upload_dir(&self, machine: &str, dir: &Path) -> (StatusCode, Value) {
        let mut form = reqwest::multipart::Form::new();
        for e in std::fs::read_dir(dir).unwrap() {
            let p = e.unwrap().path();
            let name = p.file_name().unwrap().to_str().unwrap().to_string();
            form = form.part(
                "files",
                reqwest::multipart::Part::bytes(std::fs::read(&p).unwrap()).file_name(name),
            );
        }
        let url = format!("{}/api/v1/machines/{machine}/datasets", self.url);
        self.send(self.http.post(url).multipart(form)).await
    }

    async fn identify(&self, dataset: &Value) -> String {
        let (s, j) = self
            .post(
                "/api/v1/jobs",
                json!({"kind": "identify", "dataset_id": dataset["id"]}),
            )
            .await;
        assert_eq!(s, StatusCode::ACCEPTED, "{j}");
        j["id"].as_str().unwrap().to_string()
    }

    async fn wait(&self, job: &str, want: &str) -> Value {
        let start = Instant::now();
        loop {
            let (_, j) = self.get(&format!("/api/v1/jobs/{job}")).await;
            if j["state"] == want {
                return j;
            }
            assert!(
                !(j["state"] == "failed" || j["state"] == "cancelled") || want != "succeeded",
                "job ended {j}"
            );
            assert!(start.elapsed() < Duration::from_secs(60), "job still {j}");
            tokio::time::sleep(Duration::from_millis(50)).await;
        }
    }
}

/// Plane files of a session folder, sorted, and the folder's total size in bytes.
fn csv_files(dir: &Path) -> (Vec<String>, u64) {
    let mut names = Vec::new();
    let mut total = 0;
    for e in std::fs::read_dir(dir).unwrap() {
        let e = e.unwrap();
        total += e.metadata().unwrap().len();
        let n = e.file_name().to_string_lossy().into_owned();
        if n.ends_with(".csv") {
            names.push(n);
        }
    }
    names.sort();
    (names, total)
}

fn tmp() -> (tempfile::TempDir, PathBuf) {
    let d = tempfile::tempdir().unwrap();
    let db = d.path().join("svc.sqlite");
    (d, db)
}

#[tokio::test]
async fn upload_identify_gives_the_result_of_the_cli() {
    let (d, db) = tmp();
    let key = create_key(&db, "write");
    let server = Server::start(&db, &[]);
    let api = Api::new(&server, &key);
    api.machine("VMC-1").await;
    let dir = d.path().join("s");
    write_session(&dir, "VMC-1", 7, 0);

    let (s, ds) = api.upload_dir("VMC-1", &dir).await;
    assert_eq!(s, StatusCode::CREATED, "{ds}");
    let (csvs, _) = csv_files(&dir);
    assert_eq!(ds["files"].as_array().unwrap().len(), csvs.len() + 1);
    let job = api.identify(&ds).await;
    let done = api.wait(&job, "succeeded").await;
    assert_eq!(done["progress"], 1.0);
    assert_eq!(done["attempts"], 1);
    let (s, doc) = api.get(&format!("/api/v1/jobs/{job}/result")).await;
    assert_eq!(s, StatusCode::OK);

    // The CLI on the same folder gives the identical document (same reader, solver and
    // default options; documents are stored and returned with exact doubles).
    let cli: Value =
        serde_json::from_str(&mtcal(&["identify", dir.to_str().unwrap(), "--json"])).unwrap();
    assert_eq!(doc, cli);
    // Sanity of the result against the truth of the generator: residual at noise level
    // (σ = 0.1 µm per component; thousands of samples give the RMS within a few per cent).
    let rms = doc["fit"]["residual_rms_um"].as_f64().unwrap();
    assert!((0.08..0.13).contains(&rms), "residual {rms}");

    // Raw files come back unchanged, with their checksum.
    let first = &csvs[0];
    let raw = std::fs::read(dir.join(first)).unwrap();
    let r = api
        .http
        .get(format!(
            "{}/api/v1/datasets/{}/files/{first}",
            server.url,
            ds["id"].as_str().unwrap()
        ))
        .bearer_auth(&key)
        .send()
        .await
        .unwrap();
    let sum = r.headers()["x-checksum-sha256"]
        .to_str()
        .unwrap()
        .to_string();
    assert_eq!(r.bytes().await.unwrap().as_ref(), raw.as_slice());
    let meta = ds["files"]
        .as_array()
        .unwrap()
        .iter()
        .find(|f| f["name"] == first.as_str())
        .unwrap();
    assert_eq!(meta["sha256"], sum.as_str());

    // The same session as one .tar.gz (files inside a folder) gives the same samples.
    let mut tar = tar::Builder::new(flate2::write::GzEncoder::new(
        Vec::new(),
        flate2::Compression::fast(),
    ));
    tar.append_dir_all("session", &dir).unwrap();
    let gz = tar.into_inner().unwrap().finish().unwrap();
    let (s, ds2) = api
        .send(
            api.http
                .post(format!("{}/api/v1/machines/VMC-1/datasets", server.url))
                .header("content-type", "application/gzip")
                .body(gz),
        )
        .await;
    assert_eq!(s, StatusCode::CREATED, "{ds2}");
    assert_eq!(ds2["samples"], ds["samples"]);
    assert_eq!(
        ds2["sha256"], ds["sha256"],
        "same files, same manifest checksum"
    );
}

#[tokio::test]
async fn history_and_trends_return_what_was_stored() {
    let (d, db) = tmp();
    let key = create_key(&db, "write");
    let server = Server::start(&db, &["--concurrency", "2"]);
    let api = Api::new(&server, &key);
    for m in ["VMC-A", "VMC-B"] {
        api.machine(m).await;
    }
    // Upload out of time order: history must come back in measured_at order.
    let mut jobs = Vec::new();
    for (m, seed, q) in [
        ("VMC-A", 1, 2),
        ("VMC-A", 1, 0),
        ("VMC-A", 1, 1),
        ("VMC-B", 2, 0),
        ("VMC-B", 2, 1),
    ] {
        let dir = d.path().join(format!("{m}-{q}"));
        write_session(&dir, m, seed, q);
        let (s, ds) = api.upload_dir(m, &dir).await;
        assert_eq!(s, StatusCode::CREATED, "{ds}");
        jobs.push(api.identify(&ds).await);
    }
    for j in &jobs {
        api.wait(j, "succeeded").await;
    }
    let (_, hist) = api.get("/api/v1/machines/VMC-A/results").await;
    let hist = hist.as_array().unwrap();
    let times: Vec<&str> = hist
        .iter()
        .map(|r| r["measured_at"].as_str().unwrap())
        .collect();
    assert_eq!(
        times,
        [
            "2026-01-05T08:00:00Z",
            "2026-04-05T08:00:00Z",
            "2026-07-05T08:00:00Z"
        ]
    );
    let (_, latest) = api.get("/api/v1/machines/VMC-A/results/latest").await;
    assert_eq!(latest["meta"]["id"], hist[2]["id"]);

    // Stored documents, for the expected values.
    let mut docs = Vec::new();
    for r in hist {
        let (_, full) = api
            .get(&format!("/api/v1/results/{}", r["id"].as_str().unwrap()))
            .await;
        docs.push(
            serde_json::from_value::<mtcal_solver::identification::IdentificationResult>(
                full["document"].clone(),
            )
            .unwrap(),
        );
    }
    let (s, trend) = api
        .get("/api/v1/machines/VMC-A/trends/term?term=EXX&at=50,-50")
        .await;
    assert_eq!(s, StatusCode::OK, "{trend}");
    assert_eq!(trend["unit"], "um");
    for (p, doc) in trend["points"].as_array().unwrap().iter().zip(&docs) {
        for (k, q) in [50.0, -50.0].iter().enumerate() {
            let want = doc.term_value_at("EXX", *q).unwrap();
            let got = p["values"][k].as_f64().unwrap();
            assert!(
                (got - want).abs() <= 1e-12 * (1.0 + want.abs()),
                "{got} vs {want}"
            );
        }
    }
    let (_, summary) = api.get("/api/v1/machines/VMC-A/trends/summary").await;
    for (p, doc) in summary["points"].as_array().unwrap().iter().zip(&docs) {
        assert_eq!(p["ec0y_urad"].as_f64(), doc.squareness["EC0Y"].value_urad);
        assert_eq!(p["residual_rms_um"].as_f64(), Some(doc.fit.residual_rms_um));
    }
    // The generator drifts EC0Y by 3·rate µrad per quarter (rate ≥ 0.5): the identified
    // squareness follows within its uncertainty.
    let ec: Vec<f64> = docs
        .iter()
        .map(|d| d.squareness["EC0Y"].value_urad.unwrap())
        .collect();
    assert!(ec[1] > ec[0] + 1.0 && ec[2] > ec[1] + 1.0, "EC0Y {ec:?}");

    // Difference from the baseline (default: the first result).
    let (_, diff) = api.get("/api/v1/machines/VMC-A/results/diff").await;
    assert_eq!(diff["baseline"]["id"], hist[0]["id"]);
    assert_eq!(diff["against"]["id"], hist[2]["id"]);
    let dsq = diff["squareness"]["EC0Y"].as_f64().unwrap();
    assert!((dsq - (ec[2] - ec[0])).abs() < 1e-9);
    let exx = &diff["terms"]["EXX"];
    let i = exx["positions_mm"]
        .as_array()
        .unwrap()
        .iter()
        .position(|q| q == 50.0)
        .unwrap();
    let want =
        docs[2].term_value_at("EXX", 50.0).unwrap() - docs[0].term_value_at("EXX", 50.0).unwrap();
    assert!((exx["delta"][i].as_f64().unwrap() - want).abs() < 1e-9);

    // Fleet: both machines ranked, each with its own baseline and latest result.
    let (_, fleet) = api.get("/api/v1/fleet/drift?by=urad").await;
    let ms = fleet["machines"].as_array().unwrap();
    assert_eq!(ms.len(), 2);
    assert!(ms[0]["drift_urad"].as_f64() >= ms[1]["drift_urad"].as_f64());
    let a = ms.iter().find(|m| m["machine_id"] == "VMC-A").unwrap();
    assert_eq!(a["results"], 3);
    assert!(a["drift_urad"].as_f64().unwrap() >= (ec[2] - ec[0]).abs() - 1e-9);
}

#[tokio::test]
async fn worker_killed_mid_job_finishes_the_job_exactly_once_after_restart() {
    let (d, db) = tmp();
    let key = create_key(&db, "write");
    let dir = d.path().join("s");
    write_session(&dir, "VMC-K", 3, 0);
    let first = Server::start(
        &db,
        &["--pause-before-solve-ms", "60000", "--lease-ms", "600"],
    );
    let api = Api::new(&first, &key);
    api.machine("VMC-K").await;
    let (_, ds) = api.upload_dir("VMC-K", &dir).await;
    let job = api.identify(&ds).await;
    api.wait(&job, "running").await;
    first.kill();
    assert_eq!(counts(&db).await.results, 0);

    let second = Server::start(&db, &["--lease-ms", "600"]);
    let api = Api::new(&second, &key);
    let done = api.wait(&job, "succeeded").await;
    assert_eq!(done["attempts"], 2, "{done}");
    let c = counts(&db).await;
    assert_eq!((c.jobs, c.results), (1, 1));
    let (_, r) = api
        .get(&format!(
            "/api/v1/results/{}",
            done["result_id"].as_str().unwrap()
        ))
        .await;
    assert_eq!(r["meta"]["job_id"], job.as_str());
}

#[tokio::test]
async fn rejected_requests_get_documented_errors_and_store_nothing() {
    let (d, db) = tmp();
    let key = create_key(&db, "write");
    let read_key = create_key(&db, "read");
    let dir = d.path().join("s");
    write_session(&dir, "VMC-R", 4, 0);
    let (csvs, size) = csv_files(&dir);
    let limit = (size + 100_000).to_string();
    let server = Server::start(&db, &["--max-upload-bytes", &limit, "--no-worker"]);
    let api = Api::new(&server, &key);
    api.machine("VMC-R").await;
    let before = counts(&db).await;

    // Corrupt upload: a non-number in a required column (du_um of data line 10).
    let bad_file = &csvs[1];
    let p = dir.join(bad_file);
    let text = std::fs::read_to_string(&p).unwrap();
    let mut lines: Vec<String> = text.lines().map(String::from).collect();
    let header: Vec<&str> = lines[0].split(',').collect();
    let col = header.iter().position(|c| *c == "du_um").unwrap();
    let mut cells: Vec<String> = lines[10].split(',').map(String::from).collect();
    cells[col] = "abc".into();
    lines[10] = cells.join(",");
    std::fs::write(&p, lines.join("\n") + "\n").unwrap();
    let (s, e) = api.upload_dir("VMC-R", &dir).await;
    assert_eq!(s, StatusCode::UNPROCESSABLE_ENTITY, "{e}");
    assert_eq!(e["error"]["code"], "invalid_dataset");
    let msg = e["error"]["message"].as_str().unwrap();
    assert!(
        msg.contains(bad_file.as_str()) && msg.contains("11") && msg.contains("du_um"),
        "{msg}"
    );

    // Wrong key, no key, too weak a key.
    let bad = Api {
        key: "mtk_00000000000000000000000000000000".into(),
        ..Api::new(&server, &key)
    };
    let (s, e) = bad
        .post("/api/v1/machines", json!({"id": "X1", "name": "x"}))
        .await;
    assert_eq!(
        (s, e["error"]["code"].as_str()),
        (StatusCode::UNAUTHORIZED, Some("unauthorized"))
    );
    let r = reqwest::get(format!("{}/api/v1/machines", server.url))
        .await
        .unwrap();
    assert_eq!(r.status(), StatusCode::UNAUTHORIZED);
    let weak = Api::new(&server, &read_key);
    let (s, e) = weak
        .post("/api/v1/machines", json!({"id": "X2", "name": "x"}))
        .await;
    assert_eq!(
        (s, e["error"]["code"].as_str()),
        (StatusCode::FORBIDDEN, Some("forbidden"))
    );

    // Oversize bodies: an upload over the configured limit (the session's size + 100 kB,
    // sent with a 200 kB extra file), and JSON over the 1 MiB limit of other routes.
    write_session(&dir, "VMC-R", 4, 0);
    std::fs::write(dir.join("padding.csv"), vec![b'#'; 200_000]).unwrap();
    let (s, e) = api.upload_dir("VMC-R", &dir).await;
    assert_eq!(s, StatusCode::PAYLOAD_TOO_LARGE, "{e}");
    assert_eq!(e["error"]["code"], "payload_too_large");
    let big = json!({"id": "X3", "name": "x".repeat(2 << 20)});
    let (s, e) = api.post("/api/v1/machines", big).await;
    assert_eq!(
        (s, e["error"]["code"].as_str()),
        (StatusCode::PAYLOAD_TOO_LARGE, Some("payload_too_large"))
    );

    assert_eq!(
        counts(&db).await,
        before,
        "a rejected request changed the database"
    );

    // Health and the docs are open.
    assert_eq!(
        reqwest::get(format!("{}/health", server.url))
            .await
            .unwrap()
            .status(),
        StatusCode::OK
    );
    assert_eq!(
        reqwest::get(format!("{}/api-docs/openapi.json", server.url))
            .await
            .unwrap()
            .status(),
        StatusCode::OK
    );
}

#[tokio::test]
async fn queued_job_can_be_cancelled() {
    let (d, db) = tmp();
    let key = create_key(&db, "write");
    let server = Server::start(&db, &["--no-worker"]);
    let api = Api::new(&server, &key);
    api.machine("VMC-C").await;
    let dir = d.path().join("s");
    write_session(&dir, "VMC-C", 5, 0);
    let (_, ds) = api.upload_dir("VMC-C", &dir).await;
    let job = api.identify(&ds).await;
    let (s, j) = api
        .post(&format!("/api/v1/jobs/{job}/cancel"), json!({}))
        .await;
    assert_eq!(
        (s, j["state"].as_str()),
        (StatusCode::OK, Some("cancelled"))
    );
    let (s, e) = api.get(&format!("/api/v1/jobs/{job}/result")).await;
    assert_eq!(
        (s, e["error"]["code"].as_str()),
        (StatusCode::CONFLICT, Some("job_not_finished"))
    );
    let (s, e) = api
        .post(&format!("/api/v1/jobs/{job}/cancel"), json!({}))
        .await;
    assert_eq!(
        (s, e["error"]["code"].as_str()),
        (StatusCode::CONFLICT, Some("conflict"))
    );
}

#[tokio::test]
async fn sensitivity_job_gives_the_library_result() {
    let (_d, db) = tmp();
    let key = create_key(&db, "write");
    let server = Server::start(&db, &[]);
    let api = Api::new(&server, &key);
    api.machine("VMC-S").await;
    let params = json!({"machine": {"template": "vmc3"}});
    let (s, e) = api
        .post(
            "/api/v1/jobs",
            json!({"kind": "sensitivity", "params": params}),
        )
        .await;
    assert_eq!(
        (s, e["error"]["code"].as_str()),
        (StatusCode::BAD_REQUEST, Some("invalid_request"))
    );
    let (s, j) = api
        .post(
            "/api/v1/jobs",
            json!({"kind": "sensitivity", "machine_id": "VMC-S", "params": params}),
        )
        .await;
    assert_eq!(s, StatusCode::ACCEPTED, "{j}");
    let job = j["id"].as_str().unwrap().to_string();
    api.wait(&job, "succeeded").await;
    let (_, doc) = api.get(&format!("/api/v1/jobs/{job}/result")).await;
    let mut req: mtcal_solver::sensitivity::SensitivityRequest =
        serde_json::from_value(params).unwrap();
    req.machine_id = "VMC-S".into();
    let local = mtcal_solver::sensitivity::analyse(&req).unwrap();
    assert_eq!(doc, serde_json::to_value(&local).unwrap());
    // Not an identification: the machine's identification history stays empty.
    let (_, hist) = api.get("/api/v1/machines/VMC-S/results").await;
    assert_eq!(hist.as_array().unwrap().len(), 0);
}

/// A `diagnose` job on an uploaded session gives the library's diagnosis of the same
/// files, filed under the machine as kind `diagnosis`. The session (seed plan, 5 Hz,
/// σ = 0.15 µm) carries 4 µm of X backlash, far above the noise: the diagnosis must name
/// it.
#[tokio::test]
async fn diagnose_job_gives_the_library_diagnosis() {
    use mtcal_solver::simulate::{Effect, Plan, SimOptions, random_truth, simulate};
    let (d, db) = tmp();
    let key = create_key(&db, "write");
    let server = Server::start(&db, &[]);
    let api = Api::new(&server, &key);
    api.machine("VMC-D").await;
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
    let dir = d.path().join("s");
    mtcal_formats::write_session_dir(&dir, &sim.session).unwrap();
    let (s, ds) = api.upload_dir("VMC-D", &dir).await;
    assert_eq!(s, StatusCode::CREATED, "{ds}");
    let (s, e) = api
        .post(
            "/api/v1/jobs",
            json!({"kind": "diagnose", "dataset_id": ds["id"], "params": {"order": 2}}),
        )
        .await;
    assert_eq!(
        (s, e["error"]["code"].as_str()),
        (StatusCode::BAD_REQUEST, Some("invalid_request"))
    );
    let (s, j) = api
        .post(
            "/api/v1/jobs",
            json!({"kind": "diagnose", "dataset_id": ds["id"]}),
        )
        .await;
    assert_eq!(s, StatusCode::ACCEPTED, "{j}");
    let job = j["id"].as_str().unwrap().to_string();
    let done = api.wait(&job, "succeeded").await;
    let (_, doc) = api.get(&format!("/api/v1/jobs/{job}/result")).await;

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
    let (s, stored) = api
        .get(&format!(
            "/api/v1/results/{}",
            done["result_id"].as_str().unwrap()
        ))
        .await;
    assert_eq!(s, StatusCode::OK, "{stored}");
    assert_eq!(stored["meta"]["kind"], "diagnosis");
    assert_eq!(stored["meta"]["machine_id"], "VMC-D");
    assert_eq!(stored["document"], doc);
    assert_eq!(
        stored["meta"]["scalars"]["residual_rms_um"].as_f64(),
        Some(local.baseline.residual_rms_um)
    );
    // In the machine's history of that kind, not among its identifications.
    let (_, hist) = api
        .get("/api/v1/machines/VMC-D/results?kind=diagnosis")
        .await;
    assert_eq!(hist.as_array().unwrap().len(), 1, "{hist}");
    assert_eq!(hist[0]["id"], done["result_id"]);
    let (_, hist) = api.get("/api/v1/machines/VMC-D/results").await;
    assert_eq!(hist.as_array().unwrap().len(), 0, "{hist}");
    let (s, last) = api
        .get("/api/v1/machines/VMC-D/results/latest?kind=diagnosis")
        .await;
    assert_eq!(s, StatusCode::OK);
    assert_eq!(last["document"], doc);
}

/// A rotary point set (CSV + sidecar) is stored as kind `rotary_points` with its raw bytes,
/// and a `cradle` job gives the library's check of the same files, filed as kind `cradle`.
/// Wrong pairings of job and dataset kind are refused at submission.
#[tokio::test]
async fn cradle_job_on_an_uploaded_point_set_gives_the_library_result() {
    use mtcal_solver::cradle::simulate::{CradleSimulation, simulate_cradle};
    let (d, db) = tmp();
    let key = create_key(&db, "write");
    let server = Server::start(&db, &[]);
    let api = Api::new(&server, &key);
    api.machine("VMC-C").await;
    let mut set = simulate_cradle(&CradleSimulation::example(false, 1));
    set.machine_id = Some("VMC-C".into());
    set.measured_at = Some("2026-11-02T08:30:00Z".into());
    let dir = d.path().join("c");
    std::fs::create_dir(&dir).unwrap();
    let mut csv = Vec::new();
    mtcal_formats::write_rotary_points(&mut csv, &set).unwrap();
    std::fs::write(dir.join("cradle.csv"), &csv).unwrap();
    let mut side = Vec::new();
    mtcal_formats::write_rotary_sidecar(&mut side, &set).unwrap();
    std::fs::write(dir.join("cradle.json"), &side).unwrap();

    let (s, ds) = api.upload_dir("VMC-C", &dir).await;
    assert_eq!(s, StatusCode::CREATED, "{ds}");
    assert_eq!(ds["kind"], "rotary_points");
    assert_eq!(ds["samples"], set.points.len());
    assert_eq!(ds["measured_at"], "2026-11-02T08:30:00Z");
    let r = api
        .http
        .get(format!(
            "{}/api/v1/datasets/{}/files/cradle.csv",
            server.url,
            ds["id"].as_str().unwrap()
        ))
        .bearer_auth(&key)
        .send()
        .await
        .unwrap();
    assert_eq!(r.bytes().await.unwrap().as_ref(), csv.as_slice());

    for kind in ["identify", "diagnose"] {
        let (s, e) = api
            .post(
                "/api/v1/jobs",
                json!({"kind": kind, "dataset_id": ds["id"]}),
            )
            .await;
        assert_eq!(
            (s, e["error"]["code"].as_str()),
            (StatusCode::BAD_REQUEST, Some("invalid_request")),
            "{kind}"
        );
    }
    let (s, j) = api
        .post(
            "/api/v1/jobs",
            json!({"kind": "cradle", "dataset_id": ds["id"]}),
        )
        .await;
    assert_eq!(s, StatusCode::ACCEPTED, "{j}");
    let job = j["id"].as_str().unwrap().to_string();
    let done = api.wait(&job, "succeeded").await;
    let (_, doc) = api.get(&format!("/api/v1/jobs/{job}/result")).await;
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
    let (_, stored) = api
        .get(&format!(
            "/api/v1/results/{}",
            done["result_id"].as_str().unwrap()
        ))
        .await;
    assert_eq!(stored["meta"]["kind"], "cradle");
    assert_eq!(stored["meta"]["machine_id"], "VMC-C");
}

/// Positioning runs and drift logs upload as their kinds and are diagnosed by the series
/// diagnosis; a broken CSV is refused with the reader's file:line:column and nothing is
/// stored.
#[tokio::test]
async fn series_datasets_upload_and_diagnose_bad_ones_store_nothing() {
    let (d, db) = tmp();
    let key = create_key(&db, "write");
    let server = Server::start(&db, &[]);
    let api = Api::new(&server, &key);
    api.machine("VMC-P").await;
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
    let dir = d.path().join("p");
    std::fs::create_dir(&dir).unwrap();
    std::fs::write(dir.join("pos.csv"), &text).unwrap();
    let (s, ds) = api.upload_dir("VMC-P", &dir).await;
    assert_eq!(s, StatusCode::CREATED, "{ds}");
    assert_eq!(ds["kind"], "positioning");
    assert_eq!(ds["samples"], 110);
    let (s, j) = api
        .post(
            "/api/v1/jobs",
            json!({"kind": "diagnose", "dataset_id": ds["id"]}),
        )
        .await;
    assert_eq!(s, StatusCode::ACCEPTED, "{j}");
    let job = j["id"].as_str().unwrap().to_string();
    api.wait(&job, "succeeded").await;
    let (_, doc) = api.get(&format!("/api/v1/jobs/{job}/result")).await;
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
    let dir = d.path().join("dl");
    std::fs::create_dir(&dir).unwrap();
    std::fs::write(dir.join("drift.csv"), &log).unwrap();
    let (s, ds) = api.upload_dir("VMC-P", &dir).await;
    assert_eq!(s, StatusCode::CREATED, "{ds}");
    assert_eq!(ds["kind"], "drift_log");
    assert_eq!(ds["samples"], 61);
    // fit_fraction (drift logs): out of range refused at submission; 0.5 gives the
    // library's diagnosis fitted on the first half.
    let (s, e) = api
        .post(
            "/api/v1/jobs",
            json!({"kind": "diagnose", "dataset_id": ds["id"], "params": {"fit_fraction": 0.95}}),
        )
        .await;
    assert_eq!(s, StatusCode::BAD_REQUEST, "{e}");
    let (s, j) = api
        .post(
            "/api/v1/jobs",
            json!({"kind": "diagnose", "dataset_id": ds["id"], "params": {"fit_fraction": 0.5}}),
        )
        .await;
    assert_eq!(s, StatusCode::ACCEPTED, "{j}");
    let job = j["id"].as_str().unwrap().to_string();
    api.wait(&job, "succeeded").await;
    let (_, doc) = api.get(&format!("/api/v1/jobs/{job}/result")).await;
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
    let before = counts(&db).await;
    let bad = text.replacen("X,1,+,10,", "X,1,+,10,abc", 1);
    let dir = d.path().join("bad");
    std::fs::create_dir(&dir).unwrap();
    std::fs::write(dir.join("bad.csv"), &bad).unwrap();
    let (s, e) = api.upload_dir("VMC-P", &dir).await;
    assert_eq!(s, StatusCode::UNPROCESSABLE_ENTITY, "{e}");
    assert_eq!(e["error"]["code"], "invalid_dataset");
    let msg = e["error"]["message"].as_str().unwrap();
    assert!(msg.starts_with("bad.csv:3:"), "{msg}");
    assert_eq!(counts(&db).await, before);
}
