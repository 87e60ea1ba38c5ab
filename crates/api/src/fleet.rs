//! The fleet: a machine's fleet row ([`FleetEntry`]) and the fleet ranked by drift
//! (`GET /api/v1/fleet/drift`); the fleet page (`GET /api/v1/fleet`: [`FleetList`]).

use mtcal_solver::comparison::Drift;
use mtcal_solver::text::{num, unit_label, with_u};
use mtcal_solver::tolerance::{Decision, Verdict, VerdictItem};
use serde::{Deserialize, Serialize};

/// A stored result named by id, kind and time.
// A machine's last check: the one struct the store reads, the fleet routes answer and
// the fleet page is given (converted to the view's own type by the dashboard).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct LastCheck {
    pub result_id: String,
    /// `identification`, `diagnosis`, `cradle` or `sensitivity`.
    pub kind: String,
    pub measured_at: String,
}

/// Items a [`VerdictSummary`] names.
pub const SUMMARY_ITEMS: usize = 3;

/// Why a verdict is what it is, for a fleet row: how many limits were decided, failed
/// and undecided, and the items behind the verdict in words, furthest beyond (or
/// closest to) their limit first.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct VerdictSummary {
    /// Limits decided.
    pub items: usize,
    pub failed: usize,
    pub undecided: usize,
    /// Limits not decided because the model does not explain its recording.
    #[serde(default)]
    pub misfit: usize,
    /// The failing items (the undecided ones when none fails), at most
    /// [`SUMMARY_ITEMS`], as `EXX 12.30 ± 0.40 µm at 50.00 mm (limit 10.00 µm)`.
    pub reasons: Vec<String>,
}

impl VerdictSummary {
    pub fn of(v: &Verdict) -> VerdictSummary {
        let count = |d: Decision| v.items.iter().filter(|i| i.decision == d).count();
        let (failed, undecided) = (count(Decision::Fail), count(Decision::Undecided));
        let shown = if failed > 0 {
            Decision::Fail
        } else {
            Decision::Undecided
        };
        // How far beyond its limit: |value| / limit (an item without a value last).
        let ratio = |i: &VerdictItem| match i.value {
            Some(v) if i.limit > 0.0 => v.abs() / i.limit,
            _ => f64::NEG_INFINITY,
        };
        let mut items: Vec<&VerdictItem> = v.items.iter().filter(|i| i.decision == shown).collect();
        items.sort_by(|a, b| ratio(b).total_cmp(&ratio(a)));
        VerdictSummary {
            items: v.items.len(),
            failed,
            undecided,
            misfit: count(Decision::Misfit),
            reasons: items
                .iter()
                .take(SUMMARY_ITEMS)
                .map(|i| reason(i))
                .collect(),
        }
    }
}

/// One verdict item in words: its value with U at its position, and its limit.
fn reason(i: &VerdictItem) -> String {
    let limit = format!("limit {} {}", num(i.limit), unit_label(&i.unit));
    match i.value {
        Some(_) => {
            let at = i
                .position_mm
                .map_or_else(String::new, |q| format!(" at {} mm", num(q)));
            format!("{} {}{at} ({limit})", i.item, with_u(i.value, i.u, &i.unit))
        }
        None => format!("{} not determined ({limit})", i.item),
    }
}

/// Findings a [`DiagnosisSummary`] names.
pub const FINDINGS_SHOWN: usize = 3;

/// What the diagnosis of a machine's latest check found, for its fleet row: the
/// diagnosis result, its verdict and its findings in words (the full diagnosis is on its
/// result page).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct DiagnosisSummary {
    pub result_id: String,
    /// Null when its document cannot be read (then `findings` says why).
    pub verdict: Option<mtcal_solver::diagnosis::Verdict>,
    /// The findings, at most [`FINDINGS_SHOWN`], one line each
    /// (`backlash (X): backlash_um = 6.01 (u = 0.02)`), then the possible ones
    /// (`… — possible, undetermined`); or why the document cannot be read.
    pub findings: Vec<String>,
    /// Findings and possible effects not listed in `findings`.
    #[serde(default)]
    pub more: usize,
}

impl DiagnosisSummary {
    /// The summary of diagnosis `result_id` from its stored `document`.
    pub fn of(result_id: &str, document: serde_json::Value) -> DiagnosisSummary {
        match serde_json::from_value::<mtcal_solver::diagnosis::DiagnosisResult>(document) {
            Ok(d) => {
                let all: Vec<String> = d
                    .findings
                    .iter()
                    .map(|f| f.in_words())
                    .chain(
                        d.possible
                            .iter()
                            .map(|f| format!("{} — possible, undetermined", f.name_in_words())),
                    )
                    .collect();
                DiagnosisSummary {
                    result_id: result_id.to_string(),
                    verdict: Some(d.verdict),
                    more: all.len().saturating_sub(FINDINGS_SHOWN),
                    findings: all.into_iter().take(FINDINGS_SHOWN).collect(),
                }
            }
            Err(e) => DiagnosisSummary {
                result_id: result_id.to_string(),
                verdict: None,
                findings: vec![format!("the diagnosis {result_id} cannot be read: {e}")],
                more: 0,
            },
        }
    }
}

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
    /// Why the verdict is what it is (null: no verdict).
    #[serde(default)]
    pub verdict_summary: Option<VerdictSummary>,
    /// The latest check's misfit gate when its model does not explain its recording
    /// (null: the model explains it, or the result cannot be checked).
    #[serde(default)]
    pub misfit: Option<mtcal_solver::misfit::ModelCheck>,
    /// When the latest check is decided on the explained model (the 21 terms fitted
    /// jointly with the physics its diagnosis found): the gate's statement, which says
    /// what that model adds (null otherwise).
    #[serde(default)]
    pub explained_model: Option<String>,
    /// What the diagnosis of the latest check's recording found (null: none was run).
    #[serde(default)]
    pub diagnosis: Option<DiagnosisSummary>,
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
    /// How drift is measured (see the domain's trends module).
    pub definition: String,
    pub ranked_by: String,
    pub machines: Vec<FleetEntry>,
    /// Machines left out because their stored drift does not decode, one sentence each
    /// naming the result (absent when none).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub warnings: Vec<String>,
}

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
    pub tolerance_profile: Option<crate::tolerances::ProfileRef>,
    /// Why the verdict is what it is: counts and the items behind it (null: no verdict).
    pub verdict_summary: Option<VerdictSummary>,
    /// The latest identification's misfit gate when its model does not explain its
    /// recording (its verdicts are then "misfit", not decided; null otherwise).
    pub misfit: Option<mtcal_solver::misfit::ModelCheck>,
    /// When the latest identification is decided on the explained model: the gate's
    /// statement, which says what that model adds (null otherwise).
    #[serde(default)]
    pub explained_model: Option<String>,
    /// What the diagnosis of the latest identification's recording found (null: none).
    pub diagnosis: Option<DiagnosisSummary>,
    /// The baseline the drift is measured from (its chosen one, else its first
    /// identification that is not a misfit; the latest while every one is).
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
