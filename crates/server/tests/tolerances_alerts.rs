//! Tolerance profiles (API, validation, scopes), verdicts decided at their limits, and
//! drift alerts raised when a result lands: against hand-worked changes with known
//! uncertainties, listed, acknowledged, and POSTed to a webhook on 127.0.0.1.

use axum::body::Body;
use axum::http::{Request, StatusCode};
use mtcal_server::router;
use mtcal_store::{Figure, Machine, NewResult, ResultScalars, Scope, Store};
use serde_json::{Value, json};
use std::collections::BTreeMap;
use std::sync::Arc;
use tower::ServiceExt;

/// Webhooks may reach this test's receivers on 127.0.0.1 (and nothing else private).
fn local_hooks() -> mtcal_domain::webhooks::TargetPolicy {
    mtcal_domain::webhooks::TargetPolicy::with_allow_list("127.0.0.1").unwrap()
}

fn app(store: Arc<dyn Store>) -> axum::Router {
    let mut state = crate::common::state(store);
    state.settings = Arc::new(mtcal_server::Settings {
        webhooks: local_hooks(),
        ..mtcal_server::Settings::default()
    });
    router(state)
}

async fn send(
    app: &axum::Router,
    method: &str,
    uri: &str,
    key: &str,
    body: Option<Value>,
) -> (StatusCode, Value) {
    let r = Request::builder()
        .method(method)
        .uri(uri)
        .header("authorization", format!("Bearer {key}"))
        .header("content-type", "application/json");
    let req = match body {
        Some(b) => r.body(Body::from(b.to_string())).unwrap(),
        None => r.body(Body::empty()).unwrap(),
    };
    let resp = app.clone().oneshot(req).await.unwrap();
    let status = resp.status();
    let bytes = axum::body::to_bytes(resp.into_body(), 1 << 20)
        .await
        .unwrap();
    (
        status,
        serde_json::from_slice(&bytes).unwrap_or(Value::Null),
    )
}

struct Fixture {
    _dir: tempfile::TempDir,
    store: Arc<dyn Store>,
    app: axum::Router,
    read: String,
    write: String,
    admin: String,
}

async fn fixture() -> Fixture {
    let dir = tempfile::tempdir().unwrap();
    let url = dir.path().join("t.sqlite");
    fixture_on(dir, url.to_str().unwrap()).await
}

/// The fixture on the store `url` names (`dir`: kept while the fixture lives).
async fn fixture_on(dir: tempfile::TempDir, url: &str) -> Fixture {
    let store = mtcal_store::open(url).await.unwrap();
    let (_, read) = store.create_key(Scope::Read, "viewer").await.unwrap();
    let (_, write) = store.create_key(Scope::Write, "ops").await.unwrap();
    let (_, admin) = store.create_key(Scope::Admin, "admin").await.unwrap();
    Fixture {
        _dir: dir,
        app: app(store.clone()),
        store,
        read,
        write,
        admin,
    }
}

/// Retries of these tests: 3 tries, 50 ms then 100 ms apart, a claimed try held 500 ms.
const FAST: mtcal_domain::webhooks::Retries = mtcal_domain::webhooks::Retries {
    attempts: 3,
    first: std::time::Duration::from_millis(50),
    max: std::time::Duration::from_secs(1),
    lease: std::time::Duration::from_millis(500),
};

/// A process's workers on `store` (their outbox loop delivers to 127.0.0.1 with
/// [`FAST`] retries).
fn workers(store: &Arc<dyn Store>) -> mtcal_server::Workers {
    let cfg = mtcal_server::WorkerConfig {
        queue: mtcal_store::QueueConfig {
            poll_ms: 50,
            ..Default::default()
        },
        settings: mtcal_server::Settings {
            webhooks: local_hooks(),
            webhook_retries: FAST,
            ..Default::default()
        },
        ..Default::default()
    };
    mtcal_server::worker::spawn_workers(store.clone(), cfg, Default::default())
}

/// The outbox as `GET /api/v1/webhooks/deliveries` shows it to the fixture's write key.
async fn deliveries(f: &Fixture, query: &str) -> Vec<Value> {
    let (s, b) = send(
        &f.app,
        "GET",
        &format!("/api/v1/webhooks/deliveries{query}"),
        &f.write,
        None,
    )
    .await;
    assert_eq!(s, StatusCode::OK, "{b}");
    b.as_array().unwrap().clone()
}

/// Waits (at most 20 s) until the outbox holds no pending delivery.
async fn settled(f: &Fixture) -> Vec<Value> {
    for _ in 0..400 {
        let all = deliveries(f, "").await;
        if all.iter().all(|d| d["state"] != "pending") {
            return all;
        }
        tokio::time::sleep(std::time::Duration::from_millis(50)).await;
    }
    panic!("deliveries still pending: {:?}", deliveries(f, "").await)
}

fn machine(id: &str, tags: &[&str]) -> Machine {
    Machine {
        id: id.into(),
        name: id.into(),
        topology: json!({"workpiece": ["X", "Y"], "tool": ["Z"]}),
        travel_mm: BTreeMap::from([("X".into(), [-200.0, 200.0])]),
        site: None,
        tags: tags.iter().map(|t| t.to_string()).collect(),
        baseline_result_id: None,
        created_at: String::new(),
        updated_at: String::new(),
    }
}

fn message(b: &Value) -> String {
    b["error"]["message"]
        .as_str()
        .unwrap_or_default()
        .to_string()
}

