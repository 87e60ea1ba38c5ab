//! The dashboard's sign-in and forms over a real connection: the session cookie's
//! attributes, the CSRF token every form must carry, the key's scope on every form that
//! changes something, the baseline set through its form, and the API's GET routes read
//! with the session cookie (the page script's job progress) while every other method
//! still needs the key.

use crate::common::*;
use mtcal_store::RowCounts;
use reqwest::StatusCode;
use reqwest::multipart::{Form, Part};

/// A service without a worker, machine M1 with two identifications (results imported,
/// as an import job stores them) and an active drift alert on the second; returns the
/// two result ids and the alert id.
async fn fleet_of_one() -> (App, [String; 2], String) {
    let app = spawn_app_with(AppOptions {
        run_worker: false,
        ..AppOptions::default()
    })
    .await;
    app.machine("M1").await;
    let mut ids = vec![];
    for at in ["2026-01-05T08:00:00Z", "2026-04-06T08:00:00Z"] {
        let r = check("M1", "identification", at, 0.0);
        ids.push(app.store.import_result(r).await.unwrap().id);
    }
    let alert = app
        .store
        .raise_alert(&alert("al_1", "M1", &ids[1]), &[])
        .await
        .unwrap()
        .unwrap();
    (app, [ids[0].clone(), ids[1].clone()], alert.raised.id)
}

/// What a refused form must leave as it was: the rows, M1's baseline, the alert's state.
async fn state(app: &App) -> (RowCounts, Option<String>, bool) {
    let m = app.client.machine("M1").await.unwrap();
    let alert = app.store.get_alert("al_1").await.unwrap();
    (
        app.counts().await,
        m.baseline_result_id,
        alert.acknowledged_at.is_none(),
    )
}

/// An upload form's body: `csrf` first when given, then one file.
fn upload(csrf: Option<&str>) -> Form {
    let form = match csrf {
        Some(t) => Form::new().text("csrf", t.to_string()),
        None => Form::new(),
    };
    form.part(
        "files",
        Part::bytes(b"x_mm,y_mm\n0,0\n".to_vec()).file_name("xy.csv"),
    )
}

/// Posts the baseline form of `machine` with `result_id` and the session's token.
async fn set_baseline(b: &Browser, machine: &str, result_id: &str) -> reqwest::Response {
    b.post(
        &format!("/machines/{machine}/baseline"),
        &[("csrf", &b.csrf), ("result_id", result_id)],
    )
    .await
}

#[tokio::test]
async fn the_session_cookie_is_httponly_and_samesite_strict() {
    let (app, _, _) = fleet_of_one().await;
    let b = app.sign_in(&app.read_key).await;
    let attrs: Vec<&str> = b.set_cookie.split(';').map(str::trim).collect();
    assert!(attrs.contains(&"HttpOnly"), "{}", b.set_cookie);
    assert!(attrs.contains(&"SameSite=Strict"), "{}", b.set_cookie);
    assert!(attrs.contains(&"Path=/"), "{}", b.set_cookie);
    assert!(
        !b.set_cookie.contains(&app.read_key),
        "the key is not readable in the cookie"
    );
    // The sign-in form's own token cookie too.
    let r = reqwest::get(format!("{}/signin", app.url)).await.unwrap();
    let (_, pre) = set_cookie(&r, "mtcal_signin");
    assert!(
        pre.contains("HttpOnly") && pre.contains("SameSite=Strict"),
        "{pre}"
    );
}

#[tokio::test]
async fn a_form_without_the_sessions_csrf_token_is_refused_and_changes_nothing() {
    let (app, [_, second], alert) = fleet_of_one().await;
    let b = app.sign_in(&app.write_key).await;
    let before = state(&app).await;
    let baseline = "/machines/M1/baseline";
    let ack = format!("/alerts/{alert}/ack");
    for token in [None, Some("0123456789abcdef0123456789abcdef")] {
        let with = |mut fields: Vec<(&'static str, String)>| {
            if let Some(t) = token {
                fields.push(("csrf", t.to_string()));
            }
            fields
        };
        let forms = [
            (baseline, with(vec![("result_id", second.clone())])),
            (ack.as_str(), with(vec![("next", "/".into())])),
            ("/signout", with(vec![])),
        ];
        for (path, fields) in forms {
            let fields: Vec<(&str, &str)> = fields.iter().map(|(k, v)| (*k, v.as_str())).collect();
            let r = b.post(path, &fields).await;
            assert_eq!(r.status(), StatusCode::FORBIDDEN, "{path} with {token:?}");
            assert!(r.text().await.unwrap().contains("CSRF token"), "{path}");
        }
        let r = b.post_multipart("/machines/M1/upload", upload(token)).await;
        assert_eq!(r.status(), StatusCode::FORBIDDEN, "upload with {token:?}");
        assert!(r.text().await.unwrap().contains("CSRF token"), "upload");
    }
    assert_eq!(
        state(&app).await,
        before,
        "a refused form changed something"
    );
    // Still signed in (the refused sign-out did not end the session).
    assert_eq!(b.get("/").await.status(), StatusCode::OK);
}

