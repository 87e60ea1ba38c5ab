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
//! landed result at most (a job run twice raises one); the baseline itself never alerts,
//! nor does a misfit check (its model does not explain its recording: not decided). A
//! check decided on the explained model says so (`explained_model`, and the message's
//! last sentence), as does its baseline.
//!
//! **What it says**: each alerting change with the two values it is the difference of
//! (the baseline's and the landed check's, at the position that shows it, each with its
//! expanded uncertainty) and the dates the two checks were measured ([`AlertChange`]),
//! in the message in words (no stored id: the machine, the dates and the figures) and
//! as data for the pages, which link the alert to the comparison of the two checks.
//!
//! **Acknowledgement**: who, when, and a comment (why, what was done), at most
//! [`MAX_COMMENT`] characters; the first acknowledgement is kept.
//!
//! **Webhooks**: every tag profile of the machine's tags with a `webhook_url` receives the
//! alert's JSON ([`AlertView`]) by `POST`: a delivery stored with the alert in one
//! transaction and tried by the workers with the retries, limits and signature of
//! [`crate::webhooks`]. A failing webhook is logged and shown in its delivery's state; it
//! never fails the job or the alert.

use crate::error::DomainError;
use crate::kinds::IDENTIFICATION;
use crate::webhooks;
use mtcal_solver::text::{num, unit_label, with_u};
use mtcal_solver::tolerance::{self, VerdictItem};
use mtcal_store::{
    Alert, AlertRaised, ResultMeta, Store, StoreError, WebhookDelivery, now_rfc3339,
};
use serde::{Deserialize, Serialize};
use std::sync::Arc;

/// Items named in an alert's message (all are in `items`).
const MESSAGE_ITEMS: usize = 3;

/// Longest acknowledgement comment, characters.
pub const MAX_COMMENT: usize = 1000;

/// A change that raised an alert, with the two values it is the difference of.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct AlertChange {
    /// `EXX`, `EC0Y`, …
    pub item: String,
    /// `um` or `urad`.
    pub unit: String,
    /// Where along the travel the change was taken (absent for a squareness).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub position_mm: Option<f64>,
    /// The baseline's value there and its standard uncertainty.
    pub before: Option<f64>,
    pub before_u: Option<f64>,
    /// The landed check's value there and its standard uncertainty.
    pub after: Option<f64>,
    pub after_u: Option<f64>,
    /// `after − before` and its standard uncertainty.
    pub change: Option<f64>,
    pub change_u: Option<f64>,
    /// The drift threshold it exceeded by more than U = 2u.
    pub threshold: f64,
}

/// What an alert's changes are the differences of: the two checks' dates and each
/// change's values (stored with the alert).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct AlertDetails {
    /// When the baseline and the landed check were measured (RFC 3339).
    pub baseline_measured_at: String,
    pub measured_at: String,
    pub changes: Vec<AlertChange>,
    /// When the landed check is decided on the explained model: its gate's statement.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub explained_model: Option<String>,
    /// When the baseline is decided on the explained model: its gate's statement.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub baseline_explained_model: Option<String>,
}

/// An acknowledgement's body (`POST /api/v1/alerts/{id}/ack`; optional).
#[derive(Debug, Clone, Default, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
#[serde(deny_unknown_fields)]
pub struct Acknowledgement {
    /// Why it is acknowledged, what was done (at most 1000 characters; blank: none; no
    /// control character but line breaks and tabs).
    #[cfg_attr(
        feature = "openapi",
        schema(
            max_length = 1000,
            pattern = "^[^\\u0000-\\u0008\\u000b\\u000c\\u000e-\\u001f\\u007f-\\u009f]*$"
        )
    )]
    pub comment: Option<String>,
}

/// An alert as the API, the dashboard and the webhooks show it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct AlertView {
    /// Which result raised it, against which baseline and profile, when and why.
    #[serde(flatten)]
    pub raised: AlertRaised,
    /// Each change beyond its threshold by more than its expanded uncertainty: the change
    /// at the point that shows it (`value`, `u`, `expanded_u`, `position_mm`), the
    /// threshold (`limit`) and the comparison (`reason`).
    pub items: Vec<VerdictItem>,
    /// When the baseline and the landed check were measured (absent for alerts raised by
    /// an older version).
    pub baseline_measured_at: Option<String>,
    pub measured_at: Option<String>,
    /// Each alerting change with the values before and after (empty for alerts raised
    /// by an older version).
    pub changes: Vec<AlertChange>,
    /// When the landed check is decided on the explained model (docs/compensation.md,
    /// "The explained model in the service"): its gate's statement, saying what the
    /// model adds; null otherwise (and for alerts raised by an older version).
    pub explained_model: Option<String>,
    /// The same of the baseline check.
    pub baseline_explained_model: Option<String>,
    /// Not acknowledged yet.
    pub active: bool,
    pub acknowledged_at: Option<String>,
    /// The key that acknowledged it.
    pub acknowledged_by: Option<String>,
    /// What was written when it was acknowledged.
    pub acknowledgement_comment: Option<String>,
}

