//! Tolerance profiles: what they hold, which one applies to a machine, and the rules of
//! their content. The verdict of a result against them is the module `verdicts`.
//!
//! A profile holds the solver's [`Limits`] (per error function over the measured travel,
//! per squareness, per figure of the standards, and the drift thresholds) for one
//! machine (`scope` `machine`) or for every machine with a tag (`scope` `tag`).
//!
//! **Which profile applies** to a machine: its own profile when it has one; otherwise
//! the profile of the first of the machine's tags, in the order the machine lists them,
//! that has one; otherwise none (the result has no verdict). Profiles are not merged.
//!

use crate::error::DomainError;
pub use mtcal_api::tolerances::Profile;
use mtcal_solver::tolerance::Limits;
use mtcal_store::{Machine, Store, StoreError, ToleranceProfile};
use serde::Deserialize;

/// The two scopes of a profile.
pub const SCOPES: [&str; 2] = ["machine", "tag"];

/// The profile that applies to `m` (see the module documentation for the rule).
pub fn applicable<'a>(
    profiles: &'a [ToleranceProfile],
    m: &Machine,
) -> Option<&'a ToleranceProfile> {
    profiles
        .iter()
        .find(|p| p.scope == "machine" && p.target == m.id)
        .or_else(|| {
            m.tags
                .iter()
                .find_map(|t| profiles.iter().find(|p| p.scope == "tag" && &p.target == t))
        })
}

/// The limits a stored profile holds (validated when it was written).
pub fn limits(p: &ToleranceProfile) -> Result<Limits, StoreError> {
    serde_json::from_value(p.limits.clone()).map_err(|e| {
        StoreError::Backend(format!(
            "tolerance profile {} does not read as limits: {e}",
            p.id
        ))
    })
}

/// Longest profile target (machine id or tag), characters.
pub use mtcal_store::text::TARGET_MAX;

/// The profile as the API answers it, from the stored one.
pub fn profile_of(p: &ToleranceProfile) -> Result<Profile, StoreError> {
    Ok(Profile {
        id: p.id.clone(),
        scope: p.scope.clone(),
        target: p.target.clone(),
        limits: limits(p)?,
        webhook_url: p.webhook_url.clone(),
        webhook_signed: p.webhook_url.is_some() && p.webhook_secret.is_some(),
        webhook_secret: None,
        created_at: p.created_at.clone(),
        updated_at: p.updated_at.clone(),
    })
}

/// The profile as a key of `scope` may see it: below write scope, the webhook URL's
/// path and query (which may carry a receiver's token) are left out.
pub fn seen_by(mut p: Profile, scope: mtcal_store::Scope) -> Profile {
    if !scope.allows(mtcal_store::Scope::Write) {
        p.webhook_url = p.webhook_url.as_deref().map(crate::webhooks::host_only);
    }
    p
}

/// The profile as the audit trail keeps it (the API's and `mtcal admin`'s events): its
/// webhook as a read key sees it (the host, not a token in its query), never its signing
/// secret.
pub fn audited(p: &Profile) -> Profile {
    let mut p = seen_by(p.clone(), mtcal_store::Scope::Read);
    p.webhook_secret = None;
    p
}

/// The machine a profile's change concerns (a machine profile's target), if any.
pub fn machine_of(p: &Profile) -> Option<&str> {
    (p.scope == "machine").then_some(p.target.as_str())
}

/// A new tolerance profile.
#[derive(Debug, Clone, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
#[serde(deny_unknown_fields)]
pub struct NewProfile {
    /// `machine` or `tag`.
    #[cfg_attr(feature = "openapi", schema(pattern = "^(machine|tag)$"))]
    pub scope: String,
    /// The machine id (it must exist) or the tag (not blank, at most 200 characters, no
    /// control character).
    #[cfg_attr(
        feature = "openapi",
        schema(
            max_length = 200,
            pattern = "^[^\\u0000-\\u001f\\u007f-\\u009f]*[^\\s\\u0000-\\u001f\\u007f-\\u009f][^\\u0000-\\u001f\\u007f-\\u009f]*$"
        )
    )]
    pub target: String,
    /// At least one limit; each positive and finite, names as in docs/api.md.
    pub limits: Limits,
    /// Tag profiles only: an `http` or `https` URL receiving the drift alerts.
    #[serde(default)]
    #[cfg_attr(feature = "openapi", schema(max_length = 2000))]
    pub webhook_url: Option<String>,
    /// The key of the webhook's signatures (16 to 256 visible ASCII characters);
    /// absent: one is generated and shown once in the answer. Never shown again.
    #[serde(default)]
    #[cfg_attr(feature = "openapi", schema(pattern = "^[!-~]{16,256}$"))]
    pub webhook_secret: Option<String>,
}

