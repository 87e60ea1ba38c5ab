//! Tolerance profiles as the API answers them, and a result's verdict against the one
//! that applies.

use mtcal_solver::tolerance::{Limits, Verdict};
use serde::{Deserialize, Serialize};

/// A tolerance profile.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct Profile {
    pub id: String,
    /// `machine` (the profile of one machine) or `tag` (of every machine with the tag).
    pub scope: String,
    /// The machine id or the tag.
    pub target: String,
    pub limits: Limits,
    /// Tag profiles only: drift alerts of the tag's machines are POSTed here. A read
    /// key sees its scheme, host and port only.
    pub webhook_url: Option<String>,
    /// Whether the webhook's deliveries are signed (the profile has a secret; the
    /// secret itself is never shown again).
    pub webhook_signed: bool,
    /// The webhook's signing secret, in the answer that generated it only (create or
    /// replace without `webhook_secret`): keep it, it is not shown again.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub webhook_secret: Option<String>,
    pub created_at: String,
    pub updated_at: String,
}

/// The profile a verdict is against.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct ProfileRef {
    pub id: String,
    pub scope: String,
    pub target: String,
}

/// A result's verdict.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct ResultVerdict {
    pub result_id: String,
    pub machine_id: String,
    /// The profile that applies to the machine (its own, else its first tag's that has
    /// one); null when none applies.
    pub profile: Option<ProfileRef>,
    /// The decision per limit and overall; null when no profile applies.
    pub verdict: Option<Verdict>,
}
