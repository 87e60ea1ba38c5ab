//! A database outage fails fast: the service on PostgreSQL reached through a TCP relay
//! of this test, which is cut (every connection closed, new ones refused) and restored.
//! While it is cut every request is answered 503 `unavailable` with `Retry-After`
//! (the first within the pool's wait, the next ones at once), `/ready` answers 503
//! saying the database is down and `/metrics` shows `mtcal_database_up 0`; once it is
//! restored the service answers again by itself. PostgreSQL only (a SQLite file has no
//! outage); without `MTCAL_TEST_PG` it says it skipped.

use crate::common::request;
use axum::http::StatusCode;
use mtcal_server::router;
use mtcal_store::{Scope, StoreOptions};
use std::time::{Duration, Instant};
use tokio::net::{TcpListener, TcpStream};
use tokio::sync::watch;
use tower::ServiceExt;

/// A TCP relay from a local port to `target` that can be cut and restored.
struct Relay {
    port: u16,
    cut: watch::Sender<bool>,
}

impl Relay {
    async fn start(target: String) -> Relay {
        let listener = TcpListener::bind("127.0.0.1:0").await.unwrap();
        let port = listener.local_addr().unwrap().port();
        let (cut, _) = watch::channel(false);
        let cuts = cut.clone();
        tokio::spawn(async move {
            loop {
                let Ok((mut client, _)) = listener.accept().await else {
                    return;
                };
                let mut watch = cuts.subscribe();
                if *watch.borrow() {
                    drop(client);
                    continue;
                }
                let target = target.clone();
                tokio::spawn(async move {
                    let Ok(mut server) = TcpStream::connect(&target).await else {
                        return;
                    };
                    tokio::select! {
                        _ = tokio::io::copy_bidirectional(&mut client, &mut server) => {}
                        _ = watch.wait_for(|c| *c) => {}
                    }
                });
            }
        });
        Relay { port, cut }
    }

    fn set_cut(&self, cut: bool) {
        self.cut.send_replace(cut);
    }
}

async fn get(
    app: &axum::Router,
    uri: &str,
    key: &str,
) -> (StatusCode, serde_json::Value, Option<String>, Duration) {
    let t0 = Instant::now();
    let resp = app
        .clone()
        .oneshot(request("GET", uri, "", None, vec![], Some(key)))
        .await
        .unwrap();
    let retry = resp
        .headers()
        .get("retry-after")
        .map(|v| v.to_str().unwrap().to_string());
    let status = resp.status();
    let bytes = axum::body::to_bytes(resp.into_body(), usize::MAX)
        .await
        .unwrap();
    let body = serde_json::from_slice(&bytes).unwrap_or(serde_json::Value::Null);
    (status, body, retry, t0.elapsed())
}

#[tokio::test]
async fn a_database_outage_is_answered_503_at_once_and_the_service_comes_back() {
    let name = "a_database_outage_is_answered_503_at_once_and_the_service_comes_back";
    let Some(pg) = mtcal_store::testing::ScratchPg::create(name).await.unwrap() else {
        return;
    };
    // postgres://user@127.0.0.1:PORT/db?options=… → the same through the relay.
    let at = pg.url.find("@").unwrap() + 1;
    let end = at + pg.url[at..].find('/').unwrap();
    let relay = Relay::start(pg.url[at..end].to_string()).await;
    let url = format!(
        "{}127.0.0.1:{}{}",
        &pg.url[..at],
        relay.port,
        &pg.url[end..]
    );
    let options = StoreOptions {
        pool_size: Some(4),
        acquire_timeout: Duration::from_millis(1500),
    };
    let store = mtcal_store::open_with(&url, options).await.unwrap();
    let (_, key) = store.create_key(Scope::Read, "r").await.unwrap();
    // The metrics token: `/metrics` answers without the database.
    let token = "outage-metrics-token-0123456789";
    let mut state = crate::common::state(store);
    state.settings = std::sync::Arc::new(mtcal_server::Settings {
        metrics_token: Some(token.into()),
        ..Default::default()
    });
    let app = router(state);
    let (s, ..) = get(&app, "/api/v1/machines", &key).await;
    assert_eq!(s, StatusCode::OK);

    relay.set_cut(true);
    let (s, b, retry, took) = get(&app, "/api/v1/machines", &key).await;
    assert_eq!(s, StatusCode::SERVICE_UNAVAILABLE, "{b}");
    assert_eq!(b["error"]["code"], "unavailable", "{b}");
    assert_eq!(retry.as_deref(), Some("5"));
    assert!(
        took < Duration::from_secs(5),
        "the first refusal took {took:?}"
    );
    // The next requests, pages too, are refused at once (no wait for a connection).
    for uri in ["/api/v1/machines", "/api/v1/fleet", "/api/v1/jobs"] {
        let (s, b, retry, took) = get(&app, uri, &key).await;
        assert_eq!(s, StatusCode::SERVICE_UNAVAILABLE, "{uri}: {b}");
        assert!(retry.is_some(), "{uri}");
        assert!(took < Duration::from_millis(500), "{uri} took {took:?}");
    }
    let (s, b, retry, _) = get(&app, "/ready", &key).await;
    assert_eq!(s, StatusCode::SERVICE_UNAVAILABLE);
    assert!(
        b["error"]["message"]
            .as_str()
            .unwrap()
            .contains("database: down"),
        "{b}"
    );
    assert!(retry.is_some());
    let metrics = app
        .clone()
        .oneshot(request("GET", "/metrics", "", None, vec![], Some(token)))
        .await
        .unwrap();
    let text = axum::body::to_bytes(metrics.into_body(), usize::MAX)
        .await
        .unwrap();
    let text = String::from_utf8_lossy(&text);
    assert!(text.contains("mtcal_database_up 0"), "{text}");
    assert!(text.contains("mtcal_database_unavailable_total"), "{text}");

    // Restored: within a probe interval or two the service answers again by itself.
    relay.set_cut(false);
    let t0 = Instant::now();
    loop {
        let (s, ..) = get(&app, "/api/v1/machines", &key).await;
        if s == StatusCode::OK {
            break;
        }
        assert!(
            t0.elapsed() < Duration::from_secs(10),
            "still {s} after the outage"
        );
        tokio::time::sleep(Duration::from_millis(200)).await;
    }
    let (s, b, ..) = get(&app, "/ready", &key).await;
    assert_eq!(
        (s, b["database"].as_str()),
        (StatusCode::OK, Some("up")),
        "{b}"
    );
    pg.drop_schema().await.unwrap();
}