#[tokio::test]
async fn a_read_key_signed_in_cannot_upload_set_a_baseline_or_acknowledge() {
    let (app, [_, second], alert) = fleet_of_one().await;
    let b = app.sign_in(&app.read_key).await;
    assert_eq!(b.get("/machines/M1").await.status(), StatusCode::OK, "sees");
    let before = state(&app).await;
    let r = set_baseline(&b, "M1", &second).await;
    assert_eq!(r.status(), StatusCode::FORBIDDEN, "baseline");
    assert!(r.text().await.unwrap().contains("scope write"));
    let r = b
        .post(&format!("/alerts/{alert}/ack"), &[("csrf", &b.csrf)])
        .await;
    assert_eq!(r.status(), StatusCode::FORBIDDEN, "ack");
    let r = b
        .post_multipart("/machines/M1/upload", upload(Some(&b.csrf)))
        .await;
    assert_eq!(r.status(), StatusCode::FORBIDDEN, "upload");
    assert_eq!(
        state(&app).await,
        before,
        "a refused form changed something"
    );
}

#[tokio::test]
async fn the_baseline_set_through_the_form_is_the_machines_baseline() {
    let (app, [first, second], _) = fleet_of_one().await;
    let b = app.sign_in(&app.write_key).await;
    let m = app.client.machine("M1").await.unwrap();
    assert_eq!(m.baseline_result_id, None, "the first by default");
    let r = set_baseline(&b, "M1", &second).await;
    assert_eq!(r.status(), StatusCode::SEE_OTHER);
    let to = r.headers()[reqwest::header::LOCATION].to_str().unwrap();
    assert!(to.starts_with("/machines/M1?notice="), "{to}");
    let m = app.client.machine("M1").await.unwrap();
    assert_eq!(m.baseline_result_id.as_deref(), Some(second.as_str()));
    // The fleet follows at once.
    let fleet = app
        .client
        .fleet(&mtcal_server::api::fleet::FleetParams::default())
        .await
        .unwrap();
    assert_eq!(
        fleet.machines[0].baseline_result_id.as_deref(),
        Some(second.as_str())
    );
    // Back to the first; a result of another machine is refused.
    app.machine("M2").await;
    let r = set_baseline(&b, "M2", &first).await;
    assert_eq!(r.status(), StatusCode::BAD_REQUEST);
    let r = set_baseline(&b, "M1", &first).await;
    assert_eq!(r.status(), StatusCode::SEE_OTHER);
    let m = app.client.machine("M1").await.unwrap();
    assert_eq!(m.baseline_result_id.as_deref(), Some(first.as_str()));
    assert_eq!(
        app.client.machine("M2").await.unwrap().baseline_result_id,
        None
    );
}

#[tokio::test]
async fn the_apis_gets_read_the_session_cookie_and_nothing_else_does() {
    let (app, _, _) = fleet_of_one().await;
    let mut j = job(mtcal_server::jobs::JobKind::Sensitivity, None, Some("M1"));
    j.params = serde_json::json!({"machine": {"template": "vmc3"}});
    let job = app.client.submit(&j).await.unwrap();
    let b = app.sign_in(&app.read_key).await;
    // The page script's poll: the job as the API documents it.
    let r = b.get(&format!("/api/v1/jobs/{}", job.id)).await;
    assert_eq!(r.status(), StatusCode::OK);
    let polled: mtcal_store::Job = r.json().await.unwrap();
    assert_eq!(polled.id, job.id);
    assert_eq!(polled.state, mtcal_store::JobState::Queued);
    // A change through the API with the cookie alone is unauthenticated, even by a
    // write key's session.
    let w = app.sign_in(&app.write_key).await;
    let r = w
        .http
        .post(format!("{}/api/v1/jobs/{}/cancel", app.url, job.id))
        .header(reqwest::header::COOKIE, &w.cookie)
        .send()
        .await
        .unwrap();
    assert_eq!(r.status(), StatusCode::UNAUTHORIZED);
    assert_eq!(
        app.client.job(&job.id).await.unwrap().state,
        mtcal_store::JobState::Queued
    );
    // No cookie, or one of another sign-in key that does not decrypt: no key.
    let r = reqwest::get(format!("{}/api/v1/jobs/{}", app.url, job.id))
        .await
        .unwrap();
    assert_eq!(r.status(), StatusCode::UNAUTHORIZED);
    let forged = b.cookie.replace("mtcal_session=", "mtcal_session=x");
    let r = b
        .http
        .get(format!("{}/api/v1/jobs/{}", app.url, job.id))
        .header(reqwest::header::COOKIE, forged)
        .send()
        .await
        .unwrap();
    assert_eq!(r.status(), StatusCode::UNAUTHORIZED);
}

