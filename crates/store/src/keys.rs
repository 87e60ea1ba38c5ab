//! API keys: random 128-bit secrets shown once, stored as their SHA-256; [`Keys`], the
//! store's keys and the dashboard's sign-in sessions.
//!
//! A key reads `mtk_<32 hex digits>`. Because the secret is uniformly random (not a
//! password), one SHA-256 is enough to make the stored hash useless to a reader of the
//! database; lookups are by hash.

use crate::StoreFuture;
pub use mtcal_api::keys::{ApiKey, Scope};
use rand::RngCore;
use sha2::{Digest, Sha256};

/// A key about to be stored: the record, the secret (shown once, never stored) and the
/// hash that is stored.
#[derive(Debug, Clone)]
pub struct NewKey {
    pub key: ApiKey,
    pub secret: String,
    pub hash: String,
}

impl NewKey {
    /// A fresh key of `scope` over the whole group, created now; its prefix is the
    /// secret's first 8 characters.
    pub fn generate(scope: Scope, label: &str) -> NewKey {
        NewKey::generate_in(scope, label, &[], &[])
    }

    /// A fresh key of `scope` limited to `sites` and `tags` (empty: no limit).
    pub fn generate_in(scope: Scope, label: &str, sites: &[String], tags: &[String]) -> NewKey {
        let secret = generate_secret();
        NewKey {
            key: ApiKey {
                id: crate::rules::new_id("key"),
                prefix: secret[..8].to_string(),
                scope,
                label: label.to_string(),
                created_at: crate::now_rfc3339(),
                revoked_at: None,
                sites: sites.to_vec(),
                tags: tags.to_vec(),
            },
            hash: hash_secret(&secret),
            secret,
        }
    }
}

/// A freshly generated secret.
pub fn generate_secret() -> String {
    let mut bytes = [0u8; 16];
    rand::rng().fill_bytes(&mut bytes);
    format!("mtk_{}", hex::encode(bytes))
}

/// A random token (128 bits, 32 hex digits): sessions and their CSRF tokens.
pub fn generate_token() -> String {
    let mut bytes = [0u8; 16];
    rand::rng().fill_bytes(&mut bytes);
    hex::encode(bytes)
}

/// A webhook's signing key: `whsec_` and 256 random bits (64 hex digits).
pub fn generate_webhook_secret() -> String {
    let mut bytes = [0u8; 32];
    rand::rng().fill_bytes(&mut bytes);
    format!("whsec_{}", hex::encode(bytes))
}

/// SHA-256 of a key, hex.
pub fn hash_secret(secret: &str) -> String {
    hex::encode(Sha256::digest(secret.as_bytes()))
}

/// API keys and the dashboard's sign-in sessions, kept by the database. Implementations
/// must make each method atomic.
pub trait Keys: Send + Sync {
    /// Creates a key of the whole group; returns it with the secret, which is not stored.
    fn create_key<'a>(&'a self, scope: Scope, label: &'a str) -> StoreFuture<'a, (ApiKey, String)> {
        self.create_key_in(scope, label, &[], &[])
    }

    /// Creates a key limited to `sites` and, within them, to machines with one of `tags`
    /// (either empty: no limit of that kind); returns it with the secret.
    fn create_key_in<'a>(
        &'a self,
        scope: Scope,
        label: &'a str,
        sites: &'a [String],
        tags: &'a [String],
    ) -> StoreFuture<'a, (ApiKey, String)>;

    fn key_by_secret<'a>(&'a self, secret: &'a str) -> StoreFuture<'a, Option<ApiKey>>;

    /// Every key, revoked ones included, oldest first (never a secret or a hash).
    fn list_keys(&self) -> StoreFuture<'_, Vec<ApiKey>>;

    /// Revokes key `id` (from now on it authenticates nothing, and its sign-in sessions
    /// end); revoking a revoked key keeps its first revocation time. Not found:
    /// [`crate::StoreError::NotFound`]; the last admin key that is not revoked:
    /// [`crate::StoreError::Conflict`] (nothing changed).
    fn revoke_key<'a>(&'a self, id: &'a str) -> StoreFuture<'a, ApiKey>;

    // Sign-in sessions (the dashboard's), kept by the database.
    /// Starts a session of key `key_id` ending `ttl_ms` from now by the database's clock;
    /// returns its token (stored as its SHA-256 only) and its CSRF token.
    fn create_session<'a>(&'a self, key_id: &'a str, ttl_ms: i64) -> StoreFuture<'a, NewSession>;

    /// The session `token` opens: None when it was ended, has expired (by the database's
    /// clock) or its key is revoked.
    fn session<'a>(&'a self, token: &'a str) -> StoreFuture<'a, Option<SessionRecord>>;

    /// Ends session `token` (signing out); ending an ended session does nothing.
    fn end_session<'a>(&'a self, token: &'a str) -> StoreFuture<'a, ()>;
}

/// A new sign-in session: its token (for the cookie; shown once, stored as its SHA-256)
/// and the CSRF token of its forms.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct NewSession {
    pub token: String,
    pub csrf: String,
}

/// A live sign-in session: its key (not revoked) and its forms' CSRF token.
#[derive(Debug, Clone, PartialEq)]
pub struct SessionRecord {
    pub key: crate::ApiKey,
    pub csrf: String,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scopes_are_ordered() {
        assert!(Scope::Admin.allows(Scope::Write));
        assert!(Scope::Write.allows(Scope::Read));
        assert!(!Scope::Read.allows(Scope::Write));
        assert!(!Scope::Write.allows(Scope::Admin));
    }

    #[test]
    fn secrets_are_distinct_and_hash_stably() {
        let a = generate_secret();
        let b = generate_secret();
        assert_ne!(a, b);
        assert_eq!(a.len(), 36);
        assert_eq!(hash_secret(&a), hash_secret(&a));
        assert_ne!(hash_secret(&a), hash_secret(&b));
    }
}