#[tokio::test]
async fn profiles_are_written_with_a_write_key_and_bad_ones_refused_naming_the_field() {
    let f = fixture().await;
    f.store
        .create_machine(&machine("M1", &["vmc"]))
        .await
        .unwrap();
    let good = json!({"scope": "machine", "target": "M1",
                      "limits": {"terms": {"EXX": 5.0}, "squareness": {"EC0Y": 30.0},
                                 "standards": {"iso230_2.X.E_um": 8.0}, "drift_um": 2.0}});
    let (s, b) = send(
        &f.app,
        "POST",
        "/api/v1/tolerances",
        &f.read,
        Some(good.clone()),
    )
    .await;
    assert_eq!(s, StatusCode::FORBIDDEN, "{b}");
    for (body, field) in [
        (
            json!({"scope": "plant", "target": "M1", "limits": {"drift_um": 1.0}}),
            "scope",
        ),
        (
            json!({"scope": "machine", "target": "", "limits": {"drift_um": 1.0}}),
            "target",
        ),
        (
            json!({"scope": "machine", "target": "M1", "limits": {}}),
            "limits",
        ),
        (
            json!({"scope": "machine", "target": "M1", "limits": {"terms": {"EQX": 1.0}}}),
            "limits.terms.EQX",
        ),
        (
            json!({"scope": "machine", "target": "M1", "limits": {"squareness": {"EC0Y": -1.0}}}),
            "limits.squareness.EC0Y",
        ),
        (
            json!({"scope": "machine", "target": "M1", "limits": {"standards": {"iso230_2.W.E_um": 1.0}}}),
            "limits.standards.iso230_2.W.E_um",
        ),
        (
            json!({"scope": "machine", "target": "M1", "limits": {"drift_urad": 0.0}}),
            "limits.drift_urad",
        ),
        (
            json!({"scope": "machine", "target": "M1", "limits": {"termz": {}}}),
            "termz",
        ),
        (
            json!({"scope": "machine", "target": "M1", "limits": {"terms": {"EXX": "five"}}}),
            "limits.terms.EXX",
        ),
        (
            json!({"scope": "machine", "target": "M1", "limits": {"drift_um": 1.0},
                "webhook_url": "http://127.0.0.1:1/x"}),
            "webhook_url",
        ),
        (
            json!({"scope": "tag", "target": "vmc", "limits": {"drift_um": 1.0},
                "webhook_url": "ftp://127.0.0.1/x"}),
            "webhook_url",
        ),
        // Private, link-local and the service's neighbours: not on the allow-list.
        (
            json!({"scope": "tag", "target": "vmc", "limits": {"drift_um": 1.0},
                "webhook_url": "http://169.254.169.254/latest/meta-data/"}),
            "webhook_url",
        ),
        (
            json!({"scope": "tag", "target": "vmc", "limits": {"drift_um": 1.0},
                "webhook_url": "http://0x7f.2:5432/"}),
            "webhook_url",
        ),
        (
            json!({"scope": "tag", "target": "vmc", "limits": {"drift_um": 1.0},
                "webhook_url": "http://user:pw@127.0.0.1/x"}),
            "webhook_url",
        ),
        (
            json!({"scope": "tag", "target": "vmc", "limits": {"drift_um": 1.0},
                "webhook_url": "http://127.0.0.1:1/x", "webhook_secret": "too-short"}),
            "webhook_secret",
        ),
        (
            json!({"scope": "tag", "target": "vmc", "limits": {"drift_um": 1.0},
                "webhook_secret": "a-secret-without-a-webhook"}),
            "webhook_secret",
        ),
    ] {
        let (s, b) = send(
            &f.app,
            "POST",
            "/api/v1/tolerances",
            &f.write,
            Some(body.clone()),
        )
        .await;
        assert_eq!(s, StatusCode::BAD_REQUEST, "{body}: {b}");
        assert!(
            message(&b).contains(field),
            "{body}: {b} should name {field}"
        );
    }
    let (s, b) = send(
        &f.app,
        "POST",
        "/api/v1/tolerances",
        &f.write,
        Some(json!({"scope": "machine", "target": "NOPE", "limits": {"drift_um": 1.0}})),
    )
    .await;
    assert_eq!(s, StatusCode::NOT_FOUND, "{b}");
    assert!(
        f.store.list_tolerances().await.unwrap().is_empty(),
        "nothing stored"
    );

    let (s, p) = send(
        &f.app,
        "POST",
        "/api/v1/tolerances",
        &f.write,
        Some(good.clone()),
    )
    .await;
    assert_eq!(s, StatusCode::CREATED, "{p}");
    assert_eq!(p["limits"]["terms"]["EXX"], 5.0);
    let id = p["id"].as_str().unwrap().to_string();
    let (s, b) = send(&f.app, "POST", "/api/v1/tolerances", &f.write, Some(good)).await;
    assert_eq!(s, StatusCode::CONFLICT, "{b}");
    let (s, list) = send(&f.app, "GET", "/api/v1/tolerances", &f.read, None).await;
    assert_eq!((s, list.as_array().unwrap().len()), (StatusCode::OK, 1));
    let (s, b) = send(
        &f.app,
        "PUT",
        &format!("/api/v1/tolerances/{id}"),
        &f.read,
        Some(json!({"limits": {"drift_um": 3.0}})),
    )
    .await;
    assert_eq!(s, StatusCode::FORBIDDEN, "{b}");
    let (s, b) = send(
        &f.app,
        "PUT",
        &format!("/api/v1/tolerances/{id}"),
        &f.write,
        Some(json!({"limits": {"drift_um": -3.0}})),
    )
    .await;
    assert_eq!(s, StatusCode::BAD_REQUEST, "{b}");
    assert!(message(&b).contains("limits.drift_um"), "{b}");
    let (s, b) = send(
        &f.app,
        "PUT",
        &format!("/api/v1/tolerances/{id}"),
        &f.write,
        Some(json!({"limits": {"drift_um": 3.0}})),
    )
    .await;
    assert_eq!(s, StatusCode::OK, "{b}");
    assert_eq!(
        b["limits"],
        json!({"terms": {}, "squareness": {}, "standards": {}, "drift_um": 3.0, "drift_urad": null})
    );
    let (s, got) = send(
        &f.app,
        "GET",
        &format!("/api/v1/tolerances/{id}"),
        &f.read,
        None,
    )
    .await;
    assert_eq!(
        (s, &got["limits"]["drift_um"]),
        (StatusCode::OK, &json!(3.0))
    );
    let (s, _) = send(
        &f.app,
        "DELETE",
        &format!("/api/v1/tolerances/{id}"),
        &f.read,
        None,
    )
    .await;
    assert_eq!(s, StatusCode::FORBIDDEN);
    let (s, _) = send(
        &f.app,
        "DELETE",
        &format!("/api/v1/tolerances/{id}"),
        &f.write,
        None,
    )
    .await;
    assert_eq!(s, StatusCode::NO_CONTENT);
    let (s, _) = send(
        &f.app,
        "GET",
        &format!("/api/v1/tolerances/{id}"),
        &f.read,
        None,
    )
    .await;
    assert_eq!(s, StatusCode::NOT_FOUND);
}

