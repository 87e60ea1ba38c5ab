//! The statements of [`crate::Keys`]: API keys and the dashboard's sign-in sessions.

use super::{Backend, dialect, qualified, row_by_id};
use crate::error::{Db as _, StoreError};
use crate::keys::{ApiKey, NewKey, Scope};
use crate::model::*;
use crate::rows::{self, Columns, KEY_COLUMNS};
use crate::{Keys, StoreFuture, now_rfc3339};

impl Keys for Backend {
    fn create_key_in<'a>(
        &'a self,
        scope: Scope,
        label: &'a str,
        sites: &'a [String],
        tags: &'a [String],
    ) -> StoreFuture<'a, (ApiKey, String)> {
        Box::pin(async move {
            crate::text::check_line("label", label, crate::text::LABEL_MAX)?;
            crate::text::check_key_scope(sites, tags)?;
            let k = NewKey::generate_in(scope, label, sites, tags);
            run!(
                execute(&self.pool),
                "INSERT INTO api_keys (id, hash, prefix, scope, label, created_at, sites, tags) \
                 VALUES ($1, $2, $3, $4, $5, $6, $7, $8)",
                &k.key.id,
                &k.hash,
                &k.key.prefix,
                scope.as_str(),
                &k.key.label,
                &k.key.created_at,
                serde_json::to_string(sites).db()?,
                serde_json::to_string(tags).db()?
            )?;
            Ok((k.key, k.secret))
        })
    }

    fn key_by_secret<'a>(&'a self, secret: &'a str) -> StoreFuture<'a, Option<ApiKey>> {
        Box::pin(async move {
            let q = format!(
                "SELECT {KEY_COLUMNS} FROM api_keys WHERE hash = $1 AND revoked_at IS NULL"
            );
            let row = run!(
                fetch_optional(&self.pool),
                sqlx::AssertSqlSafe(q),
                crate::keys::hash_secret(secret)
            )?;
            row.as_ref().map(rows::api_key).transpose()
        })
    }

    fn list_keys(&self) -> StoreFuture<'_, Vec<ApiKey>> {
        Box::pin(async move {
            let q = format!("SELECT {KEY_COLUMNS} FROM api_keys ORDER BY created_at, id");
            sqlx::query(sqlx::AssertSqlSafe(q))
                .fetch_all(&self.pool)
                .await
                .db()?
                .iter()
                .map(rows::api_key)
                .collect()
        })
    }

    fn revoke_key<'a>(&'a self, id: &'a str) -> StoreFuture<'a, ApiKey> {
        Box::pin(async move {
            let mut tx = self.pool.begin().await.db()?;
            if !dialect::LOCK_KEYS.is_empty() {
                sqlx::query(dialect::LOCK_KEYS)
                    .execute(&mut *tx)
                    .await
                    .db()?;
            }
            // One statement: the last admin key of the whole group that is not revoked
            // stays (admin keys limited to sites or tags do not count).
            let done = run!(
                execute(&mut *tx),
                "UPDATE api_keys SET revoked_at = $2 WHERE id = $1 AND revoked_at IS NULL \
                 AND (scope <> 'admin' OR sites <> '[]' OR tags <> '[]' \
                      OR (SELECT COUNT(*) FROM api_keys WHERE scope = 'admin' \
                          AND sites = '[]' AND tags = '[]' AND revoked_at IS NULL) > 1)",
                id,
                now_rfc3339()
            )?;
            let q = format!("SELECT {KEY_COLUMNS} FROM api_keys WHERE id = $1");
            let key = rows::api_key(&row_by_id(&mut *tx, q, id, "key").await?)?;
            // Its sign-in sessions end with it.
            run!(
                execute(&mut *tx),
                "DELETE FROM sessions WHERE key_id = $1 AND $2 = 1",
                id,
                i64::from(key.revoked_at.is_some())
            )?;
            if done.rows_affected() == 0 && key.revoked_at.is_none() {
                tx.rollback().await.db()?;
                return Err(StoreError::Conflict(format!(
                    "key {id} is the last admin key of the whole group: create another before revoking it"
                )));
            }
            tx.commit().await.db()?;
            Ok(key)
        })
    }

    fn create_session<'a>(&'a self, key_id: &'a str, ttl_ms: i64) -> StoreFuture<'a, NewSession> {
        Box::pin(async move {
            let now = dialect::NOW_MS;
            let s = NewSession {
                token: crate::keys::generate_token(),
                csrf: crate::keys::generate_token(),
            };
            // Expired sessions go as new ones come (an index range at the table's start).
            let q = format!("DELETE FROM sessions WHERE expires_ms < {now}");
            sqlx::query(sqlx::AssertSqlSafe(q))
                .execute(&self.pool)
                .await
                .db()?;
            let q = format!(
                "INSERT INTO sessions (token_hash, key_id, csrf, created_ms, expires_ms) \
                 SELECT $1, id, $3, {now}, {now} + $4 FROM api_keys \
                 WHERE id = $2 AND revoked_at IS NULL"
            );
            let done = run!(
                execute(&self.pool),
                sqlx::AssertSqlSafe(q),
                crate::keys::hash_secret(&s.token),
                key_id,
                &s.csrf,
                ttl_ms
            )?;
            if done.rows_affected() == 0 {
                return Err(StoreError::NotFound(format!(
                    "key {key_id} (or it is revoked)"
                )));
            }
            Ok(s)
        })
    }

    fn session<'a>(&'a self, token: &'a str) -> StoreFuture<'a, Option<SessionRecord>> {
        Box::pin(async move {
            let q = format!(
                "SELECT {}, s.csrf AS csrf FROM sessions s JOIN api_keys k ON k.id = s.key_id \
                 WHERE s.token_hash = $1 AND s.expires_ms > {} AND k.revoked_at IS NULL",
                qualified("k", KEY_COLUMNS),
                dialect::NOW_MS
            );
            let row = run!(
                fetch_optional(&self.pool),
                sqlx::AssertSqlSafe(q),
                crate::keys::hash_secret(token)
            )?;
            row.map(|r| {
                Ok(SessionRecord {
                    key: rows::api_key(&r)?,
                    csrf: r.text("csrf")?,
                })
            })
            .transpose()
        })
    }

    fn end_session<'a>(&'a self, token: &'a str) -> StoreFuture<'a, ()> {
        Box::pin(async move {
            run!(
                execute(&self.pool),
                "DELETE FROM sessions WHERE token_hash = $1",
                crate::keys::hash_secret(token)
            )?;
            Ok(())
        })
    }
}
