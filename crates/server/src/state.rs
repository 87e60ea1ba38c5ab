//! The state every handler shares: the store, the upload limits, the job settings, the
//! service's settings and the worker wake-up signal.

use crate::ingest::UploadLimits;
use mtcal_store::Store;
use std::sync::Arc;

/// Settings of the service an operator chooses (`mtcal serve` flags and environment;
/// docs/operations.md, "Operations").
#[derive(Debug, Clone)]
pub struct Settings {
    /// Mark the sign-in cookies `Secure` on every answer (`MTCAL_COOKIE_SECURE`). They
    /// are anyway when the request came over TLS, as a TLS-terminating proxy says with
    /// `X-Forwarded-Proto: https`.
    pub cookie_secure: bool,
    /// Slowest average an upload's body may arrive at once past `upload_grace`, bytes
    /// per second (0: no minimum; crate::upload_gate).
    pub min_upload_rate: u64,
    /// Time an upload has before its minimum rate applies.
    pub upload_grace: std::time::Duration,
    /// Longest an upload may hold its reading slot, from taking it to its answer
    /// (reading, checking, storing); past it, 408 (crate::upload_gate).
    pub upload_slot_time: std::time::Duration,
    /// Where drift alert webhooks may go (`MTCAL_WEBHOOK_ALLOW`, the service's own
    /// address; mtcal_domain::webhooks).
    pub webhooks: mtcal_domain::webhooks::TargetPolicy,
    /// How the workers try webhook deliveries (mtcal_domain::webhooks::Retries).
    pub webhook_retries: mtcal_domain::webhooks::Retries,
    /// The token a scraper of `/metrics` sends instead of an admin key of the whole group
    /// (`MTCAL_METRICS_TOKEN`; crate::metrics): read without the database, so the
    /// metrics answer during an outage too. `None`: admin keys only.
    pub metrics_token: Option<String>,
}

impl Settings {
    /// Default minimum upload rate, bytes per second (16 KiB/s: a 100 MB upload in under
    /// two hours; any plant network is far faster).
    pub const MIN_UPLOAD_RATE: u64 = 16 * 1024;
    /// Default grace period of an upload.
    pub const UPLOAD_GRACE: std::time::Duration = std::time::Duration::from_secs(10);
    /// Default longest hold of an upload slot (120 s: a 256 MiB upload needs about
    /// 2.2 MB/s, a tenth of a 100 Mbit/s plant network).
    pub const UPLOAD_SLOT_TIME: std::time::Duration = std::time::Duration::from_secs(120);
}

impl Default for Settings {
    fn default() -> Self {
        Settings {
            cookie_secure: false,
            min_upload_rate: Self::MIN_UPLOAD_RATE,
            upload_grace: Self::UPLOAD_GRACE,
            upload_slot_time: Self::UPLOAD_SLOT_TIME,
            webhooks: Default::default(),
            webhook_retries: Default::default(),
            metrics_token: None,
        }
    }
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
    /// The upload slots every upload route shares (crate::upload_gate).
    pub uploads: crate::upload_gate::Gate,
    /// The fleet's totals and filter choices this process keeps for a few seconds
    /// (mtcal_domain::fleet::page::FleetCountCache; forgotten when it writes a machine).
    pub fleet_counts: Arc<mtcal_domain::fleet::page::FleetCountCache>,
}