/// A profile's new content (replaces limits and webhook).
#[derive(Debug, Clone, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
#[serde(deny_unknown_fields)]
pub struct ProfileUpdate {
    pub limits: Limits,
    #[serde(default)]
    #[cfg_attr(feature = "openapi", schema(max_length = 2000))]
    pub webhook_url: Option<String>,
    /// A new key for the webhook's signatures (16 to 256 visible ASCII characters);
    /// absent: the profile's secret is kept (one is generated, and shown once, when it
    /// has none).
    #[serde(default)]
    #[cfg_attr(feature = "openapi", schema(pattern = "^[!-~]{16,256}$"))]
    pub webhook_secret: Option<String>,
}

/// The webhook secret a profile stores after a write, and the one its answer shows
/// (only a generated one): `given` when the request gives one, else the profile's
/// `kept` secret, else a new one; none without a webhook.
pub fn webhook_secret(
    webhook_url: Option<&str>,
    given: Option<&str>,
    kept: Option<&str>,
) -> (Option<String>, Option<String>) {
    match (webhook_url, given, kept) {
        (None, ..) => (None, None),
        (Some(_), Some(s), _) | (Some(_), None, Some(s)) => (Some(s.to_string()), None),
        (Some(_), None, None) => {
            let s = mtcal_store::keys::generate_webhook_secret();
            (Some(s.clone()), Some(s))
        }
    }
}

/// Checks a new profile's scope and target (trimmed, returned).
pub fn check_target<'a>(scope: &str, target: &'a str) -> Result<&'a str, DomainError> {
    if !SCOPES.contains(&scope) {
        return Err(DomainError::Invalid(format!(
            "scope: `machine` or `tag`, got {scope:?}"
        )));
    }
    let target = target.trim();
    // The target must be able to name what it applies to: a machine id, or a tag.
    let checked = if scope == "machine" {
        mtcal_store::text::check_id("target", target)
    } else {
        mtcal_store::text::check_line("target", target, mtcal_store::text::TAG_MAX)
    };
    checked?;
    Ok(target)
}

/// Checks a profile's content; the message names the field.
pub fn validate(
    scope: &str,
    limits: &Limits,
    webhook_url: Option<&str>,
    webhook_secret: Option<&str>,
) -> Result<(), DomainError> {
    let bad = |m: String| DomainError::Invalid(m);
    if limits.is_empty() {
        return Err(bad(
            "limits: give at least one limit (terms, squareness, standards, drift_um or drift_urad)"
                .into(),
        ));
    }
    limits.validate().map_err(|m| bad(format!("limits.{m}")))?;
    if let Some(url) = webhook_url {
        if scope != "tag" {
            return Err(bad(
                "webhook_url: only a tag profile has a webhook (alerts go to the tags of a machine)"
                    .into(),
            ));
        }
        crate::webhooks::validate_webhook_url(url).map_err(bad)?;
    }
    if let Some(secret) = webhook_secret {
        if webhook_url.is_none() {
            return Err(bad("webhook_secret: only with a webhook_url".into()));
        }
        crate::webhooks::validate_secret(secret).map_err(bad)?;
    }
    Ok(())
}

/// Creates profile `p` after checking it (its webhook target resolved against
/// `webhooks`, its machine existing); the profile as answered, with a generated webhook
/// secret shown this once. The fleet rows it applies to are not refreshed here: the
/// caller runs [`crate::fleet::refresh_profile_targets`] (in the background, or inline).
pub async fn create(
    store: &dyn Store,
    p: &NewProfile,
    webhooks: &crate::webhooks::TargetPolicy,
) -> Result<Profile, DomainError> {
    let target = check_target(&p.scope, &p.target)?;
    let content = Content {
        limits: &p.limits,
        webhook_url: p.webhook_url.as_deref(),
        webhook_secret: p.webhook_secret.as_deref(),
    };
    let c = content.checked(&p.scope, webhooks, None).await?;
    if p.scope == "machine" {
        store.get_machine(target).await?;
    }
    let stored = store
        .create_tolerance(&ToleranceProfile {
            id: mtcal_store::rules::new_id("tol"),
            scope: p.scope.clone(),
            target: target.to_string(),
            limits: c.limits,
            webhook_url: p.webhook_url.clone(),
            webhook_secret: c.secret,
            created_at: String::new(),
            updated_at: String::new(),
        })
        .await?;
    let mut answer = profile_of(&stored)?;
    answer.webhook_secret = c.shown;
    Ok(answer)
}

