//! The calls of API v1: [`Client`], one method per operation.

use crate::error::{ClientError, Result};
use crate::files::files_to_upload_in;
use mtcal_api::{
    ApiKey, CreatedKey, Dataset, FleetDrift, FleetList, FleetParams, Health, Job, Machine,
    MachinePatch, NewKey, NewMachine, Profile, Reason, ResultDiff, ResultMeta, Scope, StoredResult,
    SubmitJob, SummaryTrend, TermTrend,
};
use mtcal_formats::CsvDialect;
use reqwest::{Method, RequestBuilder, StatusCode};
use serde::de::DeserializeOwned;
use serde_json::Value;
use std::path::Path;
use std::time::{Duration, Instant};

/// A text file the service sends (an export, a report): its media type, its
/// `Content-Disposition` (when an attachment) and its text.
#[derive(Debug, Clone, PartialEq)]
pub struct Download {
    pub content_type: String,
    pub disposition: Option<String>,
    pub text: String,
}

/// A client of one service with one API key.
#[derive(Debug, Clone)]
pub struct Client {
    http: reqwest::Client,
    base: String,
    key: String,
}

impl Client {
    /// A client of the service at `base` (e.g. `http://127.0.0.1:8080`) using `key`.
    pub fn new(base: &str, key: &str) -> Client {
        Client {
            http: reqwest::Client::new(),
            base: base.trim_end_matches('/').to_string(),
            key: key.to_string(),
        }
    }

    /// The same service with another key.
    pub fn with_key(&self, key: &str) -> Client {
        Client {
            key: key.to_string(),
            ..self.clone()
        }
    }

    /// The service's base URL.
    pub fn base(&self) -> &str {
        &self.base
    }

    /// A request to `path` (absolute, e.g. `/api/v1/machines`) carrying the key.
    pub fn request(&self, method: Method, path: &str) -> RequestBuilder {
        self.http
            .request(method, format!("{}{path}", self.base))
            .bearer_auth(&self.key)
    }

    /// Sends a request: the response when it is a success, the refusal as
    /// [`ClientError::Api`] otherwise.
    pub async fn send_raw(&self, rb: RequestBuilder) -> Result<(String, reqwest::Response)> {
        let context = rb
            .try_clone()
            .and_then(|r| r.build().ok())
            .map(|r| format!("{} {}", r.method(), r.url()))
            .unwrap_or_else(|| "request".into());
        let resp = rb.send().await.map_err(|source| ClientError::Http {
            context: context.clone(),
            source,
        })?;
        let status = resp.status();
        if !status.is_success() {
            let body: Value = resp.json().await.unwrap_or(Value::Null);
            let text = |k: &str| body["error"][k].as_str().unwrap_or("").to_string();
            return Err(ClientError::Api {
                status,
                code: text("code"),
                message: text("message"),
            });
        }
        Ok((context, resp))
    }

    /// Sends a request; its JSON answer, or the refusal as [`ClientError::Api`].
    pub async fn send<T: DeserializeOwned>(&self, rb: RequestBuilder) -> Result<T> {
        let (context, resp) = self.send_raw(rb).await?;
        resp.json()
            .await
            .map_err(|source| ClientError::Http { context, source })
    }

    async fn get<T: DeserializeOwned>(&self, path: &str) -> Result<T> {
        self.send(self.request(Method::GET, path)).await
    }

    async fn post<T: DeserializeOwned>(
        &self,
        path: &str,
        body: &impl serde::Serialize,
    ) -> Result<T> {
        self.send(self.request(Method::POST, path).json(body)).await
    }

    /// `GET /health`.
    pub async fn health(&self) -> Result<Health> {
        self.get("/health").await
    }

    // Machines.

    pub async fn create_machine(&self, m: &NewMachine) -> Result<Machine> {
        self.post("/api/v1/machines", m).await
    }

    /// Creates a tolerance profile from its JSON (`{scope, target, limits, …}`, as
    /// docs/api.md states it).
    pub async fn create_tolerance(&self, profile: &Value) -> Result<Profile> {
        self.post("/api/v1/tolerances", profile).await
    }

    pub async fn machine(&self, id: &str) -> Result<Machine> {
        self.get(&format!("/api/v1/machines/{id}")).await
    }

    pub async fn update_machine(&self, id: &str, p: &MachinePatch) -> Result<Machine> {
        self.send(
            self.request(Method::PATCH, &format!("/api/v1/machines/{id}"))
                .json(p),
        )
        .await
    }

