//! The state every handler shares: the store, the upload limits, the job settings, the
//! service's settings and the worker wake-up signal.

use crate::ingest::UploadLimits;
use mtcal_store::Store;
use std::sync::Arc;

/// Settings of the service an operator chooses (`mtcal serve` flags and environment;
/// docs/api.md, "Operations").
#[derive(Debug, Clone, Default)]
pub struct Settings {
    /// Mark the sign-in cookies `Secure` on every answer (`MTCAL_COOKIE_SECURE`). They
    /// are anyway when the request came over TLS, as a TLS-terminating proxy says with
    /// `X-Forwarded-Proto: https`.
    pub cookie_secure: bool,
}

/// Shared state of the handlers (cheap to clone: everything is behind `Arc`s or `Copy`).
#[derive(Clone)]
pub struct AppState {
    pub store: Arc<dyn Store>,
    pub limits: UploadLimits,
    /// Attempts given to each submitted job.
    pub max_attempts: i64,
    /// Signalled on every enqueued job (wakes an idle worker of this process).
    pub wake: Arc<tokio::sync::Notify>,
    pub settings: Arc<Settings>,
    /// Whether the database answers (crate::outage).
    pub database: Arc<crate::outage::Database>,
}