/// A standards result with ISO 230-2 E = 6.0 µm, u = 0.5 µm (U = 1 µm).
fn standards_result(machine: &str) -> NewResult {
    NewResult {
        check_model: None,
        machine_id: machine.into(),
        dataset_id: None,
        kind: "standards".into(),
        measured_at: "2026-01-05T08:00:00Z".into(),
        document: json!({}),
        scalars: ResultScalars::default(),
        figures: vec![Figure {
            name: "iso230_2.X.E_um".into(),
            value: 6.0,
            u: Some(0.5),
        }],
    }
}

#[tokio::test]
async fn verdict_at_the_limit_with_the_machines_own_profile_winning_over_its_tags() {
    let f = fixture().await;
    f.store
        .create_machine(&machine("M1", &["line-a"]))
        .await
        .unwrap();
    let r = f.store.import_result(standards_result("M1")).await.unwrap();
    let uri = format!("/api/v1/results/{}/verdict", r.id);
    let (s, v) = send(&f.app, "GET", &uri, &f.read, None).await;
    assert_eq!(s, StatusCode::OK, "{v}");
    assert_eq!((&v["profile"], &v["verdict"]), (&Value::Null, &Value::Null));

    // The tag's profile: E + U = 6 + 1 = 7 <= 7 passes (at the limit).
    let tag = json!({"scope": "tag", "target": "line-a", "limits": {"standards": {"iso230_2.X.E_um": 7.0}}});
    let (s, b) = send(&f.app, "POST", "/api/v1/tolerances", &f.write, Some(tag)).await;
    assert_eq!(s, StatusCode::CREATED, "{b}");
    let (_, v) = send(&f.app, "GET", &uri, &f.read, None).await;
    assert_eq!(v["profile"]["scope"], "tag");
    assert_eq!(v["verdict"]["decision"], "pass", "{v}");
    assert_eq!(v["verdict"]["items"][0]["expanded_u"], 1.0);
    assert_eq!(v["verdict"]["k"], 2.0);

    // The machine's own profile wins: 6.95 lies inside [E − U, E + U]: undecided;
    // then 4.99 < E − U = 5: fail; 5.0 = E − U is not beyond it: undecided.
    let own = json!({"scope": "machine", "target": "M1", "limits": {"standards": {"iso230_2.X.E_um": 6.95}}});
    let (_, p) = send(&f.app, "POST", "/api/v1/tolerances", &f.write, Some(own)).await;
    let pid = p["id"].as_str().unwrap().to_string();
    let (_, v) = send(&f.app, "GET", &uri, &f.read, None).await;
    assert_eq!(v["profile"]["scope"], "machine");
    assert_eq!(v["verdict"]["decision"], "undecided", "{v}");
    for (limit, decision) in [
        (4.99, "fail"),
        (5.0, "undecided"),
        (7.0, "pass"),
        (6.99, "undecided"),
    ] {
        let (s, b) = send(
            &f.app,
            "PUT",
            &format!("/api/v1/tolerances/{pid}"),
            &f.write,
            Some(json!({"limits": {"standards": {"iso230_2.X.E_um": limit}}})),
        )
        .await;
        assert_eq!(s, StatusCode::OK, "{b}");
        let (_, v) = send(&f.app, "GET", &uri, &f.read, None).await;
        assert_eq!(v["verdict"]["decision"], decision, "limit {limit}: {v}");
    }
    // A limit the result has no figure for takes no part.
    let (_, _) = send(
        &f.app,
        "PUT",
        &format!("/api/v1/tolerances/{pid}"),
        &f.write,
        Some(json!({"limits": {"standards": {"iso230_4.XY.bi.G_um": 3.0}}})),
    )
    .await;
    let (_, v) = send(&f.app, "GET", &uri, &f.read, None).await;
    assert_eq!(v["verdict"]["decision"], Value::Null, "{v}");
    assert_eq!(
        v["verdict"]["not_evaluated"][0]["item"],
        "iso230_4.XY.bi.G_um"
    );
}

/// An identification's scalars: EXX = c1·q over the measured travel X ∈ [−50, 50] mm,
/// its coefficient's variance `var` (so u(q) = √var·|q|).
use crate::common::identification;

// Hand-worked: both checks have var(c1) = s² with s = 1/(50·√2), so the change
// Δ(q) = c1·q has u(q) = √2·s·|q| = 1 µm at q = ±50 mm, where |Δ| − U is largest.
// Threshold T = 5 µm. c1 = 0.12: |Δ| = 6 = T + 1σ, |Δ| − U = 4 ≤ 5: no alert.
// c1 = 0.16: |Δ| = 8 = T + 3σ, |Δ| − U = 6 > 5: alert.
const S2: f64 = 1.0 / 5000.0;

