//! # mtcal-server
//!
//! The calibration service: an axum API (`/api/v1`, OpenAPI document generated from the
//! code with utoipa, Swagger UI at `/docs` from vendored assets) and the job worker, in
//! one process. Storage goes through [`mtcal_store::Store`] only.
//!
//! Limits: every route has a body-size limit (1 MiB; uploads [`ingest::UploadLimits`],
//! 256 MiB by default) and a time limit (30 s; uploads [`Settings::upload_slot_time`], 120 s by default). Every route but `/health`,
//! `/ready`, `/metrics` ([`metrics`]) and the documentation needs an API key (see
//! [`auth`]).
#![deny(clippy::print_stdout, clippy::print_stderr)]

pub mod api;
pub mod audit;
pub mod auth;
pub mod blocking;
pub mod contract;
pub mod edge;
pub mod error;
pub mod ingest;
pub mod jobs;
pub mod metrics;
pub mod outage;
pub mod state;
pub mod upload_gate;
pub mod web;
pub mod worker;

use axum::Router;
use axum::extract::DefaultBodyLimit;
use axum::http::StatusCode;
use axum::routing::{get, post};
use std::net::SocketAddr;
use std::sync::Arc;
use std::time::Duration;
use tower_http::decompression::RequestDecompressionLayer;
use tower_http::timeout::TimeoutLayer;
use utoipa::OpenApi;
use utoipa::openapi::security::{HttpAuthScheme, HttpBuilder, SecurityScheme};

use contract::Statuses;
pub use error::ApiError;
pub use ingest::UploadLimits;
pub use mtcal_domain::webhooks::TargetPolicy as WebhookPolicy;
pub use state::{AppState, Settings};
pub use worker::{WorkerConfig, Workers};

/// Body limit of every route but uploads, bytes.
pub const JSON_BODY_LIMIT: usize = 1 << 20;
/// Time limit of every route but uploads.
pub const REQUEST_TIMEOUT: Duration = Duration::from_secs(30);
/// Longest an upload waits for a reading slot ([`MAX_CONCURRENT_UPLOADS`]) before its
/// own time limit ([`Settings::upload_slot_time`]) starts; past it the upload is refused
/// with 408.
pub const UPLOAD_SLOT_WAIT: Duration = Duration::from_secs(300);
/// Uploads read at the same time by one process; more wait for a slot (at most
/// [`UPLOAD_SLOT_WAIT`]) before their body is read. An upload may decompress to the byte
/// limit (256 MiB) and its columns take about as much again, so two at a time bound a
/// process's upload memory near 1 GB whatever the number of clients.
pub const MAX_CONCURRENT_UPLOADS: usize = 2;

struct SecurityAddon;

impl utoipa::Modify for SecurityAddon {
    fn modify(&self, openapi: &mut utoipa::openapi::OpenApi) {
        let c = openapi.components.get_or_insert_with(Default::default);
        c.add_security_scheme(
            "api_key",
            SecurityScheme::Http(
                HttpBuilder::new()
                    .scheme(HttpAuthScheme::Bearer)
                    .description(Some("API key created with `mtcal admin create-key`"))
                    .build(),
            ),
        );
    }
}

/// The OpenAPI document of API v1.
#[derive(OpenApi)]
#[openapi(
    info(title = "mtcal calibration service", version = "1",
         description = "Machines, measurement datasets, jobs (identification), results, history and trends. \
                        Errors: `{\"error\": {\"code\", \"message\"}}` with stable codes (docs/api.md)."),
    paths(
        api::health,
        api::machines::create, api::machines::get, api::machines::update, api::machines::list,
        api::datasets::upload, api::datasets::list, api::datasets::get, api::datasets::file,
        api::datasets::exclude, api::datasets::delete_files,
        api::jobs::submit, api::jobs::list, api::jobs::get, api::jobs::result, api::jobs::cancel,
        api::history::list, api::history::latest, api::history::get, api::history::diff,
        api::history::figures, api::history::exclude,
        api::exports::export, api::exports::report,
        api::trends::term, api::trends::summary, api::trends::figure, api::trends::fleet,
        api::fleet::list,
        api::keys::create, api::keys::list, api::keys::revoke,
        api::ready,
        api::tolerances::create, api::tolerances::list, api::tolerances::get,
        api::tolerances::replace, api::tolerances::delete, api::tolerances::verdict,
        api::alerts::list, api::alerts::ack, api::webhooks::deliveries,
        api::audit::list, api::audit::export,
    ),
    components(schemas(jobs::IdentifyParams, jobs::DiagnoseParams, error::ErrorBody)),
    modifiers(&SecurityAddon, &Statuses),
    tags((name = "machines"), (name = "datasets"), (name = "jobs"), (name = "history"),
         (name = "trends"), (name = "keys"), (name = "service"),
         (name = "tolerances", description = "Tolerance profiles and verdicts (ISO 14253-1 decision rule, U = 2u)"),
         (name = "alerts", description = "Drift alerts raised when a result lands"),
         (name = "audit", description = "The audit trail: every change of state a person made (append-only)"))
)]
pub struct ApiDoc;

