//! Handlers, one module per resource.

pub mod datasets;
pub mod history;
pub mod jobs;
pub mod keys;
pub mod machines;
pub mod trends;

use axum::Json;
use serde::{Deserialize, Serialize};
use utoipa::ToSchema;

#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
pub struct Health {
    pub status: String,
    pub version: String,
}

/// Liveness (no key needed).
#[utoipa::path(operation_id = "health", get, path = "/health", tag = "service", responses((status = 200, body = Health)))]
pub async fn health() -> Json<Health> {
    Json(Health {
        status: "ok".into(),
        version: env!("CARGO_PKG_VERSION").into(),
    })
}
