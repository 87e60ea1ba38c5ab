//! What a machine's fleet row holds ([`FleetEntry`], stored as JSON beside the row's
//! ranking keys), and the fleet ranked by drift (`GET /api/v1/fleet/drift`).

use crate::error::DomainError;
use crate::trends::{DRIFT_DEFINITION, Drift};
use mtcal_store::Store;
use serde::{Deserialize, Serialize};

#[derive(Debug, Clone, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct FleetEntry {
    pub machine_id: String,
    pub name: String,
    pub site: Option<String>,
    pub baseline_result_id: String,
    pub latest_result_id: String,
    pub latest_measured_at: String,
    pub results: i64,
    #[serde(flatten)]
    pub drift: Drift,
    /// The latest result's verdict against the machine's tolerance profile (null: no
    /// profile applies, or none of its limits applies to the result).
    #[serde(default)]
    pub verdict: Option<mtcal_solver::tolerance::Decision>,
    /// The tolerance profile the verdict is against.
    #[serde(default)]
    pub tolerance_profile_id: Option<String>,
    /// The worst µm term's value in each check, in time order, at the end of the latest
    /// check's measured travel where it changed more (null: not identified or not
    /// measured there); the fleet page's sparkline.
    #[serde(default)]
    pub sparkline: Vec<Option<f64>>,
}

/// How the fleet is ranked.
#[derive(Debug, Clone, Default, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::IntoParams))]
#[cfg_attr(feature = "openapi", into_params(parameter_in = Query))]
pub struct FleetQuery {
    /// `um` (translational drift, default) or `urad` (angular and squareness).
    #[cfg_attr(feature = "openapi", param(pattern = "^(um|urad)$"))]
    pub by: Option<String>,
    /// At most this many machines (default 50, at most 100 000).
    #[cfg_attr(feature = "openapi", param(minimum = 1, maximum = 100000))]
    pub limit: Option<usize>,
}

#[derive(Debug, Clone, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct FleetDrift {
    /// How drift is measured (see the trends module).
    pub definition: String,
    pub ranked_by: String,
    pub machines: Vec<FleetEntry>,
    /// Machines left out because their stored drift does not decode, one sentence each
    /// naming the result (absent when none).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub warnings: Vec<String>,
}

/// The fleet ranked by drift, from the maintained rows (ranked by the database). A
/// stored entry that does not decode (written by an older version) is left out and
/// named, not a failure of the whole fleet.
pub async fn ranked(store: &dyn Store, q: FleetQuery) -> Result<FleetDrift, DomainError> {
    let by = q.by.unwrap_or_else(|| "um".into());
    if by != "um" && by != "urad" {
        return Err(DomainError::Invalid("by: `um` or `urad`".into()));
    }
    let (mut machines, mut warnings) = (Vec::new(), Vec::new());
    for (row, name, site) in store
        .fleet_drift_ranked(by == "um", crate::paging::limit(q.limit, 50, 100_000)?)
        .await?
    {
        match serde_json::from_value::<FleetEntry>(row.entry) {
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
    Ok(FleetDrift {
        definition: DRIFT_DEFINITION.into(),
        ranked_by: by,
        machines,
        warnings,
    })
}
