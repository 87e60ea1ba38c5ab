//! The dashboard's and the API's defences over a real connection: sessions that end at
//! once (sign-out, key revocation), `next` kept on this site, the security headers of
//! every answer, the cookie's `Secure` flag, JSON answers to an over-long request line or
//! head, the authorization scheme read in any case, and the last admin key kept.

use crate::common::*;
use reqwest::StatusCode;
use reqwest::header::{HeaderMap, HeaderName, HeaderValue};

/// A service without a worker and machine M1.
async fn service() -> App {
    let app = spawn_app_with(AppOptions {
        run_worker: false,
        ..AppOptions::default()
    })
    .await;
    app.machine("M1").await;
    app
}

fn location(r: &reqwest::Response) -> String {
    r.headers()
        .get(reqwest::header::LOCATION)
        .map(|v| v.to_str().unwrap().to_string())
        .unwrap_or_default()
}

/// The sign-in form of a browser: its pre-session cookie and token.
async fn signin_form(
    http: &reqwest::Client,
    url: &str,
    headers: HeaderMap,
) -> (String, String, String) {
    let r = http
        .get(format!("{url}/signin"))
        .headers(headers)
        .send()
        .await
        .unwrap();
    let (pre, whole) = set_cookie(&r, "mtcal_signin");
    (pre, whole, csrf_of(&r.text().await.unwrap()))
}

fn no_redirects() -> reqwest::Client {
    reqwest::Client::builder()
        .redirect(reqwest::redirect::Policy::none())
        .build()
        .unwrap()
}

#[tokio::test]
async fn signing_out_or_revoking_the_key_ends_the_session_at_once() {
    let app = service().await;
    let b = app.sign_in(&app.write_key).await;
    let r = b.post("/signout", &[("csrf", &b.csrf)]).await;
    assert_eq!(r.status(), StatusCode::SEE_OTHER);
    // The old cookie, kept (as a thief would keep it), opens nothing any more: no page,
    // no API read, no form.
    let r = b.get("/machines/M1").await;
    assert_eq!(r.status(), StatusCode::SEE_OTHER, "a page after sign-out");
    assert!(location(&r).starts_with("/signin"), "{}", location(&r));
    let r = b.get("/api/v1/machines").await;
    assert_eq!(
        r.status(),
        StatusCode::UNAUTHORIZED,
        "an API read after sign-out"
    );
    let r = b.post("/signout", &[("csrf", &b.csrf)]).await;
    assert!(location(&r).starts_with("/signin"), "a form after sign-out");
    // Revoking the key ends its sessions in every browser.
    let (created, secret) = app
        .store
        .create_key(mtcal_store::Scope::Read, "browser")
        .await
        .unwrap();
    let (one, two) = (app.sign_in(&secret).await, app.sign_in(&secret).await);
    assert_eq!(one.get("/").await.status(), StatusCode::OK);
    let r = app
        .with_key(&app.admin_key)
        .revoke_key(&created.id)
        .await
        .unwrap();
    assert!(r.revoked_at.is_some());
    for b in [one, two] {
        assert_eq!(b.get("/").await.status(), StatusCode::SEE_OTHER);
        assert_eq!(
            b.get("/api/v1/fleet").await.status(),
            StatusCode::UNAUTHORIZED
        );
    }
}

