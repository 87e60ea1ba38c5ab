//! `mtcal serve`: the HTTP API (and its worker unless `--no-worker`); `mtcal worker`:
//! only the worker, for API and worker processes on several hosts sharing a database.

use anyhow::Context;
use mtcal_server::{ServeConfig, UploadLimits, WorkerConfig};
use mtcal_store::QueueConfig;
use std::net::SocketAddr;
use std::process::ExitCode;

/// What a worker process runs with (shared by `mtcal serve` and `mtcal worker`).
#[derive(clap::Args)]
pub struct WorkerArgs {
    /// Database: a SQLite file path or `sqlite://PATH` (created if missing; one host), or
    /// `postgres://user@host/db` (any number of API and worker processes on any hosts).
    #[arg(long, env = "MTCAL_DB", default_value = "mtcal.sqlite")]
    pub db: String,
    /// Database connections of this process (default 10 on PostgreSQL, 8 on SQLite).
    /// Every process sharing a PostgreSQL server counts: keep their sum below its
    /// `max_connections` less a few for administration (docs/operations.md, "Operations").
    #[arg(long, env = "MTCAL_DB_POOL", value_parser = clap::value_parser!(u32).range(1..=500))]
    pub db_pool: Option<u32>,
    /// Longest wait for a database connection, ms: past it a request answers 503 with
    /// Retry-After instead of waiting (a database outage fails fast).
    #[arg(long, env = "MTCAL_DB_TIMEOUT_MS", default_value_t = 3000,
          value_parser = clap::value_parser!(u64).range(100..=60_000))]
    pub db_timeout_ms: u64,
    /// Hosts, addresses and networks drift alert webhooks may reach although they are
    /// not public (loopback, private, link-local, …), comma-separated:
    /// `hooks.plant.local,10.20.0.0/16` (docs/api.md, "Webhooks").
    #[arg(long, env = "MTCAL_WEBHOOK_ALLOW", default_value = "",
          value_parser = mtcal_server::WebhookPolicy::with_allow_list)]
    pub webhook_allow: mtcal_server::WebhookPolicy,
    /// The token a scraper of `/metrics` sends (`Authorization: Bearer …`) instead of an
    /// admin key of the whole group; without it, admin keys only (docs/api.md).
    #[arg(long, env = "MTCAL_METRICS_TOKEN", hide_env_values = true)]
    pub metrics_token: Option<String>,
    /// Jobs run at the same time.
    #[arg(long, default_value_t = 2)]
    pub concurrency: usize,
    /// Lease of a running job, ms (a job whose worker died runs again after it).
    #[arg(long, default_value_t = 30_000)]
    pub lease_ms: i64,
    /// Attempts per job (transient failures retry with exponential backoff).
    #[arg(long, default_value_t = 3)]
    pub max_attempts: i64,
    /// Largest upload, bytes (default 256 MiB).
    #[arg(long, default_value_t = 256 << 20)]
    pub max_upload_bytes: usize,
    /// Testing aid: pause each job this long before solving.
    #[arg(long, default_value_t = 0, hide = true)]
    pub pause_before_solve_ms: u64,
    /// Testing aid: the wait after a webhook delivery's first failed try, ms (default
    /// that of `mtcal_domain::webhooks::Retries`, 10 s).
    #[arg(long, hide = true)]
    pub webhook_retry_ms: Option<u64>,
    /// Longest run of one job, seconds: a job still running then fails (code `timeout`).
    #[arg(long, env = "MTCAL_JOB_TIMEOUT_SECONDS", default_value_t = 3600)]
    pub job_timeout_seconds: u64,
    /// On SIGTERM or Ctrl-C: seconds a running job may take to finish before it is
    /// handed back to the queue (another worker claims it at once).
    #[arg(long, env = "MTCAL_GRACE_SECONDS", default_value_t = 20)]
    pub grace_seconds: u64,
    /// Log format on stderr: `text` (for people) or `json` (one object per line, for
    /// log collectors).
    #[arg(long, env = "MTCAL_LOG_FORMAT", value_enum, default_value_t = LogFormat::Text)]
    pub log_format: LogFormat,
}

