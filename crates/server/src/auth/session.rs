//! Sign-in sessions: the dashboard's cookie, read by the dashboard's pages
//! (crates/server/src/web/session.rs) and by the API's GET routes ([`super`]).
//!
//! Signing in with an API key starts a session kept by the database
//! ([`mtcal_store::Keys::create_session`]) and sets one cookie, `mtcal_session`:
//! HttpOnly, SameSite=Strict, Path=/, no expiry (it ends with the browser session),
//! `Secure` when the request came over TLS or the service is configured so
//! ([`crate::Settings::cookie_secure`]). It holds only the session's random token
//! (the database keeps its SHA-256), encrypted and authenticated (AES-256-GCM, the
//! `cookie` crate's private jar, through axum-extra). Every request reads the session
//! from the database: signing out deletes it, revoking the key deletes its sessions,
//! and a session ends [`SESSION_TTL`] after sign-in by the database's clock, all at
//! once for every process of the service. The key's scope applies as in the API (read
//! sees; write also uploads, sets baselines, acknowledges alerts).
//!
//! The API's GET routes accept the session cookie too ([`super::authenticate`]), so that the page
//! script reads them as the signed-in key (the progress of a job from
//! `GET /api/v1/jobs/{id}`); every other method of the API needs the key itself.
//!
//! CSRF: every form carries the session's token in the field `csrf`; a POST whose token
//! does not match is refused (403) before anything else is read. The sign-in form has its
//! own token in a short-lived pre-session cookie (`mtcal_signin`), so that another site
//! cannot sign a browser in with a key of its choosing.
//!
//! The cookies' encryption key comes from `MTCAL_SESSION_KEY` (any secret of at least 32
//! characters, the same for every process behind one address), else it is drawn at
//! random when the process starts: then a restart signs every browser out, and behind a
//! load balancer one process refuses the cookies of another (docs/operations.md, "Operations").

use crate::AppState;
use crate::error::ApiError;
use axum::http::HeaderMap;
use axum_extra::extract::PrivateCookieJar;
use axum_extra::extract::cookie::{Cookie, Key, SameSite};
use mtcal_store::ApiKey;
use std::sync::OnceLock;
use std::time::Duration;

/// The session cookie.
pub const SESSION_COOKIE: &str = "mtcal_session";
/// The sign-in form's pre-session cookie (its CSRF token).
pub const SIGNIN_COOKIE: &str = "mtcal_signin";
/// Longest life of a session.
pub const SESSION_TTL: Duration = Duration::from_secs(12 * 3600);

/// The process's cookie key (module docs).
pub fn cookie_key() -> Key {
    static KEY: OnceLock<Key> = OnceLock::new();
    KEY.get_or_init(|| match std::env::var("MTCAL_SESSION_KEY") {
        Ok(s) if s.len() >= 32 => Key::derive_from(s.as_bytes()),
        Ok(_) => {
            tracing::warn!(
                "MTCAL_SESSION_KEY is shorter than 32 characters: using a random key \
                 (sign-ins end when this process restarts)"
            );
            Key::generate()
        }
        Err(_) => {
            tracing::info!(
                "MTCAL_SESSION_KEY is not set: using a random key (sign-ins end when this \
                 process restarts; set it on every process behind one address)"
            );
            Key::generate()
        }
    })
    .clone()
}

/// A random token (122 bits).
pub fn token() -> String {
    uuid::Uuid::new_v4().simple().to_string()
}

/// Whether the cookies of an answer to a request with `headers` are `Secure`: always when
/// configured so, else when the request came over TLS (a TLS-terminating proxy says so
/// with `X-Forwarded-Proto: https`; the service itself speaks plain HTTP).
pub fn secure(app: &AppState, headers: &HeaderMap) -> bool {
    app.settings.cookie_secure
        || headers
            .get("x-forwarded-proto")
            .and_then(|v| v.to_str().ok())
            .and_then(|v| v.split(',').next())
            .is_some_and(|p| p.trim().eq_ignore_ascii_case("https"))
}

fn cookie(name: &'static str, value: String, secure: bool) -> Cookie<'static> {
    Cookie::build((name, value))
        .http_only(true)
        .same_site(SameSite::Strict)
        .secure(secure)
        .path("/")
        .build()
}

/// Starts a session of `key` (the caller has checked it): stored by the database, its
/// token in the cookie of the returned jar.
pub async fn start(
    app: &AppState,
    jar: PrivateCookieJar,
    key: &ApiKey,
    secure: bool,
) -> Result<PrivateCookieJar, ApiError> {
    let ttl = i64::try_from(SESSION_TTL.as_millis()).unwrap_or(i64::MAX);
    let s = app.store.create_session(&key.id, ttl).await?;
    Ok(jar
        .remove(Cookie::build(SIGNIN_COOKIE).path("/"))
        .add(cookie(SESSION_COOKIE, s.token, secure)))
}

/// Ends the session of the request (deleted from the database) and removes its cookie.
pub async fn end(app: &AppState, jar: PrivateCookieJar) -> Result<PrivateCookieJar, ApiError> {
    if let Some(c) = jar.get(SESSION_COOKIE) {
        app.store.end_session(c.value()).await?;
    }
    Ok(jar.remove(Cookie::build(SESSION_COOKIE).path("/")))
}

/// The jar with a fresh sign-in token, and the token.
pub fn signin_token(jar: PrivateCookieJar, secure: bool) -> (PrivateCookieJar, String) {
    let t = token();
    (jar.add(cookie(SIGNIN_COOKIE, t.clone(), secure)), t)
}

/// Whether `given` is the sign-in token of this browser.
pub fn signin_token_ok(jar: &PrivateCookieJar, given: &str) -> bool {
    jar.get(SIGNIN_COOKIE)
        .is_some_and(|c| same(c.value(), given))
}

/// Equality that takes as long whatever the first difference (tokens are secrets).
pub fn same(a: &str, b: &str) -> bool {
    a.len() == b.len()
        && a.bytes()
            .zip(b.bytes())
            .fold(0u8, |acc, (x, y)| acc | (x ^ y))
            == 0
}

/// A signed-in browser: its key (checked against the store on this request) and the
/// session's CSRF token. Without a valid session, a page request is sent to the
/// sign-in page (with `next` set to where it wanted to go).
#[derive(Debug, Clone)]
pub struct Session {
    pub key: ApiKey,
    pub csrf: String,
}

impl Session {
    /// The session the request's cookie names, decrypted with `key`: None when there is
    /// no cookie, when it does not decrypt, or when the database has no live session for
    /// it (ended, expired, or its key revoked).
    pub async fn from_headers(
        app: &AppState,
        key: &Key,
        headers: &HeaderMap,
    ) -> Result<Option<Session>, ApiError> {
        let jar = PrivateCookieJar::from_headers(headers, key.clone());
        let Some(c) = jar.get(SESSION_COOKIE) else {
            return Ok(None);
        };
        Ok(app.store.session(c.value()).await?.map(|s| Session {
            key: s.key,
            csrf: s.csrf,
        }))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tokens_compare_whole() {
        assert!(same("abc", "abc"));
        assert!(!same("abc", "abd"));
        assert!(!same("abc", "ab"));
        assert!(!same("", "a"));
        assert_ne!(token(), token());
        assert_eq!(token().len(), 32);
    }
}
