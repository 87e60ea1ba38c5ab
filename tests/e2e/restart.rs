//! Real processes sharing one database: a worker killed (SIGKILL) mid-job, whose job is
//! finished exactly once by the next process; an API process without a worker
//! (`serve --no-worker`) whose jobs a separate `mtcal worker` process runs; a worker
//! stopped with SIGTERM that hands its job back, claimed at once by the next worker; and
//! on PostgreSQL, one API process and three worker processes that run 200 jobs exactly
//! once each, around a worker stopped by SIGTERM and one killed by SIGKILL; a webhook
//! delivery waiting out its backoff when its worker is killed (SIGKILL), made once by the
//! restarted worker, signed, on SQLite and on PostgreSQL.

use crate::common::*;
use mtcal_client::Client;
use mtcal_store::prelude::*;
use mtcal_store::{JobState, SqliteStore};
use std::io::{BufRead, BufReader};
use std::process::{Child, Command, Stdio};

/// A running `mtcal serve`; killed (SIGKILL) on drop.
struct Server {
    child: Child,
    url: String,
}

impl Server {
    fn start(db: impl AsRef<std::ffi::OsStr>, extra: &[&str]) -> Server {
        let mut child = Command::new(BIN)
            .args(["serve", "--listen", "127.0.0.1:0", "--db"])
            .arg(db)
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

/// A folder with the SQLite file `svc.sqlite` the processes share, its store and a
/// write key.
async fn shared_db() -> (tempfile::TempDir, SqliteStore, String) {
    let dir = tempfile::tempdir().unwrap();
    let db = dir.path().join("svc.sqlite");
    let store = SqliteStore::open(db.to_str().unwrap()).await.unwrap();
    let (_, key) = store
        .create_key(mtcal_store::Scope::Write, "e2e")
        .await
        .unwrap();
    (dir, store, key)
}

#[tokio::test]
async fn worker_killed_mid_job_finishes_the_job_exactly_once_after_restart() {
    let (dir, store, key) = shared_db().await;
    let (db, session) = (dir.path().join("svc.sqlite"), dir.path().join("s"));
    write_session(&session, "VMC-K", 3, 0);
    let first = Server::start(
        &db,
        &["--pause-before-solve-ms", "60000", "--lease-ms", "600"],
    );
    let c = Client::new(&first.url, &key);
    register(&c, "VMC-K").await;
    let ds = c.upload_path("VMC-K", &session).await.unwrap();
    let job = submit(
        &c,
        mtcal_server::jobs::JobKind::Identify,
        Some(&ds.id),
        None,
    )
    .await
    .id;
    wait(&c, &job, JobState::Running).await;
    first.kill();
    assert_eq!(store.row_counts().await.unwrap().results, 0);

    let second = Server::start(&db, &["--lease-ms", "600"]);
    let c = Client::new(&second.url, &key);
    let done = wait(&c, &job, JobState::Succeeded).await;
    assert_eq!(done.attempts, 2, "{done:?}");
    let counts = store.row_counts().await.unwrap();
    assert_eq!((counts.jobs, counts.results), (1, 1));
    let r = c.result(&done.result_id.unwrap()).await.unwrap();
    assert_eq!(r.meta.job_id, job);
}

/// A running `mtcal worker` and the URL of its metrics (with `--metrics-listen`).
struct Worker(Child, Option<String>);

/// Sends SIGTERM to `child` and waits (at most 20 s) for it to exit; its exit status.
fn terminate(child: &mut Child) -> std::process::ExitStatus {
    let pid = child.id().to_string();
    assert!(
        Command::new("kill")
            .args(["-TERM", &pid])
            .status()
            .unwrap()
            .success()
    );
    let t0 = std::time::Instant::now();
    loop {
        if let Some(status) = child.try_wait().unwrap() {
            return status;
        }
        assert!(
            t0.elapsed() < std::time::Duration::from_secs(20),
            "no exit 20 s after SIGTERM"
        );
        std::thread::sleep(std::time::Duration::from_millis(50));
    }
}

impl Worker {
    fn start(db: impl AsRef<std::ffi::OsStr>, extra: &[&str]) -> Worker {
        let mut child = Command::new(BIN)
            .args(["worker", "--db"])
            .arg(db)
            .args(extra)
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .spawn()
            .expect("mtcal worker starts");
        let mut out = BufReader::new(child.stdout.take().unwrap());
        let mut metrics = None;
        loop {
            let mut line = String::new();
            assert!(out.read_line(&mut line).unwrap() > 0, "worker exited");
            if line.contains("metrics on") {
                metrics = line
                    .split_whitespace()
                    .find(|w| w.starts_with("http://"))
                    .map(str::to_string);
            }
            if line.contains("worker(s) on") {
                break;
            }
        }
        Worker(child, metrics)
    }
}

impl Drop for Worker {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

#[tokio::test]
async fn an_api_without_worker_and_a_separate_worker_process_share_the_queue() {
    let (dir, store, key) = shared_db().await;
    let (db, session) = (dir.path().join("svc.sqlite"), dir.path().join("s"));
    write_session(&session, "VMC-W", 2, 0);
    let api = Server::start(&db, &["--no-worker"]);
    let c = Client::new(&api.url, &key);
    register(&c, "VMC-W").await;
    let ds = c.upload_path("VMC-W", &session).await.unwrap();
    let kind = mtcal_server::jobs::JobKind::Identify;
    let job = submit(&c, kind, Some(&ds.id), None).await.id;
    // No worker anywhere: the job stays queued.
    tokio::time::sleep(std::time::Duration::from_millis(1500)).await;
    assert_eq!(c.job(&job).await.unwrap().state, JobState::Queued);
    let _worker = Worker::start(&db, &[]);
    let done = wait(&c, &job, JobState::Succeeded).await;
    assert_eq!(done.attempts, 1, "{done:?}");
    assert_eq!(store.row_counts().await.unwrap().results, 1);
}

#[tokio::test]
async fn a_worker_stopped_by_sigterm_hands_its_job_back_and_the_next_worker_claims_it_at_once() {
    let (dir, store, key) = shared_db().await;
    let (db, session) = (dir.path().join("svc.sqlite"), dir.path().join("s"));
    write_session(&session, "VMC-T", 4, 0);
    let mut api = Server::start(&db, &["--no-worker"]);
    let c = Client::new(&api.url, &key);
    register(&c, "VMC-T").await;
    let ds = c.upload_path("VMC-T", &session).await.unwrap();
    let kind = mtcal_server::jobs::JobKind::Identify;
    let job = submit(&c, kind, Some(&ds.id), None).await.id;
    // A lease of 10 minutes: if the job were not handed back, nobody could take it over
    // within the test's wait.
    let mut first = Worker::start(
        &db,
        &[
            "--pause-before-solve-ms",
            "60000",
            "--lease-ms",
            "600000",
            "--grace-seconds",
            "1",
        ],
    );
    wait(&c, &job, JobState::Running).await;
    let status = terminate(&mut first.0);
    assert!(status.success(), "worker exit after SIGTERM: {status}");
    let back = c.job(&job).await.unwrap();
    assert_eq!(
        (back.state, back.attempts),
        (JobState::Queued, 0),
        "{back:?}"
    );
    let token = "worker-metrics-token-0123456789";
    let second = Worker::start(
        &db,
        &["--metrics-listen", "127.0.0.1:0", "--metrics-token", token],
    );
    let done = wait(&c, &job, JobState::Succeeded).await;
    assert_eq!(done.attempts, 1, "{done:?}");
    assert_eq!(store.row_counts().await.unwrap().results, 1);
    // The worker process serves its own metrics: the job it ran, and the queue's gauges.
    // (The worker records the job's duration just after the job's outcome is stored,
    // which is what the wait above sees: read until it is there.)
    let wanted = [
        r#"mtcal_job_duration_seconds_count{kind="identify",outcome="succeeded"} 1"#,
        r#"mtcal_jobs{kind="identify",state="succeeded"} 1"#,
    ];
    let mut metrics = String::new();
    for _ in 0..100 {
        metrics = reqwest::Client::new()
            .get(second.1.clone().expect("metrics URL"))
            .bearer_auth(token)
            .send()
            .await
            .unwrap()
            .text()
            .await
            .unwrap();
        if wanted.iter().all(|w| metrics.contains(w)) {
            break;
        }
        tokio::time::sleep(std::time::Duration::from_millis(200)).await;
    }
    for w in wanted {
        assert!(metrics.contains(w), "{w} not in {metrics}");
    }
    // Without the token (or an admin key of the whole group): 401, no metrics.
    let bare = reqwest::get(second.1.clone().unwrap()).await.unwrap();
    assert_eq!(bare.status(), 401);
    // The API process also stops cleanly on SIGTERM.
    let status = terminate(&mut api.child);
    assert!(status.success(), "serve exit after SIGTERM: {status}");
}

/// On PostgreSQL: one API process (`serve --no-worker`) and worker processes on other
/// "hosts" (processes) sharing the database. A worker stopped by SIGTERM hands its job
/// back (the next worker claims it at once, though its lease was 10 minutes); a worker
/// killed by SIGKILL mid-job loses its lease and the job runs again elsewhere; then three
/// workers drain 200 more jobs. Every job finishes exactly once, with one result each.
#[tokio::test]
async fn on_postgres_three_workers_run_200_jobs_exactly_once_around_sigterm_and_sigkill() {
    use mtcal_store::testing::ScratchPg;
    let Some(pg) = ScratchPg::create("e2e::restart::on_postgres")
        .await
        .unwrap()
    else {
        return;
    };
    let store = mtcal_store::PostgresStore::open(&pg.url).await.unwrap();
    let (_, key) = store
        .create_key(mtcal_store::Scope::Write, "e2e")
        .await
        .unwrap();
    let dir = tempfile::tempdir().unwrap();
    let session = dir.path().join("s");
    write_session(&session, "VMC-PG", 6, 0);
    let api = Server::start(&pg.url, &["--no-worker"]);
    let c = Client::new(&api.url, &key);
    register(&c, "VMC-PG").await;
    let ds = c.upload_path("VMC-PG", &session).await.unwrap();
    let kind = mtcal_server::jobs::JobKind::Identify;
    let first = submit(&c, kind, Some(&ds.id), None).await.id;

    // SIGTERM: the job is handed back, not left to its 10-minute lease.
    let mut stopping = Worker::start(
        &pg.url,
        &[
            "--pause-before-solve-ms",
            "60000",
            "--lease-ms",
            "600000",
            "--grace-seconds",
            "1",
        ],
    );
    wait(&c, &first, JobState::Running).await;
    assert!(terminate(&mut stopping.0).success());
    let back = c.job(&first).await.unwrap();
    assert_eq!(
        (back.state, back.attempts),
        (JobState::Queued, 0),
        "{back:?}"
    );

    // The next worker claims it at once; SIGKILL while it holds it (lease 1.5 s).
    let killed = Worker::start(
        &pg.url,
        &["--pause-before-solve-ms", "60000", "--lease-ms", "1500"],
    );
    wait(&c, &first, JobState::Running).await;
    drop(killed);

    let workers: Vec<Worker> = (0..3)
        .map(|_| Worker::start(&pg.url, &["--lease-ms", "1500", "--concurrency", "1"]))
        .collect();
    let mut jobs = vec![first.clone()];
    for _ in 0..200 {
        jobs.push(submit(&c, kind, Some(&ds.id), None).await.id);
    }
    let t0 = std::time::Instant::now();
    loop {
        let counts = store.job_counts().await.unwrap();
        let done: i64 = counts
            .iter()
            .filter(|n| n.state == "succeeded")
            .map(|n| n.count)
            .sum();
        if done == 201 {
            break;
        }
        assert!(counts.iter().all(|n| n.state != "failed"), "{counts:?}");
        assert!(t0.elapsed().as_secs() < 240, "not drained: {counts:?}");
        tokio::time::sleep(std::time::Duration::from_millis(200)).await;
    }
    drop(workers);
    let counts = store.row_counts().await.unwrap();
    assert_eq!((counts.jobs, counts.results), (201, 201));
    let mut result_ids = std::collections::BTreeSet::new();
    for id in &jobs {
        let j = c.job(id).await.unwrap();
        assert_eq!(j.state, JobState::Succeeded);
        assert!(result_ids.insert(j.result_id.clone().unwrap()), "{j:?}");
    }
    // The first job: one attempt killed, one finished (the handed-back one not counted).
    assert_eq!(c.job(&first).await.unwrap().attempts, 2);
    drop(api);
    pg.drop_schema().await.unwrap();
}

/// A job that runs past `--job-timeout-seconds` fails with code `timeout` (its heartbeats
/// would otherwise renew the lease forever) and is not retried.
#[tokio::test]
async fn a_job_past_its_run_time_limit_fails_with_timeout() {
    let (dir, _store, key) = shared_db().await;
    let (db, session) = (dir.path().join("svc.sqlite"), dir.path().join("s"));
    write_session(&session, "VMC-L", 5, 0);
    let api = Server::start(
        &db,
        &[
            "--pause-before-solve-ms",
            "60000",
            "--job-timeout-seconds",
            "1",
        ],
    );
    let c = Client::new(&api.url, &key);
    register(&c, "VMC-L").await;
    let ds = c.upload_path("VMC-L", &session).await.unwrap();
    let kind = mtcal_server::jobs::JobKind::Identify;
    let job = submit(&c, kind, Some(&ds.id), None).await.id;
    let failed = wait(&c, &job, JobState::Failed).await;
    assert_eq!(failed.error_code.as_deref(), Some("timeout"), "{failed:?}");
    assert_eq!(failed.attempts, 1);
    assert!(
        failed
            .error_message
            .as_deref()
            .is_some_and(|m| m.contains("longer than the limit of 1 s")),
        "{failed:?}"
    );
}

/// A client that trickles its request head (a header line every 300 ms, never the empty
/// line) is disconnected after `--header-timeout-seconds`, while other clients are served.
#[tokio::test]
async fn a_client_trickling_its_request_head_is_disconnected() {
    use std::io::{Read, Write};
    let (dir, _store, _key) = shared_db().await;
    let api = Server::start(
        dir.path().join("svc.sqlite"),
        &["--header-timeout-seconds", "1"],
    );
    let addr = api.url.trim_start_matches("http://").to_string();
    let mut slow = std::net::TcpStream::connect(&addr).unwrap();
    slow.set_read_timeout(Some(std::time::Duration::from_millis(300)))
        .unwrap();
    slow.write_all(b"GET /health HTTP/1.1\r\nHost: mtcal\r\n")
        .unwrap();
    let t0 = std::time::Instant::now();
    let closed_after = loop {
        assert!(
            t0.elapsed() < std::time::Duration::from_secs(8),
            "still open after 8 s"
        );
        let mut buf = [0u8; 256];
        match slow.read(&mut buf) {
            // EOF, or the server's answer before it closes: either way it gave up on us.
            Ok(_) => break t0.elapsed(),
            Err(e)
                if e.kind() == std::io::ErrorKind::WouldBlock
                    || e.kind() == std::io::ErrorKind::TimedOut => {}
            Err(_) => break t0.elapsed(),
        }
        if slow.write_all(b"X-Slow: 1\r\n").is_err() {
            break t0.elapsed();
        }
    };
    assert!(
        closed_after >= std::time::Duration::from_millis(500),
        "{closed_after:?}"
    );
    let health = reqwest::get(format!("{}/health", api.url)).await.unwrap();
    assert!(health.status().is_success());
}

/// A request the webhook receiver of the outbox tests got.
#[derive(Clone)]
struct Hit {
    at: std::time::Instant,
    signature: Option<String>,
    body: Vec<u8>,
}

/// A webhook receiver on 127.0.0.1 that answers its first request 503 (a target down
/// for a moment) and every later one 200; each request goes to the channel.
async fn flaky_receiver() -> (String, tokio::sync::mpsc::UnboundedReceiver<Hit>) {
    use std::sync::atomic::{AtomicUsize, Ordering};
    let (tx, rx) = tokio::sync::mpsc::unbounded_channel();
    let seen = std::sync::Arc::new(AtomicUsize::new(0));
    let handler = move |headers: axum::http::HeaderMap, body: axum::body::Bytes| {
        let (tx, seen) = (tx.clone(), seen.clone());
        async move {
            let _ = tx.send(Hit {
                at: std::time::Instant::now(),
                signature: headers
                    .get("mtcal-signature")
                    .and_then(|v| v.to_str().ok())
                    .map(str::to_string),
                body: body.to_vec(),
            });
            if seen.fetch_add(1, Ordering::SeqCst) == 0 {
                axum::http::StatusCode::SERVICE_UNAVAILABLE
            } else {
                axum::http::StatusCode::OK
            }
        }
    };
    let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
    let addr = listener.local_addr().unwrap();
    let app = axum::Router::new().route("/hook", axum::routing::post(handler));
    tokio::spawn(async move { axum::serve(listener, app).await });
    (format!("http://{addr}/hook"), rx)
}

/// Checks a delivery's signature as a receiver would, with nothing of the service's
/// code: the Python `verify` of docs/api.md ("Webhooks"), taken from the document and
/// run on the request's header and raw body.
fn verify_signature(secret: &str, hit: &Hit) -> Result<(), String> {
    let doc = include_str!("../../docs/api.md");
    let example = doc
        .split("```python\n")
        .find(|b| b.contains("def verify(secret: str, header: str, body: bytes"))
        .and_then(|b| b.split("```").next())
        .expect("docs/api.md holds the Python verify example");
    let script = format!(
        "{example}\nimport sys\nok = verify(sys.argv[1], sys.argv[2], sys.stdin.buffer.read())\n\
         sys.exit(0 if ok else 1)\n"
    );
    let header = hit.signature.as_deref().ok_or("unsigned")?;
    let mut child = Command::new("python3")
        .args(["-c", &script, secret, header])
        .stdin(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .map_err(|e| format!("python3: {e}"))?;
    use std::io::Write;
    child.stdin.take().unwrap().write_all(&hit.body).unwrap();
    let out = child.wait_with_output().unwrap();
    if out.status.success() {
        Ok(())
    } else {
        Err(format!(
            "the signature does not verify: {}",
            String::from_utf8_lossy(&out.stderr)
        ))
    }
}

/// The outbox as `GET /api/v1/webhooks/deliveries` shows it.
async fn deliveries(base: &str, key: &str) -> Vec<serde_json::Value> {
    reqwest::Client::new()
        .get(format!("{base}/api/v1/webhooks/deliveries"))
        .bearer_auth(key)
        .send()
        .await
        .unwrap()
        .json()
        .await
        .unwrap()
}

/// Waits (at most 20 s) until the only delivery satisfies `done`; returns it.
async fn delivery_until(
    base: &str,
    key: &str,
    done: impl Fn(&serde_json::Value) -> bool,
) -> serde_json::Value {
    let t0 = std::time::Instant::now();
    loop {
        let all = deliveries(base, key).await;
        assert_eq!(all.len(), 1, "{all:?}");
        if done(&all[0]) {
            return all[0].clone();
        }
        assert!(t0.elapsed().as_secs() < 20, "{all:?}");
        tokio::time::sleep(std::time::Duration::from_millis(50)).await;
    }
}

/// A webhook delivery survives its worker killed by SIGKILL, on the database `db`: a
/// drift alert's delivery is stored with the alert; the first worker process's try
/// meets a 503 and the delivery waits out its backoff (3 s); the worker is killed
/// (SIGKILL) in that wait; nothing is sent while no worker runs, though the try falls
/// due; a restarted worker process delivers it, signed with the profile's secret
/// (checked by the Python example of docs/api.md), the same body; it is delivered once (two tries in
/// all), never again.
async fn outbox_survives_a_killed_worker(db: &str) {
    const SECRET: &str = "sigkill-outbox-secret-01";
    let store = mtcal_store::open(db).await.unwrap();
    let (_, key) = store
        .create_key(mtcal_store::Scope::Write, "e2e")
        .await
        .unwrap();
    let (hook, mut rx) = flaky_receiver().await;
    let allow = ["--webhook-allow", "127.0.0.1"];
    let api = Server::start(db, &[&allow[..], &["--no-worker"]].concat());
    register(&Client::new(&api.url, &key), "M1").await;
    let http = reqwest::Client::new();
    let tagged = http
        .patch(format!("{}/api/v1/machines/M1", api.url))
        .bearer_auth(&key)
        .json(&serde_json::json!({"tags": ["line-a"]}))
        .send()
        .await
        .unwrap();
    assert_eq!(tagged.status(), 200);
    let made = http
        .post(format!("{}/api/v1/tolerances", api.url))
        .bearer_auth(&key)
        .json(&serde_json::json!({"scope": "tag", "target": "line-a",
            "limits": {"drift_um": 5.0}, "webhook_url": hook, "webhook_secret": SECRET}))
        .send()
        .await
        .unwrap();
    assert_eq!(made.status(), 201, "{}", made.text().await.unwrap());
    // A baseline, then a check whose EXX drifted 16 µm over its 100 mm: an alert, and
    // its delivery stored with it.
    let mut raised = None;
    for (at, c1) in [
        ("2026-01-05T08:00:00Z", 0.0),
        ("2026-04-05T08:00:00Z", 0.16),
    ] {
        let r = store
            .import_result(check("M1", "identification", at, c1))
            .await
            .unwrap();
        raised = mtcal_domain::landing::result_landed(&store, "M1", &r.id)
            .await
            .unwrap();
    }
    let alert = raised.expect("a drift alert");
    let pending = delivery_until(&api.url, &key, |_| true).await;
    assert_eq!(
        (&pending["state"], &pending["attempts"]),
        (&serde_json::json!("pending"), &serde_json::json!(0))
    );

    let worker_args = [&allow[..], &["--webhook-retry-ms", "3000"]].concat();
    let first = Worker::start(db, &worker_args);
    let tried = tokio::time::timeout(std::time::Duration::from_secs(20), rx.recv())
        .await
        .expect("a first try")
        .unwrap();
    verify_signature(SECRET, &tried).unwrap();
    let mut forged = tried.clone();
    forged.body.push(b' ');
    assert!(
        verify_signature(SECRET, &forged).is_err(),
        "a changed body verifies"
    );
    // The 503 is recorded: the delivery waits for its next try.
    delivery_until(&api.url, &key, |d| {
        d["attempts"] == 1 && d["state"] == "pending" && d["last_error"].is_string()
    })
    .await;
    drop(first); // SIGKILL
    // The next try falls due (3 s after the first) while no worker runs: nothing is sent.
    tokio::time::sleep(std::time::Duration::from_millis(4000)).await;
    assert!(rx.try_recv().is_err(), "a try without a worker");
    let waiting = delivery_until(&api.url, &key, |_| true).await;
    assert_eq!(
        (&waiting["state"], &waiting["attempts"]),
        (&serde_json::json!("pending"), &serde_json::json!(1))
    );

    let restarted = std::time::Instant::now();
    let second = Worker::start(db, &worker_args);
    let delivered = tokio::time::timeout(std::time::Duration::from_secs(20), rx.recv())
        .await
        .expect("delivered after the restart")
        .unwrap();
    assert!(delivered.at > restarted);
    verify_signature(SECRET, &delivered).unwrap();
    assert_eq!(delivered.body, tried.body, "the same delivery");
    let body: serde_json::Value = serde_json::from_slice(&delivered.body).unwrap();
    assert_eq!(body["id"], alert.raised.id.as_str());
    let done = delivery_until(&api.url, &key, |d| d["state"] != "pending").await;
    assert_eq!(
        (&done["state"], &done["attempts"]),
        (&serde_json::json!("delivered"), &serde_json::json!(2))
    );
    // Never again: several of the worker's polls later, no third request.
    tokio::time::sleep(std::time::Duration::from_millis(1500)).await;
    assert!(rx.try_recv().is_err(), "delivered twice");
    drop(second);
    drop(api);
}

#[tokio::test]
async fn a_webhook_delivery_survives_its_worker_killed_by_sigkill_on_sqlite() {
    let dir = tempfile::tempdir().unwrap();
    let db = dir.path().join("svc.sqlite");
    outbox_survives_a_killed_worker(db.to_str().unwrap()).await;
}

#[tokio::test]
async fn a_webhook_delivery_survives_its_worker_killed_by_sigkill_on_postgres() {
    let Some(pg) = mtcal_store::testing::ScratchPg::create("e2e::restart::outbox")
        .await
        .unwrap()
    else {
        return;
    };
    outbox_survives_a_killed_worker(&pg.url).await;
    pg.drop_schema().await.unwrap();
}