/// Log format of `--log-format`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum LogFormat {
    Text,
    Json,
}

impl WorkerArgs {
    /// The database connections of this process.
    pub fn store_options(&self) -> mtcal_store::StoreOptions {
        mtcal_store::StoreOptions {
            pool_size: self.db_pool,
            acquire_timeout: std::time::Duration::from_millis(self.db_timeout_ms),
        }
    }

    /// The database URL fit to print (no password).
    pub fn db_shown(&self) -> String {
        mtcal_store::redacted(&self.db)
    }

    pub fn config(&self) -> WorkerConfig {
        WorkerConfig {
            queue: QueueConfig {
                concurrency: self.concurrency.max(1),
                lease_ms: self.lease_ms.max(100),
                max_attempts: self.max_attempts.max(1),
                ..QueueConfig::default()
            },
            limits: UploadLimits {
                max_bytes: self.max_upload_bytes,
                ..UploadLimits::default()
            },
            pause_before_solve_ms: self.pause_before_solve_ms,
            grace: std::time::Duration::from_secs(self.grace_seconds.min(3600)),
            max_run: std::time::Duration::from_secs(self.job_timeout_seconds.clamp(1, 7 * 86_400)),
            settings: mtcal_server::Settings {
                webhooks: self.webhook_allow.clone(),
                webhook_retries: match self.webhook_retry_ms {
                    Some(ms) => mtcal_domain::webhooks::Retries {
                        first: std::time::Duration::from_millis(ms.clamp(1, 3_600_000)),
                        ..Default::default()
                    },
                    None => Default::default(),
                },
                metrics_token: self.metrics_token.clone().filter(|t| !t.trim().is_empty()),
                ..mtcal_server::Settings::default()
            },
            ..WorkerConfig::default()
        }
    }
}

#[derive(clap::Args)]
pub struct Args {
    #[command(flatten)]
    pub worker: WorkerArgs,
    /// Address to listen on (port 0 picks a free port; the address is printed).
    #[arg(long, env = "MTCAL_LISTEN", default_value = "127.0.0.1:8080")]
    pub listen: SocketAddr,
    /// Serve the API only; run no worker (workers run as `mtcal worker` elsewhere).
    #[arg(long)]
    pub no_worker: bool,
    /// Mark the sign-in cookies `Secure` on every answer (they are anyway when a
    /// TLS-terminating proxy sends `X-Forwarded-Proto: https`).
    #[arg(long, env = "MTCAL_COOKIE_SECURE")]
    pub cookie_secure: bool,
    /// Slowest average rate of an upload's body once its grace period is over, bytes per
    /// second (0: none); a slower upload is answered 408 and its slot freed.
    #[arg(long, env = "MTCAL_MIN_UPLOAD_RATE", default_value_t = mtcal_server::Settings::MIN_UPLOAD_RATE)]
    pub min_upload_rate: u64,
    /// Seconds an upload has before the minimum rate applies.
    #[arg(long, env = "MTCAL_UPLOAD_GRACE_SECONDS", default_value_t = 10,
          value_parser = clap::value_parser!(u64).range(1..=3600))]
    pub upload_grace_seconds: u64,
    /// Longest an upload may hold a reading slot, seconds (reading, checking, storing);
    /// past it the upload is answered 408 and its slot freed.
    #[arg(long, env = "MTCAL_UPLOAD_SLOT_SECONDS", default_value_t = 120,
          value_parser = clap::value_parser!(u64).range(1..=3600))]
    pub upload_slot_seconds: u64,
    /// Seconds a client has to send a request's head (slow clients are disconnected).
    #[arg(long, env = "MTCAL_HEADER_TIMEOUT_SECONDS", default_value_t = 10)]
    pub header_timeout_seconds: u64,
}

