//! The HTTP application: every route with its limits and layers ([`router`]), the probes,
//! and the service started on a store ([`app`], [`spawn_local`]).

use crate::error::{self, ApiError};
use crate::http::serve_http;
use crate::ingest::UploadLimits;
use crate::limits::{HEADER_READ_TIMEOUT, JSON_BODY_LIMIT, REQUEST_TIMEOUT};
use crate::openapi::ApiDoc;
use crate::state::AppState;
use crate::worker::{self, WorkerConfig, Workers};
use crate::{api, auth, edge, metrics, outage, upload_gate, web};
use axum::Router;
use axum::extract::DefaultBodyLimit;
use axum::http::StatusCode;
use axum::routing::{get, post};
use std::net::SocketAddr;
use std::sync::Arc;
use tower_http::decompression::RequestDecompressionLayer;
use tower_http::timeout::TimeoutLayer;
use utoipa::OpenApi;

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
        .route(
            "/api/v1/results/{id}/verification",
            get(history::verification),
        )
        .route(
            "/api/v1/machines/{id}/trends/verification",
            get(trends::verification),
        )
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
            auth::scope::guard,
        ))
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

/// The routes for load balancers, orchestrators and Prometheus: `/health`, `/ready`
/// (no key) and `/metrics` (the metrics token or an admin key of the whole group), served
/// by `mtcal serve` on its address and by `mtcal worker --metrics-listen`.
fn probes() -> Router<AppState> {
    Router::new()
        .route("/health", get(api::health))
        .route("/ready", get(api::ready))
        .route("/metrics", get(metrics::serve_metrics))
}

/// Serves [`probes`] for a worker-only process on `listener` until `stop` resolves
/// (`settings`: the metrics token).
pub async fn serve_probes(
    store: Arc<dyn mtcal_store::Store>,
    settings: crate::Settings,
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
            settings: Arc::new(settings),
            database: Arc::default(),
            uploads: Default::default(),
            fleet_counts: Arc::default(),
        });
    serve_http(listener, app, HEADER_READ_TIMEOUT, stop).await
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
        fleet_counts: Arc::default(),
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