#[tokio::test]
async fn a_drift_inside_its_uncertainty_raises_no_alert_one_3_sigma_outside_does() {
    let f = fixture().await;
    f.store
        .create_machine(&machine("M1", &["vmc"]))
        .await
        .unwrap();
    let (s, b) = send(
        &f.app,
        "POST",
        "/api/v1/tolerances",
        &f.write,
        Some(json!({"scope": "machine", "target": "M1", "limits": {"drift_um": 5.0}})),
    )
    .await;
    assert_eq!(s, StatusCode::CREATED, "{b}");
    // A check of M1 at `at` with EXX drifted by `rate`, stored and landed: its alert.
    let land = |at: &'static str, rate: f64| {
        let store = f.store.clone();
        async move {
            let r = store
                .import_result(identification("M1", at, rate, S2))
                .await
                .unwrap();
            let alert = mtcal_domain::landing::result_landed(&store, "M1", &r.id)
                .await
                .unwrap();
            (r, alert)
        }
    };
    let (base, alert) = land("2026-01-05T08:00:00Z", 0.0).await;
    assert!(alert.is_none(), "the baseline never alerts");
    let (_, alert) = land("2026-04-05T08:00:00Z", 0.12).await;
    assert!(alert.is_none(), "T + 1σ is inside the expanded uncertainty");
    let (outside, alert) = land("2026-07-05T08:00:00Z", 0.16).await;
    let alert = alert.expect("T + 3σ alerts");
    assert_eq!(alert.items.len(), 1);
    let item = &alert.items[0];
    assert_eq!(item.item, "EXX");
    assert!((item.value.unwrap().abs() - 8.0).abs() < 1e-9, "{item:?}");
    assert!((item.u.unwrap() - 1.0).abs() < 1e-9, "{item:?}");
    assert_eq!(item.position_mm.map(f64::abs), Some(50.0));
    assert_eq!(item.limit, 5.0);
    assert_eq!(alert.raised.baseline_result_id, base.id);
    // The message says it in words: the machine, both checks' dates, the values before
    // and after with U, the change and the threshold; no stored id.
    let m = &alert.raised.message;
    assert!(
        m.starts_with(
            "M1 drifted between its baseline check of 2026-01-05 and the check of 2026-07-05: EXX at "
        ) && m.contains(" mm from ") && m.contains("0.000 ± 1.414 µm (2026-01-05) to ")
            && m.contains("8.000 ± 1.414 µm (2026-07-05), a change of ")
            && m.contains("8.000 ± 2.000 µm, beyond the threshold of 5.000 µm by more than U"),
        "{m}"
    );
    assert!(!m.contains(&base.id) && !m.contains(&outside.id), "{m}");
    assert_eq!(
        (
            alert.baseline_measured_at.as_deref(),
            alert.measured_at.as_deref()
        ),
        (Some("2026-01-05T08:00:00Z"), Some("2026-07-05T08:00:00Z"))
    );
    let c = &alert.changes[0];
    // Before: c1 = 0 with u = s·50 = 0.7071 µm; after: ±8 µm; the change their difference.
    assert_eq!(c.item, "EXX");
    assert!(c.before.unwrap().abs() < 1e-12, "{c:?}");
    assert!(
        (c.before_u.unwrap() - 50.0 * S2.sqrt()).abs() < 1e-9,
        "{c:?}"
    );
    assert!((c.after.unwrap().abs() - 8.0).abs() < 1e-9, "{c:?}");
    assert!((c.after.unwrap() - c.before.unwrap() - c.change.unwrap()).abs() < 1e-9);
    assert_eq!(c.threshold, 5.0);
    // Landing twice (a job run again) raises no second alert.
    assert!(
        mtcal_domain::landing::result_landed(&f.store, "M1", &outside.id)
            .await
            .unwrap()
            .is_none()
    );

    // Listed, filtered, acknowledged once with who and when.
    let (s, list) = send(
        &f.app,
        "GET",
        "/api/v1/alerts?machine=M1&active=true",
        &f.read,
        None,
    )
    .await;
    assert_eq!(s, StatusCode::OK, "{list}");
    assert_eq!(list.as_array().unwrap().len(), 1);
    assert_eq!(list[0]["id"], alert.raised.id.as_str());
    assert_eq!(list[0]["active"], true);
    let (s, _) = send(&f.app, "GET", "/api/v1/alerts?machine=M2", &f.read, None).await;
    assert_eq!(s, StatusCode::OK);
    let (s, b) = send(&f.app, "GET", "/api/v1/alerts?active=maybe", &f.read, None).await;
    assert_eq!(s, StatusCode::BAD_REQUEST, "{b}");
    let ack = format!("/api/v1/alerts/{}/ack", alert.raised.id);
    let (s, _) = send(&f.app, "POST", &ack, &f.read, None).await;
    assert_eq!(s, StatusCode::FORBIDDEN);
    // A comment longer than 1000 characters is refused and acknowledges nothing.
    let long = json!({"comment": "x".repeat(1001)});
    let (s, b) = send(&f.app, "POST", &ack, &f.write, Some(long)).await;
    assert_eq!(s, StatusCode::BAD_REQUEST, "{b}");
    let (s, b) = send(&f.app, "POST", &ack, &f.write, Some(json!({"note": "x"}))).await;
    assert_eq!(s, StatusCode::BAD_REQUEST, "{b}");
    let (_, list) = send(&f.app, "GET", "/api/v1/alerts?active=true", &f.read, None).await;
    assert_eq!(list.as_array().unwrap().len(), 1, "{list}");
    let comment = json!({"comment": "  ballscrew re-tensioned, check repeated  "});
    let (s, a) = send(&f.app, "POST", &ack, &f.write, Some(comment)).await;
    assert_eq!(s, StatusCode::OK, "{a}");
    assert_eq!(a["active"], false);
    assert_eq!(
        a["acknowledgement_comment"],
        "ballscrew re-tensioned, check repeated"
    );
    // Acknowledged again (no body): the first acknowledgement stays, with its comment.
    let (s, again) = send(&f.app, "POST", &ack, &f.write, None).await;
    assert_eq!(s, StatusCode::OK, "{again}");
    assert_eq!(
        again["acknowledgement_comment"],
        a["acknowledgement_comment"]
    );
    assert!(
        a["acknowledged_by"].as_str().unwrap().contains("(ops)"),
        "{a}"
    );
    assert!(a["acknowledged_at"].is_string());
    let (_, list) = send(&f.app, "GET", "/api/v1/alerts?active=true", &f.read, None).await;
    assert!(list.as_array().unwrap().is_empty(), "{list}");
    let (s, _) = send(
        &f.app,
        "POST",
        "/api/v1/alerts/alert_nope/ack",
        &f.write,
        None,
    )
    .await;
    assert_eq!(s, StatusCode::NOT_FOUND);

    // Without a drift threshold nothing alerts.
    f.store.create_machine(&machine("M2", &[])).await.unwrap();
    let b2 = f
        .store
        .import_result(identification("M2", "2026-01-05T08:00:00Z", 0.0, S2))
        .await
        .unwrap();
    let r2 = f
        .store
        .import_result(identification("M2", "2026-04-05T08:00:00Z", 0.5, S2))
        .await
        .unwrap();
    let _ = b2;
    assert!(
        mtcal_domain::landing::result_landed(&f.store, "M2", &r2.id)
            .await
            .unwrap()
            .is_none()
    );
}