impl Args {
    pub fn config(&self) -> ServeConfig {
        ServeConfig {
            db_url: self.worker.db.clone(),
            store: self.worker.store_options(),
            listen: self.listen,
            run_worker: !self.no_worker,
            header_timeout: std::time::Duration::from_secs(
                self.header_timeout_seconds.clamp(1, 600),
            ),
            worker: WorkerConfig {
                settings: mtcal_server::Settings {
                    cookie_secure: self.cookie_secure,
                    min_upload_rate: self.min_upload_rate,
                    upload_grace: std::time::Duration::from_secs(self.upload_grace_seconds),
                    upload_slot_time: std::time::Duration::from_secs(self.upload_slot_seconds),
                    ..self.worker.config().settings
                },
                ..self.worker.config()
            },
        }
    }
}

/// Logging to stderr, `RUST_LOG` to tune (default: info for mtcal crates); `json`
/// writes one JSON object per event (time, level, target, fields).
pub fn init_logging(format: LogFormat) {
    init_logging_with(format, "warn,mtcal_server=info,mtcal_store=info");
}

/// [`init_logging`] with another default filter (`RUST_LOG` still wins). Colours only
/// when stderr is a terminal: a log written to a file holds no escape codes.
pub fn init_logging_with(format: LogFormat, default_filter: &str) {
    use std::io::IsTerminal;
    let filter = tracing_subscriber::EnvFilter::try_from_default_env()
        .unwrap_or_else(|_| default_filter.into());
    let builder = tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_ansi(std::io::stderr().is_terminal())
        .with_writer(std::io::stderr);
    let _ = match format {
        LogFormat::Text => builder.try_init(),
        LogFormat::Json => builder.json().try_init(),
    };
}

pub fn run(args: Args) -> anyhow::Result<ExitCode> {
    init_logging(args.worker.log_format);
    let cfg = args.config();
    let rt = tokio::runtime::Runtime::new()?;
    rt.block_on(mtcal_server::serve(
        cfg,
        |addr| {
            super::out::announce(&format!(
                "mtcal: listening on http://{addr} (docs: http://{addr}/docs)"
            ));
        },
        mtcal_server::shutdown_signal(),
    ))
    .with_context(|| format!("serving {}", args.worker.db_shown()))?;
    Ok(ExitCode::SUCCESS)
}

#[derive(clap::Args)]
pub struct WorkerCmd {
    #[command(flatten)]
    pub worker: WorkerArgs,
    /// Also serve `/health`, `/ready` and `/metrics` (Prometheus) on this address, for a
    /// worker process that has no API.
    #[arg(long, env = "MTCAL_METRICS_LISTEN")]
    pub metrics_listen: Option<SocketAddr>,
}

/// `mtcal worker`: claims and runs jobs of the database until SIGTERM or Ctrl-C; then
/// it stops claiming, lets running jobs finish within `--grace-seconds` and hands the
/// others back to the queue, where another worker claims them at once.
pub fn run_worker(cmd: WorkerCmd) -> anyhow::Result<ExitCode> {
    let args = cmd.worker;
    init_logging(args.log_format);
    let rt = tokio::runtime::Runtime::new()?;
    rt.block_on(async {
        let (store, workers) =
            mtcal_server::run_workers(&args.db, args.store_options(), args.config()).await?;
        let (stop_probes, probes_stopped) = tokio::sync::oneshot::channel::<()>();
        let probes = match cmd.metrics_listen {
            Some(addr) => {
                let listener = tokio::net::TcpListener::bind(addr)
                    .await
                    .with_context(|| format!("--metrics-listen {addr}"))?;
                super::out::announce(&format!(
                    "mtcal: metrics on http://{}/metrics",
                    listener.local_addr()?
                ));
                Some(tokio::spawn(mtcal_server::serve_probes(
                    store,
                    args.config().settings,
                    listener,
                    async move {
                        let _ = probes_stopped.await;
                    },
                )))
            }
            None => None,
        };
        super::out::announce(&format!(
            "mtcal: {} worker(s) on {}",
            workers.len(),
            args.db_shown()
        ));
        mtcal_server::shutdown_signal().await;
        tracing::info!("stopping: finishing or handing back running jobs");
        workers.shutdown().await;
        let _ = stop_probes.send(());
        if let Some(p) = probes {
            let _ = p.await;
        }
        anyhow::Ok(())
    })
    .with_context(|| format!("working on {}", args.db_shown()))?;
    Ok(ExitCode::SUCCESS)
}
