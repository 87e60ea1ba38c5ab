//! The audit trail over HTTP: every route that changes state a person decides (API and
//! dashboard) records exactly one event, with the actor, the way it came, the client's
//! address and the target's JSON before and after, checked against what the test sent
//! (not against what the route answered); a request that changes nothing records
//! nothing; the trail is read by admins only, filtered, and exported as CSV.

use crate::common::*;
use mtcal_store::{AuditEvent, JobState};
use reqwest::{Method, StatusCode};
use serde_json::{Value, json};

/// The trail as read through the API, and how far the test has read it.
struct Trail<'a> {
    app: &'a App,
    seen: i64,
}

impl Trail<'_> {
    /// Events newest first (admin key).
    async fn events(&self, query: &str) -> Vec<AuditEvent> {
        let r = self
            .app
            .with_key(&self.app.admin_key)
            .request(Method::GET, &format!("/api/v1/audit?{query}"))
            .send()
            .await
            .unwrap();
        assert_eq!(r.status(), StatusCode::OK);
        r.json().await.unwrap()
    }

    /// The one event recorded since the last call: of `action`, through `via`.
    async fn one(&mut self, action: &str, via: &str) -> AuditEvent {
        let new: Vec<AuditEvent> = self
            .events("limit=1000")
            .await
            .into_iter()
            .filter(|e| e.seq > self.seen)
            .collect();
        assert_eq!(new.len(), 1, "{action}: one event, got {new:#?}");
        let e = new.into_iter().next().unwrap();
        assert_eq!(
            (e.event.action.as_str(), e.event.via.as_str()),
            (action, via)
        );
        assert_eq!(e.event.client.as_deref(), Some("127.0.0.1"), "{action}");
        self.seen = e.seq;
        e
    }

    /// Posts a dashboard form (answered with a redirect); the one event it recorded.
    async fn form(
        &mut self,
        b: &Browser,
        path: &str,
        fields: &[(&str, &str)],
        action: &str,
    ) -> AuditEvent {
        let mut all = vec![("csrf", b.csrf.as_str())];
        all.extend_from_slice(fields);
        let r = b.post(path, &all).await;
        assert_eq!(r.status(), StatusCode::SEE_OTHER, "{path}");
        self.one(action, "dashboard").await
    }

    /// Nothing recorded since the last call.
    async fn none(&self, what: &str) {
        let newest = self.events("limit=1").await;
        assert!(
            newest.iter().all(|e| e.seq <= self.seen),
            "{what}: {newest:#?}"
        );
    }
}

/// The id of the one key of `scope` (the test app has one of each).
async fn key_id(app: &App, scope: &str) -> String {
    let (_, keys) = send(app, &app.admin_key, Method::GET, "/api/v1/keys", None).await;
    let keys = keys.as_array().unwrap();
    keys.iter()
        .find(|k| k["scope"] == scope)
        .unwrap_or_else(|| panic!("no {scope} key: {keys:?}"))["id"]
        .as_str()
        .unwrap()
        .to_string()
}

/// Sends `body` (JSON, if any) to `path` with `key`; the answer's status and JSON.
async fn send(
    app: &App,
    key: &str,
    m: Method,
    path: &str,
    body: Option<Value>,
) -> (StatusCode, Value) {
    let mut rb = app.with_key(key).request(m, path);
    if let Some(b) = body {
        rb = rb.json(&b);
    }
    let r = rb.send().await.unwrap();
    let status = r.status();
    let text = r.text().await.unwrap();
    (status, serde_json::from_str(&text).unwrap_or(Value::Null))
}

#[tokio::test]
async fn every_state_changing_route_records_one_event_with_before_and_after() {
    let app = spawn_app().await;
    let writer = key_id(&app, "write").await;
    let mut t = Trail { app: &app, seen: 0 };
    let (r1, ds) = machines_and_a_result(&app, &mut t, &writer).await;
    profiles_and_alerts(&app, &mut t, &writer, &r1).await;
    exclusions_and_keys(&app, &mut t, &ds).await;
    dashboard(&app, &mut t, &writer, &r1).await;
    reading(&app, &mut t, &writer).await;
}

