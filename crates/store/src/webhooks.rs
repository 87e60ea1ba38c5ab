//! The webhook outbox: [`Webhooks`].

use crate::StoreFuture;
use crate::model::{DeliveryOutcome, WebhookDelivery};

/// The outbox of webhook deliveries (written with their alert by
/// [`crate::Tolerances::raise_alert`]). Implementations must make each method atomic.
pub trait Webhooks: Send + Sync {
    /// Claims the oldest due `pending` delivery for one try: its attempts counted and its
    /// next try moved `lease_ms` ahead (database clock), so that a try whose worker dies
    /// is made again then; `None` when none is due.
    fn claim_delivery(&self, lease_ms: i64) -> StoreFuture<'_, Option<WebhookDelivery>>;

    /// Records the outcome of the try claimed as attempt `attempt` (a stale claim,
    /// whose delivery was claimed again since, changes nothing).
    fn finish_delivery<'a>(
        &'a self,
        id: &'a str,
        attempt: i64,
        outcome: &'a DeliveryOutcome,
    ) -> StoreFuture<'a, ()>;

    /// Deliveries newest first, of one alert or all, of one state or all, at most
    /// `limit`.
    fn list_deliveries<'a>(
        &'a self,
        alert_id: Option<&'a str>,
        state: Option<&'a str>,
        limit: i64,
    ) -> StoreFuture<'a, Vec<WebhookDelivery>>;
}