    pub async fn machines(&self, after: Option<&str>, limit: Option<i64>) -> Result<Vec<Machine>> {
        let mut rb = self.request(Method::GET, "/api/v1/machines");
        if let Some(a) = after {
            rb = rb.query(&[("after", a)]);
        }
        if let Some(l) = limit {
            rb = rb.query(&[("limit", l)]);
        }
        self.send(rb).await
    }

    // Datasets.

    /// Uploads files as multipart parts.
    pub async fn upload_files(
        &self,
        machine: &str,
        files: &[(String, Vec<u8>)],
    ) -> Result<Dataset> {
        self.upload_files_in(machine, files, CsvDialect::Plain)
            .await
    }

    /// Uploads files as multipart parts, their CSV files written in `dialect` (the
    /// `csv_dialect` form field, sent when not plain).
    pub async fn upload_files_in(
        &self,
        machine: &str,
        files: &[(String, Vec<u8>)],
        dialect: CsvDialect,
    ) -> Result<Dataset> {
        let mut form = reqwest::multipart::Form::new();
        if dialect != CsvDialect::Plain {
            form = form.text("csv_dialect", dialect.name());
        }
        for (name, bytes) in files {
            form = form.part(
                "files",
                reqwest::multipart::Part::bytes(bytes.clone()).file_name(name.clone()),
            );
        }
        let rb = self
            .request(
                Method::POST,
                &format!("/api/v1/machines/{machine}/datasets"),
            )
            .multipart(form);
        self.upload(machine, rb).await
    }

    /// Uploads one archive (`.tar.gz` when `gzip`, else `.tar`) as the request body.
    pub async fn upload_archive(
        &self,
        machine: &str,
        bytes: Vec<u8>,
        gzip: bool,
    ) -> Result<Dataset> {
        let ct = if gzip {
            "application/gzip"
        } else {
            "application/x-tar"
        };
        let rb = self
            .request(
                Method::POST,
                &format!("/api/v1/machines/{machine}/datasets"),
            )
            .header(reqwest::header::CONTENT_TYPE, ct)
            .body(bytes);
        self.upload(machine, rb).await
    }

    /// Sends an upload. The service refuses an upload (a key without write scope, an
    /// unknown machine, a size) before it reads the body and closes the connection, so
    /// the client may see a broken pipe instead of the answer. Then it sends the same
    /// upload route an empty request, which the service refuses at once for the same key
    /// or machine: a refusal of the key (401, 403) or of the machine (404) is the reason
    /// given, else the connection error.
    async fn upload(&self, machine: &str, rb: RequestBuilder) -> Result<Dataset> {
        match self.send(rb).await {
            Err(e @ ClientError::Http { .. }) => {
                let probe = self.request(
                    Method::POST,
                    &format!("/api/v1/machines/{machine}/datasets"),
                );
                match self.send_raw(probe).await {
                    Err(
                        refusal @ ClientError::Api {
                            status:
                                StatusCode::UNAUTHORIZED | StatusCode::FORBIDDEN | StatusCode::NOT_FOUND,
                            ..
                        },
                    ) => Err(refusal),
                    _ => Err(e),
                }
            }
            other => other,
        }
    }

    /// Uploads a dataset from disk (a session folder, a dataset file with its sidecar, or
    /// an archive). It is read first with the service's own reader
    /// (`mtcal_formats::read_path`), so a bad input is refused here with the message the
    /// service would give; then the files read are sent.
    pub async fn upload_path(&self, machine: &str, path: &Path) -> Result<Dataset> {
        self.upload_path_in(machine, path, CsvDialect::Plain).await
    }

    /// [`Client::upload_path`] with CSV files written in `dialect`.
    pub async fn upload_path_in(
        &self,
        machine: &str,
        path: &Path,
        dialect: CsvDialect,
    ) -> Result<Dataset> {
        let files = files_to_upload_in(path, dialect)?;
        self.upload_files_in(machine, &files, dialect).await
    }

    pub async fn dataset(&self, id: &str) -> Result<Dataset> {
        self.get(&format!("/api/v1/datasets/{id}")).await
    }

    /// The bytes of one file of a dataset, as uploaded.
    pub async fn dataset_file(&self, id: &str, name: &str) -> Result<Vec<u8>> {
        let rb = self.request(Method::GET, &format!("/api/v1/datasets/{id}/files/{name}"));
        let (context, resp) = self.send_raw(rb).await?;
        let bytes = resp
            .bytes()
            .await
            .map_err(|source| ClientError::Http { context, source })?;
        Ok(bytes.to_vec())
    }

