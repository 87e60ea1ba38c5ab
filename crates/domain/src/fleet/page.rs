//! The fleet page's read: every machine with its last check, the verdict of its latest
//! identification, its drift since its baseline with the uncertainty, its sparkline and
//! its active alerts; filtered by site and tag; machines with active alerts first, then
//! in the order asked (`GET /api/v1/fleet` and the dashboard's fleet page).
//!
//! Everything comes from the rows the service maintains ([`crate::fleet::rows`]),
//! filtered, ordered and counted by the database in one read snapshot
//! ([`mtcal_store::Fleet::fleet_page`]: an index walk that stops once the page is full).

use crate::error::DomainError;
use crate::fleet::entry::{DiagnosisSummary, FleetEntry, VerdictSummary};
use crate::kinds::IDENTIFICATION;
use crate::trends::{DRIFT_DEFINITION, Drift};
use mtcal_solver::tolerance::Decision;
pub use mtcal_store::LastCheck;
use mtcal_store::{FleetPageQuery, FleetPageRow, FleetSort, Store};
use serde::{Deserialize, Serialize};

/// Machines a page holds unless asked otherwise (the fleet page's page).
pub const DEFAULT_LIMIT: usize = 100;
/// Most machines one page holds.
pub const MAX_LIMIT: usize = 1000;

#[derive(Debug, Clone, Default, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::IntoParams))]
#[cfg_attr(feature = "openapi", into_params(parameter_in = Query))]
pub struct FleetParams {
    /// Only the machines of this site (empty: every site).
    pub site: Option<String>,
    /// Only the machines carrying this tag, matched whole (empty: every tag).
    pub tag: Option<String>,
    /// `drift` (largest drift in µm first, the default), `drift_urad` (in µrad),
    /// `name` (by machine id) or `last_check` (most recent first); machines without the
    /// key (no identification) come after those with it, by id.
    #[cfg_attr(
        feature = "openapi",
        param(pattern = "^(drift|drift_urad|name|last_check)$")
    )]
    pub sort: Option<String>,
    /// Machines skipped, in this order (default 0, at most 1 000 000).
    #[cfg_attr(feature = "openapi", param(maximum = 1_000_000))]
    pub offset: Option<usize>,
    /// At most this many machines (default 100, at most 1000).
    #[cfg_attr(feature = "openapi", param(minimum = 1, maximum = 1000))]
    pub limit: Option<usize>,
}

/// One machine of the fleet.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct FleetMachine {
    pub machine_id: String,
    pub name: String,
    pub site: Option<String>,
    pub tags: Vec<String>,
    /// Drift alerts not acknowledged.
    pub active_alerts: i64,
    /// Its latest identification; for a machine without one, its latest check of
    /// another kind (null: no check yet).
    pub last_check: Option<LastCheck>,
    /// The latest identification's verdict against the machine's tolerance profile
    /// (null: no identification, no profile applies, or none of its limits applies).
    pub verdict: Option<Decision>,
    /// The tolerance profile that applies to the machine (its own, else its first tag's
    /// that has one), whether or not it has a check to decide.
    pub tolerance_profile_id: Option<String>,
    /// That profile's scope and target (`tag` `vmc`).
    pub tolerance_profile: Option<crate::verdicts::ProfileRef>,
    /// Why the verdict is what it is: counts and the items behind it (null: no verdict).
    pub verdict_summary: Option<VerdictSummary>,
    /// The latest identification's misfit gate when its model does not explain its
    /// recording (its verdicts are then "misfit", not decided; null otherwise).
    pub misfit: Option<mtcal_solver::misfit::ModelCheck>,
    /// What the diagnosis of the latest identification's recording found (null: none).
    pub diagnosis: Option<DiagnosisSummary>,
    /// The baseline the drift is measured from (its chosen one, else its first
    /// identification).
    pub baseline_result_id: Option<String>,
    /// Its identifications.
    pub results: i64,
    /// Drift since the baseline (`definition`), each with its standard uncertainty
    /// (null: no identification).
    pub drift: Option<Drift>,
    /// Why there is no drift, when there is none (e.g. its checks are of a kind drift is
    /// not measured on).
    pub drift_note: Option<String>,
    /// The worst µm term's value in each identification, in time order, at the end of
    /// the latest one's measured travel where it changed more (null: not identified or
    /// not measured there).
    pub sparkline: Vec<Option<f64>>,
}

