//! Slow and large clients: an upload whose body falls below the minimum rate once its
//! grace period is over is answered 408 naming the rate (and stores nothing), on the
//! API's upload route and the dashboard's alike; and the dashboard's upload waits for
//! the same reading slots as the API's (`MAX_CONCURRENT_UPLOADS` for both together), so
//! slow API uploads holding every slot hold the dashboard's too; and clients that keep
//! just above the minimum rate hold their slots no longer than the slot time
//! (`Settings::upload_slot_time`): they are answered 408 naming it, and an upload waiting
//! behind them is read.

use crate::common::{AppOptions, spawn_app, spawn_app_with};
use mtcal_server::{MAX_CONCURRENT_UPLOADS, Settings};
use reqwest::StatusCode;
use reqwest::multipart::{Form, Part};
use std::time::Duration;
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::TcpStream;

/// Opens an upload on a connection of its own: the head (with `extra` header lines),
/// announcing `length` bytes, then only `first` of them.
async fn start_upload(
    url: &str,
    path: &str,
    extra: &str,
    length: usize,
    first: &[u8],
) -> TcpStream {
    let host = url.trim_start_matches("http://");
    let mut c = TcpStream::connect(host).await.unwrap();
    let head = format!(
        "POST {path} HTTP/1.1\r\nHost: {host}\r\n{extra}Content-Length: {length}\r\n\
         Connection: close\r\n\r\n"
    );
    c.write_all(head.as_bytes()).await.unwrap();
    c.write_all(first).await.unwrap();
    c
}

/// The whole answer on `c` (the server closes the connection), within `wait`.
async fn answer(mut c: TcpStream, wait: Duration) -> String {
    let mut out = Vec::new();
    tokio::time::timeout(wait, c.read_to_end(&mut out))
        .await
        .expect("an answer in time")
        .ok();
    String::from_utf8_lossy(&out).into_owned()
}

#[tokio::test]
async fn an_upload_below_the_minimum_rate_is_refused_408_naming_it() {
    let app = spawn_app_with(AppOptions {
        run_worker: false,
        settings: Settings {
            min_upload_rate: 1000,
            upload_grace: Duration::from_secs(1),
            ..Settings::default()
        },
        ..AppOptions::default()
    })
    .await;
    app.machine("M1").await;
    let b = app.sign_in(&app.write_key).await;
    let api = format!(
        "Authorization: Bearer {}\r\nContent-Type: application/gzip\r\n",
        app.write_key
    );
    let boundary = "XyZ";
    let page = format!(
        "Cookie: {}\r\nContent-Type: multipart/form-data; boundary={boundary}\r\n",
        b.cookie
    );
    let first = format!(
        "--{boundary}\r\nContent-Disposition: form-data; name=\"csrf\"\r\n\r\n{}\r\n\
         --{boundary}\r\nContent-Disposition: form-data; name=\"files\"; \
         filename=\"xy.csv\"\r\n\r\nx_mm,y_mm\n",
        b.csrf
    );
    for (route, path, extra, first) in [
        (
            "API",
            "/api/v1/machines/M1/datasets",
            api.as_str(),
            &b"\x1f\x8b"[..],
        ),
        (
            "dashboard",
            "/machines/M1/upload",
            page.as_str(),
            first.as_bytes(),
        ),
    ] {
        // 100 kB announced; a few bytes sent, then nothing: far below 1000 bytes/s.
        let c = start_upload(&app.url, path, extra, 100_000, first).await;
        let text = answer(c, Duration::from_secs(20)).await;
        assert!(text.starts_with("HTTP/1.1 408"), "{route}: {text}");
        assert!(
            text.contains("minimum rate of 1000 bytes/s"),
            "{route}: the answer names the rate: {text}"
        );
    }
    assert_eq!(app.counts().await.datasets, 0, "nothing stored");
}