/// The committed form of the OpenAPI document (`openapi/openapi.json`).
pub fn openapi_json() -> String {
    let mut s = ApiDoc::openapi()
        .to_pretty_json()
        .expect("the OpenAPI document serialises");
    s.push('\n');
    s
}

/// The whole HTTP application. Every `/api/v1` route sits behind [`auth::authenticate`],
/// the outermost layer, so that a request without a valid key is refused (401) before
/// body limits, decompression or any extractor look at it.
pub fn router(state: AppState) -> Router {
    use api::*;
    let uploads = Router::new()
        .route("/api/v1/machines/{id}/datasets", post(datasets::upload))
        .layer(DefaultBodyLimit::max(state.limits.max_bytes))
        .layer(RequestDecompressionLayer::new())
        .layer(axum::middleware::from_fn(api::datasets::note_encoding));
    let uploads = upload_gate::guard(uploads, &state)
        .layer(axum::middleware::from_fn_with_state(
            state.clone(),
            auth::require_write,
        ))
        .layer(upload_gate::outer_limit(&state));
    let rest = Router::new()
        .route(
            "/api/v1/machines",
            post(machines::create).get(machines::list),
        )
        .route(
            "/api/v1/machines/{id}",
            get(machines::get).patch(machines::update),
        )
        .route("/api/v1/machines/{id}/datasets", get(datasets::list))
        .route("/api/v1/datasets/{id}", get(datasets::get))
        .route("/api/v1/datasets/{id}/exclude", post(datasets::exclude))
        .route(
            "/api/v1/datasets/{id}/delete-files",
            post(datasets::delete_files),
        )
        .route("/api/v1/datasets/{id}/files/{name}", get(datasets::file))
        .route("/api/v1/jobs", post(jobs::submit).get(jobs::list))
        .route("/api/v1/jobs/{id}", get(jobs::get))
        .route("/api/v1/jobs/{id}/result", get(jobs::result))
        .route("/api/v1/jobs/{id}/cancel", post(jobs::cancel))
        .route("/api/v1/machines/{id}/results", get(history::list))
        .route("/api/v1/machines/{id}/results/latest", get(history::latest))
        .route("/api/v1/machines/{id}/results/diff", get(history::diff))
        .route("/api/v1/results/{id}", get(history::get))
        .route("/api/v1/results/{id}/exclude", post(history::exclude))
        .route("/api/v1/results/{id}/figures", get(history::figures))
        .route("/api/v1/results/{id}/export", get(exports::export))
        .route("/api/v1/results/{id}/report", get(exports::report))
        .route("/api/v1/machines/{id}/trends/term", get(trends::term))
        .route("/api/v1/machines/{id}/trends/summary", get(trends::summary))
        .route("/api/v1/machines/{id}/trends/figure", get(trends::figure))
        .route("/api/v1/fleet", get(api::fleet::list))
        .route("/api/v1/fleet/drift", get(trends::fleet))
        .route(
            "/api/v1/tolerances",
            post(api::tolerances::create).get(api::tolerances::list),
        )
        .route(
            "/api/v1/tolerances/{id}",
            get(api::tolerances::get)
                .put(api::tolerances::replace)
                .delete(api::tolerances::delete),
        )
        .route(
            "/api/v1/results/{id}/verdict",
            get(api::tolerances::verdict),
        )
        .route("/api/v1/alerts", get(api::alerts::list))
        .route("/api/v1/alerts/{id}/ack", post(api::alerts::ack))
        .route(
            "/api/v1/webhooks/deliveries",
            get(api::webhooks::deliveries),
        )
        .route("/api/v1/audit", get(api::audit::list))
        .route("/api/v1/audit/export", get(api::audit::export))
        .route("/api/v1/keys", post(keys::create).get(keys::list))
        .route("/api/v1/keys/{id}", axum::routing::delete(keys::revoke))
        .layer(DefaultBodyLimit::max(JSON_BODY_LIMIT))
        .layer(TimeoutLayer::with_status_code(
            StatusCode::REQUEST_TIMEOUT,
            REQUEST_TIMEOUT,
        ));
    let api = uploads
        .merge(rest)
        .route_layer(axum::middleware::from_fn_with_state(
            state.clone(),
            auth::authenticate,
        ))
        .route_layer(axum::middleware::from_fn_with_state(
            state.clone(),
            outage::guard,
        ));
    let open = probes().merge(
        utoipa_swagger_ui::SwaggerUi::new("/docs").url("/api-docs/openapi.json", ApiDoc::openapi()),
    );
    let app = api
        .merge(open)
        .fallback(|| async { ApiError::NotFound("no such route".into()) })
        .layer(axum::middleware::from_fn(error::json_errors))
        .with_state(state.clone());
    // The dashboard's pages answer their errors as pages, not JSON.
    app.merge(web::router(state))
        .route_layer(axum::middleware::from_fn(metrics::track))
        .layer(axum::middleware::from_fn(edge::guard))
}

