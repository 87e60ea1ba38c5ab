//! The statements of [`crate::Tolerances`]: tolerance profiles and the drift alerts
//! they raise.

use super::{Backend, dialect, row_by_id};
use crate::error::{Db as _, StoreError, unique_conflict};
use crate::model::*;
use crate::rows;
use crate::{StoreFuture, Tolerances, now_rfc3339};

impl Tolerances for Backend {
    fn create_tolerance<'a>(
        &'a self,
        p: &'a ToleranceProfile,
    ) -> StoreFuture<'a, ToleranceProfile> {
        Box::pin(async move {
            crate::text::check_line("target", &p.target, crate::text::TARGET_MAX)?;
            let now = now_rfc3339();
            bound!(
                "INSERT INTO tolerance_profiles (id, scope, target, limits, webhook_url, \
                 webhook_secret, created_at, updated_at) VALUES ($1, $2, $3, $4, $5, $6, $7, $7)",
                &p.id,
                &p.scope,
                &p.target,
                serde_json::to_string(&p.limits).db()?,
                &p.webhook_url,
                &p.webhook_secret,
                &now
            )
            .execute(&self.pool)
            .await
            .map_err(|e| {
                unique_conflict(e, || {
                    format!("{} {} already has a tolerance profile", p.scope, p.target)
                })
            })?;
            self.get_tolerance(&p.id).await
        })
    }

    fn get_tolerance<'a>(&'a self, id: &'a str) -> StoreFuture<'a, ToleranceProfile> {
        Box::pin(async move {
            let q = format!(
                "SELECT {} FROM tolerance_profiles WHERE id = $1",
                rows::TOLERANCE_COLUMNS
            );
            rows::tolerance(&row_by_id(&self.pool, q, id, "tolerance profile").await?)
        })
    }

    fn list_tolerances(&self) -> StoreFuture<'_, Vec<ToleranceProfile>> {
        Box::pin(async move {
            let q = format!(
                "SELECT {} FROM tolerance_profiles ORDER BY scope, target",
                rows::TOLERANCE_COLUMNS
            );
            sqlx::query(sqlx::AssertSqlSafe(q))
                .fetch_all(&self.pool)
                .await
                .db()?
                .iter()
                .map(rows::tolerance)
                .collect()
        })
    }

    fn update_tolerance<'a>(
        &'a self,
        p: &'a ToleranceProfile,
    ) -> StoreFuture<'a, ToleranceProfile> {
        Box::pin(async move {
            let done = run!(
                execute(&self.pool),
                "UPDATE tolerance_profiles SET limits = $2, webhook_url = $3, updated_at = $4, \
                 webhook_secret = $5 WHERE id = $1",
                &p.id,
                serde_json::to_string(&p.limits).db()?,
                &p.webhook_url,
                now_rfc3339(),
                &p.webhook_secret
            )?;
            if done.rows_affected() == 0 {
                return Err(StoreError::NotFound(format!("tolerance profile {}", p.id)));
            }
            self.get_tolerance(&p.id).await
        })
    }

    fn delete_tolerance<'a>(&'a self, id: &'a str) -> StoreFuture<'a, ()> {
        Box::pin(async move {
            let done = run!(
                execute(&self.pool),
                "DELETE FROM tolerance_profiles WHERE id = $1",
                id
            )?;
            if done.rows_affected() == 0 {
                return Err(StoreError::NotFound(format!("tolerance profile {id}")));
            }
            Ok(())
        })
    }

    fn raise_alert<'a>(
        &'a self,
        a: &'a Alert,
        deliveries: &'a [WebhookDelivery],
    ) -> StoreFuture<'a, Option<Alert>> {
        Box::pin(async move {
            let mut tx = self.pool.begin().await.db()?;
            let done = run!(
                execute(&mut *tx),
                "INSERT INTO alerts (id, machine_id, result_id, baseline_result_id, profile_id, \
                 raised_at, message, items, details, acknowledged_at, acknowledged_by, \
                 acknowledgement_comment) \
                 VALUES ($1, $2, $3, $4, $5, $6, $7, $8, $9, NULL, NULL, NULL) \
                 ON CONFLICT (result_id) DO NOTHING",
                &a.raised.id,
                &a.raised.machine_id,
                &a.raised.result_id,
                &a.raised.baseline_result_id,
                &a.raised.profile_id,
                &a.raised.raised_at,
                &a.raised.message,
                serde_json::to_string(&a.items).db()?,
                match &a.details {
                    Some(d) => Some(serde_json::to_string(d).db()?),
                    None => None,
                }
            )?;
            if done.rows_affected() == 0 {
                tx.rollback().await.db()?;
                return Ok(None);
            }
            let now = now_rfc3339();
            for d in deliveries {
                let q = format!(
                    "INSERT INTO webhook_deliveries (id, alert_id, profile_id, url, body, state, \
                     attempts, next_attempt_ms, last_error, created_at, updated_at) \
                     VALUES ($1, $2, $3, $4, $5, 'pending', 0, {}, NULL, $6, $6)",
                    dialect::NOW_MS
                );
                run!(
                    execute(&mut *tx),
                    sqlx::AssertSqlSafe(q),
                    &d.id,
                    &a.raised.id,
                    &d.profile_id,
                    &d.url,
                    &d.body,
                    &now
                )?;
            }
            tx.commit().await.db()?;
            self.get_alert(&a.raised.id).await.map(Some)
        })
    }

    fn get_alert<'a>(&'a self, id: &'a str) -> StoreFuture<'a, Alert> {
        Box::pin(async move {
            let q = format!("SELECT {} FROM alerts WHERE id = $1", rows::ALERT_COLUMNS);
            rows::alert(&row_by_id(&self.pool, q, id, "alert").await?)
        })
    }

    fn list_alerts<'a>(
        &'a self,
        machine_id: Option<&'a str>,
        active: Option<bool>,
        limit: i64,
    ) -> StoreFuture<'a, Vec<Alert>> {
        Box::pin(async move {
            let state = match active {
                Some(true) => " AND acknowledged_at IS NULL",
                Some(false) => " AND acknowledged_at IS NOT NULL",
                None => "",
            };
            let q = format!(
                "SELECT {} FROM alerts WHERE ($1 IS NULL OR machine_id = $1){state} \
                 ORDER BY raised_at DESC, id DESC LIMIT $2",
                rows::ALERT_COLUMNS
            );
            run!(
                fetch_all(&self.pool),
                sqlx::AssertSqlSafe(q),
                machine_id,
                limit
            )?
            .iter()
            .map(rows::alert)
            .collect()
        })
    }

    fn acknowledge_alert<'a>(
        &'a self,
        id: &'a str,
        by: &'a str,
        comment: Option<&'a str>,
    ) -> StoreFuture<'a, Alert> {
        Box::pin(async move {
            crate::text::check_line("by", by, crate::text::BY_MAX)?;
            run!(
                execute(&self.pool),
                "UPDATE alerts SET acknowledged_at = $2, acknowledged_by = $3, \
                 acknowledgement_comment = $4 WHERE id = $1 AND acknowledged_at IS NULL",
                id,
                now_rfc3339(),
                by,
                comment
            )?;
            self.get_alert(id).await
        })
    }
}
