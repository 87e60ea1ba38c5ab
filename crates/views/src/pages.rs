//! HTML pages (maud templates): the base layout ([`page`]), the print layout
//! ([`print_page`]: self-contained, CSS inlined, plots inline SVG), and one module per
//! page. Each page is a function of plain view data; the server fills it from the same
//! functions that back the API routes.
//!
//! Figures are shown as value ± U with U = 2u (k = 2), u the standard uncertainty the
//! API reports; plots draw the same ±2σ.

use maud::{DOCTYPE, Markup, PreEscaped, html};

pub mod alerts;
pub mod audit;
pub mod compare;
pub mod explained;
pub mod fleet;
pub mod jobs;
pub mod machine;
pub mod report;
pub mod result;
pub mod signin;

/// Who is signed in: the API key's label and scope, and the CSRF token every form of
/// the page carries.
#[derive(Debug, Clone, PartialEq)]
pub struct Viewer {
    pub label: String,
    /// `read`, `write` or `admin`.
    pub scope: String,
    pub csrf: String,
}

impl Viewer {
    /// Whether the key may upload, set baselines and acknowledge alerts.
    pub fn can_write(&self) -> bool {
        self.scope == "write" || self.scope == "admin"
    }
}

/// What the diagnosis of a recording found, as the fleet row of its machine and the
/// page of a result computed from it show it (the full diagnosis is on its own page).
#[derive(Debug, Clone, PartialEq)]
pub struct DiagnosisFindings {
    pub result_id: String,
    /// `consistent`, `explained`, `partly_explained` (None: unreadable).
    pub verdict: Option<String>,
    /// Its findings in words, at most a few (or why it cannot be read).
    pub findings: Vec<String>,
    /// Findings not listed.
    pub more: usize,
}

impl DiagnosisFindings {
    /// In one sentence, inline, linked to the diagnosis' page.
    pub fn sentence(&self) -> Markup {
        html! {
            "The service's " a href=(result_href(&self.result_id)) { "diagnosis of this recording" }
            @match self.verdict.as_deref() {
                Some("consistent") => { " finds the rigid model consistent with it." }
                None => { ": " (self.findings.join("; ")) "." }
                Some(_) => {
                    " found: " (self.findings.join("; "))
                    @if self.more > 0 { " and " (self.more) " more" }
                    "."
                }
            }
        }
    }
}

/// Name of the hidden form field carrying the CSRF token.
pub const CSRF_FIELD: &str = "csrf";

/// The hidden CSRF field of a form.
pub fn csrf_field(token: &str) -> Markup {
    html! { input type="hidden" name=(CSRF_FIELD) value=(token); }
}

/// Which navigation entry is the current page.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Nav {
    Fleet,
    Jobs,
    Alerts,
    Other,
}

/// The base layout: header with navigation and sign-out, the body, the footnote on
/// uncertainties. Assets come from `/static/` (served by mtcal itself).
pub fn page(title: &str, nav: Nav, viewer: Option<&Viewer>, body: Markup) -> Markup {
    html! {
        (DOCTYPE)
        html lang="en" {
            head {
                meta charset="utf-8";
                meta name="viewport" content="width=device-width, initial-scale=1";
                title { (title) " — mtcal" }
                link rel="stylesheet" href=(crate::assets::href("mtcal.css"));
                script src=(crate::assets::href("mtcal.js")) defer {}
            }
            body {
                header.top {
                    a.brand href="/" { "mtcal" }
                    @if let Some(v) = viewer {
                        nav {
                            a href="/" class=[(nav == Nav::Fleet).then_some("active")] { "Fleet" }
                            a href="/jobs" class=[(nav == Nav::Jobs).then_some("active")] { "Jobs" }
                            a href="/alerts" class=[(nav == Nav::Alerts).then_some("active")] { "Alerts" }
                            @if v.scope == "admin" { a href="/audit" { "Audit" } }
                            a href="/docs" { "API" }
                        }
                        div.who {
                            span.key { (v.label) " · " (v.scope) }
                            form.inline method="post" action="/signout" {
                                (csrf_field(&v.csrf))
                                button type="submit" { "Sign out" }
                            }
                        }
                    }
                }
                main { (body) }
                footer {
                    "Figures are value ± U, U = 2u (k = 2); plots show ±2σ. Nothing is evaluated \
                     outside the travel a check measured. Everything shown here is also served \
                     by the API ("
                    a href="/docs" { "/docs" } ")."
                }
            }
        }
    }
}

/// A self-contained page for printing or saving: the stylesheet inlined, no navigation,
/// no script (plots are inline SVG already).
pub fn print_page(title: &str, body: Markup) -> Markup {
    html! {
        (DOCTYPE)
        html lang="en" {
            head {
                meta charset="utf-8";
                title { (title) }
                style { (PreEscaped(crate::assets::CSS)) }
            }
            body.print {
                main { (body) }
            }
        }
    }
}

/// An error page: the status and what went wrong, with a way back.
pub fn error_page(viewer: Option<&Viewer>, status: u16, reason: &str, message: &str) -> Markup {
    let (heading, what_to_do) = error_words(status);
    page(
        heading,
        Nav::Other,
        viewer,
        html! {
            section.card #error {
                h1 { (heading) }
                p.error { (message) }
                p { (what_to_do) }
                p.muted { "HTTP " (status) " " (reason) }
                p { a href="/" { "Back to the fleet" } " · " a href="/jobs" { "jobs" } }
            }
        },
    )
}