/// What a webhook receiver accepted: the body's bytes and the signature header.
struct Delivered {
    body: Vec<u8>,
    signature: Option<String>,
}

impl Delivered {
    fn json(&self) -> Value {
        serde_json::from_slice(&self.body).unwrap()
    }
}

/// A webhook receiver on 127.0.0.1: answers 500 to the first `fail_first` requests, then
/// 200; every request it accepted goes to the channel.
async fn receiver(fail_first: usize) -> (String, tokio::sync::mpsc::UnboundedReceiver<Delivered>) {
    use std::sync::atomic::{AtomicUsize, Ordering};
    let (tx, rx) = tokio::sync::mpsc::unbounded_channel();
    let seen = Arc::new(AtomicUsize::new(0));
    let handler = move |headers: axum::http::HeaderMap, body: axum::body::Bytes| {
        let (tx, seen) = (tx.clone(), seen.clone());
        async move {
            if seen.fetch_add(1, Ordering::SeqCst) < fail_first {
                return StatusCode::INTERNAL_SERVER_ERROR;
            }
            assert_eq!(headers["content-type"], "application/json");
            let signature = headers
                .get("mtcal-signature")
                .map(|v| v.to_str().unwrap().to_string());
            tx.send(Delivered {
                body: body.to_vec(),
                signature,
            })
            .unwrap();
            StatusCode::NO_CONTENT
        }
    };
    let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
    let addr = listener.local_addr().unwrap();
    assert!(addr.ip().is_loopback());
    let app = axum::Router::new().route("/hook", axum::routing::post(handler));
    tokio::spawn(async move { axum::serve(listener, app).await });
    (format!("http://{addr}/hook"), rx)
}

/// Checks a delivery's signature as a receiver would, with nothing of the service's
/// code: `t=<unix seconds>,v1=<hex HMAC-SHA256(secret, "<t>.<body>")>`, within five
/// minutes of now.
fn verify(secret: &str, d: &Delivered) -> Result<(), String> {
    use hmac::{Hmac, Mac};
    let header = d.signature.as_deref().ok_or("unsigned")?;
    let (mut t, mut v1) = (None, None);
    for part in header.split(',') {
        match part.split_once('=') {
            Some(("t", x)) => t = Some(x),
            Some(("v1", x)) => v1 = Some(x),
            _ => return Err(format!("unknown part {part:?}")),
        }
    }
    let (t, v1) = (t.ok_or("no t")?, v1.ok_or("no v1")?);
    let now = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .unwrap()
        .as_secs() as i64;
    if (now - t.parse::<i64>().map_err(|e| e.to_string())?).abs() > 300 {
        return Err(format!("timestamp {t} is not within 5 min of {now}"));
    }
    let mut mac = Hmac::<sha2::Sha256>::new_from_slice(secret.as_bytes()).unwrap();
    mac.update(format!("{t}.").as_bytes());
    mac.update(&d.body);
    mac.verify_slice(&hex::decode(v1).map_err(|e| e.to_string())?)
        .map_err(|_| "signature does not match".to_string())
}

/// Lands a baseline of machine M1, then a check whose EXX drifted beyond a 5 µm
/// threshold (0.16 µm/mm), and returns the alert it raised.
async fn drift_alert(f: &Fixture) -> mtcal_domain::alerts::AlertView {
    for (at, slope) in [
        ("2026-01-05T08:00:00Z", 0.0),
        ("2026-04-05T08:00:00Z", 0.16),
    ] {
        let r = f
            .store
            .import_result(identification("M1", at, slope, S2))
            .await
            .unwrap();
        let raised = mtcal_domain::landing::result_landed(&f.store, "M1", &r.id)
            .await
            .unwrap();
        if slope > 0.0 {
            return raised.expect("alert");
        }
    }
    unreachable!()
}

