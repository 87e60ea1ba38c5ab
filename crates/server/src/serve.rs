//! The processes: `mtcal serve` ([`serve`]: API and workers) and `mtcal worker`
//! ([`run_workers`]), and the signal that stops them.

use crate::app::app;
use crate::http::serve_http;
use crate::worker::{self, WorkerConfig, Workers};
use std::net::SocketAddr;
use std::sync::Arc;
use std::time::Duration;

/// Settings of `mtcal serve`.
#[derive(Debug, Clone)]
pub struct ServeConfig {
    pub db_url: String,
    /// The database connections of this process ([`mtcal_store::StoreOptions`]).
    pub store: mtcal_store::StoreOptions,
    pub listen: SocketAddr,
    pub worker: WorkerConfig,
    /// Run the worker in this process (API only when false).
    pub run_worker: bool,
    /// [`crate::limits::HEADER_READ_TIMEOUT`] unless set otherwise.
    pub header_timeout: Duration,
}

/// Opens the store `db_url` names and starts `worker.queue.concurrency` workers on the
/// current runtime (`mtcal worker`: no HTTP); they poll the queue, so they need no
/// signal from the API process that queued the job.
pub async fn run_workers(
    db_url: &str,
    options: mtcal_store::StoreOptions,
    worker: WorkerConfig,
) -> anyhow::Result<(Arc<dyn mtcal_store::Store>, Workers)> {
    let store = mtcal_store::open_with(db_url, options).await?;
    let mut worker = worker;
    worker
        .settings
        .webhooks
        .own
        .extend(mtcal_domain::webhooks::database_addrs(db_url).await);
    let workers =
        worker::spawn_workers(store.clone(), worker, Arc::new(tokio::sync::Notify::new()));
    Ok((store, workers))
}

/// Resolves on SIGTERM or SIGINT (Ctrl-C).
pub async fn shutdown_signal() {
    let ctrl_c = async {
        let _ = tokio::signal::ctrl_c().await;
    };
    #[cfg(unix)]
    let term = async {
        match tokio::signal::unix::signal(tokio::signal::unix::SignalKind::terminate()) {
            Ok(mut s) => {
                s.recv().await;
            }
            Err(_) => std::future::pending::<()>().await,
        }
    };
    #[cfg(not(unix))]
    let term = std::future::pending::<()>();
    tokio::select! {
        _ = ctrl_c => {}
        _ = term => {}
    }
}

/// Connections of the start-up work ([`start_up_store`]).
pub const START_UP_POOL: u32 = 2;

/// The store the start-up work beside the server runs on (the check models to fill,
/// the fleet refresh): on PostgreSQL a pool of its own of [`START_UP_POOL`]
/// connections, so that its statements do not wait in the requests' pool behind a busy
/// API (nor fail there for want of a connection); on SQLite `store` itself (one file,
/// one writer; an in-memory database is the pool's own).
pub async fn start_up_store(
    url: &str,
    store: Arc<dyn mtcal_store::Store>,
    options: mtcal_store::StoreOptions,
) -> anyhow::Result<Arc<dyn mtcal_store::Store>> {
    if !(url.starts_with("postgres://") || url.starts_with("postgresql://")) {
        return Ok(store);
    }
    let own = mtcal_store::StoreOptions {
        pool_size: Some(START_UP_POOL),
        ..options
    };
    Ok(mtcal_store::open_with(url, own).await?)
}

/// Opens the store, starts the workers and serves until `stop` resolves (`mtcal serve`:
/// [`shutdown_signal`]); then stops accepting connections, lets requests in flight end,
/// and shuts the workers down ([`Workers::shutdown`]: running jobs finish within the
/// grace period or are handed back). `ready` is called with the bound address (port 0
/// picks a free one).
pub async fn serve(
    cfg: ServeConfig,
    ready: impl FnOnce(SocketAddr),
    stop: impl std::future::Future<Output = ()> + Send + 'static,
) -> anyhow::Result<()> {
    let store = mtcal_store::open_with(&cfg.db_url, cfg.store).await?;
    let listener = tokio::net::TcpListener::bind(cfg.listen).await?;
    let mut worker = cfg.worker.clone();
    worker.settings.webhooks.own.push(listener.local_addr()?);
    worker
        .settings
        .webhooks
        .own
        .extend(mtcal_domain::webhooks::database_addrs(&cfg.db_url).await);
    let (app, workers) = app(store.clone(), &worker, cfg.run_worker);
    let store = start_up_store(&cfg.db_url, store, cfg.store).await?;
    // The check models of results stored before they were kept beside them, then the
    // drift of results stored before this version or imported in bulk.
    tokio::spawn(async move {
        let started = std::time::Instant::now();
        match mtcal_domain::trends::fill_check_models(store.as_ref(), 500).await {
            Ok(n) => tracing::info!(
                results = n,
                seconds = started.elapsed().as_secs_f64(),
                "check models stored"
            ),
            Err(e) => tracing::warn!(%e, "check models not stored"),
        }
        match mtcal_domain::fleet::refresh_all(store.as_ref()).await {
            Ok(n) => tracing::info!(
                machines = n.machines,
                recomputed = n.recomputed,
                "fleet drift refreshed"
            ),
            Err(e) => tracing::warn!(%e, "fleet drift not refreshed"),
        }
    });
    ready(listener.local_addr()?);
    serve_http(listener, app, cfg.header_timeout, stop).await?;
    tracing::info!("stopping: no new connections; workers finishing or handing back jobs");
    workers.shutdown().await;
    Ok(())
}