/// Machines created and changed through the API, and a real identification `(result,
/// dataset)` whose baseline move and forced export are recorded.
async fn machines_and_a_result(app: &App, t: &mut Trail<'_>, writer: &str) -> (String, String) {
    let (w, _) = (app.write_key.clone(), app.admin_key.clone());
    // Machines: created, renamed.
    let (s, _) = send(
        app,
        &w,
        Method::POST,
        "/api/v1/machines",
        Some(json!({"id": "M1", "name": "Mill"})),
    )
    .await;
    assert_eq!(s, StatusCode::CREATED);
    let e = t.one("machine.create", "api").await;
    assert_eq!(
        (e.event.actor.as_str(), e.event.target.as_str()),
        (writer, "M1")
    );
    assert!(
        e.event.actor_name.starts_with("e2e (mtk_"),
        "{}",
        e.event.actor_name
    );
    assert_eq!(
        (
            e.event.before.as_ref(),
            e.event.after.as_ref().map(|v| &v["name"])
        ),
        (None, Some(&json!("Mill")))
    );
    send(
        app,
        &w,
        Method::PATCH,
        "/api/v1/machines/M1",
        Some(json!({"name": "Mill 2"})),
    )
    .await;
    let e = t.one("machine.update", "api").await;
    assert_eq!(
        (
            e.event.before.unwrap()["name"].clone(),
            e.event.after.unwrap()["name"].clone()
        ),
        (json!("Mill"), json!("Mill 2"))
    );

    // A real identification to move the baseline to, export and exclude.
    let dir = app.path("check");
    write_session(&dir, "M1", 4, 0);
    let ds = app.client.upload_path("M1", &dir).await.unwrap();
    t.none("an upload").await;
    let job = app.identify(&ds.id).await;
    app.wait(&job, JobState::Succeeded).await;
    t.none("a job").await;
    let r1 = app.client.latest("M1", None).await.unwrap().meta.id;
    let body = json!({"baseline_result_id": r1});
    send(app, &w, Method::PATCH, "/api/v1/machines/M1", Some(body)).await;
    let e = t.one("baseline.set", "api").await;
    assert_eq!(e.event.machine_id.as_deref(), Some("M1"));
    assert_eq!(e.event.before.unwrap()["baseline_result_id"], Value::Null);
    assert_eq!(e.event.after.unwrap()["baseline_result_id"], json!(r1));
    let path = format!("/api/v1/results/{r1}/export?format=isg&force=true");
    let (s, _) = send(app, &app.read_key, Method::GET, &path, None).await;
    assert_eq!(s, StatusCode::OK);
    let e = t.one("export.forced", "api").await;
    assert_eq!(
        (
            e.event.target.as_str(),
            e.event.after.unwrap()["format"].clone()
        ),
        (r1.as_str(), json!("isg"))
    );
    let path = format!("/api/v1/results/{r1}/export?format=isg");
    send(app, &app.read_key, Method::GET, &path, None).await;
    t.none("an export within the gate").await;

    (r1, ds.id)
}

/// Tolerance profiles created, replaced and deleted; an alert acknowledged.
async fn profiles_and_alerts(app: &App, t: &mut Trail<'_>, writer: &str, r1: &str) {
    let w = app.write_key.clone();
    // Tolerance profiles: created, replaced (its webhook's query never kept), deleted.
    let body = json!({"scope": "machine", "target": "M1", "limits": {"drift_um": 5}});
    let (s, p) = send(app, &w, Method::POST, "/api/v1/tolerances", Some(body)).await;
    assert_eq!(s, StatusCode::CREATED, "{p}");
    let pid = p["id"].as_str().unwrap().to_string();
    let e = t.one("profile.create", "api").await;
    assert_eq!(
        (
            e.event.before,
            e.event.after.unwrap()["limits"]["drift_um"].clone()
        ),
        (None, json!(5.0))
    );
    let path = format!("/api/v1/tolerances/{pid}");
    let body = json!({"limits": {"drift_um": 7}});
    send(app, &w, Method::PUT, &path, Some(body)).await;
    let e = t.one("profile.replace", "api").await;
    assert_eq!(e.event.before.unwrap()["limits"]["drift_um"], json!(5.0));
    assert_eq!(e.event.after.unwrap()["limits"]["drift_um"], json!(7.0));
    let (s, _) = send(app, &w, Method::DELETE, &path, None).await;
    assert_eq!(s, StatusCode::NO_CONTENT);
    let e = t.one("profile.delete", "api").await;
    assert_eq!(
        (e.event.before.unwrap()["id"].clone(), e.event.after),
        (json!(pid), None)
    );

    // An alert acknowledged; again: nothing changes, nothing recorded.
    app.store
        .raise_alert(&alert("al_1", "M1", r1), &[])
        .await
        .unwrap();
    let body = json!({"comment": "re-measured"});
    send(
        app,
        &w,
        Method::POST,
        "/api/v1/alerts/al_1/ack",
        Some(body.clone()),
    )
    .await;
    let e = t.one("alert.ack", "api").await;
    assert_eq!(e.event.before.unwrap()["acknowledged_by"], Value::Null);
    let after = e.event.after.unwrap();
    assert_eq!(
        after["acknowledgement_comment"],
        json!("re-measured"),
        "{after}"
    );
    assert!(
        after["acknowledged_by"].as_str().unwrap().contains(writer),
        "{after}"
    );
    send(app, &w, Method::POST, "/api/v1/alerts/al_1/ack", Some(body)).await;
    t.none("a second acknowledgement").await;
}