#[tokio::test]
async fn an_alert_is_posted_to_the_webhook_of_the_machines_tag_and_a_dead_one_fails_nothing() {
    let f = fixture().await;
    let (url, mut rx) = receiver(1).await;
    // A webhook that nobody answers (a closed port on 127.0.0.1).
    let dead = {
        let l = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
        format!("http://{}/hook", l.local_addr().unwrap())
    };
    f.store
        .create_machine(&machine("M1", &["line-a", "line-b"]))
        .await
        .unwrap();
    let mut secrets = vec![];
    for (tag, hook, drift) in [("line-a", &url, json!(5.0)), ("line-b", &dead, json!(50.0))] {
        let (s, b) = send(&f.app, "POST", "/api/v1/tolerances", &f.write,
            Some(json!({"scope": "tag", "target": tag, "limits": {"drift_um": drift}, "webhook_url": hook}))).await;
        assert_eq!(s, StatusCode::CREATED, "{b}");
        assert_eq!(b["webhook_url"], hook.as_str());
        secrets.push(b["webhook_secret"].as_str().unwrap().to_string());
    }
    // The first tag's profile applies (5 µm); both tags' webhooks are told, by the
    // workers.
    let alert = drift_alert(&f).await;
    let w = workers(&f.store);
    let got = tokio::time::timeout(std::time::Duration::from_secs(20), rx.recv())
        .await
        .expect("the webhook is called within its tries")
        .unwrap();
    verify(&secrets[0], &got).unwrap();
    assert!(verify(&secrets[1], &got).is_err(), "another hook's secret");
    let mut forged = Delivered {
        body: got.body.clone(),
        signature: got.signature.clone(),
    };
    forged.body.extend_from_slice(b" ");
    assert!(verify(&secrets[0], &forged).is_err(), "a changed body");
    let got = got.json();
    assert_eq!(
        got["id"],
        alert.raised.id.as_str(),
        "after one refused try: {got}"
    );
    assert_eq!(got["machine_id"], "M1");
    assert_eq!(got["items"][0]["item"], "EXX");
    assert_eq!(got["active"], true);
    // The receiver's first answer was a 500: delivered at the second try; the dead one
    // failed after its three tries, each error kept.
    let all = settled(&f).await;
    w.shutdown().await;
    let of = |u: &str| all.iter().find(|d| d["url"] == u).unwrap().clone();
    let (ok, failed) = (of(&url), of(&dead));
    assert_eq!(
        (&ok["state"], &ok["attempts"], &ok["alert_id"]),
        (&json!("delivered"), &json!(2), &json!(alert.raised.id)),
        "{ok}"
    );
    assert!(ok["last_error"].as_str().unwrap().contains("500"), "{ok}");
    assert_eq!(ok["next_attempt_at"], Value::Null);
    assert_eq!(
        (&failed["state"], &failed["attempts"]),
        (&json!("failed"), &json!(3)),
        "{failed}"
    );
    assert!(
        failed["last_error"].as_str().is_some_and(|e| !e.is_empty()),
        "{failed}"
    );
    assert_eq!(deliveries(&f, "?state=failed").await, [failed]);
    assert_eq!(
        deliveries(&f, &format!("?alert_id={}&limit=1", alert.raised.id))
            .await
            .len(),
        1
    );
    for (q, says) in [("?state=lost", "state"), ("?limit=0", "limit")] {
        let (s, b) = send(
            &f.app,
            "GET",
            &format!("/api/v1/webhooks/deliveries{q}"),
            &f.write,
            None,
        )
        .await;
        assert_eq!(s, StatusCode::BAD_REQUEST, "{q}: {b}");
        assert!(message(&b).contains(says), "{q}: {b}");
    }
}

