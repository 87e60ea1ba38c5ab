//! Handlers, one module per resource.

pub mod alerts;
pub mod datasets;
pub mod exports;
pub mod fleet;
pub mod history;
pub mod jobs;
pub mod keys;
pub mod machines;
pub mod tolerances;
pub mod trends;
pub mod webhooks;

use crate::AppState;
use crate::error::{ApiError, ErrorBody};
use axum::Json;
use axum::extract::State;
pub use mtcal_api::service::Health;
use serde::{Deserialize, Serialize};
use std::time::Duration;
use utoipa::ToSchema;

/// Liveness (no key needed): the process answers; says nothing of the database (see
/// [`ready`]).
#[utoipa::path(operation_id = "health", summary = "Liveness", get, path = "/health", tag = "service", responses((status = 200, body = Health)))]
pub async fn health() -> Json<Health> {
    Json(Health {
        status: "ok".into(),
        version: env!("CARGO_PKG_VERSION").into(),
    })
}

#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
pub struct Ready {
    /// `ready`.
    pub status: String,
    pub version: String,
    /// `up`: the database answered this probe.
    pub database: String,
}

/// How long `/ready` waits for the database before it answers 503.
pub const READY_TIMEOUT: Duration = Duration::from_secs(3);

/// Readiness (no key needed): the database answers within 3 s and has every migration
/// this build embeds. 503 with the reason and `Retry-After` otherwise (the database
/// marked down for the other routes, crate::outage), so a load balancer or an
/// orchestrator sends no traffic to a process that cannot serve it.
#[utoipa::path(operation_id = "ready", summary = "Readiness: database reachable, migrations applied", get, path = "/ready", tag = "service",
    responses((status = 200, body = Ready),
              (status = 503, body = ErrorBody, description = "database down (`database: down` in the message) or migrations missing; with Retry-After")))]
pub async fn ready(State(s): State<AppState>) -> Result<Json<Ready>, ApiError> {
    let pending = tokio::time::timeout(READY_TIMEOUT, crate::outage::probe(&s))
        .await
        .map_err(|_| {
            s.database.mark_down();
            ApiError::NotReady(format!(
                "database: down (it did not answer within {} s)",
                READY_TIMEOUT.as_secs()
            ))
        })?
        .map_err(|e| ApiError::NotReady(format!("database: down ({e})")))?;
    if !pending.is_empty() {
        return Err(ApiError::NotReady(format!(
            "migrations not applied: {pending:?}"
        )));
    }
    Ok(Json(Ready {
        status: "ready".into(),
        version: env!("CARGO_PKG_VERSION").into(),
        database: "up".into(),
    }))
}