/// Replaces the limits and webhook of profile `id` with `u` after checking them as
/// [`create`] checks a new profile's; the profile as answered, with a generated webhook
/// secret shown this once (a profile without a secret that gains a webhook). The fleet
/// rows it applies to are not refreshed here (as for [`create`]).
pub async fn replace(
    store: &dyn Store,
    id: &str,
    u: &ProfileUpdate,
    webhooks: &crate::webhooks::TargetPolicy,
) -> Result<Profile, DomainError> {
    let old = store.get_tolerance(id).await?;
    let content = Content {
        limits: &u.limits,
        webhook_url: u.webhook_url.as_deref(),
        webhook_secret: u.webhook_secret.as_deref(),
    };
    let c = content
        .checked(&old.scope, webhooks, old.webhook_secret.as_deref())
        .await?;
    let stored = store
        .update_tolerance(&ToleranceProfile {
            limits: c.limits,
            webhook_url: u.webhook_url.clone(),
            webhook_secret: c.secret,
            ..old
        })
        .await?;
    let mut answer = profile_of(&stored)?;
    answer.webhook_secret = c.shown;
    Ok(answer)
}

/// A profile's content as a request gives it (a new profile's or a replacement's).
struct Content<'a> {
    limits: &'a Limits,
    webhook_url: Option<&'a str>,
    webhook_secret: Option<&'a str>,
}

/// A profile's content checked ([`Content::checked`]): the limits as the store holds
/// them, the webhook secret to store and the one to show.
struct Checked {
    limits: serde_json::Value,
    secret: Option<String>,
    shown: Option<String>,
}

impl Content<'_> {
    /// Checks the content for a profile of `scope` ([`validate`]; the webhook's target
    /// resolved against `webhooks`), `kept` being the profile's present secret
    /// ([`webhook_secret`]).
    async fn checked(
        &self,
        scope: &str,
        webhooks: &crate::webhooks::TargetPolicy,
        kept: Option<&str>,
    ) -> Result<Checked, DomainError> {
        validate(scope, self.limits, self.webhook_url, self.webhook_secret)?;
        if let Some(url) = self.webhook_url {
            crate::webhooks::resolve(url, webhooks)
                .await
                .map_err(DomainError::Invalid)?;
        }
        let (secret, shown) = webhook_secret(self.webhook_url, self.webhook_secret, kept);
        Ok(Checked {
            limits: limits_json(self.limits)?,
            secret,
            shown,
        })
    }
}

/// Limits as the store holds them.
pub fn limits_json(l: &Limits) -> Result<serde_json::Value, DomainError> {
    serde_json::to_value(l).map_err(|e| DomainError::Internal(e.to_string()))
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    fn profile(id: &str, scope: &str, target: &str) -> ToleranceProfile {
        ToleranceProfile {
            id: id.into(),
            scope: scope.into(),
            target: target.into(),
            limits: json!({}),
            webhook_url: None,
            webhook_secret: None,
            created_at: String::new(),
            updated_at: String::new(),
        }
    }

    fn machine(id: &str, tags: &[&str]) -> Machine {
        Machine {
            id: id.into(),
            name: id.into(),
            topology: json!({}),
            travel_mm: Default::default(),
            site: None,
            tags: tags.iter().map(|t| t.to_string()).collect(),
            baseline_result_id: None,
            created_at: String::new(),
            updated_at: String::new(),
        }
    }

    #[test]
    fn own_profile_wins_then_first_tag_in_the_machines_order() {
        let ps = [
            profile("t_b", "tag", "b"),
            profile("t_a", "tag", "a"),
            profile("m_1", "machine", "M1"),
        ];
        let id = |m: &Machine| applicable(&ps, m).map(|p| p.id.clone());
        assert_eq!(id(&machine("M1", &["a", "b"])).as_deref(), Some("m_1"));
        assert_eq!(id(&machine("M2", &["b", "a"])).as_deref(), Some("t_b"));
        assert_eq!(id(&machine("M2", &["x", "a"])).as_deref(), Some("t_a"));
        assert_eq!(id(&machine("M2", &["x"])), None);
        // A tag named like a machine is not that machine's profile.
        let ps = [profile("t_m", "tag", "M3")];
        assert_eq!(applicable(&ps, &machine("M3", &[])), None);
    }
}