/// One page of the fleet.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct FleetList {
    /// How drift is measured.
    pub definition: String,
    pub site: Option<String>,
    pub tag: Option<String>,
    pub sort: String,
    pub offset: usize,
    pub limit: usize,
    /// Machines matching the filters in all.
    pub total: usize,
    /// Every site and every tag of the fleet, sorted (the filters' choices).
    pub sites: Vec<String>,
    pub tags: Vec<String>,
    /// Machines with active alerts first, then in `sort` order.
    pub machines: Vec<FleetMachine>,
    /// Machines whose stored drift does not decode (written by an older version), one
    /// sentence each; they are listed without drift (absent when none).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub warnings: Vec<String>,
}

/// A filter value, empty meaning none.
fn given(v: &Option<String>) -> Option<String> {
    v.as_ref().filter(|v| !v.is_empty()).cloned()
}

fn order(sort: &str) -> Result<FleetSort, DomainError> {
    match sort {
        "drift" => Ok(FleetSort::DriftUm),
        "drift_urad" => Ok(FleetSort::DriftUrad),
        "name" => Ok(FleetSort::Name),
        "last_check" => Ok(FleetSort::LastCheck),
        other => Err(DomainError::Invalid(format!(
            "sort: drift, drift_urad, name or last_check, got {other:?}"
        ))),
    }
}

/// A machine's entry from its page row; a stored drift that does not decode adds a
/// warning and leaves the drift out.
fn machine(
    r: FleetPageRow,
    profiles: &[mtcal_store::ToleranceProfile],
    warnings: &mut Vec<String>,
) -> FleetMachine {
    let m = r.machine;
    let applies = crate::profiles::applicable(profiles, &m).map(|p| crate::verdicts::ProfileRef {
        id: p.id.clone(),
        scope: p.scope.clone(),
        target: p.target.clone(),
    });
    let entry = r
        .drift
        .and_then(|d| match serde_json::from_value::<FleetEntry>(d.entry) {
            Ok(e) => Some(e),
            Err(e) => {
                warnings.push(format!(
                    "machine {}: its stored drift does not decode ({e}); listed without it",
                    m.id
                ));
                None
            }
        });
    let other = r.other_check;
    let drift_note = match (&entry, &other) {
        (Some(_), _) => None,
        (None, Some(c)) => Some(format!(
            "not applicable: drift is measured between identifications, and this \
             machine's checks are of kind {}",
            c.kind
        )),
        (None, None) => None,
    };
    let (last_check, verdict, summary, baseline, results, drift, sparkline, misfit, diagnosis) =
        match entry {
            Some(e) => (
                Some(LastCheck {
                    result_id: e.latest_result_id,
                    kind: IDENTIFICATION.into(),
                    measured_at: e.latest_measured_at,
                }),
                e.verdict,
                e.verdict_summary,
                Some(e.baseline_result_id),
                e.results,
                Some(e.drift),
                e.sparkline,
                e.misfit,
                e.diagnosis,
            ),
            None => (other, None, None, None, 0, None, vec![], None, None),
        };
    FleetMachine {
        machine_id: m.id,
        name: m.name,
        site: m.site,
        tags: m.tags,
        active_alerts: r.active_alerts.max(0),
        last_check,
        verdict,
        tolerance_profile_id: applies.as_ref().map(|p| p.id.clone()),
        tolerance_profile: applies,
        verdict_summary: summary,
        misfit,
        diagnosis,
        baseline_result_id: baseline,
        results,
        drift,
        drift_note,
        sparkline,
    }
}

/// One page of the fleet (`GET /api/v1/fleet`; the dashboard's fleet page).
pub async fn page(store: &dyn Store, q: &FleetParams) -> Result<FleetList, DomainError> {
    let sort = q.sort.clone().unwrap_or_else(|| "drift".into());
    let by = order(&sort)?;
    let limit = crate::paging::limit(q.limit, DEFAULT_LIMIT, MAX_LIMIT)?;
    let offset = crate::paging::offset(q.offset)?;
    let (site, tag) = (given(&q.site), given(&q.tag));
    let found = store
        .fleet_page(&FleetPageQuery {
            site: site.clone(),
            tag: tag.clone(),
            sort: by,
            offset: i64::try_from(offset).unwrap_or(i64::MAX),
            limit: limit as i64,
        })
        .await?;
    let profiles = store.list_tolerances().await?;
    let mut warnings = vec![];
    let machines = found
        .rows
        .into_iter()
        .map(|r| machine(r, &profiles, &mut warnings))
        .collect();
    Ok(FleetList {
        definition: DRIFT_DEFINITION.into(),
        site,
        tag,
        sort,
        offset,
        limit,
        total: usize::try_from(found.total).unwrap_or(0),
        sites: found.sites,
        tags: found.tags,
        machines,
        warnings,
    })
}
