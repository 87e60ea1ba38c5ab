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
    /// The check it belongs to (None: a job without a dataset, e.g. a sensitivity run).
    pub check: Option<JobCheck>,
}

/// The check a job belongs to: its dataset's kind, files and measurement time.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct JobCheck {
    pub dataset_id: String,
    /// `session`, `rotary_points`, `positioning` or `drift_log`.
    pub kind: String,
    pub files: Vec<String>,
    pub measured_at: String,
}

/// Files a job's check names before "and N more".
const FILES_SHOWN: usize = 3;

impl JobCheck {
    /// In words: `session xy.csv, xz.csv, yz.csv and 1 more, measured 2026-01-05 08:00
    /// UTC`.
    pub fn describe(&self) -> String {
        let mut files = self
            .files
            .iter()
            .take(FILES_SHOWN)
            .cloned()
            .collect::<Vec<_>>()
            .join(", ");
        if self.files.len() > FILES_SHOWN {
            files.push_str(&format!(" and {} more", self.files.len() - FILES_SHOWN));
        }
        format!(
            "{} {files}, measured {}",
            self.kind.replace('_', " "),
            when(&self.measured_at)
        )
    }
}

/// The check cell of a job: its machine and its check in words.
fn check_cell(j: &JobRow) -> Markup {
    html! {
        @if let Some(m) = &j.machine_id { a href=(machine_href(m)) { (m) } }
        @if let Some(c) = &j.check {
            br;
            span.check title={ "dataset " (c.dataset_id) } { (c.describe()) }
        }
    }
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
            @if let Some(c) = &j.check { span.check.muted title={ "dataset " (c.dataset_id) } { "of " (c.describe()) } " " }
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
                thead { tr { th { "created" } th { "kind" } th { "check (machine, dataset, measured)" } th { "state" } th { "progress" } th { "message / error" } th {} } }
                tbody {
                    @for j in jobs {
                        tr data-job=(j.id) data-poll=(poll_href(&j.id)) {
                            td { (when(&j.created_at)) }
                            td { (j.kind) }
                            td.check { (check_cell(j)) }
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
                check: Some(JobCheck {
                    dataset_id: "ds_1".into(),
                    kind: "session".into(),
                    files: ["session.json", "xy.csv", "xz.csv", "yz.csv"]
                        .map(String::from)
                        .into(),
                    measured_at: "2026-04-05T07:30:00Z".into(),
                }),
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
        // Which check each job belongs to: its machine, dataset and when it was measured.
        let row = &html[html.find(r#"data-job="j1""#).unwrap()..];
        let row = &row[..row.find("</tr>").unwrap()];
        assert!(row.contains(r#"href="/machines/VMC-1""#), "{row}");
        assert!(
            row.contains(
                "session session.json, xy.csv, xz.csv and 1 more, measured 2026-04-05 07:30 UTC"
            ),
            "{row}"
        );
        assert!(row.contains(r#"title="dataset ds_1""#));
        assert!(
            job_progress(&jobs[0], false)
                .into_string()
                .contains("of session session.json, xy.csv")
        );
        let block = job_progress(&jobs[1], true).into_string();
        assert!(block.contains("data-reload") && block.contains(r#"data-state="running""#));
    }
}
