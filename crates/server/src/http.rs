//! The accept loop: HTTP/1 and HTTP/2 on hyper-util, with a header-read time limit and a
//! graceful drain.

use crate::edge;
use crate::limits::SHUTDOWN_DRAIN;
use axum::Router;
use std::time::Duration;

/// Serves `app` on `listener` (HTTP/1 and HTTP/2) until `stop` resolves; then stops
/// accepting, lets requests in flight end (at most [`SHUTDOWN_DRAIN`]) and returns. Each
/// HTTP/1 connection must send a request head within `header_timeout`.
pub async fn serve_http(
    listener: tokio::net::TcpListener,
    app: Router,
    header_timeout: Duration,
    stop: impl std::future::Future<Output = ()> + Send,
) -> std::io::Result<()> {
    use hyper_util::rt::{TokioExecutor, TokioIo, TokioTimer};
    use hyper_util::server::conn::auto::Builder;
    let mut builder = Builder::new(TokioExecutor::new());
    builder
        .http1()
        .timer(TokioTimer::new())
        .max_headers(edge::HYPER_MAX_HEADERS)
        .header_read_timeout(header_timeout);
    let graceful = hyper_util::server::graceful::GracefulShutdown::new();
    tokio::pin!(stop);
    loop {
        tokio::select! {
            accepted = listener.accept() => {
                let stream = match accepted {
                    Ok((stream, _)) => stream,
                    Err(e) => {
                        // Out of file descriptors and the like: wait, do not spin.
                        tracing::warn!(%e, "accepting a connection");
                        tokio::time::sleep(Duration::from_millis(50)).await;
                        continue;
                    }
                };
                let _ = stream.set_nodelay(true);
                let service = hyper_util::service::TowerToHyperService::new(app.clone());
                let conn = builder
                    .serve_connection_with_upgrades(TokioIo::new(stream), service)
                    .into_owned();
                let conn = graceful.watch(conn);
                tokio::spawn(async move {
                    let _ = conn.await;
                });
            }
            _ = &mut stop => break,
        }
    }
    drop(listener);
    tokio::select! {
        _ = graceful.shutdown() => {}
        _ = tokio::time::sleep(SHUTDOWN_DRAIN) => {
            tracing::warn!("requests still in flight after the drain period were dropped");
        }
    }
    Ok(())
}
