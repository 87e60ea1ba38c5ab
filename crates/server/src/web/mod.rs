//! The dashboard: server-rendered pages (crates/views) at `/`, `/machines/{id}`,
//! `/results/{id}`, `/compare?a=&b=`, `/jobs`, `/alerts`, `/signin`, `/signout` and the vendored
//! assets at `/static/*`.
//!
//! Every page is rendered from the same functions that back the documented API routes
//! (everything a page shows is also served by a route of docs/api.md), and every form
//! posts to a web route that checks the session cookie and its CSRF token and then calls
//! those same functions: there is no private data path. The page script reads the API
//! itself (a job's progress from `GET /api/v1/jobs/{id}`) with the session cookie as its
//! key. Sessions: [`session`].

pub mod audit;
pub mod forms;
pub mod pages;
pub mod session;

use crate::error::ApiError;
use crate::{AppState, JSON_BODY_LIMIT, REQUEST_TIMEOUT};
use axum::Router;
use axum::extract::{DefaultBodyLimit, Form, Path, Query, Request, State};
use axum::http::{HeaderMap, StatusCode, header};
use axum::middleware::Next;
use axum::response::{Html, IntoResponse, Redirect, Response};
use axum::routing::{get, post};
use axum_extra::extract::PrivateCookieJar;
use mtcal_views::pages::Viewer;
use serde::Deserialize;
use session::{Session, WebState};
use tower_http::timeout::TimeoutLayer;

/// An error shown as an HTML page (the API's error, its status and message; a 500's
/// cause is logged, not shown).
#[derive(Debug)]
pub struct WebError(pub ApiError);

impl From<ApiError> for WebError {
    fn from(e: ApiError) -> Self {
        WebError(e)
    }
}

impl From<mtcal_store::StoreError> for WebError {
    fn from(e: mtcal_store::StoreError) -> Self {
        WebError(e.into())
    }
}

impl From<mtcal_domain::DomainError> for WebError {
    fn from(e: mtcal_domain::DomainError) -> Self {
        WebError(e.into())
    }
}

/// What an error page says, left on the response by [`WebError`] for [`error_pages`],
/// which renders it inside the layout of whoever is signed in.
#[derive(Debug, Clone)]
struct ErrorMessage(String);

impl IntoResponse for WebError {
    fn into_response(self) -> Response {
        let status = self.0.status();
        let message = match &self.0 {
            ApiError::Internal(cause) => {
                tracing::error!(%cause, "web page failed");
                "something went wrong on the server; the cause is in its log".to_string()
            }
            e => e.to_string(),
        };
        let mut resp = (status, error_html(None, status, &message)).into_response();
        resp.extensions_mut().insert(ErrorMessage(message));
        self.0.mark(&mut resp);
        resp
    }
}

/// The error page of `status` with `message`, in the layout of `viewer` (None: the
/// layout without navigation).
fn error_html(viewer: Option<&Viewer>, status: StatusCode, message: &str) -> Html<String> {
    Html(
        mtcal_views::pages::error_page(
            viewer,
            status.as_u16(),
            status.canonical_reason().unwrap_or("error"),
            message,
        )
        .into_string(),
    )
}

/// Every error answer of a page route as a page in the layout with its navigation (the
/// signed-in viewer's, read from the session cookie): a [`WebError`]'s, and an answer
/// made outside the handlers (a form or query the extractor refuses, a body over its
/// limit, a request timed out, a method not allowed, the outage guard's 503), whose
/// text or JSON message becomes the page's message. A page already in HTML (the sign-in
/// form refusing a key) is left as it is.
async fn error_pages(State(s): State<WebState>, req: Request, next: Next) -> Response {
    let headers = req.headers().clone();
    let resp = next.run(req).await;
    let status = resp.status();
    if !(status.is_client_error() || status.is_server_error()) {
        return resp;
    }
    let given = resp.extensions().get::<ErrorMessage>().cloned();
    let is_html = resp
        .headers()
        .get(header::CONTENT_TYPE)
        .and_then(|v| v.to_str().ok())
        .is_some_and(|v| v.starts_with("text/html"));
    if given.is_none() && is_html {
        return resp;
    }
    let (mut parts, body) = resp.into_parts();
    let (status, message) = match given {
        Some(ErrorMessage(m)) => (status, m),
        None => {
            let bytes = axum::body::to_bytes(body, 16 * 1024)
                .await
                .unwrap_or_default();
            let text = String::from_utf8_lossy(&bytes).trim().to_string();
            // The API's error body (the outage guard), else the extractor's text.
            let text = serde_json::from_str::<serde_json::Value>(&text)
                .ok()
                .and_then(|v| v["error"]["message"].as_str().map(str::to_string))
                .unwrap_or(text);
            if status.is_server_error() {
                let shown = text
                    .is_empty()
                    .then(|| "the service could not answer".to_string());
                (status, shown.unwrap_or(text))
            } else if status == StatusCode::METHOD_NOT_ALLOWED
                || (status == StatusCode::REQUEST_TIMEOUT && text.is_empty())
            {
                (
                    status,
                    status.canonical_reason().unwrap_or("refused").to_string(),
                )
            } else if status == StatusCode::REQUEST_TIMEOUT {
                // The upload gate's words: the rate or the slot time it passed.
                (status, text)
            } else {
                // As the API maps a refused form or query: a bad request (400), a body
                // over its limit (413) or of the wrong type (415).
                let e = ApiError::from_rejection(status, text);
                (e.status(), e.to_string())
            }
        }
    };
    let viewer = match session::Session::from_headers(&s.app, &s.key, &headers).await {
        Ok(Some(session)) => Some(session.viewer()),
        _ => None,
    };
    parts.status = status;
    parts.headers.remove(header::CONTENT_LENGTH);
    parts.headers.insert(
        header::CONTENT_TYPE,
        axum::http::HeaderValue::from_static("text/html; charset=utf-8"),
    );
    let page = error_html(viewer.as_ref(), status, &message).0;
    Response::from_parts(parts, axum::body::Body::from(page))
}

