//! Tolerance profiles and the verdict of a result against them.
//!
//! A profile holds the solver's [`Limits`] (per error function over the measured travel,
//! per squareness, per figure of the standards, and the drift thresholds) for one
//! machine (`scope` `machine`) or for every machine with a tag (`scope` `tag`).
//!
//! **Which profile applies** to a machine: its own profile when it has one; otherwise
//! the profile of the first of the machine's tags, in the order the machine lists them,
//! that has one; otherwise none (the result has no verdict). Profiles are not merged.
//!
//! **The verdict** is the solver's decision rule ([`mtcal_solver::tolerance::evaluate`],
//! ISO 14253-1 style with U = 2u) applied to the result's figures: for an identification
//! its identifiable error functions on their reporting grid over the measured travel and
//! its squareness errors ([`mtcal_solver::tolerance::identification_figures`]); for every
//! kind the figures of the standards stored with it (ISO 230-2 per axis, ISO 230-4 per
//! plane).

use mtcal_solver::identification::IdentificationResult;
use mtcal_solver::tolerance::{self, Figures, Limits, Verdict};
use mtcal_store::{Machine, Store, StoreError, StoredResult, ToleranceProfile};

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

/// The figures of a stored result that limits are decided against, given the figures of
/// the standards stored with it (blocking: the identification's functions are evaluated
/// on their reporting grid).
fn figures(r: &StoredResult, standards: &[mtcal_store::Figure]) -> Result<Figures, StoreError> {
    let mut f = if r.meta.kind == crate::api::history::KIND {
        match serde_json::from_value::<IdentificationResult>(r.document.clone()) {
            Ok(doc) => tolerance::identification_figures(&doc),
            Err(e) => {
                return Err(StoreError::Backend(format!(
                    "result {} does not read as an identification: {e}",
                    r.meta.id
                )));
            }
        }
    } else {
        Figures::default()
    };
    f.add_standards(standards.iter().map(|s| (s.name.as_str(), s.value, s.u)));
    Ok(f)
}

/// The verdict of result `r` of machine `m` against the profile that applies among
/// `profiles` (`None`: no profile applies). The decision is worked out off the async
/// threads ([`crate::blocking`]).
pub async fn verdict(
    store: &dyn Store,
    profiles: &[ToleranceProfile],
    m: &Machine,
    r: &StoredResult,
) -> Result<Option<(ToleranceProfile, Verdict)>, StoreError> {
    let Some(p) = applicable(profiles, m) else {
        return Ok(None);
    };
    let limits = limits(p)?;
    let standards = store.result_figures(&r.meta.id).await?;
    let r = r.clone();
    let v = crate::blocking::run::<_, StoreError>(move || {
        figures(&r, &standards).map(|f| tolerance::evaluate(&limits, &f))
    })
    .await??;
    Ok(Some((p.clone(), v)))
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
