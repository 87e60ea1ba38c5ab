//! API keys: what a key may do, a key as listed (never its secret), a key to create and a
//! key just created (its secret shown this once).

use serde::{Deserialize, Serialize};

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
    /// The sites the key acts on (empty: the whole group). A machine without a site is
    /// in the site [`DEFAULT_SITE`].
    #[serde(default)]
    pub sites: Vec<String>,
    /// Within those sites, only machines with at least one of these tags (empty: every
    /// machine of the sites).
    #[serde(default)]
    pub tags: Vec<String>,
}

/// The site of a machine that names none (machines registered before sites existed).
pub const DEFAULT_SITE: &str = "default";

/// The site a machine is in: its own, else [`DEFAULT_SITE`].
pub fn site_of(site: Option<&str>) -> &str {
    site.unwrap_or(DEFAULT_SITE)
}

impl ApiKey {
    /// Whether the key covers the whole group (no site and no tag list).
    pub fn is_group(&self) -> bool {
        self.sites.is_empty() && self.tags.is_empty()
    }

    /// Whether a machine of `site` with `tags` is within the key's scope.
    pub fn covers(&self, site: Option<&str>, tags: &[String]) -> bool {
        let site = site_of(site);
        (self.sites.is_empty() || self.sites.iter().any(|s| s == site))
            && (self.tags.is_empty() || self.tags.iter().any(|t| tags.contains(t)))
    }

    /// Whether a scope of `sites` and `tags` lies within this key's scope (no wider):
    /// every site of it is one of the key's (or the key has no site list), and likewise
    /// its tags.
    pub fn contains(&self, sites: &[String], tags: &[String]) -> bool {
        let within = |mine: &[String], theirs: &[String]| {
            mine.is_empty() || (!theirs.is_empty() && theirs.iter().all(|t| mine.contains(t)))
        };
        within(&self.sites, sites) && within(&self.tags, tags)
    }
}

#[derive(Debug, Clone, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
#[serde(deny_unknown_fields)]
pub struct NewKey {
    pub scope: Scope,
    /// Not blank, at most 200 characters, no control character.
    #[cfg_attr(feature = "openapi", schema(schema_with = crate::schemas::label))]
    pub label: String,
    /// The sites the key acts on (absent or empty: the whole group, which only a key of
    /// the whole group may give).
    #[serde(default)]
    pub sites: Vec<String>,
    /// Within them, only machines with one of these tags (absent or empty: all).
    #[serde(default)]
    pub tags: Vec<String>,
}

/// A new key: `secret` is shown this once and not stored.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct CreatedKey {
    pub key: ApiKey,
    pub secret: String,
}