#[tokio::test]
async fn the_dashboard_upload_waits_for_the_slots_api_uploads_hold() {
    let app = spawn_app().await;
    app.machine("M1").await;
    let b = app.sign_in(&app.write_key).await;
    // Slow API uploads hold every reading slot (still within their grace period).
    let api = format!(
        "Authorization: Bearer {}\r\nContent-Type: application/gzip\r\n",
        app.write_key
    );
    let mut slow = vec![];
    for _ in 0..MAX_CONCURRENT_UPLOADS {
        let path = "/api/v1/machines/M1/datasets";
        slow.push(start_upload(&app.url, path, &api, 100_000, b"\x1f\x8b").await);
    }
    tokio::time::sleep(Duration::from_millis(300)).await;
    let form = Form::new().text("csrf", b.csrf.clone()).part(
        "files",
        Part::bytes(b"x_mm,y_mm\n0,0\n".to_vec()).file_name("xy.csv"),
    );
    let page = {
        let http = b.http.clone();
        let url = format!("{}/machines/M1/upload", app.url);
        let cookie = b.cookie.clone();
        tokio::spawn(async move {
            http.post(url)
                .header(reqwest::header::COOKIE, cookie)
                .multipart(form)
                .send()
                .await
                .unwrap()
                .status()
        })
    };
    tokio::time::sleep(Duration::from_millis(1500)).await;
    assert!(
        !page.is_finished(),
        "the dashboard's upload was read while API uploads held every slot"
    );
    // The slow clients give up: their slots go to the dashboard's upload.
    drop(slow);
    let status = tokio::time::timeout(Duration::from_secs(30), page)
        .await
        .expect("the dashboard's upload read once a slot was free")
        .unwrap();
    assert!(
        status != StatusCode::REQUEST_TIMEOUT && !status.is_server_error(),
        "{status}"
    );
}

/// Sends `c`'s body in pieces of `piece` bytes every 100 ms (a steady rate) until the
/// server stops reading or 60 s have passed; the answer read meanwhile, within `wait`.
async fn trickle(c: TcpStream, piece: usize, wait: Duration) -> String {
    let (mut rd, mut wr) = c.into_split();
    let writer = tokio::spawn(async move {
        for _ in 0..600 {
            if wr.write_all(&vec![b'x'; piece]).await.is_err() {
                break;
            }
            tokio::time::sleep(Duration::from_millis(100)).await;
        }
    });
    let mut out = Vec::new();
    tokio::time::timeout(wait, rd.read_to_end(&mut out))
        .await
        .expect("an answer in time")
        .ok();
    writer.abort();
    String::from_utf8_lossy(&out).into_owned()
}

#[tokio::test]
async fn clients_above_the_minimum_rate_hold_a_slot_no_longer_than_the_slot_time() {
    let slot_time = Duration::from_secs(3);
    let app = spawn_app_with(AppOptions {
        run_worker: false,
        settings: Settings {
            min_upload_rate: 1000,
            upload_grace: Duration::from_secs(1),
            upload_slot_time: slot_time,
            ..Settings::default()
        },
        ..AppOptions::default()
    })
    .await;
    app.machine("M1").await;
    let api = format!(
        "Authorization: Bearer {}\r\nContent-Type: application/gzip\r\n",
        app.write_key
    );
    // Every slot taken by a client sending 4000 bytes/s (four times the minimum rate) of
    // a 1 MB body: 250 s at that rate, were the slot time not bounding it.
    let started = std::time::Instant::now();
    let mut slow = vec![];
    for _ in 0..MAX_CONCURRENT_UPLOADS {
        let c = start_upload(
            &app.url,
            "/api/v1/machines/M1/datasets",
            &api,
            1_000_000,
            b"",
        )
        .await;
        slow.push(tokio::spawn(trickle(c, 400, Duration::from_secs(30))));
    }
    tokio::time::sleep(Duration::from_millis(300)).await;
    // An upload behind them waits for a slot, then is read.
    let quick = {
        let form = Form::new().part(
            "files",
            Part::bytes(b"x_mm,y_mm\n0,0\n".to_vec()).file_name("xy.csv"),
        );
        app.with_key(&app.write_key)
            .request(reqwest::Method::POST, "/api/v1/machines/M1/datasets")
            .multipart(form)
            .send()
    };
    let quick = tokio::time::timeout(Duration::from_secs(20), quick)
        .await
        .expect("the waiting upload is answered once the slot time freed a slot")
        .unwrap()
        .status();
    assert!(
        quick != StatusCode::REQUEST_TIMEOUT && !quick.is_server_error(),
        "{quick}"
    );
    for c in slow {
        let text = c.await.unwrap();
        assert!(text.starts_with("HTTP/1.1 408"), "{text}");
        assert!(
            text.contains("longer than the limit of 3 s"),
            "the answer names the slot time: {text}"
        );
    }
    // (No sooner than the slot time; the 30 s each waited for its answer bounds it above.)
    let took = started.elapsed();
    assert!(
        took >= slot_time,
        "answered after {took:?}, before the slot time"
    );
    assert_eq!(app.counts().await.datasets, 0, "nothing stored");
}
