//! A worker killed (SIGKILL) mid-job: the job is finished exactly once by the next
//! process. The one test with real `mtcal serve` processes, since it kills one.

use crate::common::*;
use mtcal_client::Client;
use mtcal_store::{JobState, SqliteStore, Store};
use std::io::{BufRead, BufReader};
use std::path::Path;
use std::process::{Child, Command, Stdio};

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

#[tokio::test]
async fn worker_killed_mid_job_finishes_the_job_exactly_once_after_restart() {
    let dir = tempfile::tempdir().unwrap();
    let db = dir.path().join("svc.sqlite");
    let store = SqliteStore::open(db.to_str().unwrap()).await.unwrap();
    let (_, key) = store
        .create_key(mtcal_store::Scope::Write, "e2e")
        .await
        .unwrap();
    let session = dir.path().join("s");
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
