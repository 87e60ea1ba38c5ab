//! Verification at the next check, in the service: a machine with 6 µm of X backlash is
//! checked (a misfit, diagnosed and decided on its explained model), checked again with
//! the 6 µm left (the compensation not set: not as predicted), then with 0.3 µm left
//! (as predicted). The result's route, the machine's trend and the machine page say
//! each (docs/compensation.md, "Verification at the next check").

use crate::common::*;
use crate::explained::{backlash, checked, explained_of, get_json, latest, profile};
use mtcal_server::api::history::Verification;
use std::time::Duration;

/// Simulated lost motion of X, µm, and what is left once compensated.
const LOST_X: f64 = 6.0;
const LEFT_X: f64 = 0.3;

/// Waits until check `id` (else the machine's latest check, when `id` is None) is
/// verified with nothing pending (the later check's diagnosis has landed).
async fn settled(app: &App, machine: &str, id: Option<&str>) -> Verification {
    for _ in 0..1200 {
        let id = match id {
            Some(id) => id.to_string(),
            None => latest(app, machine).await.meta.id,
        };
        let v = app.client.verification(&id).await.unwrap();
        if !v.findings.is_empty() && v.findings.iter().all(|f| f.state != "pending") {
            return v;
        }
        tokio::time::sleep(Duration::from_millis(100)).await;
    }
    panic!("the check of {machine} was never verified");
}

/// The machine page's "Verification of the compensation" section.
async fn page_section(app: &App, machine: &str) -> String {
    let browser = app.sign_in(&app.read_key).await;
    let page = browser.get(&format!("/machines/{machine}")).await;
    let page = page.text().await.unwrap();
    let at = page
        .find(r#"id="verification""#)
        .expect("the machine page verifies the compensation");
    let s = &page[at..];
    s[..s.find("</section>").unwrap()].to_string()
}

async fn scenario(options: AppOptions) {
    let machine = "VERIFY-1";
    let app = spawn_app_with(options).await;
    app.machine(machine).await;
    // A drift threshold: the checks (each simulated with its own geometry) alert.
    profile(&app, machine, serde_json::json!({"drift_um": 0.5})).await;

    // The first check: a misfit, decided on its explained model; nothing before it.
    let (ds, _) = checked(&app, machine, 41, &[backlash("X", LOST_X)]).await;
    let first = explained_of(&app, machine, &ds).await;
    let v = app.client.verification(&first.meta.id).await.unwrap();
    assert!(v.findings.is_empty(), "{v:?}");
    assert_eq!(v.statement, "nothing to verify: no check before this one");
    let trend = app.client.verification_trend(machine).await.unwrap();
    assert!(trend.is_empty(), "{trend:?}");

    // Checked again with the compensation not set: the 6 µm are still there.
    let (ds, _) = checked(&app, machine, 42, &[backlash("X", LOST_X)]).await;
    let second = explained_of(&app, machine, &ds).await;
    let v = settled(&app, machine, Some(&second.meta.id)).await;
    assert_eq!(
        v.previous_result_id.as_deref(),
        Some(first.meta.id.as_str())
    );
    assert_eq!(v.findings.len(), 1, "{v:?}");
    let x = &v.findings[0];
    assert_eq!(
        (x.effect.as_str(), x.axis.as_deref()),
        ("backlash", Some("X"))
    );
    assert_eq!(
        (x.state.as_str(), x.as_predicted),
        ("still_present", Some(false)),
        "{}",
        x.statement
    );
    assert!((x.before - LOST_X).abs() < 0.3, "{}", x.statement);
    assert!(
        x.measured.is_some_and(|m| (m - LOST_X).abs() < 0.3),
        "{}",
        x.statement
    );
    assert_eq!(x.predicted, 0.0);
    assert!(
        x.statement.ends_with(
            "(predicted 0): not as predicted (the compensation was not set, or did not take)"
        ),
        "{}",
        x.statement
    );
    assert!(
        v.statement.ends_with(": 0 of 1 as predicted"),
        "{}",
        v.statement
    );
    let section = page_section(&app, machine).await;
    assert!(
        section.contains("0 of 1 as predicted") && section.contains("not as predicted (the"),
        "{section}"
    );

    // Its drift alert is measured between two explained models and says so; the
    // misfit it supersedes raised none.
    let alerts = get_json(&app, &format!("/api/v1/alerts?machine={machine}")).await;
    let alerts = alerts.as_array().unwrap();
    let a = alerts
        .iter()
        .find(|a| a["result_id"] == second.meta.id.as_str())
        .expect("the second check drifted from the first");
    assert_eq!(a["baseline_result_id"], first.meta.id.as_str(), "{a}");
    for f in ["explained_model", "baseline_explained_model"] {
        let s = a[f].as_str().unwrap_or_default();
        assert!(s.starts_with("decided on the explained model"), "{f}: {a}");
    }
    let message = a["message"].as_str().unwrap();
    assert!(
        message.ends_with(
            ". Both checks are decided on the explained model (the 21 terms fitted jointly with the physics the diagnosis of each recording found)"
        ),
        "{message}"
    );
    assert_eq!(alerts.len(), 1, "a misfit raises no alert: {alerts:?}");

    // Checked again with the compensation set: 0.3 µm left, as predicted.
    let (ds, _) = checked(&app, machine, 43, &[backlash("X", LEFT_X)]).await;
    let v = settled(&app, machine, None).await;
    let third = latest(&app, machine).await;
    assert_eq!(third.meta.dataset_id.as_deref(), Some(ds.as_str()));
    assert_eq!(
        v.previous_result_id.as_deref(),
        Some(second.meta.id.as_str())
    );
    assert_eq!(v.findings.len(), 1, "{v:?}");
    let x = &v.findings[0];
    assert_eq!(x.as_predicted, Some(true), "{}", x.statement);
    assert!((x.before - LOST_X).abs() < 0.3, "{}", x.statement);
    // Gone, or found at what was left.
    assert!(x.measured.is_none_or(|m| m < 0.5), "{}", x.statement);
    assert!(x.statement.contains("(predicted 0)"), "{}", x.statement);
    assert!(!x.statement.contains("not as predicted"), "{}", x.statement);
    assert!(
        v.statement.ends_with(": 1 of 1 as predicted"),
        "{}",
        v.statement
    );

    // The trend: the two checks after the first, in time order, each against the one
    // before it.
    let trend = app.client.verification_trend(machine).await.unwrap();
    let ids: Vec<_> = trend.iter().map(|t| t.result_id.as_str()).collect();
    assert_eq!(ids, [second.meta.id.as_str(), third.meta.id.as_str()]);
    let predicted: Vec<_> = trend.iter().map(|t| t.findings[0].as_predicted).collect();
    assert_eq!(predicted, [Some(false), Some(true)]);
    assert_eq!(
        trend[1].previous_result_id.as_deref(),
        Some(second.meta.id.as_str())
    );
    // The machine page shows the latest.
    let section = page_section(&app, machine).await;
    assert!(section.contains("1 of 1 as predicted"), "{section}");
    assert!(!section.contains("not as predicted"), "{section}");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_compensation_is_verified_at_the_next_checks() {
    scenario(AppOptions::default()).await;
}

/// The same on PostgreSQL (skipped, saying so, without `MTCAL_TEST_PG`).
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_compensation_is_verified_at_the_next_checks_on_postgres() {
    on_postgres("e2e::verification::postgres", scenario).await;
}
