//! Drift alerts: raised when a result lands (where the fleet's drift is maintained,
//! [`crate::fleet::result_landed`]), stored, and POSTed to the webhooks of the machine's
//! tags.
//!
//! **When**: the landed identification's change since the machine's baseline, term by
//! term over the travel both checks measured and per squareness, each with the standard
//! uncertainty of the difference ([`crate::trends::changes`]), is decided against the
//! drift threshold of the applicable tolerance profile ([`crate::tolerances`]) by the
//! solver's rule ([`mtcal_solver::tolerance::drift_alerts`]): a change alerts when
//! |change| − U > threshold, U = 2u, i.e. when it exceeds the threshold by more than its
//! expanded uncertainty. A change inside its uncertainty never alerts. One alert per
//! landed result at most (a job run twice raises one); the baseline itself never alerts.
//!
//! **Webhooks**: every tag profile of the machine's tags with a `webhook_url` receives the
//! alert's JSON ([`AlertView`]) by `POST`, off the request path (a task of its own): at
//! most [`WEBHOOK_ATTEMPTS`] tries, each within [`WEBHOOK_TIMEOUT`], [`WEBHOOK_BACKOFF`]
//! doubling between them, redirects not followed. A failing webhook is logged; it never
//! fails the job or the alert.

use crate::api::history::KIND;
use mtcal_solver::tolerance::{self, VerdictItem};
use mtcal_store::{Alert, Store, StoreError, now_rfc3339};
use serde::{Deserialize, Serialize};
use std::sync::{Arc, OnceLock};
use std::time::Duration;
use utoipa::ToSchema;

/// Tries per webhook delivery.
pub const WEBHOOK_ATTEMPTS: u32 = 3;
/// Time limit of one try (connect, send, answer).
pub const WEBHOOK_TIMEOUT: Duration = Duration::from_secs(5);
/// Wait before the second try; doubled before each further one.
pub const WEBHOOK_BACKOFF: Duration = Duration::from_millis(500);
/// Longest webhook URL accepted, bytes.
pub const WEBHOOK_URL_MAX: usize = 2000;
/// Items named in an alert's message (all are in `items`).
const MESSAGE_ITEMS: usize = 3;

/// An alert as the API, the dashboard and the webhooks show it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
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

/// Checks a webhook target: an absolute `http` or `https` URL with a host, at most
/// [`WEBHOOK_URL_MAX`] bytes; the message says what is wrong.
pub fn validate_webhook_url(url: &str) -> Result<(), String> {
    if url.len() > WEBHOOK_URL_MAX {
        return Err(format!(
            "webhook_url: at most {WEBHOOK_URL_MAX} bytes, got {}",
            url.len()
        ));
    }
    let u = reqwest::Url::parse(url)
        .map_err(|e| format!("webhook_url: not an absolute URL ({e}): {url:?}"))?;
    if !matches!(u.scheme(), "http" | "https") {
        return Err(format!(
            "webhook_url: the scheme must be http or https, got {:?}",
            u.scheme()
        ));
    }
    if u.host_str().is_none_or(str::is_empty) {
        return Err("webhook_url: the URL names no host".into());
    }
    Ok(())
}

/// Decides the change of result `result_id` of machine `machine_id` since its baseline
/// against the applicable drift threshold; stores and announces an alert when one is
/// raised (returned; `None`: no profile, no threshold, the result is the baseline, is
/// excluded, or no change exceeds its threshold beyond its uncertainty).
pub async fn check_landed(
    store: &Arc<dyn Store>,
    machine_id: &str,
    result_id: &str,
) -> Result<Option<AlertView>, StoreError> {
    let machine = store.get_machine(machine_id).await?;
    let profiles = store.list_tolerances().await?;
    let Some(profile) = crate::tolerances::applicable(&profiles, &machine) else {
        return Ok(None);
    };
    let limits = crate::tolerances::limits(profile)?;
    if limits.drift_um.is_none() && limits.drift_urad.is_none() {
        return Ok(None);
    }
    let results = store.list_results(machine_id, KIND).await?;
    let Some(baseline) = crate::fleet::baseline(&machine, &results) else {
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
    for url in webhooks(&profiles, &machine.tags) {
        tokio::spawn(deliver(url, view.clone()));
    }
    Ok(Some(view))
}

/// The webhook URLs of the tag profiles of `tags` (each once).
fn webhooks(profiles: &[mtcal_store::ToleranceProfile], tags: &[String]) -> Vec<String> {
    let mut urls: Vec<String> = profiles
        .iter()
        .filter(|p| p.scope == "tag" && tags.contains(&p.target))
        .filter_map(|p| p.webhook_url.clone())
        .collect();
    urls.sort();
    urls.dedup();
    urls
}

fn client() -> &'static reqwest::Client {
    static CLIENT: OnceLock<reqwest::Client> = OnceLock::new();
    CLIENT.get_or_init(|| {
        reqwest::Client::builder()
            .timeout(WEBHOOK_TIMEOUT)
            .connect_timeout(WEBHOOK_TIMEOUT)
            .redirect(reqwest::redirect::Policy::none())
            .user_agent(concat!("mtcal/", env!("CARGO_PKG_VERSION")))
            .build()
            .expect("the webhook client builds")
    })
}

/// POSTs `alert` to `url` (see the module documentation for tries and limits); returns
/// whether a try was answered with a 2xx status.
pub async fn deliver(url: String, alert: AlertView) -> bool {
    let mut wait = WEBHOOK_BACKOFF;
    for attempt in 1..=WEBHOOK_ATTEMPTS {
        match client().post(&url).json(&alert).send().await {
            Ok(r) if r.status().is_success() => {
                tracing::info!(alert = %alert.id, %url, attempt, "webhook delivered");
                return true;
            }
            Ok(r) => {
                tracing::warn!(alert = %alert.id, %url, attempt, status = %r.status(), "webhook refused")
            }
            Err(e) => tracing::warn!(alert = %alert.id, %url, attempt, %e, "webhook failed"),
        }
        if attempt < WEBHOOK_ATTEMPTS {
            tokio::time::sleep(wait).await;
            wait *= 2;
        }
    }
    tracing::warn!(alert = %alert.id, %url, "webhook given up after {WEBHOOK_ATTEMPTS} tries");
    false
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn webhook_targets_are_http_urls() {
        for ok in [
            "http://127.0.0.1:8080/hook",
            "https://alerts.example.com/mtcal?x=1",
        ] {
            validate_webhook_url(ok).unwrap();
        }
        for (bad, says) in [
            ("ftp://example.com/x", "scheme"),
            ("file:///etc/passwd", "scheme"),
            ("/relative/path", "absolute"),
            ("http://", "absolute"),
            ("not a url", "absolute"),
        ] {
            let e = validate_webhook_url(bad).unwrap_err();
            assert!(
                e.starts_with("webhook_url:") && e.contains(says),
                "{bad}: {e}"
            );
        }
        let long = format!("http://127.0.0.1/{}", "a".repeat(WEBHOOK_URL_MAX));
        assert!(validate_webhook_url(&long).unwrap_err().contains("at most"));
    }
}
