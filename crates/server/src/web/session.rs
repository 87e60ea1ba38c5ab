//! The dashboard's side of the sign-in sessions ([`crate::auth::session`]): the page
//! routes' state, the [`Session`] extractor that sends a browser without a session to
//! the sign-in page, and the checks of a form (CSRF token, write scope).

use crate::AppState;
pub use crate::auth::session::{
    SESSION_COOKIE, SESSION_TTL, SIGNIN_COOKIE, Session, cookie_key, end, same, secure,
    signin_token, signin_token_ok, start, token,
};
use crate::error::ApiError;
use axum::extract::{FromRef, FromRequestParts, OriginalUri};
use axum::http::request::Parts;
use axum::response::{IntoResponse, Redirect, Response};
use axum_extra::extract::cookie::Key;
use mtcal_views::pages::Viewer;

/// State of the web routes: the service's state and the cookie key.
#[derive(Clone)]
pub struct WebState {
    pub app: AppState,
    pub key: Key,
}

impl FromRef<WebState> for Key {
    fn from_ref(s: &WebState) -> Key {
        s.key.clone()
    }
}

impl FromRef<WebState> for AppState {
    fn from_ref(s: &WebState) -> AppState {
        s.app.clone()
    }
}

impl Session {
    /// The viewer the pages show.
    pub fn viewer(&self) -> Viewer {
        Viewer {
            label: self.key.label.clone(),
            scope: self.key.scope.as_str().into(),
            csrf: self.csrf.clone(),
        }
    }

    /// The session's holder as the audit trail records it, from `client`.
    pub fn actor(&self, client: crate::audit::Client) -> crate::audit::Actor {
        crate::audit::Actor::of_key(&self.key, "dashboard", client.0)
    }

    /// Refuses a form whose token is not the session's (403).
    pub fn check_csrf(&self, given: &str) -> Result<(), super::WebError> {
        if same(&self.csrf, given) {
            Ok(())
        } else {
            Err(super::WebError(ApiError::Forbidden(
                "the form's CSRF token does not match this session; reload the page and try again"
                    .into(),
            )))
        }
    }

    /// Refuses a key without write scope (403).
    pub fn require_write(&self) -> Result<(), super::WebError> {
        if self.key.scope.allows(mtcal_store::Scope::Write) {
            Ok(())
        } else {
            Err(super::WebError(ApiError::Forbidden(format!(
                "this needs a key with scope write; key {} has scope {}",
                self.key.prefix,
                self.key.scope.as_str()
            ))))
        }
    }
}

/// Rejection of [`Session`]: to the sign-in page, or a storage failure.
pub enum NoSession {
    SignIn(String),
    Failed(super::WebError),
}

impl IntoResponse for NoSession {
    fn into_response(self) -> Response {
        match self {
            NoSession::SignIn(next) => Redirect::to(&format!(
                "/signin?next={}",
                mtcal_views::pages::encode(&next)
            ))
            .into_response(),
            NoSession::Failed(e) => e.into_response(),
        }
    }
}

impl FromRequestParts<WebState> for Session {
    type Rejection = NoSession;

    async fn from_request_parts(parts: &mut Parts, state: &WebState) -> Result<Self, NoSession> {
        let next = OriginalUri::from_request_parts(parts, state)
            .await
            .map(|u| u.0.to_string())
            .unwrap_or_else(|_| "/".into());
        match Session::from_headers(&state.app, &state.key, &parts.headers).await {
            Ok(Some(session)) => Ok(session),
            Ok(None) => Err(NoSession::SignIn(next)),
            Err(e) => Err(NoSession::Failed(super::WebError(e))),
        }
    }
}