impl AlertView {
    pub fn of(a: &Alert) -> Result<AlertView, StoreError> {
        let details: AlertDetails = match &a.details {
            Some(d) => serde_json::from_value(d.clone()).map_err(|e| {
                StoreError::Backend(format!("alert {} details do not read: {e}", a.raised.id))
            })?,
            None => AlertDetails::default(),
        };
        let date = |s: String| (!s.is_empty()).then_some(s);
        Ok(AlertView {
            raised: a.raised.clone(),
            items: serde_json::from_value(a.items.clone()).map_err(|e| {
                StoreError::Backend(format!("alert {} items do not read: {e}", a.raised.id))
            })?,
            baseline_measured_at: date(details.baseline_measured_at),
            measured_at: date(details.measured_at),
            changes: details.changes,
            explained_model: details.explained_model,
            baseline_explained_model: details.baseline_explained_model,
            active: a.acknowledged_at.is_none(),
            acknowledged_at: a.acknowledged_at.clone(),
            acknowledged_by: a.acknowledged_by.clone(),
            acknowledgement_comment: a.acknowledgement_comment.clone(),
        })
    }
}

/// Decides the change of result `result_id` of machine `machine_id` since its baseline
/// against the applicable drift threshold; stores and announces an alert when one is
/// raised (returned; `None`: no profile, no threshold, the result is the baseline, is
/// excluded, is a misfit, or no change exceeds its threshold beyond its uncertainty), with the
/// deliveries to its webhooks (the outbox of [`crate::webhooks`]).
pub async fn check_landed(
    store: &Arc<dyn Store>,
    machine_id: &str,
    result_id: &str,
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
    let Some(baseline) = crate::history::baseline(store.as_ref(), &machine, &results).await? else {
        return Ok(None);
    };
    let Some(landed) = results.iter().find(|r| r.id == result_id) else {
        return Ok(None);
    };
    if landed.id == baseline.id {
        return Ok(None);
    }
    // A misfit is not decided: its change is not a figure to alert on.
    let model = crate::trends::stored_check_model;
    let now_model = model(store.as_ref(), &landed.id).await?;
    if now_model.misfit {
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
    let details = AlertDetails {
        baseline_measured_at: baseline.measured_at.clone(),
        measured_at: landed.measured_at.clone(),
        changes: items.iter().map(|i| change(baseline, landed, i)).collect(),
        explained_model: now_model.explained_model,
        baseline_explained_model: model(store.as_ref(), &baseline.id).await?.explained_model,
    };
    let message = message(&machine.id, &details);
    let alert = Alert {
        raised: AlertRaised {
            id: mtcal_store::rules::new_id("alert"),
            machine_id: machine.id.clone(),
            result_id: landed.id.clone(),
            baseline_result_id: baseline.id.clone(),
            profile_id: profile.id.clone(),
            raised_at: now_rfc3339(),
            message,
        },
        items: serde_json::to_value(&items).map_err(|e| StoreError::Backend(e.to_string()))?,
        details: Some(
            serde_json::to_value(&details).map_err(|e| StoreError::Backend(e.to_string()))?,
        ),
        acknowledged_at: None,
        acknowledged_by: None,
        acknowledgement_comment: None,
    };
    // The webhooks' deliveries, stored with the alert: the body is the alert as the API
    // shows it (as stored: not acknowledged).
    let body = serde_json::to_string(&AlertView::of(&alert)?)
        .map_err(|e| StoreError::Backend(e.to_string()))?;
    let deliveries: Vec<WebhookDelivery> = webhooks::targets(&profiles, &machine.tags)
        .into_iter()
        .map(|to| WebhookDelivery {
            id: mtcal_store::rules::new_id("whd"),
            alert_id: alert.raised.id.clone(),
            profile_id: to.profile_id,
            url: to.url,
            body: body.clone(),
            state: "pending".into(),
            attempts: 0,
            next_attempt_ms: 0,
            last_error: None,
            created_at: String::new(),
            updated_at: String::new(),
        })
        .collect();
    let Some(stored) = store.raise_alert(&alert, &deliveries).await? else {
        return Ok(None);
    };
    let view = AlertView::of(&stored)?;
    tracing::warn!(alert = %view.raised.id, machine = %view.raised.machine_id, webhooks = deliveries.len(), "drift alert raised");
    Ok(Some(view))
}

/// The change of alerting item `i` with the values of `before` and `after` it is the
/// difference of, at the item's position (a term) or as a whole (a squareness).
fn change(before: &ResultMeta, after: &ResultMeta, i: &VerdictItem) -> AlertChange {
    let value = |r: &ResultMeta| match i.position_mm {
        Some(q) => crate::trends::value(&r.scalars, &i.item, q),
        None => crate::trends::squareness(&r.scalars, &i.item),
    };
    let (b, a) = (value(before), value(after));
    AlertChange {
        item: i.item.clone(),
        unit: i.unit.clone(),
        position_mm: i.position_mm,
        before: b.as_ref().map(|v| v.value),
        before_u: b.and_then(|v| v.u),
        after: a.as_ref().map(|v| v.value),
        after_u: a.and_then(|v| v.u),
        change: i.value,
        change_u: i.u,
        threshold: i.limit,
    }
}

/// The date of an RFC 3339 time as it was stated (`2026-01-05`).
fn date(rfc3339: &str) -> &str {
    rfc3339.get(..10).unwrap_or(rfc3339)
}

/// An alert's message: the machine, the two checks' dates and, for the first
/// [`MESSAGE_ITEMS`] changes, the values before and after with their expanded
/// uncertainties, the change and the threshold (no stored id).
pub fn message(machine: &str, d: &AlertDetails) -> String {
    let (from, to) = (date(&d.baseline_measured_at), date(&d.measured_at));
    let parts: Vec<String> = d
        .changes
        .iter()
        .take(MESSAGE_ITEMS)
        .map(|c| {
            let at = c
                .position_mm
                .map_or_else(String::new, |q| format!(" at {} mm", num(q)));
            format!(
                "{}{at} from {} ({from}) to {} ({to}), a change of {}, beyond the threshold \
                 of {} {} by more than U",
                c.item,
                with_u(c.before, c.before_u, &c.unit),
                with_u(c.after, c.after_u, &c.unit),
                with_u(c.change, c.change_u, &c.unit),
                num(c.threshold),
                unit_label(&c.unit),
            )
        })
        .collect();
    let mut m = format!(
        "{machine} drifted between its baseline check of {from} and the check of {to}: {}",
        parts.join("; ")
    );
    if d.changes.len() > MESSAGE_ITEMS {
        m.push_str(&format!(" (and {} more)", d.changes.len() - MESSAGE_ITEMS));
    }
    match (&d.baseline_explained_model, &d.explained_model) {
        (Some(_), Some(_)) => m.push_str(
            ". Both checks are decided on the explained model (the 21 terms fitted jointly with the physics the diagnosis of each recording found)",
        ),
        (None, Some(_)) => m.push_str(&format!(
            ". The check of {to} is decided on the explained model (the 21 terms fitted jointly with the physics the diagnosis of its recording found)"
        )),
        (Some(_), None) => m.push_str(&format!(
            ". The baseline check of {from} is decided on the explained model (the 21 terms fitted jointly with the physics the diagnosis of its recording found)"
        )),
        (None, None) => {}
    }
    m
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

/// Acknowledges alert `id` as `by` with an optional comment (blank: none; at most
/// [`MAX_COMMENT`] characters, no control characters but line breaks and tabs); the
/// first acknowledgement is kept.
pub async fn acknowledge(
    store: &dyn Store,
    id: &str,
    by: &str,
    comment: Option<&str>,
) -> Result<AlertView, DomainError> {
    let comment = comment.map(str::trim).filter(|c| !c.is_empty());
    if let Some(c) = comment {
        let n = c.chars().count();
        if n > MAX_COMMENT {
            return Err(DomainError::Invalid(format!(
                "comment: at most {MAX_COMMENT} characters, got {n}"
            )));
        }
        if c.chars()
            .any(|ch| ch.is_control() && ch != '\n' && ch != '\t' && ch != '\r')
        {
            return Err(DomainError::Invalid(
                "comment: no control characters but line breaks and tabs".into(),
            ));
        }
    }
    Ok(AlertView::of(
        &store.acknowledge_alert(id, by, comment).await?,
    )?)
}
