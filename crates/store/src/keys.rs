//! API keys: random 128-bit secrets shown once, stored as their SHA-256.
//!
//! A key reads `mtk_<32 hex digits>`. Because the secret is uniformly random (not a
//! password), one SHA-256 is enough to make the stored hash useless to a reader of the
//! database; lookups are by hash.

use rand::RngCore;
use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};

/// What a key may do. Scopes are ordered: admin ⊃ write ⊃ read.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
#[serde(rename_all = "lowercase")]
pub enum Scope {
    Read,
    Write,
    Admin,
}

impl Scope {
    pub fn as_str(self) -> &'static str {
        match self {
            Scope::Read => "read",
            Scope::Write => "write",
            Scope::Admin => "admin",
        }
    }

    pub fn parse(s: &str) -> Option<Scope> {
        Some(match s {
            "read" => Scope::Read,
            "write" => Scope::Write,
            "admin" => Scope::Admin,
            _ => return None,
        })
    }

    /// Whether a key of this scope may do what `needed` requires.
    pub fn allows(self, needed: Scope) -> bool {
        self >= needed
    }
}

/// A stored key (never the secret).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct ApiKey {
    pub id: String,
    pub prefix: String,
    pub scope: Scope,
    pub label: String,
    pub created_at: String,
    /// When the key was revoked (RFC 3339); a revoked key authenticates nothing.
    pub revoked_at: Option<String>,
}

/// A key about to be stored: the record, the secret (shown once, never stored) and the
/// hash that is stored.
#[derive(Debug, Clone)]
pub struct NewKey {
    pub key: ApiKey,
    pub secret: String,
    pub hash: String,
}

impl NewKey {
    /// A fresh key of `scope`, created now; its prefix is the secret's first 8 characters.
    pub fn generate(scope: Scope, label: &str) -> NewKey {
        let secret = generate_secret();
        NewKey {
            key: ApiKey {
                id: crate::rules::new_id("key"),
                prefix: secret[..8].to_string(),
                scope,
                label: label.to_string(),
                created_at: crate::now_rfc3339(),
                revoked_at: None,
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
