//! The audit trail's side of HTTP: who made a change and from where ([`Actor`]), and
//! the recording of one change ([`Actor::record`]) by the route that made it.
//!
//! Every route that changes state a person decides records one event once the change
//! is made: the actor (the request's API key, or the key a dashboard session signed in
//! with), the action and its target, the target's JSON before and after, the time and
//! the client's address. The table is append-only (its triggers, `mtcal_store::audit`).
//! When the event cannot be written the answer is the store's error (503 when the
//! database is unreachable), so that a caller never takes an unrecorded change for a
//! recorded one; the log names the event.

use crate::error::ApiError;
use axum::extract::{ConnectInfo, FromRequestParts};
use axum::http::request::Parts;
use mtcal_store::{ApiKey, NewAuditEvent, Store};
use serde::Serialize;
use serde_json::Value;
use std::net::SocketAddr;

/// Who makes a request, and from where.
#[derive(Debug, Clone)]
pub struct Actor {
    /// The key's id; empty when none was recognised.
    pub key_id: String,
    /// `key ID (LABEL)`, as acknowledgements and exclusions record who gave them.
    pub by: String,
    /// The key's label and prefix.
    pub name: String,
    /// `api` or `dashboard`.
    pub via: &'static str,
    /// The client's address (the connection's peer).
    pub client: Option<String>,
    /// The key itself, whose scope limits what the request reaches (None: unknown).
    pub key: Option<ApiKey>,
}

/// One change to record: what, on which target, and the target before and after.
#[derive(Debug, Clone, Default)]
pub struct Change<'a> {
    pub action: &'a str,
    pub target: &'a str,
    pub machine: Option<&'a str>,
    pub before: Option<Value>,
    pub after: Option<Value>,
}

/// `v` as JSON (a record the service answers with serialises; `None` if one did not).
pub fn json<T: Serialize>(v: &T) -> Option<Value> {
    serde_json::to_value(v).ok()
}

/// The client address of a request (the connection's peer), when the server knows it.
pub fn client_of(parts: &Parts) -> Option<String> {
    parts
        .extensions
        .get::<ConnectInfo<SocketAddr>>()
        .map(|c| c.0.ip().to_string())
}

impl Actor {
    /// The holder of `key`, through `via`.
    pub fn of_key(key: &ApiKey, via: &'static str, client: Option<String>) -> Actor {
        Actor {
            key_id: key.id.clone(),
            by: format!("key {} ({})", key.id, key.label),
            name: format!("{} ({})", key.label, key.prefix),
            via,
            client,
            key: Some(key.clone()),
        }
    }

    /// The scope of the actor's key (`crate::auth::scope`); an unknown key reaches
    /// nothing (401).
    pub fn within(&self) -> Result<crate::auth::scope::Within<'_>, ApiError> {
        self.key
            .as_ref()
            .map(crate::auth::scope::Within)
            .ok_or_else(|| ApiError::Unauthorized("unknown key".into()))
    }

    /// Someone whose key was not recognised (a failed sign-in).
    pub fn unknown(via: &'static str, client: Option<String>) -> Actor {
        Actor {
            key_id: String::new(),
            by: "unknown key".into(),
            name: "unknown key".into(),
            via,
            client,
            key: None,
        }
    }

    /// Appends `change` to the audit trail; a request that changed nothing (the same
    /// record before and after: excluding an excluded result, revoking a revoked key) is
    /// no event.
    pub async fn record(&self, store: &dyn Store, change: Change<'_>) -> Result<(), ApiError> {
        if change.before.is_some() && change.before == change.after {
            return Ok(());
        }
        let event = NewAuditEvent {
            actor: self.key_id.clone(),
            actor_name: self.name.clone(),
            via: self.via.into(),
            action: change.action.into(),
            target: change.target.into(),
            machine_id: change.machine.map(str::to_string),
            before: change.before,
            after: change.after,
            client: self.client.clone(),
        };
        if let Err(e) = store.record_audit(&event).await {
            tracing::error!(action = %event.action, target = %event.target, actor = %event.actor,
                %e, "a change was made but its audit event could not be written");
            return Err(e.into());
        }
        Ok(())
    }
}

/// The actor of an API request: its key (put there by [`crate::auth::authenticate`]),
/// through `api`. A route takes it beside the scope extractor that checks the key.
impl FromRequestParts<crate::AppState> for Actor {
    type Rejection = ApiError;

    async fn from_request_parts(
        parts: &mut Parts,
        state: &crate::AppState,
    ) -> Result<Self, ApiError> {
        let key = match parts.extensions.get::<ApiKey>() {
            Some(k) => k.clone(),
            None => crate::auth::key_of(state, &parts.headers).await?,
        };
        Ok(Actor::of_key(&key, "api", client_of(parts)))
    }
}

/// The client address of a request, for routes that know their actor otherwise (the
/// dashboard's forms: the session's key).
#[derive(Debug, Clone)]
pub struct Client(pub Option<String>);

impl<S: Send + Sync> FromRequestParts<S> for Client {
    type Rejection = std::convert::Infallible;

    async fn from_request_parts(parts: &mut Parts, _: &S) -> Result<Self, Self::Rejection> {
        Ok(Client(client_of(parts)))
    }
}