#[tokio::test]
async fn next_leads_only_to_a_path_of_this_site() {
    let app = service().await;
    let alert_result = app
        .store
        .import_result(check("M1", "identification", "2026-01-05T08:00:00Z", 0.0))
        .await
        .unwrap();
    app.store
        .raise_alert(&alert("al_1", "M1", &alert_result.id), &[])
        .await
        .unwrap();
    let http = no_redirects();
    for (next, to) in [
        ("/machines/M1?term=EXX", "/machines/M1?term=EXX"),
        ("/\t/evil.example/", "/"),
        ("/\n/evil.example/", "/"),
        ("//evil.example/", "/"),
        ("/\\evil.example/", "/"),
        ("https://evil.example/", "/"),
        ("/\r\nSet-Cookie: x=y", "/"),
        ("/ok\u{0}", "/"),
    ] {
        let (pre, _, token) = signin_form(&http, &app.url, HeaderMap::new()).await;
        let r = http
            .post(format!("{}/signin", app.url))
            .header(reqwest::header::COOKIE, pre)
            .form(&[
                ("csrf", token.as_str()),
                ("key", &app.write_key),
                ("next", next),
            ])
            .send()
            .await
            .unwrap();
        assert_eq!(r.status(), StatusCode::SEE_OTHER, "{next:?}");
        assert_eq!(location(&r), to, "{next:?}");
    }
    // In the sign-in page's address, a control character is refused (400, JSON) before
    // any page is made.
    let r = http
        .get(format!("{}/signin?next=/%09/evil.example/", app.url))
        .send()
        .await
        .unwrap();
    assert_eq!(r.status(), StatusCode::BAD_REQUEST);
    // The acknowledgement's `next` with control characters: no 500, back to `/`.
    let b = app.sign_in(&app.write_key).await;
    let r = b
        .post(
            "/alerts/al_1/ack",
            &[("csrf", b.csrf.as_str()), ("next", "/alerts\r\nX: y")],
        )
        .await;
    assert_eq!(r.status(), StatusCode::SEE_OTHER);
    assert_eq!(location(&r), "/");
}

#[tokio::test]
async fn every_answer_carries_the_security_headers() {
    let app = service().await;
    let b = app.sign_in(&app.read_key).await;
    let http = no_redirects();
    let pages = ["/", "/machines/M1", "/jobs", "/alerts"];
    let mut answers = vec![];
    for p in pages {
        answers.push((p, b.get(p).await, true));
    }
    for (p, html) in [
        ("/signin", true),
        ("/docs/", true),
        ("/health", false),
        ("/api/v1/machines", false),
        ("/api/v1/nothing", false),
        ("/static/nothing.css", true),
    ] {
        answers.push((
            p,
            http.get(format!("{}{p}", app.url)).send().await.unwrap(),
            html,
        ));
    }
    for (p, r, html) in answers {
        let h = r.headers();
        assert_eq!(h["x-content-type-options"], "nosniff", "{p}");
        assert_eq!(h["x-frame-options"], "DENY", "{p}");
        let csp = h
            .get("content-security-policy")
            .map(|v| v.to_str().unwrap());
        if html {
            let csp = csp.unwrap_or_else(|| panic!("{p}: no Content-Security-Policy"));
            assert!(csp.contains("frame-ancestors 'none'"), "{p}: {csp}");
            assert!(csp.contains("script-src 'self'"), "{p}: {csp}");
        }
    }
}

#[tokio::test]
async fn the_session_cookie_is_secure_over_tls_or_when_configured() {
    let app = service().await;
    let http = no_redirects();
    let sign_in = |headers: HeaderMap| {
        let (http, url, key) = (http.clone(), app.url.clone(), app.read_key.clone());
        async move {
            let (pre, pre_whole, token) = signin_form(&http, &url, headers.clone()).await;
            let r = http
                .post(format!("{url}/signin"))
                .headers(headers)
                .header(reqwest::header::COOKIE, pre)
                .form(&[("csrf", token.as_str()), ("key", &key)])
                .send()
                .await
                .unwrap();
            (pre_whole, set_cookie(&r, "mtcal_session").1)
        }
    };
    let secure = |c: &str| c.split(';').any(|a| a.trim() == "Secure");
    let (pre, session) = sign_in(HeaderMap::new()).await;
    assert!(!secure(&pre) && !secure(&session), "plain HTTP: {session}");
    let mut tls = HeaderMap::new();
    tls.insert(
        HeaderName::from_static("x-forwarded-proto"),
        HeaderValue::from_static("https"),
    );
    let (pre, session) = sign_in(tls).await;
    assert!(
        secure(&pre) && secure(&session),
        "behind TLS: {pre} / {session}"
    );
    // Configured so: Secure whatever the request says.
    let app = spawn_app_with(AppOptions {
        run_worker: false,
        settings: mtcal_server::Settings {
            cookie_secure: true,
            ..Default::default()
        },
        ..AppOptions::default()
    })
    .await;
    let b = app.sign_in(&app.read_key).await;
    assert!(secure(&b.set_cookie), "{}", b.set_cookie);
}

