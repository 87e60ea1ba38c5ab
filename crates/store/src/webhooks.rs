//! The webhook outbox: [`Webhooks`].

use crate::StoreFuture;

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

/// The states of a webhook delivery of the outbox: `pending` (to be tried, at
/// `next_attempt_ms` of the database's clock), `delivered` (a try was answered 2xx),
/// `failed` (its tries are used up, or its target was refused).
pub const DELIVERY_STATES: [&str; 3] = ["pending", "delivered", "failed"];

/// A webhook delivery of the outbox: alert `alert_id` POSTed to the webhook of profile
/// `profile_id` at `url`, `body` the exact bytes sent (and signed). Written with its
/// alert, in the same transaction; tried by the workers.
#[derive(Clone, PartialEq, Eq)]
pub struct WebhookDelivery {
    pub id: String,
    pub alert_id: String,
    pub profile_id: String,
    pub url: String,
    pub body: String,
    /// One of [`DELIVERY_STATES`].
    pub state: String,
    /// Tries made (a claimed try counts).
    pub attempts: i64,
    /// When it is tried next, or was last claimed (database clock, ms since the epoch).
    pub next_attempt_ms: i64,
    /// Why the last try failed.
    pub last_error: Option<String>,
    pub created_at: String,
    pub updated_at: String,
}

impl std::fmt::Debug for WebhookDelivery {
    /// Without the URL (its query may hold a token) or the body.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("WebhookDelivery")
            .field("id", &self.id)
            .field("alert_id", &self.alert_id)
            .field("profile_id", &self.profile_id)
            .field("state", &self.state)
            .field("attempts", &self.attempts)
            .field("next_attempt_ms", &self.next_attempt_ms)
            .field("last_error", &self.last_error)
            .finish_non_exhaustive()
    }
}

/// What became of a claimed try of a webhook delivery.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum DeliveryOutcome {
    Delivered,
    /// Try again `after_ms` from now (database clock).
    Retry {
        after_ms: i64,
        error: String,
    },
    /// No more tries.
    Failed {
        error: String,
    },
}
