//! Webhook delivery: the URL rules of a webhook target, the targets of a machine (the
//! webhooks of its tags' profiles), and the POST with its tries and limits.
//!
//! A body is POSTed off the request path (the caller spawns the task): at most
//! [`WEBHOOK_ATTEMPTS`] tries, each within [`WEBHOOK_TIMEOUT`], [`WEBHOOK_BACKOFF`]
//! doubling between them, redirects not followed. A failing webhook is logged; it never
//! fails what raised it.

use serde::Serialize;
use std::sync::OnceLock;
use std::time::Duration;

/// Tries per webhook delivery.
pub const WEBHOOK_ATTEMPTS: u32 = 3;
/// Time limit of one try (connect, send, answer).
pub const WEBHOOK_TIMEOUT: Duration = Duration::from_secs(5);
/// Wait before the second try; doubled before each further one.
pub const WEBHOOK_BACKOFF: Duration = Duration::from_millis(500);
/// Longest webhook URL accepted, bytes.
pub const WEBHOOK_URL_MAX: usize = 2000;
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

/// The webhook URLs of the tag profiles of `tags` (each once).
pub fn targets(profiles: &[mtcal_store::ToleranceProfile], tags: &[String]) -> Vec<String> {
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

/// POSTs `body` (alert `alert_id`) to `url` (see the module documentation for tries and limits); returns
/// whether a try was answered with a 2xx status.
pub async fn deliver<T: Serialize>(url: String, alert_id: String, body: T) -> bool {
    let mut wait = WEBHOOK_BACKOFF;
    for attempt in 1..=WEBHOOK_ATTEMPTS {
        match client().post(&url).json(&body).send().await {
            Ok(r) if r.status().is_success() => {
                tracing::info!(alert = %alert_id, %url, attempt, "webhook delivered");
                return true;
            }
            Ok(r) => {
                tracing::warn!(alert = %alert_id, %url, attempt, status = %r.status(), "webhook refused")
            }
            Err(e) => tracing::warn!(alert = %alert_id, %url, attempt, %e, "webhook failed"),
        }
        if attempt < WEBHOOK_ATTEMPTS {
            tokio::time::sleep(wait).await;
            wait *= 2;
        }
    }
    tracing::warn!(alert = %alert_id, %url, "webhook given up after {WEBHOOK_ATTEMPTS} tries");
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
