//! Sign-in sessions: the dashboard's cookie, read by the dashboard's pages
//! (crates/server/src/web/session.rs) and by the API's GET routes ([`super`]).
//!
//! Signing in with an API key sets one cookie, `mtcal_session`: HttpOnly, SameSite=Strict,
//! Path=/, no expiry (it ends with the browser session), and at most [`SESSION_TTL`] old.
//! Its value is encrypted and authenticated (AES-256-GCM, the `cookie` crate's private
//! jar, through axum-extra) and holds the key's secret, a random CSRF token and the time
//! of sign-in. Every request looks the secret up again, so a revoked key ends its
//! sessions at once, and the key's scope applies as in the API (read sees; write also
//! uploads, sets baselines, acknowledges alerts).
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
//! The encryption key comes from `MTCAL_SESSION_KEY` (any secret of at least 32
//! characters, shared by every instance behind one address), else it is drawn at random
//! when the process starts (sessions then end when it restarts).

use crate::AppState;
use crate::error::ApiError;
use axum::http::HeaderMap;
use axum_extra::extract::PrivateCookieJar;
use axum_extra::extract::cookie::{Cookie, Key, SameSite};
use mtcal_store::ApiKey;
use serde::{Deserialize, Serialize};
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
            tracing::warn!("MTCAL_SESSION_KEY is shorter than 32 characters: using a random key");
            Key::generate()
        }
        Err(_) => Key::generate(),
    })
    .clone()
}

/// A random token (122 bits).
pub fn token() -> String {
    uuid::Uuid::new_v4().simple().to_string()
}

/// What the session cookie holds.
#[derive(Debug, Clone, Serialize, Deserialize)]
struct SessionData {
    /// The API key's secret.
    k: String,
    /// The CSRF token of the session's forms.
    c: String,
    /// Unix seconds of sign-in.
    t: i64,
}

fn now() -> i64 {
    time::OffsetDateTime::now_utc().unix_timestamp()
}

fn cookie(name: &'static str, value: String) -> Cookie<'static> {
    Cookie::build((name, value))
        .http_only(true)
        .same_site(SameSite::Strict)
        .path("/")
        .build()
}

/// The jar with a new session for `secret` (the caller has checked the key).
pub fn start(jar: PrivateCookieJar, secret: &str) -> PrivateCookieJar {
    let data = SessionData {
        k: secret.to_string(),
        c: token(),
        t: now(),
    };
    let value = serde_json::to_string(&data).unwrap_or_default();
    jar.remove(Cookie::build(SIGNIN_COOKIE).path("/"))
        .add(cookie(SESSION_COOKIE, value))
}

/// The jar without the session.
pub fn end(jar: PrivateCookieJar) -> PrivateCookieJar {
    jar.remove(Cookie::build(SESSION_COOKIE).path("/"))
}

/// The jar with a fresh sign-in token, and the token.
pub fn signin_token(jar: PrivateCookieJar) -> (PrivateCookieJar, String) {
    let t = token();
    (jar.add(cookie(SIGNIN_COOKIE, t.clone())), t)
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
    /// The session the request's cookie holds, decrypted with `key`: None when there is
    /// no cookie, when it does not decrypt or is too old, or when its API key is unknown
    /// or revoked (looked up again on every request).
    pub async fn from_headers(
        app: &AppState,
        key: &Key,
        headers: &HeaderMap,
    ) -> Result<Option<Session>, ApiError> {
        let jar = PrivateCookieJar::from_headers(headers, key.clone());
        let Some(data) = jar
            .get(SESSION_COOKIE)
            .and_then(|c| serde_json::from_str::<SessionData>(c.value()).ok())
        else {
            return Ok(None);
        };
        if now() - data.t > SESSION_TTL.as_secs() as i64 || data.t > now() + 60 {
            return Ok(None);
        }
        Ok(app
            .store
            .key_by_secret(&data.k)
            .await?
            .map(|key| Session { key, csrf: data.c }))
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
