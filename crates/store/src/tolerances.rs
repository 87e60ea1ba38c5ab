//! Tolerance profiles and the drift alerts they raise: [`Tolerances`].

use crate::StoreFuture;
use crate::model::{Alert, ToleranceProfile, WebhookDelivery};

/// Tolerance profiles (one per machine or tag) and the drift alerts raised against them.
/// Implementations must make each method atomic.
pub trait Tolerances: Send + Sync {
    /// Stores a new profile; one per (scope, target): a second is a
    /// [`crate::StoreError::Conflict`] naming the first.
    fn create_tolerance<'a>(&'a self, p: &'a ToleranceProfile)
    -> StoreFuture<'a, ToleranceProfile>;

    fn get_tolerance<'a>(&'a self, id: &'a str) -> StoreFuture<'a, ToleranceProfile>;

    /// Every profile, by scope then target (profiles are few: one per machine or tag at
    /// most).
    fn list_tolerances(&self) -> StoreFuture<'_, Vec<ToleranceProfile>>;

    /// Replaces the limits and the webhook (its URL and the key of its signatures) of the
    /// stored profile `p.id` with `p`'s; its scope, target and creation stay as stored.
    fn update_tolerance<'a>(&'a self, p: &'a ToleranceProfile)
    -> StoreFuture<'a, ToleranceProfile>;

    fn delete_tolerance<'a>(&'a self, id: &'a str) -> StoreFuture<'a, ()>;

    // Drift alerts.
    /// Stores an alert unless its result already raised one, with its webhook
    /// deliveries (`pending`, due now by the database's clock) in the same transaction;
    /// returns the stored alert (`None`: the result had one, e.g. a job run twice, and
    /// nothing is written).
    fn raise_alert<'a>(
        &'a self,
        a: &'a Alert,
        deliveries: &'a [WebhookDelivery],
    ) -> StoreFuture<'a, Option<Alert>>;

    fn get_alert<'a>(&'a self, id: &'a str) -> StoreFuture<'a, Alert>;

    /// Alerts newest first, of one machine or all, active only (`Some(true)`),
    /// acknowledged only (`Some(false)`) or both, at most `limit`.
    fn list_alerts<'a>(
        &'a self,
        machine_id: Option<&'a str>,
        active: Option<bool>,
        limit: i64,
    ) -> StoreFuture<'a, Vec<Alert>>;

    /// Acknowledges an alert (recorded with `by`, the time and the comment given);
    /// acknowledging an acknowledged alert keeps the first record.
    fn acknowledge_alert<'a>(
        &'a self,
        id: &'a str,
        by: &'a str,
        comment: Option<&'a str>,
    ) -> StoreFuture<'a, Alert>;
}