/// The result of a page handler.
pub type PageResult = Result<Response, WebError>;

/// An HTML page response.
pub fn html(m: mtcal_views::Markup) -> Response {
    ([(header::CACHE_CONTROL, "no-store")], Html(m.into_string())).into_response()
}

/// The dashboard's routes (merged into the service's router outside the API's JSON
/// error layer: their errors are pages).
pub fn router(app: AppState) -> Router {
    let upload_limit = app.limits.max_bytes;
    let state = WebState {
        app,
        key: session::cookie_key(),
    };
    // The same gate as the API's upload route: one set of slots, rate and time limits.
    let uploads = Router::new()
        .route("/machines/{id}/upload", post(pages::upload))
        .layer(DefaultBodyLimit::max(upload_limit));
    let uploads = crate::upload_gate::guard(uploads, &state.app)
        .layer(crate::upload_gate::outer_limit(&state.app));
    let rest = Router::new()
        .route("/", get(pages::fleet))
        .route("/machines/{id}", get(pages::machine))
        .route("/machines", post(forms::create_machine))
        .route("/machines/{id}/baseline", post(pages::set_baseline))
        .route("/machines/{id}/tolerance", post(forms::create_profile))
        .route("/results/{id}", get(pages::result))
        .route("/compare", get(pages::compare))
        .route("/alerts", get(pages::alerts))
        .route("/alerts/{id}/ack", post(pages::ack_alert))
        .route("/jobs", get(pages::jobs))
        .route("/audit", get(audit::page))
        .route("/signin", get(signin_form).post(signin))
        .route("/signout", post(signout))
        .layer(DefaultBodyLimit::max(JSON_BODY_LIMIT))
        .layer(TimeoutLayer::with_status_code(
            StatusCode::REQUEST_TIMEOUT,
            REQUEST_TIMEOUT,
        ));
    let guard = axum::middleware::from_fn_with_state(state.app.clone(), crate::outage::guard);
    let scope = axum::middleware::from_fn_with_state(state.app.clone(), scope_guard);
    let assets = Router::new().route("/static/{file}", get(asset));
    let pages = axum::middleware::from_fn_with_state(state.clone(), error_pages);
    uploads
        .merge(rest)
        .route_layer(scope)
        .route_layer(guard)
        .merge(assets)
        .route_layer(pages)
        .with_state(state)
}

/// The sites-and-roles check of every page (`crate::auth::scope`) for the key of the
/// request's session: an id outside its scope is a 404 page. A request without a
/// session goes on (its page sends it to the sign-in page).
async fn scope_guard(
    State(s): State<AppState>,
    req: axum::extract::Request,
    next: axum::middleware::Next,
) -> Response {
    let (mut parts, body) = req.into_parts();
    let cookie = session::cookie_key();
    let found = Session::from_headers(&s, &cookie, &parts.headers).await;
    let checked = match found {
        Ok(Some(session)) => crate::auth::scope::check_request(&s, &session.key, &mut parts).await,
        Ok(None) => Ok(()),
        Err(e) => Err(e),
    };
    if let Err(e) = checked {
        return WebError(e).into_response();
    }
    next.run(axum::extract::Request::from_parts(parts, body))
        .await
}

/// `/static/{file}`: the vendored stylesheet and script (pages link them with a content
/// hash, `mtcal_views::assets::href`).
async fn asset(Path(file): Path<String>) -> Response {
    match mtcal_views::assets::get(&file) {
        Some((content_type, body)) => (
            [
                (header::CONTENT_TYPE, content_type),
                (header::CACHE_CONTROL, "public, max-age=86400"),
            ],
            body,
        )
            .into_response(),
        None => WebError(ApiError::NotFound(format!("no asset {file}"))).into_response(),
    }
}

#[derive(Debug, Deserialize)]
struct NextQuery {
    next: Option<String>,
}

