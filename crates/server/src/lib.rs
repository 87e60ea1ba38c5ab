//! # mtcal-server
//!
//! The calibration service: an axum API (`/api/v1`, OpenAPI document generated from the
//! code with utoipa, Swagger UI at `/docs` from vendored assets) and the job worker, in
//! one process. Storage goes through [`mtcal_store::Store`] only.
//!
//! Limits: every route has a body-size limit (1 MiB; uploads [`ingest::UploadLimits`],
//! 256 MiB by default) and a time limit (30 s; uploads [`Settings::upload_slot_time`], 120 s by default). Every route but `/health`,
//! `/ready` and the documentation needs an API key (see [`auth`]); `/metrics` one of
//! admin scope of the whole group ([`metrics`]).
#![deny(clippy::print_stdout, clippy::print_stderr)]

pub mod api;
pub mod app;
pub mod audit;
pub mod auth;
pub mod blocking;
pub mod contract;
pub mod edge;
pub mod error;
pub mod explain;
pub mod http;
pub mod ingest;
pub mod jobs;
pub mod limits;
pub mod metrics;
pub mod openapi;
pub mod outage;
pub mod serve;
pub mod state;
pub mod upload_gate;
pub mod web;
pub mod worker;

pub use app::{app, router, serve_probes, spawn_local};
pub use error::ApiError;
pub use http::serve_http;
pub use ingest::UploadLimits;
pub use limits::{
    HEADER_READ_TIMEOUT, JSON_BODY_LIMIT, MAX_CONCURRENT_UPLOADS, REQUEST_TIMEOUT, SHUTDOWN_DRAIN,
    UPLOAD_SLOT_WAIT,
};
pub use mtcal_domain::webhooks::TargetPolicy as WebhookPolicy;
pub use openapi::{ApiDoc, openapi_json};
pub use serve::{ServeConfig, run_workers, serve, shutdown_signal};
pub use state::{AppState, Settings};
pub use worker::{WorkerConfig, Workers};
