//! `mtcal submit`: a client of the service (`mtcal_client`). Uploads a session (read
//! first with the service's own reader, so a bad one is refused before it is sent),
//! submits an `identify` job, shows its progress, prints the result.

use anyhow::bail;
use indicatif::{ProgressBar, ProgressStyle};
use mtcal_client::{Client, ClientError};
use mtcal_server::api::jobs::SubmitJob;
use mtcal_server::jobs::JobKind;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Duration;

#[derive(clap::Args)]
pub struct Args {
    /// Session folder (session.json and its plane files), or a .tar.gz of one.
    pub session_dir: PathBuf,
    #[command(flatten)]
    pub read: super::ReadArgs,
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
        let ds = c
            .upload_path_in(&args.machine, &args.session_dir, args.read.csv_dialect)
            .await
            .map_err(|e| match e {
                ClientError::Input(m) => anyhow::Error::from(super::BadInput(m)),
                other => other.into(),
            })?;
        super::out::noteln!("uploaded dataset {} ({} samples)", ds.id, ds.samples);
        let job = c
            .submit(&SubmitJob {
                kind: JobKind::Identify,
                dataset_id: Some(ds.id.clone()),
                machine_id: None,
                params: serde_json::json!({}),
            })
            .await?;
        let id = job.id.clone();
        let bar = ProgressBar::new(100);
        bar.set_style(
            ProgressStyle::with_template("{spinner} [{elapsed_precise}] {bar:30} {pos}% {msg}")
                .expect("valid template"),
        );
        let job = c
            .wait_job(
                &id,
                Duration::from_secs(args.timeout_s),
                Duration::from_millis(200),
                |j| {
                    bar.set_position((j.progress * 100.0).round() as u64);
                    bar.set_message(format!(
                        "{}: {}",
                        j.state.as_str(),
                        j.progress_message.as_deref().unwrap_or("")
                    ));
                },
            )
            .await?;
        bar.finish_and_clear();
        if job.state != mtcal_store::JobState::Succeeded {
            bail!(
                "job {id} {}: {} ({})",
                job.state.as_str(),
                job.error_message.as_deref().unwrap_or(""),
                job.error_code.as_deref().unwrap_or("")
            );
        }
        let doc = c.job_result(&id).await?;
        super::out::document(args.json, &doc, |doc| {
            format!("job {id}: {}\n", summary(doc, job.result_id.as_deref()))
        })?;
        Ok(ExitCode::SUCCESS)
    })
}

/// One line about an identification result document: its figures with the digits the
/// pages print (`mtcal_views::pages::num`), a figure it does not hold as `—`.
pub fn summary(doc: &serde_json::Value, result_id: Option<&str>) -> String {
    use mtcal_views::pages::num;
    let f = |v: &serde_json::Value| v.as_f64().map_or_else(|| "—".to_string(), num);
    let ec0y = match doc["squareness"]["EC0Y"]["value_urad"].as_f64() {
        Some(v) => {
            let u = doc["squareness"]["EC0Y"]["std_urad"].as_f64();
            mtcal_views::pages::with_u(Some(v), u, "urad")
        }
        None => "not identifiable".to_string(),
    };
    format!(
        "result {} — residual {} µm, rank {}/{} (condition {}), EC0Y {ec0y}",
        result_id.unwrap_or("—"),
        f(&doc["fit"]["residual_rms_um"]),
        doc["observability"]["rank"],
        doc["observability"]["parameters"],
        f(&doc["observability"]["condition_number"]),
    )
}

#[cfg(test)]
mod tests {
    #[test]
    fn the_summary_prints_numbers_with_sensible_digits() {
        let doc = serde_json::json!({
            "fit": {"residual_rms_um": 0.150_123_456},
            "observability": {"rank": 51, "parameters": 51, "condition_number": 214.210_336_959_451_58},
            "squareness": {"EC0Y": {"value_urad": -16.840_123, "std_urad": 0.058_1}},
        });
        assert_eq!(
            super::summary(&doc, Some("r1")),
            "result r1 — residual 0.150 µm, rank 51/51 (condition 214.2), EC0Y -16.84 ± 0.116 µrad"
        );
        let doc = serde_json::json!({"fit": {}, "observability": {"rank": 3, "parameters": 51,
            "condition_number": 1.7e7}, "squareness": {"EC0Y": {"value_urad": null}}});
        assert!(super::summary(&doc, None).contains("condition 1.700e7"));
        assert!(super::summary(&doc, None).contains("EC0Y not identifiable"));
    }
}
