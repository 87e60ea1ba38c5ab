//! `mtcal submit`: a client of the service. Uploads a session folder, submits an
//! `identify` job, shows its progress, prints the result.

use anyhow::{Context, bail};
use indicatif::{ProgressBar, ProgressStyle};
use serde_json::{Value, json};
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::{Duration, Instant};

#[derive(clap::Args)]
pub struct Args {
    /// Session folder (session.json and its plane files).
    pub session_dir: PathBuf,
    /// Machine id the session belongs to (registered with the service).
    #[arg(long)]
    pub machine: String,
    /// Service URL.
    #[arg(long, default_value = "http://127.0.0.1:8080")]
    pub url: String,
    /// API key with write scope (default: the MTCAL_API_KEY environment variable).
    #[arg(long)]
    pub key: Option<String>,
    /// Print the whole result document (JSON) instead of a summary.
    #[arg(long)]
    pub json: bool,
    /// Give up waiting after this many seconds.
    #[arg(long, default_value_t = 600)]
    pub timeout_s: u64,
}

/// A small API client.
pub struct Client {
    http: reqwest::Client,
    base: String,
    key: String,
}

impl Client {
    pub fn new(base: &str, key: &str) -> Client {
        Client {
            http: reqwest::Client::new(),
            base: base.trim_end_matches('/').to_string(),
            key: key.to_string(),
        }
    }

    async fn check(resp: reqwest::Response) -> anyhow::Result<Value> {
        let status = resp.status();
        let body: Value = resp.json().await.unwrap_or(Value::Null);
        if !status.is_success() {
            bail!(
                "service answered {status}: {} ({})",
                body["error"]["message"].as_str().unwrap_or("no message"),
                body["error"]["code"].as_str().unwrap_or("no code")
            );
        }
        Ok(body)
    }

    pub async fn get(&self, path: &str) -> anyhow::Result<Value> {
        let r = self
            .http
            .get(format!("{}{path}", self.base))
            .bearer_auth(&self.key)
            .send()
            .await
            .with_context(|| format!("GET {}{path}", self.base))?;
        Self::check(r).await
    }

    pub async fn post(&self, path: &str, body: &Value) -> anyhow::Result<Value> {
        let r = self
            .http
            .post(format!("{}{path}", self.base))
            .bearer_auth(&self.key)
            .json(body)
            .send()
            .await
            .with_context(|| format!("POST {}{path}", self.base))?;
        Self::check(r).await
    }

    /// Uploads every file of a session folder as multipart; returns the dataset.
    pub async fn upload_session(&self, machine: &str, dir: &Path) -> anyhow::Result<Value> {
        let mut names: Vec<_> = std::fs::read_dir(dir)
            .with_context(|| format!("reading {}", dir.display()))?
            .filter_map(|e| e.ok())
            .filter(|e| e.file_type().is_ok_and(|t| t.is_file()))
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .filter(|n| n == "session.json" || n.ends_with(".csv") || n.ends_with(".csv.gz"))
            .collect();
        names.sort();
        if !names.iter().any(|n| n == "session.json") {
            return Err(super::BadInput(format!("{}: no session.json", dir.display())).into());
        }
        let mut files = vec![];
        for n in names {
            let bytes = std::fs::read(dir.join(&n))?;
            files.push((n, bytes));
        }
        self.upload_files(machine, files).await
    }

    /// Uploads the files of one dataset (name, bytes) as multipart; returns the dataset.
    pub async fn upload_files(
        &self,
        machine: &str,
        files: Vec<(String, Vec<u8>)>,
    ) -> anyhow::Result<Value> {
        let mut form = reqwest::multipart::Form::new();
        for (n, bytes) in files {
            form = form.part("files", reqwest::multipart::Part::bytes(bytes).file_name(n));
        }
        let r = self
            .http
            .post(format!("{}/api/v1/machines/{machine}/datasets", self.base))
            .bearer_auth(&self.key)
            .multipart(form)
            .send()
            .await
            .context("uploading the dataset")?;
        Self::check(r).await
    }

    /// Polls a job until it ends, calling `tick(progress, message)` on the way.
    pub async fn wait_job(
        &self,
        id: &str,
        timeout: Duration,
        mut tick: impl FnMut(f64, &str),
    ) -> anyhow::Result<Value> {
        let start = Instant::now();
        loop {
            let job = self.get(&format!("/api/v1/jobs/{id}")).await?;
            let state = job["state"].as_str().unwrap_or_default();
            tick(
                job["progress"].as_f64().unwrap_or(0.0),
                &format!(
                    "{state}: {}",
                    job["progress_message"].as_str().unwrap_or("")
                ),
            );
            if matches!(state, "succeeded" | "failed" | "cancelled") {
                return Ok(job);
            }
            if start.elapsed() > timeout {
                bail!("job {id} still {state} after {} s", timeout.as_secs());
            }
            tokio::time::sleep(Duration::from_millis(200)).await;
        }
    }
}

pub fn run(args: Args) -> anyhow::Result<ExitCode> {
    let rt = tokio::runtime::Runtime::new()?;
    rt.block_on(async {
        let key = match args
            .key
            .clone()
            .or_else(|| std::env::var("MTCAL_API_KEY").ok())
        {
            Some(k) => k,
            None => {
                return Err(super::BadInput("give --key or set MTCAL_API_KEY".into()).into());
            }
        };
        let c = Client::new(&args.url, &key);
        let ds = c.upload_session(&args.machine, &args.session_dir).await?;
        let ds_id = ds["id"].as_str().unwrap_or_default().to_string();
        eprintln!("uploaded dataset {ds_id} ({} samples)", ds["samples"]);
        let job = c
            .post(
                "/api/v1/jobs",
                &json!({"kind": "identify", "dataset_id": ds_id}),
            )
            .await?;
        let id = job["id"].as_str().unwrap_or_default().to_string();
        let bar = ProgressBar::new(100);
        bar.set_style(
            ProgressStyle::with_template("{spinner} [{elapsed_precise}] {bar:30} {pos}% {msg}")
                .expect("valid template"),
        );
        let job = c
            .wait_job(&id, Duration::from_secs(args.timeout_s), |p, m| {
                bar.set_position((p * 100.0).round() as u64);
                bar.set_message(m.to_string());
            })
            .await?;
        bar.finish_and_clear();
        if job["state"] != "succeeded" {
            bail!(
                "job {id} {}: {} ({})",
                job["state"].as_str().unwrap_or("?"),
                job["error_message"].as_str().unwrap_or(""),
                job["error_code"].as_str().unwrap_or("")
            );
        }
        let doc = c.get(&format!("/api/v1/jobs/{id}/result")).await?;
        if args.json {
            println!("{}", serde_json::to_string_pretty(&doc)?);
        } else {
            println!(
                "job {id}: result {} — residual {} µm, rank {}/{} (condition {}), EC0Y {} µrad",
                job["result_id"].as_str().unwrap_or(""),
                doc["fit"]["residual_rms_um"],
                doc["observability"]["rank"],
                doc["observability"]["parameters"],
                doc["observability"]["condition_number"],
                doc["squareness"]["EC0Y"]["value_urad"]
            );
        }
        Ok(ExitCode::SUCCESS)
    })
}
