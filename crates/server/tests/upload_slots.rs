//! At most `MAX_CONCURRENT_UPLOADS` uploads are read at once: more clients than that
//! stream their bodies slowly at the same time, and the process's gauge of uploads being
//! read (`mtcal_uploads_reading` at `/metrics`), sampled meanwhile, reaches the limit and
//! never passes it. Without the upload route's concurrency limit every client would be
//! read at once. A test binary of its own: the gauge counts the whole process.

use mtcal_server::{MAX_CONCURRENT_UPLOADS, WorkerConfig};
use mtcal_store::Scope;
use std::time::Duration;
use tokio::io::{AsyncReadExt, AsyncWriteExt};

/// Pieces of each upload's body, and the pause between two.
const PIECES: usize = 20;
const PAUSE: Duration = Duration::from_millis(40);

/// Sends one upload over a connection of its own: the head at once, then a body of
/// `PIECES` × 100 bytes, one piece per `PAUSE`; the answer's status line.
async fn slow_upload(addr: std::net::SocketAddr, key: String) -> String {
    let mut c = tokio::net::TcpStream::connect(addr).await.unwrap();
    let head = format!(
        "POST /api/v1/machines/M1/datasets HTTP/1.1\r\nHost: {addr}\r\n\
         Authorization: Bearer {key}\r\nContent-Type: application/gzip\r\n\
         Content-Length: {}\r\nConnection: close\r\n\r\n",
        PIECES * 100
    );
    c.write_all(head.as_bytes()).await.unwrap();
    for _ in 0..PIECES {
        tokio::time::sleep(PAUSE).await;
        c.write_all(&[b'x'; 100]).await.unwrap();
    }
    let mut answer = Vec::new();
    c.read_to_end(&mut answer).await.unwrap();
    let answer = String::from_utf8_lossy(&answer);
    answer.lines().next().unwrap_or_default().to_string()
}

/// The value of `mtcal_uploads_reading` in a `/metrics` text.
fn uploads_reading(metrics: &str) -> i64 {
    metrics
        .lines()
        .find_map(|l| l.strip_prefix("mtcal_uploads_reading "))
        .and_then(|v| v.trim().parse().ok())
        .unwrap_or_else(|| panic!("no mtcal_uploads_reading in:\n{metrics}"))
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn no_more_uploads_than_the_limit_are_read_at_once() {
    let dir = tempfile::tempdir().unwrap();
    let store = mtcal_store::open(dir.path().join("t.sqlite").to_str().unwrap())
        .await
        .unwrap();
    let (_, key) = store.create_key(Scope::Write, "w").await.unwrap();
    let (_, admin) = store.create_key(Scope::Admin, "scraper").await.unwrap();
    let addr = mtcal_server::spawn_local(store, &WorkerConfig::default(), false)
        .await
        .unwrap();
    let http = reqwest::Client::new();
    let made = http
        .post(format!("http://{addr}/api/v1/machines"))
        .bearer_auth(&key)
        .json(&serde_json::json!({"id": "M1", "name": "M1"}))
        .send()
        .await
        .unwrap();
    assert_eq!(made.status(), 201);
    let metrics = || async {
        let text = http
            .get(format!("http://{addr}/metrics"))
            .bearer_auth(&admin)
            .send()
            .await
            .unwrap()
            .text()
            .await
            .unwrap();
        uploads_reading(&text)
    };
    assert_eq!(metrics().await, 0);

    let clients = 3 * MAX_CONCURRENT_UPLOADS;
    let mut uploads = tokio::task::JoinSet::new();
    for _ in 0..clients {
        uploads.spawn(slow_upload(addr, key.clone()));
    }
    let mut most = 0;
    while !uploads.is_empty() {
        most = most.max(metrics().await);
        tokio::time::sleep(Duration::from_millis(10)).await;
        while let Some(done) = uploads.try_join_next() {
            let status = done.unwrap();
            // The bodies are not archives: refused as such, not timed out or failed.
            assert!(
                status.starts_with("HTTP/1.1 4") && !status.contains(" 408 "),
                "{status}"
            );
        }
    }
    assert_eq!(
        most, MAX_CONCURRENT_UPLOADS as i64,
        "uploads read at once, at most (of {clients} streaming together)"
    );
    assert_eq!(metrics().await, 0, "every upload counted out");
}