/// A webhook's secret is write-only: generated and shown once when none is given, kept
/// when a replacement gives none, replaced when one is given, never in what a key reads
/// back; deliveries are signed with the secret the profile holds at the time.
#[tokio::test]
async fn webhook_secrets_are_shown_once_and_sign_the_deliveries() {
    let f = fixture().await;
    let (url, mut rx) = receiver(0).await;
    f.store
        .create_machine(&machine("M1", &["line-a"]))
        .await
        .unwrap();
    let (s, b) = send(&f.app, "POST", "/api/v1/tolerances", &f.write,
        Some(json!({"scope": "tag", "target": "line-a", "limits": {"drift_um": 5.0}, "webhook_url": url}))).await;
    assert_eq!(s, StatusCode::CREATED, "{b}");
    let generated = b["webhook_secret"].as_str().unwrap().to_string();
    assert!(
        generated.starts_with("whsec_") && generated.len() == 6 + 64,
        "{generated}"
    );
    assert_eq!(b["webhook_signed"], true);
    let id = b["id"].as_str().unwrap().to_string();
    let path = format!("/api/v1/tolerances/{id}");
    for key in [&f.read, &f.write] {
        for uri in ["/api/v1/tolerances", path.as_str()] {
            let (s, b) = send(&f.app, "GET", uri, key, None).await;
            assert_eq!(s, StatusCode::OK, "{b}");
            let text = b.to_string();
            assert!(
                !text.contains(&generated[6..]),
                "{uri} shows the secret: {text}"
            );
            assert!(!text.contains("webhook_secret"), "{uri}: {text}");
            assert!(text.contains(r#""webhook_signed":true"#), "{uri}: {text}");
        }
    }
    // A replacement without a secret keeps it (and does not show it).
    let (s, b) = send(
        &f.app,
        "PUT",
        &path,
        &f.write,
        Some(json!({"limits": {"drift_um": 4.0}, "webhook_url": url})),
    )
    .await;
    assert_eq!(s, StatusCode::OK, "{b}");
    assert!(b.get("webhook_secret").is_none(), "{b}");
    assert_eq!(
        f.store
            .get_tolerance(&id)
            .await
            .unwrap()
            .webhook_secret
            .as_deref(),
        Some(generated.as_str())
    );
    // One given replaces it, and is not echoed.
    let chosen = "receiver-chosen-secret-0001";
    let (s, b) = send(
        &f.app,
        "PUT",
        &path,
        &f.write,
        Some(json!({"limits": {"drift_um": 4.0}, "webhook_url": url, "webhook_secret": chosen})),
    )
    .await;
    assert_eq!(s, StatusCode::OK, "{b}");
    assert!(!b.to_string().contains(chosen), "{b}");
    drift_alert(&f).await;
    let w = workers(&f.store);
    let got = tokio::time::timeout(std::time::Duration::from_secs(20), rx.recv())
        .await
        .expect("delivered")
        .unwrap();
    w.shutdown().await;
    verify(chosen, &got).unwrap();
    assert!(verify(&generated, &got).is_err(), "the replaced secret");
    // Removing the webhook removes its secret.
    let (s, b) = send(
        &f.app,
        "PUT",
        &path,
        &f.write,
        Some(json!({"limits": {"drift_um": 4.0}})),
    )
    .await;
    assert_eq!(s, StatusCode::OK, "{b}");
    assert_eq!(b["webhook_signed"], false);
    assert_eq!(
        f.store.get_tolerance(&id).await.unwrap().webhook_secret,
        None
    );
}

/// The outbox survives its worker: a delivery is stored with its alert (pending, before
/// any worker runs); a worker claims a try and dies before finishing it; once the
/// claim's time has passed, the restarted worker delivers it, signed. Admin and write
/// keys see the states, a read key is refused; nothing shows the secret or the URL's
/// query.
async fn outbox_story(f: Fixture) {
    let (url, mut rx) = receiver(0).await;
    let hook = format!("{url}?token=query-secret");
    f.store
        .create_machine(&machine("M1", &["line-a"]))
        .await
        .unwrap();
    let (s, b) = send(
        &f.app,
        "POST",
        "/api/v1/tolerances",
        &f.write,
        Some(
            json!({"scope": "tag", "target": "line-a", "limits": {"drift_um": 5.0},
                    "webhook_url": hook, "webhook_secret": "outbox-test-secret-01"}),
        ),
    )
    .await;
    assert_eq!(s, StatusCode::CREATED, "{b}");
    let alert = drift_alert(&f).await;
    let before = deliveries(&f, "").await;
    assert_eq!(before.len(), 1, "{before:?}");
    assert_eq!(
        (
            &before[0]["state"],
            &before[0]["attempts"],
            &before[0]["alert_id"]
        ),
        (&json!("pending"), &json!(0), &json!(alert.raised.id))
    );
    assert_eq!(before[0]["url"], url.as_str(), "shown without its query");
    let (s, _) = send(&f.app, "GET", "/api/v1/webhooks/deliveries", &f.read, None).await;
    assert_eq!(s, StatusCode::FORBIDDEN);
    let (s, b) = send(&f.app, "GET", "/api/v1/webhooks/deliveries", &f.admin, None).await;
    assert_eq!(s, StatusCode::OK);
    let text = b.to_string();
    assert!(
        !text.contains("query-secret") && !text.contains("outbox-test-secret"),
        "{text}"
    );
    // A worker claims the try and dies mid-try (it never records an outcome).
    let claimed = f
        .store
        .claim_delivery(FAST.lease.as_millis() as i64)
        .await
        .unwrap()
        .unwrap();
    assert_eq!(claimed.attempts, 1);
    assert!(
        f.store.claim_delivery(60_000).await.unwrap().is_none(),
        "claimed once"
    );
    let during = deliveries(&f, "").await;
    assert_eq!(
        (&during[0]["state"], &during[0]["attempts"]),
        (&json!("pending"), &json!(1))
    );
    assert!(rx.try_recv().is_err(), "nothing was sent");
    // The restarted worker.
    let w = workers(&f.store);
    let got = tokio::time::timeout(std::time::Duration::from_secs(20), rx.recv())
        .await
        .expect("delivered after the restart")
        .unwrap();
    verify("outbox-test-secret-01", &got).unwrap();
    assert_eq!(got.json()["id"], alert.raised.id.as_str());
    let after = settled(&f).await;
    w.shutdown().await;
    assert_eq!(
        (&after[0]["state"], &after[0]["attempts"]),
        (&json!("delivered"), &json!(2)),
        "{after:?}"
    );
    // The dead worker's late outcome changes nothing.
    f.store
        .finish_delivery(
            &claimed.id,
            claimed.attempts,
            &mtcal_store::DeliveryOutcome::Failed {
                error: "late".into(),
            },
        )
        .await
        .unwrap();
    assert_eq!(deliveries(&f, "").await, after);
    assert!(rx.try_recv().is_err(), "delivered once");
}

#[tokio::test]
async fn a_pending_delivery_survives_a_worker_that_died_on_sqlite() {
    outbox_story(fixture().await).await;
}

#[tokio::test]
async fn a_pending_delivery_survives_a_worker_that_died_on_postgres() {
    let Some(pg) = mtcal_store::testing::ScratchPg::create("outbox")
        .await
        .unwrap()
    else {
        eprintln!("MTCAL_TEST_PG not set: skipped");
        return;
    };
    outbox_story(fixture_on(tempfile::tempdir().unwrap(), &pg.url).await).await;
    pg.drop_schema().await.unwrap();
}

/// The check report of a backlash machine's identification whose dataset has a stored
/// diagnosis that does not read: the report opens with the misfit banner and says that
/// the diagnosis (named by its id) could not be read, never "No diagnosis was run"; it
/// holds the uncertainty budget table with the instrument "not included" (the session
/// states none).
#[tokio::test]
async fn the_report_says_a_stored_diagnosis_could_not_be_read() {
    let doc = crate::common::backlash_identification();
    let f = fixture().await;
    f.store.create_machine(&machine("M1", &[])).await.unwrap();
    let ds = f
        .store
        .insert_dataset(mtcal_store::NewDataset {
            machine_id: "M1".into(),
            kind: "session".into(),
            measured_at: "2026-01-05T08:00:00Z".into(),
            samples: 1,
            files: vec![("session.json".into(), b"{}".to_vec())],
        })
        .await
        .unwrap();
    let stored = |kind: &str, document: Value| NewResult {
        check_model: None,
        machine_id: "M1".into(),
        dataset_id: Some(ds.id.clone()),
        kind: kind.into(),
        measured_at: "2026-01-05T08:00:00Z".into(),
        document,
        scalars: ResultScalars::default(),
        figures: vec![],
    };
    let r = f
        .store
        .import_result(stored(
            "identification",
            serde_json::to_value(&doc).unwrap(),
        ))
        .await
        .unwrap();
    let report = |id: String| {
        let app = f.app.clone();
        let key = f.read.clone();
        async move {
            let req = Request::builder()
                .uri(format!("/api/v1/results/{id}/report"))
                .header("authorization", format!("Bearer {key}"))
                .body(Body::empty())
                .unwrap();
            let resp = app.oneshot(req).await.unwrap();
            assert_eq!(resp.status(), StatusCode::OK);
            let bytes = axum::body::to_bytes(resp.into_body(), 1 << 24)
                .await
                .unwrap();
            String::from_utf8(bytes.to_vec()).unwrap()
        }
    };
    let before = report(r.id.clone()).await;
    assert!(before.contains("No diagnosis was run"));
    let bad = f
        .store
        .import_result(stored(
            "diagnosis",
            json!({"kind": "diagnosis", "machine_id": "M1", "findings": "not a list"}),
        ))
        .await
        .unwrap();
    let page = report(r.id.clone()).await;
    assert!(!page.contains("No diagnosis was run"), "{page}");
    let findings = &page[page.find(r#"id="findings""#).expect("findings")..];
    let findings = &findings[..findings.find("</section>").unwrap()];
    assert!(
        findings.contains("could not be read") && findings.contains(&bad.id),
        "{findings}"
    );
    let article = &page[page.find("<article").unwrap()..];
    let first = &article[article.find("<section").unwrap()..];
    assert!(
        first[..first.find('>').unwrap()].contains(r#"id="misfit""#),
        "the report opens with the misfit banner"
    );
    let banner = &first[..first.find("</section>").unwrap()];
    assert!(
        banner.contains("the model does not explain this recording") && banner.contains(&bad.id),
        "{banner}"
    );
    let budget = &page[page.find(r#"id="budget""#).expect("the budget table")..];
    assert!(budget.contains(r#"data-item="EXX""#) && budget.contains("not included"));
}

/// A backlash machine's identification (the model does not explain its recording): its
/// compensation export answers 409 `model_misfit` unless `force=true`, whose table says
/// why in its first line; its verdict on a term is "misfit" with the gate's statement.
#[tokio::test]
async fn a_misfit_result_is_not_decided_and_its_table_needs_force() {
    let doc = crate::common::backlash_identification();
    assert!(doc.model_check().is_misfit());
    let f = fixture().await;
    f.store.create_machine(&machine("M1", &[])).await.unwrap();
    let r = f
        .store
        .import_result(NewResult {
            check_model: None,
            machine_id: "M1".into(),
            dataset_id: None,
            kind: "identification".into(),
            measured_at: "2026-01-05T08:00:00Z".into(),
            document: serde_json::to_value(&doc).unwrap(),
            scalars: ResultScalars::default(),
            figures: vec![],
        })
        .await
        .unwrap();
    let uri = format!("/api/v1/results/{}/export?format=csv", r.id);
    let (s, b) = send(&f.app, "GET", &uri, &f.read, None).await;
    assert_eq!(s, StatusCode::CONFLICT, "{b}");
    assert_eq!(b["error"]["code"], "model_misfit", "{b}");
    let req = Request::builder()
        .uri(format!("{uri}&force=true"))
        .header("authorization", format!("Bearer {}", f.read))
        .body(Body::empty())
        .unwrap();
    let resp = f.app.clone().oneshot(req).await.unwrap();
    assert_eq!(resp.status(), StatusCode::OK);
    let text = axum::body::to_bytes(resp.into_body(), 1 << 24)
        .await
        .unwrap();
    let text = String::from_utf8(text.to_vec()).unwrap();
    assert!(
        text.starts_with("# FORCED, NOT FOR USE WITHOUT REVIEW: the model does not explain"),
        "{}",
        &text[..200.min(text.len())]
    );
    let own = json!({"scope": "machine", "target": "M1", "limits": {"terms": {"EXX": 1000.0}}});
    let (s, b) = send(&f.app, "POST", "/api/v1/tolerances", &f.write, Some(own)).await;
    assert_eq!(s, StatusCode::CREATED, "{b}");
    let (_, v) = send(
        &f.app,
        "GET",
        &format!("/api/v1/results/{}/verdict", r.id),
        &f.read,
        None,
    )
    .await;
    assert_eq!(v["verdict"]["decision"], "misfit", "{v}");
    assert_eq!(v["verdict"]["model_check"]["state"], "misfit", "{v}");
    let reason = v["verdict"]["items"][0]["reason"].as_str().unwrap();
    assert!(reason.starts_with("not decided: model misfit"), "{reason}");
}
