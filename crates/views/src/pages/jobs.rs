//! The jobs page (queued, running with progress, failed with the error) and the job
//! progress block the machine page reuses.

use super::{Nav, Viewer, machine_href, page, result_href, state_badge, when};
use maud::{Markup, html};

/// A job as the API reports it.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct JobRow {
    pub id: String,
    pub kind: String,
    pub machine_id: Option<String>,
    /// `queued`, `running`, `succeeded`, `failed`, `cancelled`.
    pub state: String,
    /// 0 … 1.
    pub progress: f64,
    pub progress_message: Option<String>,
    pub error_code: Option<String>,
    pub error_message: Option<String>,
    pub result_id: Option<String>,
    pub created_at: String,
}

/// URL the script polls for a job's state: the API's `GET /api/v1/jobs/{id}`, which
/// reads the browser's session cookie as its key.
pub fn poll_href(id: &str) -> String {
    format!("/api/v1/jobs/{}", super::encode(id))
}

/// A job with its state, progress bar and message; polled by the script while it runs
/// (`reload`: reload the page when it ends).
pub fn job_progress(j: &JobRow, reload: bool) -> Markup {
    html! {
        div.job data-job=(j.id) data-poll=(poll_href(&j.id)) data-reload[reload] {
            (state_badge(&j.state)) " "
            strong { (j.kind) } " "
            progress max="1" value=(j.progress) {}
            " " span.message { (j.error_message.as_deref().or(j.progress_message.as_deref()).unwrap_or("")) }
            @if let Some(r) = &j.result_id { " " a href=(result_href(r)) { "result" } }
        }
    }
}

/// The jobs page; `state`: the filter applied (empty: all).
pub fn jobs_page(viewer: &Viewer, jobs: &[JobRow], state: &str) -> Markup {
    let states = ["", "queued", "running", "failed", "succeeded", "cancelled"];
    page(
        "Jobs",
        Nav::Jobs,
        Some(viewer),
        html! {
            h1 { "Jobs" }
            form.filters method="get" action="/jobs" {
                label { "state"
                    select name="state" {
                        @for s in states { option value=(s) selected[state == s] { (if s.is_empty() { "all" } else { s }) } }
                    }
                }
                button type="submit" { "Apply" }
            }
            table #jobs {
                thead { tr { th { "created" } th { "kind" } th { "machine" } th { "state" } th { "progress" } th { "message / error" } th {} } }
                tbody {
                    @for j in jobs {
                        tr data-job=(j.id) data-poll=(poll_href(&j.id)) {
                            td { (when(&j.created_at)) }
                            td { (j.kind) }
                            td { @if let Some(m) = &j.machine_id { a href=(machine_href(m)) { (m) } } }
                            td { (state_badge(&j.state)) }
                            td { progress max="1" value=(j.progress) {} }
                            td {
                                @if let Some(e) = &j.error_message {
                                    span.message.error { @if let Some(c) = &j.error_code { code { (c) } ": " } (e) }
                                } @else {
                                    span.message { (j.progress_message.as_deref().unwrap_or("")) }
                                }
                            }
                            td { @if let Some(r) = &j.result_id { a href=(result_href(r)) { "result" } } }
                        }
                    }
                }
            }
            @if jobs.is_empty() { p.muted { "No job." } }
        },
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pages::tests::viewer;

    #[test]
    fn failed_jobs_show_their_error_running_ones_their_progress() {
        let jobs = [
            JobRow {
                id: "j1".into(),
                kind: "identify".into(),
                machine_id: Some("VMC-1".into()),
                state: "failed".into(),
                error_code: Some("bad_input".into()),
                error_message: Some("xy.csv:3:dv_um: not a number".into()),
                created_at: "2026-04-06T08:00:00Z".into(),
                ..JobRow::default()
            },
            JobRow {
                id: "j2".into(),
                kind: "identify".into(),
                state: "running".into(),
                progress: 0.4,
                progress_message: Some("reading".into()),
                created_at: "2026-04-06T08:01:00Z".into(),
                ..JobRow::default()
            },
        ];
        let html = jobs_page(&viewer("read"), &jobs, "").into_string();
        assert!(html.contains("<code>bad_input</code>: xy.csv:3:dv_um: not a number"));
        assert!(html.contains(r#"<progress max="1" value="0.4">"#));
        assert!(html.contains(r#"data-poll="/api/v1/jobs/j2""#));
        let block = job_progress(&jobs[1], true).into_string();
        assert!(block.contains("data-reload") && block.contains(r#"data-state="running""#));
    }
}