/// A result and a dataset excluded, the dataset's bytes deleted; a key created and
/// revoked.
async fn exclusions_and_keys(app: &App, t: &mut Trail<'_>, ds: &str) {
    let (w, a) = (app.write_key.clone(), app.admin_key.clone());
    // Exclusions: a result, then the dataset, then its bytes (admin).
    let r2 = app
        .store
        .import_result(check("M1", "identification", "2026-02-01T08:00:00Z", 1.0))
        .await
        .unwrap()
        .id;
    let why = json!({"reason": "wrong fixture"});
    send(
        app,
        &w,
        Method::POST,
        &format!("/api/v1/results/{r2}/exclude"),
        Some(why.clone()),
    )
    .await;
    let e = t.one("result.exclude", "api").await;
    assert_eq!(e.event.before.unwrap()["excluded"], Value::Null);
    assert_eq!(
        e.event.after.unwrap()["excluded"]["reason"],
        json!("wrong fixture")
    );
    send(
        app,
        &w,
        Method::POST,
        &format!("/api/v1/results/{r2}/exclude"),
        Some(why.clone()),
    )
    .await;
    t.none("a second exclusion").await;
    send(
        app,
        &w,
        Method::POST,
        &format!("/api/v1/datasets/{}/exclude", ds),
        Some(why.clone()),
    )
    .await;
    let e = t.one("dataset.exclude", "api").await;
    assert_eq!(
        (
            e.event.target.as_str(),
            e.event.before.unwrap()["excluded"].clone()
        ),
        (ds, Value::Null)
    );
    assert_eq!(
        e.event.after.unwrap()["excluded"]["reason"],
        json!("wrong fixture")
    );
    send(
        app,
        &a,
        Method::POST,
        &format!("/api/v1/datasets/{}/delete-files", ds),
        Some(why),
    )
    .await;
    let e = t.one("dataset.delete_files", "api").await;
    assert_eq!(e.event.before.unwrap()["deleted"], Value::Null);
    assert_eq!(
        e.event.after.unwrap()["deleted"]["reason"],
        json!("wrong fixture")
    );

    // Keys: created (never its secret), revoked.
    let (_, k) = send(
        app,
        &a,
        Method::POST,
        "/api/v1/keys",
        Some(json!({"scope": "read", "label": "auditor"})),
    )
    .await;
    let e = t.one("key.create", "api").await;
    let secret = k["secret"].as_str().unwrap();
    let kid = k["key"]["id"].as_str().unwrap().to_string();
    assert_eq!(
        (
            e.event.target.as_str(),
            e.event.after.clone().unwrap()["label"].clone()
        ),
        (kid.as_str(), json!("auditor"))
    );
    assert!(
        !serde_json::to_string(&e).unwrap().contains(&secret[4..]),
        "no secret in the trail"
    );
    send(
        app,
        &a,
        Method::DELETE,
        &format!("/api/v1/keys/{kid}"),
        None,
    )
    .await;
    let e = t.one("key.revoke", "api").await;
    assert_eq!(e.event.before.unwrap()["revoked_at"], Value::Null);
    assert!(e.event.after.unwrap()["revoked_at"].is_string());
}

