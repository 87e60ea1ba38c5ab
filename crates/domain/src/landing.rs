//! What follows when an identification result lands (the worker, after storing it): the
//! machine's fleet row is refreshed, then the drift alert check runs.

use crate::alerts::{self, AlertView};
use crate::fleet;
use mtcal_store::{Store, StoreError};
use std::sync::Arc;

/// An identification `result_id` of machine `machine_id` has landed: its drift row is
/// refreshed ([`fleet::refresh_machine`]), then the drift alert check runs
/// ([`alerts::check_landed`], its webhooks delivered where `webhooks` allows); the alert
/// raised, if any.
pub async fn result_landed(
    store: &Arc<dyn Store>,
    machine_id: &str,
    result_id: &str,
    webhooks: &crate::webhooks::TargetPolicy,
) -> Result<Option<AlertView>, StoreError> {
    fleet::refresh_machine(store.as_ref(), machine_id).await?;
    alerts::check_landed(store, machine_id, result_id, webhooks).await
}
