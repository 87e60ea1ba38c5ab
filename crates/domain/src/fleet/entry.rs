//! What a machine's fleet row holds ([`FleetEntry`], stored as JSON beside the row's
//! ranking keys), and the fleet ranked by drift (`GET /api/v1/fleet/drift`).

use crate::error::DomainError;
use crate::trends::DRIFT_DEFINITION;
pub use mtcal_api::fleet::{
    DiagnosisSummary, FINDINGS_SHOWN, FleetDrift, FleetEntry, FleetQuery, SUMMARY_ITEMS,
    VerdictSummary,
};
use mtcal_store::Store;

/// Most machines one ranking holds.
pub const MAX_RANKED: usize = 100_000;

/// The fleet ranked by drift, from the maintained rows (ranked by the database), of the
/// machines `within` holds (None: every machine). A stored entry that does not decode
/// (written by an older version) is left out and named, not a failure of the whole fleet.
pub async fn ranked(
    store: &dyn Store,
    q: FleetQuery,
    within: Option<&std::collections::HashSet<String>>,
) -> Result<FleetDrift, DomainError> {
    let by = q.by.unwrap_or_else(|| "um".into());
    if by != "um" && by != "urad" {
        return Err(DomainError::Invalid("by: `um` or `urad`".into()));
    }
    let limit = crate::paging::limit(q.limit, 50, MAX_RANKED)?;
    // A scope: its machines among the whole ranking.
    let read = if within.is_some() { MAX_RANKED } else { limit };
    let (mut machines, mut warnings) = (Vec::new(), Vec::new());
    for (row, name, site) in store.fleet_drift_ranked(by == "um", read).await? {
        if within.is_some_and(|w| !w.contains(&row.machine_id)) {
            continue;
        }
        if machines.len() >= limit {
            break;
        }
        match row.entry.decode::<FleetEntry>() {
            Ok(mut e) => {
                e.name = name;
                e.site = site;
                machines.push(e);
            }
            Err(e) => warnings.push(format!(
                "machine {} skipped: its stored drift does not decode ({e})",
                row.machine_id
            )),
        }
    }
    machines.truncate(limit);
    Ok(FleetDrift {
        definition: DRIFT_DEFINITION.into(),
        ranked_by: by,
        machines,
        warnings,
    })
}