    /// A machine's datasets in time order; excluded ones (deleted ones included) only
    /// when `include_excluded`.
    pub async fn datasets(&self, machine: &str, include_excluded: bool) -> Result<Vec<Dataset>> {
        let rb = self
            .request(Method::GET, &format!("/api/v1/machines/{machine}/datasets"))
            .query(&[("include_excluded", include_excluded)]);
        self.send(rb).await
    }

    /// Excludes a dataset and the results computed from it (write key; recorded with
    /// `reason`).
    pub async fn exclude_dataset(&self, id: &str, reason: &str) -> Result<Dataset> {
        self.post(
            &format!("/api/v1/datasets/{id}/exclude"),
            &Reason::of(reason),
        )
        .await
    }

    /// Deletes a dataset's raw bytes, keeping a tombstone (admin key; recorded with
    /// `reason`).
    pub async fn delete_dataset_files(&self, id: &str, reason: &str) -> Result<Dataset> {
        self.post(
            &format!("/api/v1/datasets/{id}/delete-files"),
            &Reason::of(reason),
        )
        .await
    }

    // Jobs.

    pub async fn submit(&self, j: &SubmitJob) -> Result<Job> {
        self.post("/api/v1/jobs", j).await
    }

    /// Jobs newest first, only those in `state` when given (at most 1000).
    pub async fn jobs(&self, state: Option<&str>) -> Result<Vec<Job>> {
        match state {
            Some(st) => {
                self.get(&format!("/api/v1/jobs?limit=1000&state={st}"))
                    .await
            }
            None => self.get("/api/v1/jobs?limit=1000").await,
        }
    }

    pub async fn job(&self, id: &str) -> Result<Job> {
        self.get(&format!("/api/v1/jobs/{id}")).await
    }

    /// The result document of a succeeded job.
    pub async fn job_result(&self, id: &str) -> Result<Value> {
        self.get(&format!("/api/v1/jobs/{id}/result")).await
    }

    pub async fn cancel(&self, id: &str) -> Result<Job> {
        self.post(&format!("/api/v1/jobs/{id}/cancel"), &serde_json::json!({}))
            .await
    }

    /// Polls a job every `poll` until it ends (succeeded, failed or cancelled), calling
    /// `tick` with each state seen; [`ClientError::Timeout`] after `timeout`.
    pub async fn wait_job(
        &self,
        id: &str,
        timeout: Duration,
        poll: Duration,
        mut tick: impl FnMut(&Job),
    ) -> Result<Job> {
        let start = Instant::now();
        loop {
            let job = self.job(id).await?;
            tick(&job);
            if job.state.is_terminal() {
                return Ok(job);
            }
            if start.elapsed() > timeout {
                return Err(ClientError::Timeout {
                    id: id.into(),
                    state: job.state.as_str().into(),
                    waited_s: timeout.as_secs(),
                });
            }
            tokio::time::sleep(poll).await;
        }
    }

    // History and trends.

    /// A machine's results of `kind` (default identification) in time order.
    pub async fn results(&self, machine: &str, kind: Option<&str>) -> Result<Vec<ResultMeta>> {
        let mut rb = self.request(Method::GET, &format!("/api/v1/machines/{machine}/results"));
        if let Some(k) = kind {
            rb = rb.query(&[("kind", k)]);
        }
        self.send(rb).await
    }

    /// Excludes a result from the history (write key; recorded with `reason`).
    pub async fn exclude_result(&self, id: &str, reason: &str) -> Result<ResultMeta> {
        self.post(
            &format!("/api/v1/results/{id}/exclude"),
            &Reason::of(reason),
        )
        .await
    }

    pub async fn latest(&self, machine: &str, kind: Option<&str>) -> Result<StoredResult> {
        let mut rb = self.request(
            Method::GET,
            &format!("/api/v1/machines/{machine}/results/latest"),
        );
        if let Some(k) = kind {
            rb = rb.query(&[("kind", k)]);
        }
        self.send(rb).await
    }

    pub async fn result(&self, id: &str) -> Result<StoredResult> {
        self.get(&format!("/api/v1/results/{id}")).await
    }