/// The routes without a key for load balancers, orchestrators and Prometheus:
/// `/health`, `/ready`, `/metrics` (served by `mtcal serve` on its address and by
/// `mtcal worker --metrics-listen`).
fn probes() -> Router<AppState> {
    Router::new()
        .route("/health", get(api::health))
        .route("/ready", get(api::ready))
        .route("/metrics", get(metrics::serve_metrics))
}

/// Serves [`probes`] for a worker-only process on `listener` until `stop` resolves.
pub async fn serve_probes(
    store: Arc<dyn mtcal_store::Store>,
    listener: tokio::net::TcpListener,
    stop: impl std::future::Future<Output = ()> + Send + 'static,
) -> std::io::Result<()> {
    let app = probes()
        .route_layer(axum::middleware::from_fn(metrics::track))
        .with_state(AppState {
            store,
            limits: UploadLimits::default(),
            max_attempts: 1,
            wake: Arc::new(tokio::sync::Notify::new()),
            settings: Arc::default(),
            database: Arc::default(),
            uploads: Default::default(),
        });
    serve_http(listener, app, HEADER_READ_TIMEOUT, stop).await
}

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
    /// [`HEADER_READ_TIMEOUT`] unless set otherwise.
    pub header_timeout: Duration,
}

/// The service on `store`: starts `worker.queue.concurrency` workers on the current
/// runtime when `run_worker`, and returns the HTTP application with them. `mtcal serve`,
/// the end-to-end tests and the load generator all start the service through here.
pub fn app(
    store: Arc<dyn mtcal_store::Store>,
    worker: &WorkerConfig,
    run_worker: bool,
) -> (Router, Workers) {
    let wake = Arc::new(tokio::sync::Notify::new());
    let workers = if run_worker {
        worker::spawn_workers(store.clone(), worker.clone(), wake.clone())
    } else {
        Workers::none()
    };
    let router = router(AppState {
        store,
        limits: worker.limits,
        max_attempts: worker.queue.max_attempts,
        wake,
        settings: Arc::new(worker.settings.clone()),
        database: Arc::default(),
        uploads: Default::default(),
    });
    (router, workers)
}

/// Starts the service on `store` on a free port of 127.0.0.1, served in the background of
/// the current runtime (tests, benchmarks); returns its address.
pub async fn spawn_local(
    store: Arc<dyn mtcal_store::Store>,
    worker: &WorkerConfig,
    run_worker: bool,
) -> std::io::Result<SocketAddr> {
    let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await?;
    let addr = listener.local_addr()?;
    let mut worker = worker.clone();
    worker.settings.webhooks.own.push(addr);
    let (app, _workers) = app(store, &worker, run_worker);
    tokio::spawn(async move {
        let _keep = _workers;
        serve_http(listener, app, HEADER_READ_TIMEOUT, std::future::pending()).await
    });
    Ok(addr)
}

/// Time a client has to send a request's head (request line and headers) on an HTTP/1
/// connection, from the connection's start or the previous response: a connection that
/// trickles its head (a slow-loris client) is closed instead of holding a task forever.
pub const HEADER_READ_TIMEOUT: Duration = Duration::from_secs(10);
/// Time requests in flight have to finish once the server stops.
pub const SHUTDOWN_DRAIN: Duration = Duration::from_secs(30);

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
                let (stream, peer) = match accepted {
                    Ok(accepted) => accepted,
                    Err(e) => {
                        // Out of file descriptors and the like: wait, do not spin.
                        tracing::warn!(%e, "accepting a connection");
                        tokio::time::sleep(Duration::from_millis(50)).await;
                        continue;
                    }
                };
                let _ = stream.set_nodelay(true);
                // The client's address, for the audit trail (crate::audit).
                let app = tower::Layer::layer(
                    &axum::Extension(axum::extract::ConnectInfo(peer)),
                    app.clone(),
                );
                let service = hyper_util::service::TowerToHyperService::new(app);
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
    // Drift of results stored before this version or imported in bulk.
    tokio::spawn(async move {
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
