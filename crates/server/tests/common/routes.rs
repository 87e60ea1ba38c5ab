//! What the request tests that walk every route share: the routes of the API (from the
//! OpenAPI document the code generates) and of the dashboard (read from its router), a
//! template filled with the ids of one machine's data, and requests sent with an API key
//! or a dashboard session.

use crate::common::request;
use axum::body::Body;
use axum::http::{Request, StatusCode, header};
use mtcal_store::Store;
use serde_json::Value;
use std::sync::Arc;
use tower::ServiceExt;

/// What one site holds: an id of each kind.
#[derive(Debug, Clone)]
pub struct Ids {
    pub machine: String,
    pub dataset: String,
    pub result: String,
    pub job: String,
    pub alert: String,
    pub profile: String,
    pub delivery: String,
    pub key: String,
    pub site: String,
}

impl Ids {
    /// Every id and the site's name: none may appear in an answer to another site.
    pub fn tokens(&self) -> Vec<&str> {
        vec![
            &self.machine,
            &self.dataset,
            &self.result,
            &self.job,
            &self.alert,
            &self.profile,
            &self.delivery,
            &self.key,
            &self.site,
        ]
    }

    /// The id a route's `{param}` after `segment` takes.
    pub fn for_segment(&self, segment: &str, param: &str) -> String {
        if param == "name" {
            return "session.json".into();
        }
        match segment {
            "machines" => self.machine.clone(),
            "results" => self.result.clone(),
            "datasets" => self.dataset.clone(),
            "jobs" => self.job.clone(),
            "alerts" => self.alert.clone(),
            "tolerances" => self.profile.clone(),
            "keys" => self.key.clone(),
            other => panic!("a route with an id after `{other}`: add its kind to this test"),
        }
    }
}

/// Ids of each kind that do not exist.
pub fn missing() -> Ids {
    Ids {
        machine: "NO-SUCH-M".into(),
        dataset: "ds_00000000000000000000000000000000".into(),
        result: "res_00000000000000000000000000000000".into(),
        job: "job_00000000000000000000000000000000".into(),
        alert: "alert_00000000000000000000000000000000".into(),
        profile: "tol_00000000000000000000000000000000".into(),
        delivery: "whd_00000000000000000000000000000000".into(),
        key: "key_00000000000000000000000000000000".into(),
        site: "no-such-site".into(),
    }
}

pub async fn call(
    app: &axum::Router,
    method: &str,
    uri: &str,
    body: Option<&Value>,
    key: &str,
) -> (StatusCode, String) {
    let bytes = body.map(|b| b.to_string().into_bytes()).unwrap_or_default();
    let ct = if body.is_some() {
        "application/json"
    } else {
        ""
    };
    answer(app, request(method, uri, ct, None, bytes, Some(key))).await
}

/// Sends `req`: the answer's status and its body as text.
pub async fn answer(app: &axum::Router, req: Request<Body>) -> (StatusCode, String) {
    let resp = app.clone().oneshot(req).await.unwrap();
    let status = resp.status();
    let bytes = axum::body::to_bytes(resp.into_body(), usize::MAX)
        .await
        .unwrap();
    (status, String::from_utf8_lossy(&bytes).into_owned())
}

/// The routes of the OpenAPI document the code generates: (method, path template).
pub fn api_routes() -> Vec<(String, String)> {
    let doc: Value = serde_json::from_str(&mtcal_server::openapi_json()).unwrap();
    let mut out = vec![];
    for (path, ops) in doc["paths"].as_object().unwrap() {
        for method in ops.as_object().unwrap().keys() {
            out.push((method.to_uppercase(), path.clone()));
        }
    }
    out
}

/// The dashboard's routes, read from its router's source: (method, path template).
pub fn page_routes() -> Vec<(String, String)> {
    let src = include_str!("../../src/web/mod.rs");
    let mut out = vec![];
    for part in src.split(".route(\"").skip(1) {
        let (path, rest) = part.split_once('"').unwrap();
        let call = rest.split(")\n").next().unwrap_or(rest);
        for method in ["get", "post"] {
            if call.contains(&format!("{method}(")) {
                out.push((method.to_uppercase(), path.to_string()));
            }
        }
    }
    assert!(
        out.len() >= 10,
        "the dashboard's routes were not found: {out:?}"
    );
    out
}

/// `template` with each `{param}` replaced by `ids`' id of the kind its segment names.
pub fn fill(template: &str, ids: &Ids) -> String {
    let segments: Vec<&str> = template.split('/').collect();
    let mut out = vec![];
    for (i, seg) in segments.iter().enumerate() {
        match seg.strip_prefix('{').and_then(|s| s.strip_suffix('}')) {
            Some(param) => out.push(ids.for_segment(segments[i - 1], param)),
            None => out.push(seg.to_string()),
        }
    }
    out.join("/")
}

/// How a request is authenticated: an API key, or a dashboard session (its cookie and
/// its forms' CSRF token).
#[derive(Clone)]
pub enum Auth {
    Key(String),
    Session { cookie: String, csrf: String },
}

/// A dashboard session of the key `secret`.
pub async fn session_of(store: &Arc<dyn Store>, secret: &str) -> Auth {
    use axum::response::IntoResponse;
    use axum_extra::extract::PrivateCookieJar;
    use axum_extra::extract::cookie::Cookie;
    let key = store.key_by_secret(secret).await.unwrap().unwrap();
    let s = store.create_session(&key.id, 3_600_000).await.unwrap();
    let session = mtcal_server::auth::session::SESSION_COOKIE;
    let jar = PrivateCookieJar::new(mtcal_server::auth::session::cookie_key())
        .add(Cookie::new(session, s.token));
    let resp = jar.into_response();
    let set = resp.headers()[header::SET_COOKIE].to_str().unwrap();
    Auth::Session {
        cookie: set.split(';').next().unwrap().to_string(),
        csrf: s.csrf,
    }
}

/// Sends `method uri` as `who` with `body` (JSON to the API; a form, with the session's
/// CSRF token, to a page): its status and body as text.
pub async fn send_as(
    app: &axum::Router,
    who: &Auth,
    method: &str,
    uri: &str,
    body: Option<&Value>,
) -> (StatusCode, String) {
    let (cookie, csrf) = match who {
        Auth::Key(k) => return call(app, method, uri, body, k).await,
        Auth::Session { cookie, csrf } => (cookie, csrf),
    };
    let mut form = format!("csrf={csrf}");
    if let Some(Value::String(f)) = body {
        form = format!("{form}&{f}");
    }
    let mut r = Request::builder()
        .method(method)
        .uri(uri)
        .header(header::COOKIE, cookie.as_str());
    if method != "GET" {
        r = r.header(header::CONTENT_TYPE, "application/x-www-form-urlencoded");
    }
    answer(app, r.body(Body::from(form)).unwrap()).await
}