    /// `GET /api/v1/results/{id}/export` with its query (`format`, `step_mm`): the
    /// compensation table.
    pub async fn export(&self, id: &str, query: &[(&str, &str)]) -> Result<Download> {
        self.download(
            self.request(Method::GET, &format!("/api/v1/results/{id}/export"))
                .query(query),
        )
        .await
    }

    /// `GET /api/v1/results/{id}/report`: the check report (HTML).
    pub async fn report(&self, id: &str) -> Result<Download> {
        self.download(self.request(Method::GET, &format!("/api/v1/results/{id}/report")))
            .await
    }

    async fn download(&self, rb: RequestBuilder) -> Result<Download> {
        let (context, resp) = self.send_raw(rb).await?;
        let header = |name: reqwest::header::HeaderName| {
            resp.headers()
                .get(name)
                .and_then(|v| v.to_str().ok())
                .map(String::from)
        };
        let content_type = header(reqwest::header::CONTENT_TYPE).unwrap_or_default();
        let disposition = header(reqwest::header::CONTENT_DISPOSITION);
        let text = resp
            .text()
            .await
            .map_err(|source| ClientError::Http { context, source })?;
        Ok(Download {
            content_type,
            disposition,
            text,
        })
    }

    /// `results/diff` with its query parameters (`baseline`, `against`, `step_mm`, …) as
    /// given.
    pub async fn diff(&self, machine: &str, query: &[(&str, &str)]) -> Result<ResultDiff> {
        self.send(
            self.request(
                Method::GET,
                &format!("/api/v1/machines/{machine}/results/diff"),
            )
            .query(query),
        )
        .await
    }

    /// A term's values at `at` (mm) over the machine's results.
    pub async fn term_trend(&self, machine: &str, term: &str, at: &[f64]) -> Result<TermTrend> {
        let at = at.iter().map(f64::to_string).collect::<Vec<_>>().join(",");
        self.send(
            self.request(
                Method::GET,
                &format!("/api/v1/machines/{machine}/trends/term"),
            )
            .query(&[("term", term), ("at", &at)]),
        )
        .await
    }

    /// Check `id` verified against the predictions of the check before it.
    pub async fn verification(&self, id: &str) -> Result<mtcal_api::history::Verification> {
        self.get(&format!("/api/v1/results/{id}/verification"))
            .await
    }

    /// The machine's checks verified against the check before each, in time order.
    pub async fn verification_trend(
        &self,
        machine: &str,
    ) -> Result<Vec<mtcal_api::history::Verification>> {
        self.get(&format!("/api/v1/machines/{machine}/trends/verification"))
            .await
    }

    pub async fn summary_trend(&self, machine: &str) -> Result<SummaryTrend> {
        self.get(&format!("/api/v1/machines/{machine}/trends/summary"))
            .await
    }

    /// The fleet ranked by drift (`by`: `um` or `urad`).
    pub async fn fleet_drift(&self, by: Option<&str>, limit: Option<usize>) -> Result<FleetDrift> {
        let mut rb = self.request(Method::GET, "/api/v1/fleet/drift");
        if let Some(b) = by {
            rb = rb.query(&[("by", b)]);
        }
        if let Some(l) = limit {
            rb = rb.query(&[("limit", l)]);
        }
        self.send(rb).await
    }

    /// A page of the fleet as the dashboard's fleet page shows it (`GET /api/v1/fleet`).
    pub async fn fleet(&self, q: &FleetParams) -> Result<FleetList> {
        self.send(self.request(Method::GET, "/api/v1/fleet").query(q))
            .await
    }

    // Keys.

    pub async fn create_key(&self, scope: Scope, label: &str) -> Result<CreatedKey> {
        self.create_scoped_key(&NewKey {
            scope,
            label: label.into(),
            sites: vec![],
            tags: vec![],
        })
        .await
    }

    /// Creates a key limited to sites (and tags) (`sites` empty: the whole group).
    pub async fn create_scoped_key(&self, k: &NewKey) -> Result<CreatedKey> {
        self.post("/api/v1/keys", k).await
    }

    /// Every key, revoked ones included (admin).
    pub async fn keys(&self) -> Result<Vec<ApiKey>> {
        self.send(self.request(Method::GET, "/api/v1/keys")).await
    }

    /// Revokes key `id` (admin).
    pub async fn revoke_key(&self, id: &str) -> Result<ApiKey> {
        self.send(self.request(Method::DELETE, &format!("/api/v1/keys/{id}")))
            .await
    }
}