/// What an error page says in words: its heading, and what a person does next.
fn error_words(status: u16) -> (&'static str, &'static str) {
    match status {
        422 => (
            "The dataset was not accepted",
            "Correct the file at the line and column named (docs/datasets.md lists every \
             rule), then upload it again. Nothing was stored.",
        ),
        413 => (
            "The upload is too large",
            "Send fewer or smaller files, or compress them (.gz or one .tar.gz). Nothing was \
             stored.",
        ),
        408 => (
            "The upload took too long",
            "Try again on a faster connection, or compress the files. Nothing was stored.",
        ),
        400 | 415 => (
            "The request was not accepted",
            "Check the fields named above and send the form again. Nothing was changed.",
        ),
        401 | 403 => (
            "Not allowed",
            "Sign in with a key whose scope allows this (write for uploads and profiles).",
        ),
        404 => (
            "Not found",
            "The link may be old: start again from the fleet.",
        ),
        409 => (
            "Not possible now",
            "The message says what stands in the way; nothing was changed.",
        ),
        503 => (
            "The service is not ready",
            "The database cannot be reached now; try again in a few seconds.",
        ),
        _ => (
            "Something went wrong",
            "The cause is in the service's log; try again, or tell whoever runs the service.",
        ),
    }
}

/// An SVG document inline (plots escape their own text).
pub fn svg(doc: String) -> Markup {
    PreEscaped(doc)
}

pub use mtcal_solver::text::{num, with_u};

/// `2026-01-05 08:00 UTC` from an RFC 3339 time (the input unchanged if it is not one).
pub fn when(rfc3339: &str) -> String {
    match time::OffsetDateTime::parse(rfc3339, &time::format_description::well_known::Rfc3339) {
        Ok(t) => {
            let t = t.to_offset(time::UtcOffset::UTC);
            format!("{} {:02}:{:02} UTC", t.date(), t.hour(), t.minute())
        }
        Err(_) => rfc3339.to_string(),
    }
}

/// A verdict badge: `pass`, `fail`, `undecided`, or `no tolerance` when none applies.
pub fn verdict_badge(verdict: Option<&str>) -> Markup {
    match verdict {
        // The decision's words ("not decided: model misfit"), its id as the class.
        Some(v) => html! {
            span class={ "badge verdict " (v) } {
                (mtcal_solver::tolerance::Decision::parse(v).map_or(v, |d| d.label()))
            }
        },
        None => html! { span.badge.none title="no tolerance profile applies" { "no tolerance" } },
    }
}

/// A job state badge.
pub fn state_badge(state: &str) -> Markup {
    html! { span class={ "badge state " (state) } data-state=(state) { (state) } }
}

/// `/machines/{id}` with the id percent-encoded.
pub fn machine_href(id: &str) -> String {
    format!("/machines/{}", encode(id))
}

/// `/results/{id}`.
pub fn result_href(id: &str) -> String {
    format!("/results/{}", encode(id))
}

/// Percent-encodes everything but unreserved characters (RFC 3986), for path segments
/// and query values.
pub fn encode(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for b in s.bytes() {
        if b.is_ascii_alphanumeric() || b"-._~".contains(&b) {
            out.push(b as char);
        } else {
            out.push_str(&format!("%{b:02X}"));
        }
    }
    out
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    pub(crate) fn viewer(scope: &str) -> Viewer {
        Viewer {
            label: "plant <north>".into(),
            scope: scope.into(),
            csrf: "tok\"en".into(),
        }
    }

    /// An error page says what happened and what to do in words, with the message and
    /// the way back; the HTTP status is small print.
    #[test]
    fn an_error_page_says_what_to_do() {
        let html = error_page(
            None,
            422,
            "Unprocessable Entity",
            "xy.csv:3:du_um: `1,5` has a decimal comma",
        )
        .into_string();
        assert!(
            html.contains("<h1>The dataset was not accepted</h1>"),
            "{html}"
        );
        assert!(html.contains("Correct the file at the line and column named"));
        assert!(html.contains("xy.csv:3:du_um:"));
        assert!(html.contains("HTTP 422 Unprocessable Entity"));
        assert!(html.contains(r#"<a href="/">Back to the fleet</a>"#));
        assert!(!html.contains("<h1>422"));
    }

    #[test]
    fn layout_has_navigation_sign_out_and_csrf() {
        let v = viewer("read");
        let html = page("Fleet", Nav::Fleet, Some(&v), html! { p { "body" } }).into_string();
        assert!(html.starts_with("<!DOCTYPE html>"));
        assert!(html.contains(r#"href="/static/mtcal.css?v="#));
        assert!(html.contains(r#"<a href="/" class="active">Fleet</a>"#));
        assert!(html.contains(r#"action="/signout""#));
        assert!(
            html.contains(r#"<input type="hidden" name="csrf" value="tok&quot;en">"#),
            "{html}"
        );
        assert!(html.contains("plant &lt;north&gt;"), "labels escaped");
        let anonymous = page("Sign in", Nav::Other, None, html! {}).into_string();
        assert!(!anonymous.contains("/signout"));
    }

    #[test]
    fn print_page_is_self_contained() {
        let html = print_page("report", html! { p { "x" } }).into_string();
        assert!(html.contains("<style>"));
        assert!(!html.contains("/static/"), "no external asset");
        assert!(!html.contains("<script"));
    }

    #[test]
    fn times_and_addresses() {
        assert_eq!(when("2026-01-05T08:00:00Z"), "2026-01-05 08:00 UTC");
        assert_eq!(when("2026-01-05T10:00:00+02:00"), "2026-01-05 08:00 UTC");
        assert_eq!(encode("VMC 42/a"), "VMC%2042%2Fa");
    }
}
