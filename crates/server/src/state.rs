//! The state every handler shares: the store, the upload limits, the job settings and the
//! worker wake-up signal.

use crate::ingest::UploadLimits;
use mtcal_store::Store;
use std::sync::Arc;

/// Shared state of the handlers (cheap to clone: everything is behind `Arc`s or `Copy`).
#[derive(Clone)]
pub struct AppState {
    pub store: Arc<dyn Store>,
    pub limits: UploadLimits,
    /// Attempts given to each submitted job.
    pub max_attempts: i64,
    /// Signalled on every enqueued job (wakes an idle worker of this process).
    pub wake: Arc<tokio::sync::Notify>,
}
