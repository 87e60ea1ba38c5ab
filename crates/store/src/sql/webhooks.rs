//! The statements of [`crate::Webhooks`]: the outbox of webhook deliveries.

use super::{Backend, dialect};
use crate::error::Db as _;
use crate::model::*;
use crate::rows::{self, DELIVERY_COLUMNS};
use crate::{StoreFuture, Webhooks, now_rfc3339};

impl Webhooks for Backend {
    fn claim_delivery(&self, lease_ms: i64) -> StoreFuture<'_, Option<WebhookDelivery>> {
        Box::pin(async move {
            let q = format!(
                "UPDATE webhook_deliveries SET attempts = attempts + 1, \
                 next_attempt_ms = {now} + $1, updated_at = $2 \
                 WHERE id = (SELECT id FROM webhook_deliveries WHERE state = 'pending' \
                             AND next_attempt_ms <= {now} ORDER BY next_attempt_ms, id \
                             LIMIT 1 {lock}) \
                 AND state = 'pending' RETURNING {DELIVERY_COLUMNS}",
                now = dialect::NOW_MS,
                lock = dialect::CLAIM_LOCK
            );
            let row = run!(
                fetch_optional(&self.pool),
                sqlx::AssertSqlSafe(q),
                lease_ms,
                now_rfc3339()
            )?;
            row.as_ref().map(rows::delivery).transpose()
        })
    }

    fn finish_delivery<'a>(
        &'a self,
        id: &'a str,
        attempt: i64,
        outcome: &'a DeliveryOutcome,
    ) -> StoreFuture<'a, ()> {
        Box::pin(async move {
            let (state, after_ms, error) = match outcome {
                DeliveryOutcome::Delivered => ("delivered", 0, None),
                DeliveryOutcome::Retry { after_ms, error } => ("pending", *after_ms, Some(error)),
                DeliveryOutcome::Failed { error } => ("failed", 0, Some(error)),
            };
            let q = format!(
                "UPDATE webhook_deliveries SET state = $3, next_attempt_ms = {} + $4, \
                 last_error = COALESCE($5, last_error), updated_at = $6 \
                 WHERE id = $1 AND attempts = $2 AND state = 'pending'",
                dialect::NOW_MS
            );
            run!(
                execute(&self.pool),
                sqlx::AssertSqlSafe(q),
                id,
                attempt,
                state,
                after_ms,
                error,
                now_rfc3339()
            )?;
            Ok(())
        })
    }

    fn list_deliveries<'a>(
        &'a self,
        alert_id: Option<&'a str>,
        state: Option<&'a str>,
        limit: i64,
    ) -> StoreFuture<'a, Vec<WebhookDelivery>> {
        Box::pin(async move {
            let q = format!(
                "SELECT {DELIVERY_COLUMNS} FROM webhook_deliveries \
                 WHERE ($1 IS NULL OR alert_id = $1) AND ($2 IS NULL OR state = $2) \
                 ORDER BY created_at DESC, id DESC LIMIT $3"
            );
            run!(
                fetch_all(&self.pool),
                sqlx::AssertSqlSafe(q),
                alert_id,
                state,
                limit
            )?
            .iter()
            .map(rows::delivery)
            .collect()
        })
    }
}
