//! Drift alerts: raised when a result lands (after its fleet row, the module `landing`), stored,
//! POSTed to the webhooks of the machine's tags, listed and acknowledged.
//!
//! **When**: the landed identification's change since the machine's baseline, term by
//! term over the travel both checks measured and per squareness, each with the standard
//! uncertainty of the difference ([`crate::trends::changes`]), is decided against the
//! drift threshold of the applicable tolerance profile ([`crate::profiles`]) by the
//! solver's rule ([`mtcal_solver::tolerance::drift_alerts`]): a change alerts when
//! |change| − U > threshold, U = 2u, i.e. when it exceeds the threshold by more than its
//! expanded uncertainty. A change inside its uncertainty never alerts. One alert per
//! landed result at most (a job run twice raises one); the baseline itself never alerts.
//!
//! **Webhooks**: every tag profile of the machine's tags with a `webhook_url` receives the
//! alert's JSON ([`AlertView`]) by `POST`, off the request path (a task of its own), with
//! the tries and limits of [`crate::webhooks`]. A failing webhook is logged; it never
//! fails the job or the alert.

use crate::error::DomainError;
use crate::kinds::IDENTIFICATION;
use crate::webhooks;
use mtcal_solver::tolerance::{self, VerdictItem};
use mtcal_store::{Alert, Store, StoreError, now_rfc3339};
use serde::{Deserialize, Serialize};
use std::sync::Arc;

/// Items named in an alert's message (all are in `items`).
const MESSAGE_ITEMS: usize = 3;

/// An alert as the API, the dashboard and the webhooks show it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct AlertView {
    pub id: String,
    pub machine_id: String,
    /// The landed result whose change raised it.
    pub result_id: String,
    /// The baseline the change is measured from.
    pub baseline_result_id: String,
    /// The tolerance profile whose drift threshold was exceeded.
    pub profile_id: String,
    pub raised_at: String,
    /// What changed, by how much, against which threshold.
    pub message: String,
    /// Each change beyond its threshold by more than its expanded uncertainty: the change
    /// at the point that shows it (`value`, `u`, `expanded_u`, `position_mm`), the
    /// threshold (`limit`) and the comparison (`reason`).
    pub items: Vec<VerdictItem>,
    /// Not acknowledged yet.
    pub active: bool,
    pub acknowledged_at: Option<String>,
    /// The key that acknowledged it.
    pub acknowledged_by: Option<String>,
}

impl AlertView {
    pub fn of(a: &Alert) -> Result<AlertView, StoreError> {
        Ok(AlertView {
            id: a.id.clone(),
            machine_id: a.machine_id.clone(),
            result_id: a.result_id.clone(),
            baseline_result_id: a.baseline_result_id.clone(),
            profile_id: a.profile_id.clone(),
            raised_at: a.raised_at.clone(),
            message: a.message.clone(),
            items: serde_json::from_value(a.items.clone()).map_err(|e| {
                StoreError::Backend(format!("alert {} items do not read: {e}", a.id))
            })?,
            active: a.acknowledged_at.is_none(),
            acknowledged_at: a.acknowledged_at.clone(),
            acknowledged_by: a.acknowledged_by.clone(),
        })
    }
}

/// Decides the change of result `result_id` of machine `machine_id` since its baseline
/// against the applicable drift threshold; stores and announces an alert when one is
/// raised (returned; `None`: no profile, no threshold, the result is the baseline, is
/// excluded, or no change exceeds its threshold beyond its uncertainty). Its webhooks
/// are delivered where `hooks` allows.
pub async fn check_landed(
    store: &Arc<dyn Store>,
    machine_id: &str,
    result_id: &str,
    hooks: &webhooks::TargetPolicy,
) -> Result<Option<AlertView>, StoreError> {
    let machine = store.get_machine(machine_id).await?;
    let profiles = store.list_tolerances().await?;
    let Some(profile) = crate::profiles::applicable(&profiles, &machine) else {
        return Ok(None);
    };
    let limits = crate::profiles::limits(profile)?;
    if limits.drift_um.is_none() && limits.drift_urad.is_none() {
        return Ok(None);
    }
    let results = store.list_results(machine_id, IDENTIFICATION).await?;
    let Some(baseline) = crate::history::baseline(&machine, &results) else {
        return Ok(None);
    };
    let Some(landed) = results.iter().find(|r| r.id == result_id) else {
        return Ok(None);
    };
    if landed.id == baseline.id {
        return Ok(None);
    }
    let (base, now) = (baseline.scalars.clone(), landed.scalars.clone());
    let items = crate::blocking::run::<_, StoreError>(move || {
        tolerance::drift_alerts(&limits, &crate::trends::changes(&base, &now))
    })
    .await?;
    if items.is_empty() {
        return Ok(None);
    }
    let mut message = format!("{} drifted since baseline {}: ", machine.id, baseline.id);
    let parts: Vec<String> = items
        .iter()
        .take(MESSAGE_ITEMS)
        .map(|i| format!("{} {}", i.item, i.reason))
        .collect();
    message.push_str(&parts.join("; "));
    if items.len() > MESSAGE_ITEMS {
        message.push_str(&format!(" (and {} more)", items.len() - MESSAGE_ITEMS));
    }
    let alert = Alert {
        id: mtcal_store::rules::new_id("alert"),
        machine_id: machine.id.clone(),
        result_id: landed.id.clone(),
        baseline_result_id: baseline.id.clone(),
        profile_id: profile.id.clone(),
        raised_at: now_rfc3339(),
        message,
        items: serde_json::to_value(&items).map_err(|e| StoreError::Backend(e.to_string()))?,
        acknowledged_at: None,
        acknowledged_by: None,
    };
    let Some(stored) = store.raise_alert(&alert).await? else {
        return Ok(None);
    };
    let view = AlertView::of(&stored)?;
    tracing::warn!(alert = %view.id, machine = %view.machine_id, "drift alert raised");
    for url in webhooks::targets(&profiles, &machine.tags) {
        let policy = hooks.clone();
        tokio::spawn(webhooks::deliver(
            url,
            policy,
            view.id.clone(),
            view.clone(),
        ));
    }
    Ok(Some(view))
}

/// Most alerts one list returns.
pub const MAX_ALERTS: usize = 1000;

/// Which alerts a list holds.
#[derive(Debug, Clone, Default, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::IntoParams))]
#[cfg_attr(feature = "openapi", into_params(parameter_in = Query))]
pub struct AlertQuery {
    /// Only this machine's alerts.
    pub machine: Option<String>,
    /// `true`: only alerts not acknowledged; `false`: only acknowledged ones.
    pub active: Option<bool>,
    /// At most this many, newest first (default 100, at most 1000).
    #[cfg_attr(feature = "openapi", param(minimum = 1, maximum = 1000))]
    pub limit: Option<usize>,
}

/// Alerts newest first (`GET /api/v1/alerts`; the dashboard's pages too).
pub async fn list(store: &dyn Store, q: &AlertQuery) -> Result<Vec<AlertView>, DomainError> {
    let limit = crate::paging::limit(q.limit, 100, MAX_ALERTS)?;
    let rows = store
        .list_alerts(q.machine.as_deref(), q.active, limit as i64)
        .await?;
    Ok(rows.iter().map(AlertView::of).collect::<Result<_, _>>()?)
}

/// Acknowledges alert `id` as `by` (the first acknowledgement is kept).
pub async fn acknowledge(store: &dyn Store, id: &str, by: &str) -> Result<AlertView, DomainError> {
    Ok(AlertView::of(&store.acknowledge_alert(id, by).await?)?)
}