/// The dashboard: a failed sign-in, a sign-in, its forms, the sign-out.
async fn dashboard(app: &App, t: &mut Trail<'_>, writer: &str, r1: &str) {
    let w = app.write_key.clone();
    let http = reqwest::Client::builder()
        .redirect(reqwest::redirect::Policy::none())
        .build()
        .unwrap();
    let r = app.post_sign_in(&http, "mtk_not-a-key").await;
    assert_eq!(r.status(), StatusCode::UNAUTHORIZED);
    let e = t.one("signin.failed", "dashboard").await;
    assert_eq!(
        (e.event.actor.as_str(), e.event.before, e.event.after),
        ("", None, None)
    );
    let b = app.sign_in(&w).await;
    let e = t.one("signin", "dashboard").await;
    assert_eq!(
        (
            e.event.actor.as_str(),
            e.event.after.unwrap()["scope"].clone()
        ),
        (writer, json!("write"))
    );
    let fields = [("id", "M2"), ("name", "Lathe")];
    let e = t.form(&b, "/machines", &fields, "machine.create").await;
    assert_eq!(e.event.actor, writer);
    assert_eq!(e.event.after.unwrap()["name"], json!("Lathe"));
    let r3 = app
        .store
        .import_result(check("M1", "identification", "2026-03-01T08:00:00Z", 2.0))
        .await
        .unwrap()
        .id;
    let fields = [("result_id", r3.as_str())];
    let e = t
        .form(&b, "/machines/M1/baseline", &fields, "baseline.set")
        .await;
    assert_eq!(e.event.before.unwrap()["baseline_result_id"], json!(r1));
    assert_eq!(e.event.after.unwrap()["baseline_result_id"], json!(r3));
    let fields = [("target", "machine"), ("drift_um", "3")];
    let e = t
        .form(&b, "/machines/M2/tolerance", &fields, "profile.create")
        .await;
    assert_eq!(e.event.machine_id.as_deref(), Some("M2"));
    assert_eq!(e.event.after.unwrap()["limits"]["drift_um"], json!(3.0));
    app.store
        .raise_alert(&alert("al_2", "M1", &r3), &[])
        .await
        .unwrap();
    let fields = [("next", "/alerts"), ("comment", "seen")];
    let e = t.form(&b, "/alerts/al_2/ack", &fields, "alert.ack").await;
    assert_eq!(
        e.event.after.unwrap()["acknowledgement_comment"],
        json!("seen")
    );
    t.form(&b, "/signout", &[], "signout").await;
}

/// The trail read back: filters, pages, the CSV export, who may read it.
async fn reading(app: &App, t: &mut Trail<'_>, writer: &str) {
    let (w, a) = (app.write_key.clone(), app.admin_key.clone());
    // Filters and the CSV export; read and write keys may not read the trail.
    let m2 = t.events("machine=M2").await;
    assert_eq!(
        m2.iter()
            .map(|e| e.event.action.as_str())
            .collect::<Vec<_>>(),
        ["profile.create", "machine.create"]
    );
    let by_writer = t.events(&format!("actor={writer}&action=alert.ack")).await;
    assert_eq!(by_writer.len(), 2);
    let all = t.events("limit=1000").await;
    assert_eq!(
        all.len() as i64,
        t.seen,
        "one event per change, {} changes",
        t.seen
    );
    let page = t.events(&format!("limit=5&before={}", all[4].seq)).await;
    assert_eq!(page, all[5..10].to_vec());
    let csv_text = app
        .with_key(&a)
        .request(Method::GET, "/api/v1/audit/export")
        .send()
        .await
        .unwrap()
        .text()
        .await
        .unwrap();
    let mut rd = csv::Reader::from_reader(csv_text.as_bytes());
    let records: Vec<csv::StringRecord> = rd.records().map(Result::unwrap).collect();
    assert_eq!(records.len(), all.len());
    for (rec, e) in records.iter().zip(&all) {
        assert_eq!(
            (&rec[0], &rec[5]),
            (e.seq.to_string().as_str(), e.event.action.as_str())
        );
        let after: Option<Value> =
            (!rec[10].is_empty()).then(|| serde_json::from_str(&rec[10]).unwrap());
        assert_eq!(after, e.event.after);
    }
    for key in [&app.read_key, &w] {
        let (s, _) = send(app, key, Method::GET, "/api/v1/audit", None).await;
        assert_eq!(s, StatusCode::FORBIDDEN);
    }
    let admin = app.sign_in(&a).await;
    let page = admin.get("/audit?machine=M2").await;
    assert_eq!(page.status(), StatusCode::OK);
    let html = page.text().await.unwrap();
    assert!(
        html.contains("<code>profile.create</code>") && !html.contains("<code>key.create</code>")
    );
    let b = app.sign_in(&w).await;
    assert_eq!(b.get("/audit").await.status(), StatusCode::FORBIDDEN);
}