/// Where to go after signing in or a form: a path of this site only, else `/`. Only a
/// path that starts with one `/`, holds no backslash, no white space and no control
/// character (browsers drop tabs and line feeds from a URL, so `/\t/evil.example` would
/// lead to `//evil.example`), and reads as a path and query without scheme or host.
pub(crate) fn local_path(next: Option<&str>) -> String {
    let local = |n: &str| {
        n.starts_with('/')
            && !n.starts_with("//")
            && !n
                .chars()
                .any(|c| c == '\\' || c.is_whitespace() || c.is_control())
            && n.parse::<axum::http::Uri>()
                .is_ok_and(|u| u.scheme().is_none() && u.authority().is_none())
    };
    match next {
        Some(n) if local(n) => n.into(),
        _ => "/".into(),
    }
}

async fn signin_form(
    State(s): State<WebState>,
    headers: HeaderMap,
    jar: PrivateCookieJar,
    Query(q): Query<NextQuery>,
) -> Response {
    let (jar, token) = session::signin_token(jar, session::secure(&s.app, &headers));
    let next = local_path(q.next.as_deref());
    (
        jar,
        html(mtcal_views::pages::signin::signin_page(&token, &next, None)),
    )
        .into_response()
}

#[derive(Debug, Deserialize)]
struct SigninForm {
    /// Missing reads as empty: refused by the token check (403), like a wrong one.
    #[serde(default)]
    csrf: String,
    key: String,
    next: Option<String>,
}

/// Checks the key; on success starts a session and goes on to `next`.
async fn signin(
    State(s): State<WebState>,
    client: crate::audit::Client,
    headers: HeaderMap,
    jar: PrivateCookieJar,
    Form(f): Form<SigninForm>,
) -> PageResult {
    let next = local_path(f.next.as_deref());
    let secure = session::secure(&s.app, &headers);
    if !session::signin_token_ok(&jar, &f.csrf) {
        let (jar, token) = session::signin_token(jar, secure);
        let page = mtcal_views::pages::signin::signin_page(
            &token,
            &next,
            Some("the sign-in form expired; enter the key again"),
        );
        return Ok((StatusCode::FORBIDDEN, jar, html(page)).into_response());
    }
    let secret = f.key.trim();
    match s
        .app
        .store
        .key_by_secret(secret)
        .await
        .map_err(ApiError::from)?
    {
        Some(key) => {
            let jar = session::start(&s.app, jar, &key, secure).await?;
            let who = crate::audit::Actor::of_key(&key, "dashboard", client.0);
            who.record(s.app.store.as_ref(), signed("signin", &key))
                .await?;
            Ok((jar, Redirect::to(&next)).into_response())
        }
        None => {
            // Nothing of the secret is kept: a wrong key may be a real one mistyped.
            let change = crate::audit::Change {
                action: "signin.failed",
                ..Default::default()
            };
            let who = crate::audit::Actor::unknown("dashboard", client.0);
            who.record(s.app.store.as_ref(), change).await?;
            let (jar, token) = session::signin_token(jar, secure);
            let page = mtcal_views::pages::signin::signin_page(
                &token,
                &next,
                Some("unknown or revoked API key"),
            );
            Ok((StatusCode::UNAUTHORIZED, jar, html(page)).into_response())
        }
    }
}

/// A session's start or end (`action`) as the audit trail records it: its key, and the
/// key's scope after.
fn signed<'a>(action: &'a str, key: &'a mtcal_store::ApiKey) -> crate::audit::Change<'a> {
    crate::audit::Change {
        action,
        target: &key.id,
        machine: None,
        before: None,
        after: Some(serde_json::json!({"key": key.id, "scope": key.scope.as_str()})),
    }
}

#[derive(Debug, Deserialize)]
pub struct CsrfForm {
    /// Missing reads as empty: refused by the token check (403), like a wrong one.
    #[serde(default)]
    pub csrf: String,
}

/// Ends the session in the database (the cookie, if kept, opens nothing any more).
async fn signout(
    session: Session,
    client: crate::audit::Client,
    State(s): State<WebState>,
    jar: PrivateCookieJar,
    Form(f): Form<CsrfForm>,
) -> PageResult {
    session.check_csrf(&f.csrf)?;
    let jar = session::end(&s.app, jar).await?;
    let change = signed("signout", &session.key);
    session
        .actor(client)
        .record(s.app.store.as_ref(), change)
        .await?;
    Ok((jar, Redirect::to("/signin")).into_response())
}

#[cfg(test)]
mod tests {
    use super::local_path;

    #[test]
    fn next_stays_on_this_site() {
        assert_eq!(
            local_path(Some("/machines/A?term=EXX")),
            "/machines/A?term=EXX"
        );
        assert_eq!(local_path(Some("//evil.example/")), "/");
        assert_eq!(local_path(Some("https://evil.example/")), "/");
        assert_eq!(local_path(Some("/\\evil.example")), "/");
        assert_eq!(local_path(None), "/");
        for bad in [
            "/\t/evil.example/",
            "/\n/evil.example/",
            "/ /evil.example/",
            "/\u{0}x",
            "/\r\nSet-Cookie: a=b",
            "/\u{85}/evil.example",
        ] {
            assert_eq!(local_path(Some(bad)), "/", "{bad:?}");
        }
    }
}