/// Machines and tolerance profiles are created from the pages, with the API's rules: a
/// write key registers a machine on the fleet page and gives a machine a profile on its
/// page (the fleet then names it); a bad field is refused with its name and stores
/// nothing; a read key sees no form and its posts are refused.
#[tokio::test]
async fn machines_and_profiles_are_created_from_the_pages() {
    let (app, _, _) = fleet_of_one().await;
    let reader = app.sign_in(&app.read_key).await;
    let page = reader.get("/").await.text().await.unwrap();
    assert!(
        !page.contains(r#"id="new-machine""#),
        "a read key gets no form"
    );
    let r = reader
        .post("/machines", &[("csrf", &reader.csrf), ("id", "M9")])
        .await;
    assert_eq!(r.status(), StatusCode::FORBIDDEN);

    let b = app.sign_in(&app.write_key).await;
    let page = b.get("/").await.text().await.unwrap();
    assert!(page.contains(r#"id="new-machine""#));
    let before = state(&app).await;
    for (fields, says) in [
        (vec![("id", "M 9")], "id"),
        (
            vec![("id", "M9"), ("x_min", "300"), ("x_max", "-300")],
            "travel_mm.X",
        ),
        (vec![("id", "M9"), ("x_min", "-300")], "travel_mm.X"),
        (vec![("id", "M1")], "M1"),
    ] {
        let mut all = vec![("csrf", b.csrf.as_str())];
        all.extend(fields.iter().copied());
        let r = b.post("/machines", &all).await;
        assert!(r.status().is_client_error(), "{fields:?}: {}", r.status());
        let text = r.text().await.unwrap();
        assert!(text.contains(says), "{fields:?}: {text}");
    }
    assert_eq!(
        state(&app).await,
        before,
        "a refused form changed something"
    );
    let r = b
        .post(
            "/machines",
            &[
                ("csrf", &b.csrf),
                ("id", "M9"),
                ("name", "Line 9"),
                ("site", "north"),
                ("tags", "vmc, line9"),
                ("x_min", "-300"),
                ("x_max", "300"),
            ],
        )
        .await;
    assert_eq!(r.status(), StatusCode::SEE_OTHER);
    let m = app.client.machine("M9").await.unwrap();
    assert_eq!(m.name, "Line 9");
    assert_eq!(m.tags, ["vmc", "line9"]);
    assert_eq!(m.travel_mm["X"], [-300.0, 300.0]);

    // A profile for M1 (which has checks) from its page: its verdict follows.
    let page = b.get("/machines/M1").await.text().await.unwrap();
    assert!(page.contains(r#"id="new-profile""#));
    let r = b
        .post(
            "/machines/M1/tolerance",
            &[
                ("csrf", &b.csrf),
                ("target", "machine"),
                ("squareness_urad", "x"),
            ],
        )
        .await;
    assert_eq!(r.status(), StatusCode::BAD_REQUEST);
    assert!(r.text().await.unwrap().contains("squareness_urad"));
    let r = b
        .post(
            "/machines/M1/tolerance",
            &[("csrf", &b.csrf), ("target", "machine")],
        )
        .await;
    assert_eq!(r.status(), StatusCode::BAD_REQUEST, "no limit at all");
    assert!(app.store.list_tolerances().await.unwrap().is_empty());
    let r = b
        .post(
            "/machines/M1/tolerance",
            &[
                ("csrf", &b.csrf),
                ("target", "machine"),
                ("positioning_um", "1000"),
                ("squareness_urad", "1000"),
            ],
        )
        .await;
    assert_eq!(r.status(), StatusCode::SEE_OTHER);
    let profiles = app.store.list_tolerances().await.unwrap();
    assert_eq!(profiles.len(), 1);
    assert_eq!(
        (profiles[0].scope.as_str(), profiles[0].target.as_str()),
        ("machine", "M1")
    );
    // The fleet names the profile that applies to M1 now.
    let f = app
        .client
        .fleet(&mtcal_server::api::fleet::FleetParams::default())
        .await
        .unwrap();
    let m1 = f.machines.iter().find(|m| m.machine_id == "M1").unwrap();
    assert_eq!(
        m1.tolerance_profile_id.as_deref(),
        Some(profiles[0].id.as_str())
    );
}
