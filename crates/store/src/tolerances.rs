//! Tolerance profiles and the drift alerts they raise: [`Tolerances`].

use crate::StoreFuture;
use crate::webhooks::WebhookDelivery;
use serde::{Deserialize, Serialize};
use serde_json::Value;

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

/// A tolerance profile as stored: the limits a machine's results are judged against,
/// for one machine (`scope` `machine`, `target` its id) or for every machine with a tag
/// (`scope` `tag`, `target` the tag). `limits` is the JSON of the solver's
/// `tolerance::Limits` (the service validates it); `webhook_url` (tag profiles) receives
/// the drift alerts of the tag's machines, signed with `webhook_secret`.
#[derive(Clone, PartialEq, Serialize, Deserialize)]
pub struct ToleranceProfile {
    pub id: String,
    pub scope: String,
    pub target: String,
    pub limits: Value,
    pub webhook_url: Option<String>,
    /// The key of the webhook's signatures: never shown, serialised or printed.
    #[serde(skip_serializing, default)]
    pub webhook_secret: Option<String>,
    pub created_at: String,
    pub updated_at: String,
}

impl std::fmt::Debug for ToleranceProfile {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ToleranceProfile")
            .field("id", &self.id)
            .field("scope", &self.scope)
            .field("target", &self.target)
            .field("limits", &self.limits)
            .field("webhook_url", &self.webhook_url)
            .field(
                "webhook_secret",
                &self.webhook_secret.as_ref().map(|_| "(set)"),
            )
            .field("created_at", &self.created_at)
            .field("updated_at", &self.updated_at)
            .finish()
    }
}

/// What raised a drift alert: the landed result `result_id` of `machine_id` changed since
/// `baseline_result_id` beyond the drift threshold of `profile_id`, at `raised_at`. Held
/// by the stored alert ([`Alert`]) and by the alert the API shows, alike.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct AlertRaised {
    pub id: String,
    pub machine_id: String,
    /// The landed result whose change raised it.
    pub result_id: String,
    /// The baseline the change is measured from.
    pub baseline_result_id: String,
    /// The tolerance profile whose drift threshold was exceeded.
    pub profile_id: String,
    /// RFC 3339.
    pub raised_at: String,
    /// One line saying what changed, by how much, against which threshold.
    pub message: String,
}

/// A drift alert as stored: raised when `result_id` landed with a change since
/// `baseline_result_id` beyond the drift threshold of `profile_id` by more than the
/// expanded uncertainty. `items` is the JSON of the alerting verdict items. Active until
/// acknowledged.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Alert {
    #[serde(flatten)]
    pub raised: AlertRaised,
    pub items: Value,
    /// What each change is the difference of, with the dates (JSON; `None` for alerts
    /// raised by an older version).
    #[serde(default)]
    pub details: Option<Value>,
    pub acknowledged_at: Option<String>,
    /// The key that acknowledged it (`key <id> (<label>)`).
    pub acknowledged_by: Option<String>,
    /// What the person who acknowledged it wrote (why, what was done).
    #[serde(default)]
    pub acknowledgement_comment: Option<String>,
}