#[tokio::test]
async fn an_over_long_request_line_or_head_gets_a_json_answer() {
    let app = service().await;
    let http = reqwest::Client::new();
    let long = format!("{}/api/v1/machines/{}", app.url, "x".repeat(10_000));
    let mut many = HeaderMap::new();
    for i in 0..120 {
        many.insert(
            HeaderName::try_from(format!("x-h{i}")).unwrap(),
            HeaderValue::from_static("v"),
        );
    }
    let mut big = HeaderMap::new();
    big.insert("x-big", HeaderValue::try_from("v".repeat(40_000)).unwrap());
    let answers = [
        (http.get(long).send().await.unwrap(), 414, "uri_too_long"),
        (
            http.get(format!("{}/health", app.url))
                .headers(many)
                .send()
                .await
                .unwrap(),
            431,
            "headers_too_large",
        ),
        (
            http.get(format!("{}/health", app.url))
                .headers(big)
                .send()
                .await
                .unwrap(),
            431,
            "headers_too_large",
        ),
    ];
    for (r, status, code) in answers {
        assert_eq!(r.status().as_u16(), status);
        let body: serde_json::Value = r.json().await.expect("a JSON body");
        assert_eq!(body["error"]["code"], code, "{body}");
        assert!(
            body["error"]["message"]
                .as_str()
                .unwrap()
                .contains("at most"),
            "{body}"
        );
    }
}

#[tokio::test]
async fn the_authorization_scheme_is_read_in_any_case() {
    let app = service().await;
    let http = reqwest::Client::new();
    for scheme in ["Bearer", "bearer", "BEARER", "bEaReR"] {
        let r = http
            .get(format!("{}/api/v1/machines", app.url))
            .header("authorization", format!("{scheme} {}", app.read_key))
            .send()
            .await
            .unwrap();
        assert_eq!(r.status(), StatusCode::OK, "{scheme}");
    }
    let r = http
        .get(format!("{}/api/v1/machines", app.url))
        .header("authorization", format!("Basic {}", app.read_key))
        .send()
        .await
        .unwrap();
    assert_eq!(r.status(), StatusCode::UNAUTHORIZED);
}

#[tokio::test]
async fn an_admin_cannot_revoke_itself_or_the_last_admin_key() {
    let app = service().await;
    let admin = app.with_key(&app.admin_key);
    let me = admin
        .keys()
        .await
        .unwrap()
        .into_iter()
        .find(|k| k.scope == mtcal_store::Scope::Admin)
        .unwrap();
    let e = admin.revoke_key(&me.id).await.unwrap_err().to_string();
    assert!(e.contains("409") || e.contains("conflict"), "{e}");
    // A second admin may revoke the first; then it is the last one, which nothing revokes.
    let (second, secret) = app
        .store
        .create_key(mtcal_store::Scope::Admin, "second")
        .await
        .unwrap();
    let other = app.with_key(&secret);
    assert!(other.revoke_key(&me.id).await.unwrap().revoked_at.is_some());
    let e = app
        .store
        .revoke_key(&second.id)
        .await
        .unwrap_err()
        .to_string();
    assert!(e.contains("last admin key"), "{e}");
    let e = other.revoke_key(&second.id).await.unwrap_err().to_string();
    assert!(e.contains("409") || e.contains("conflict"), "{e}");
    assert!(
        app.store.key_by_secret(&secret).await.unwrap().is_some(),
        "still active"
    );
}
