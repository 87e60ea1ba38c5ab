//! The sign-in page: an API key entered once gives a session cookie.

use super::{Nav, csrf_field, page};
use maud::{Markup, html};

/// `csrf`: the token of the sign-in form (bound to a pre-session cookie); `next`: where
/// to go after signing in; `error`: why the last attempt failed.
pub fn signin_page(csrf: &str, next: &str, error: Option<&str>) -> Markup {
    page(
        "Sign in",
        Nav::Other,
        None,
        html! {
            section.card.signin {
                h1 { "Sign in" }
                p.muted { "Enter an API key (from " code { "mtcal admin create-key" } " or printed by "
                          code { "mtcal demo" } "). A read key sees; a write key also uploads, sets \
                          baselines and acknowledges alerts. The key is kept server-side for this \
                          browser session only." }
                @if let Some(e) = error { div.notice.error #signin-error { (e) } }
                form.stack method="post" action="/signin" {
                    (csrf_field(csrf))
                    input type="hidden" name="next" value=(next);
                    label { "API key" input #key type="password" name="key" autocomplete="off" required autofocus; }
                    button type="submit" { "Sign in" }
                }
            }
        },
    )
}

#[cfg(test)]
mod tests {
    #[test]
    fn signin_form_posts_the_key_with_a_csrf_token() {
        let html = super::signin_page("t0k", "/machines/A", Some("unknown or revoked API key"))
            .into_string();
        assert!(html.contains(r#"action="/signin""#));
        assert!(html.contains(r#"type="password" name="key""#));
        assert!(html.contains(r#"name="csrf" value="t0k""#));
        assert!(html.contains(r#"name="next" value="/machines/A""#));
        assert!(html.contains("unknown or revoked API key"));
    }
}
