//! The worker: claims jobs from the store's queue, runs their solver work in
//! `spawn_blocking`, heartbeats the lease meanwhile, and records the outcome.
//!
//! Outcomes: result stored (exactly once, see `mtcal_store::queue`); bad input → failed
//! without retry; transient trouble or a panic → back to the queue after the backoff,
//! failed once the attempts are spent; cancellation seen at a heartbeat → cancelled
//! (the blocking computation is abandoned, its result discarded).
//!
//! A job that runs longer than [`WorkerConfig::max_run`] fails with code `timeout`.
//!
//! At start, the workers' process stores the explained models a crash left unmade
//! (`crate::explain::catch_up`). Each process with workers also runs one outbox loop: it tries the due webhook
//! deliveries of drift alerts (`mtcal_domain::webhooks::deliver_next`), one at a time,
//! polling as the job loops do.
//!
//! Shutdown ([`Workers::shutdown`], on SIGTERM or Ctrl-C): the workers stop claiming;
//! a running job has the grace period ([`WorkerConfig::grace`]) to finish, after which
//! it is handed back to the queue (`release_job`: queued at once, the attempt not
//! counted), so another worker claims it without waiting for the lease to expire.

use crate::ingest::UploadLimits;
use crate::jobs::{self, JobError, JobInput};
use mtcal_store::{
    Failure, Heartbeat, Job, Lease, NewResult, Progress, QueueConfig, Store, StoreError,
};
use std::sync::Arc;
use std::time::{Duration, Instant};
use tokio::sync::{Notify, watch};

/// Worker settings.
#[derive(Debug, Clone)]
pub struct WorkerConfig {
    pub queue: QueueConfig,
    /// Prefix of the lease owner names (`<id>-<slot>`); unique per process.
    pub worker_id: String,
    pub limits: UploadLimits,
    /// Testing aid: pause this long after loading a job's input, before solving
    /// (heartbeats continue), so that tests can kill a worker mid-job.
    pub pause_before_solve_ms: u64,
    /// How long a running job may take to finish once shutdown is asked for, before it
    /// is handed back to the queue.
    pub grace: Duration,
    /// Longest run of one job (from its claim): a job still running then fails with
    /// code `timeout` and is not retried (heartbeats alone would renew its lease forever).
    pub max_run: Duration,
    /// The service's settings (the API's and the worker's).
    pub settings: crate::state::Settings,
}

impl Default for WorkerConfig {
    fn default() -> Self {
        WorkerConfig {
            queue: QueueConfig::default(),
            worker_id: format!("w{}", &uuid::Uuid::new_v4().simple().to_string()[..8]),
            limits: UploadLimits::default(),
            pause_before_solve_ms: 0,
            grace: Duration::from_secs(20),
            max_run: Duration::from_secs(3600),
            settings: crate::state::Settings::default(),
        }
    }
}

/// The worker loops of one process, and the switch that stops them.
pub struct Workers {
    /// The job loops.
    handles: Vec<tokio::task::JoinHandle<()>>,
    /// The webhook outbox loop.
    outbox: Option<tokio::task::JoinHandle<()>>,
    stop: watch::Sender<bool>,
}

impl Workers {
    /// No workers (an API-only process).
    pub fn none() -> Workers {
        Workers {
            handles: Vec::new(),
            outbox: None,
            stop: watch::channel(false).0,
        }
    }

    pub fn len(&self) -> usize {
        self.handles.len()
    }

    pub fn is_empty(&self) -> bool {
        self.handles.is_empty()
    }

    /// Stops claiming, lets running jobs finish within the grace period, hands the others
    /// back to the queue, and returns when every loop has ended.
    pub async fn shutdown(self) {
        let _ = self.stop.send(true);
        for h in self.handles.into_iter().chain(self.outbox) {
            let _ = h.await;
        }
    }
}

/// Starts `concurrency` worker loops on the current runtime. `wake` is signalled by the
/// API when it enqueues a job, so that an idle worker of this process claims it at once
/// (the poll interval only matters for jobs submitted through another process).
pub fn spawn_workers(store: Arc<dyn Store>, cfg: WorkerConfig, wake: Arc<Notify>) -> Workers {
    let (stop, stopping) = watch::channel(false);
    let handles = (0..cfg.queue.concurrency.max(1))
        .map(|slot| {
            let store = store.clone();
            let cfg = cfg.clone();
            let wake = wake.clone();
            let stopping = stopping.clone();
            tokio::spawn(async move { worker_loop(store, cfg, slot, wake, stopping).await })
        })
        .collect();
    // What a crash between a diagnosis landing and its explained fit left undone.
    let (again, limits) = (store.clone(), cfg.limits);
    tokio::spawn(async move {
        match crate::explain::catch_up(&again, limits).await {
            Ok(made) if !made.is_empty() => {
                tracing::info!(n = made.len(), "explained models stored at start")
            }
            Ok(_) => {}
            Err(e) => tracing::warn!(%e, "explained models not caught up at start"),
        }
    });
    let outbox = Some(tokio::spawn(outbox_loop(store, cfg, stopping)));
    Workers {
        handles,
        outbox,
        stop,
    }
}

/// Tries the due webhook deliveries one after the other, then waits a poll interval;
/// a try under way when shutdown is asked for is finished (it takes at most the
/// webhook time limits).
async fn outbox_loop(store: Arc<dyn Store>, cfg: WorkerConfig, stopping: watch::Receiver<bool>) {
    let (policy, retries) = (&cfg.settings.webhooks, &cfg.settings.webhook_retries);
    let poll = Duration::from_millis(cfg.queue.poll_ms);
    loop {
        if *stopping.borrow() {
            return;
        }
        match mtcal_domain::webhooks::deliver_next(store.as_ref(), policy, retries).await {
            Ok(true) => continue,
            Ok(false) => {}
            Err(e) => tracing::error!(%e, "webhook outbox"),
        }
        tokio::select! {
            _ = tokio::time::sleep(poll) => {}
            _ = stop_requested(stopping.clone()) => {}
        }
    }
}

/// Resolves once shutdown has been asked for (never, if the switch is dropped unset).
async fn stop_requested(mut stopping: watch::Receiver<bool>) {
    if stopping.wait_for(|s| *s).await.is_err() {
        std::future::pending::<()>().await;
    }
}

async fn worker_loop(
    store: Arc<dyn Store>,
    cfg: WorkerConfig,
    slot: usize,
    wake: Arc<Notify>,
    stopping: watch::Receiver<bool>,
) {
    let me = format!("{}-{slot}", cfg.worker_id);
    let reap_every = Duration::from_millis((cfg.queue.lease_ms / 2).max(100) as u64);
    let mut last_reap: Option<Instant> = None;
    loop {
        if *stopping.borrow() {
            return;
        }
        if last_reap.is_none_or(|t| t.elapsed() >= reap_every) {
            match store.reap_expired().await {
                Ok(n) if n > 0 => tracing::warn!(n, "requeued jobs whose lease expired"),
                Ok(_) => {}
                Err(e) => tracing::error!(%e, "reaper"),
            }
            last_reap = Some(Instant::now());
        }
        match store.claim_job(&me, cfg.queue.lease_ms).await {
            Ok(Some(job)) => run_job(&store, &cfg, &me, job, stopping.clone()).await,
            Ok(None) => {
                tokio::select! {
                    _ = wake.notified() => {}
                    _ = tokio::time::sleep(Duration::from_millis(cfg.queue.poll_ms)) => {}
                    _ = stop_requested(stopping.clone()) => {}
                }
            }
            Err(e) => {
                tracing::error!(%e, "claiming a job");
                tokio::time::sleep(Duration::from_millis(cfg.queue.poll_ms * 5)).await;
            }
        }
    }
}

/// Shortest interval between two progress writes of a job.
const PROGRESS_EVERY: Duration = Duration::from_millis(100);

/// Why a job stopped before producing an output.
enum Stop {
    Cancel,
    LeaseLost,
    /// Shutdown, and the grace period is over: hand the job back.
    HandBack,
    /// The job ran longer than [`WorkerConfig::max_run`].
    TimedOut,
}

/// A failure of bad input: never retried.
fn bad_input(message: &str) -> Failure<'_> {
    Failure {
        code: "bad_input",
        message,
        retry_after_ms: None,
    }
}

async fn run_job(
    store: &Arc<dyn Store>,
    cfg: &WorkerConfig,
    me: &str,
    job: Job,
    stopping: watch::Receiver<bool>,
) {
    let lease = cfg.queue.lease_ms;
    let held = Lease::new(&job.id, me);
    let (stop_tx, mut stop_rx) = watch::channel(None::<u8>);
    // The solver's progress (fraction of the job, phase), written with each heartbeat.
    let (progress_tx, progress_rx) = watch::channel((0.2, "solving".to_string()));
    // Heartbeat: extend the lease every third of it, and learn about cancellation; a new
    // phase is written at once, at most every PROGRESS_EVERY.
    let hb = spawn_heartbeat(store, (&job.id, me), lease, progress_rx, stop_tx);
    let work = async {
        let input = load_input(store, cfg, &job).await?;
        if cfg.pause_before_solve_ms > 0 {
            tokio::time::sleep(Duration::from_millis(cfg.pause_before_solve_ms)).await;
        }
        let solving = Progress {
            fraction: 0.2,
            message: "solving",
        };
        let _ = store.heartbeat(held, lease, solving).await;
        let report = move |fraction: f64, phase: &str| {
            // Solving spans 0.2..0.95 of the job (loading before, storing after).
            let _ = progress_tx.send((0.2 + 0.75 * fraction.clamp(0.0, 1.0), phase.to_string()));
        };
        match tokio::task::spawn_blocking(move || {
            let mut report = report;
            jobs::execute_with_progress(&input, &mut report)
        })
        .await
        {
            Ok(out) => out,
            Err(e) => Err(JobError::Transient(format!("worker panicked: {e}"))),
        }
    };
    let kind = job.kind.as_str();
    let claimed = Instant::now();
    if let Some(waited) = job
        .started_at
        .as_deref()
        .and_then(|s| crate::metrics::seconds_between(&job.created_at, s))
    {
        crate::metrics::metrics().job_claimed(kind, waited);
    }
    let grace = cfg.grace;
    let outcome = tokio::select! {
        out = work => Ok(out),
        _ = stop_rx.changed() => Err(match *stop_rx.borrow() {
            Some(0) => Stop::Cancel,
            _ => Stop::LeaseLost,
        }),
        _ = async move {
            stop_requested(stopping).await;
            tokio::time::sleep(grace).await;
        } => Err(Stop::HandBack),
        _ = tokio::time::sleep(cfg.max_run) => Err(Stop::TimedOut),
    };
    hb.abort();
    let recorded = record_outcome(store, cfg, &job, held, outcome).await;
    // Claim to outcome: recorded before what follows a landed result.
    let outcome = match &recorded {
        Ok(j) if j.state == mtcal_store::JobState::Queued => "requeued",
        Ok(j) => j.state.as_str(),
        Err(_) => "lost",
    };
    crate::metrics::metrics().job_finished(kind, outcome, claimed.elapsed().as_secs_f64());
    if let Ok(j) = &recorded {
        result_landed(store, cfg, &job, j).await;
    }
    match recorded {
        Ok(j) => tracing::info!(job = %j.id, state = j.state.as_str(), "job finished"),
        Err(e) => tracing::warn!(job = %job.id, %e, "job outcome not recorded"),
    }
}

/// The heartbeat of a running job: extends the lease every third of it and learns about
/// cancellation (`stop_tx`: 0 cancel requested, 1 lease lost); a new phase of
/// `progress_rx` is written at once, at most every PROGRESS_EVERY.
fn spawn_heartbeat(
    store: &Arc<dyn Store>,
    (id, me): (&str, &str),
    lease: i64,
    mut progress_rx: watch::Receiver<(f64, String)>,
    stop_tx: watch::Sender<Option<u8>>,
) -> tokio::task::JoinHandle<()> {
    let store = store.clone();
    let (id, me) = (id.to_string(), me.to_string());
    tokio::spawn(async move {
        let every = Duration::from_millis((lease / 3).max(50) as u64);
        let mut changed = true;
        loop {
            tokio::select! {
                _ = tokio::time::sleep(every) => {}
                r = progress_rx.changed(), if changed => {
                    changed = r.is_ok();
                    tokio::time::sleep(PROGRESS_EVERY).await;
                }
            }
            let (fraction, message) = progress_rx.borrow_and_update().clone();
            let at = Progress {
                fraction,
                message: &message,
            };
            match store.heartbeat(Lease::new(&id, &me), lease, at).await {
                Ok(Heartbeat::Continue) => {}
                Ok(Heartbeat::CancelRequested) => {
                    let _ = stop_tx.send(Some(0));
                    return;
                }
                Ok(Heartbeat::LeaseLost) => {
                    let _ = stop_tx.send(Some(1));
                    return;
                }
                Err(e) => tracing::warn!(%e, "heartbeat"),
            }
        }
    })
}

/// Records a job's outcome in the store: its result, its failure (retried when
/// transient), its cancellation or its hand-back to the queue.
async fn record_outcome(
    store: &Arc<dyn Store>,
    cfg: &WorkerConfig,
    job: &Job,
    held: Lease<'_>,
    outcome: Result<Result<jobs::JobOutput, JobError>, Stop>,
) -> Result<Job, StoreError> {
    match outcome {
        Ok(Ok(out)) => {
            let kind = job.kind.result_kind();
            let r = NewResult {
                machine_id: job.machine_id.clone().unwrap_or_default(),
                dataset_id: job.dataset_id.clone(),
                kind: kind.to_string(),
                measured_at: out.measured_at,
                check_model: mtcal_domain::trends::landing_check_model(kind, &out.document),
                document: out.document,
                scalars: out.scalars,
                figures: out.figures,
            };
            match store.complete_job(held, r).await {
                Err(StoreError::LeaseLost(_)) => store.finish_cancelled(held).await,
                // A result the store refuses would be refused again: not retried.
                Err(StoreError::Invalid(m)) => store.fail_job(held, bad_input(&m)).await,
                other => other,
            }
        }
        Ok(Err(JobError::BadInput(m))) => store.fail_job(held, bad_input(&m)).await,
        Ok(Err(JobError::Transient(m))) => {
            let retry =
                (job.attempts < job.max_attempts).then(|| cfg.queue.backoff_ms(job.attempts));
            let failure = Failure {
                code: "transient",
                message: &m,
                retry_after_ms: retry,
            };
            store.fail_job(held, failure).await
        }
        Err(Stop::Cancel) => store.finish_cancelled(held).await,
        Err(Stop::LeaseLost) => Err(StoreError::LeaseLost(job.id.clone())),
        // The blocking computation cannot be interrupted: it is abandoned and its result
        // discarded, as on cancellation.
        Err(Stop::TimedOut) => {
            let m = format!(
                "the job ran longer than the limit of {} s and was stopped (the service's \
             --job-timeout-seconds)",
                cfg.max_run.as_secs()
            );
            let failure = Failure {
                code: "timeout",
                message: &m,
                retry_after_ms: None,
            };
            store.fail_job(held, failure).await
        }
        Err(Stop::HandBack) => {
            tracing::warn!(job = %job.id, "shutting down: job handed back to the queue");
            store.release_job(held).await
        }
    }
}

/// What follows a landed result: an identification refreshes the fleet's drift and
/// alerts and, when its model does not explain its recording, queues its dataset's
/// diagnosis; a diagnosis stores the explained model of the check it explains and
/// refreshes the machine's fleet row.
async fn result_landed(store: &Arc<dyn Store>, cfg: &WorkerConfig, job: &Job, j: &Job) {
    if j.state == mtcal_store::JobState::Succeeded
        && job.kind.result_kind() == mtcal_domain::kinds::IDENTIFICATION
        && let Some(m) = &job.machine_id
        && let Some(r) = &j.result_id
        && let Err(e) = mtcal_domain::landing::result_landed(store, m, r).await
    {
        tracing::warn!(machine = %m, %e, "fleet drift or drift alerts not refreshed");
    }
    // A diagnosis that explains a check's misfit: the check's explained model is stored
    // beside it (`crate::explain`); then the machine's fleet row shows its findings.
    if j.state == mtcal_store::JobState::Succeeded
        && job.kind.result_kind() == mtcal_domain::kinds::DIAGNOSIS
        && let Some(r) = &j.result_id
    {
        match crate::explain::diagnosis_landed(store, cfg.limits, r).await {
            Ok(Some(e)) => tracing::info!(diagnosis = %r, result = %e.id, "explained model stored"),
            Ok(None) => {}
            Err(e) => tracing::warn!(diagnosis = %r, %e, "the explained model was not made"),
        }
    }
    if j.state == mtcal_store::JobState::Succeeded
        && job.kind.result_kind() == mtcal_domain::kinds::DIAGNOSIS
        && let Some(m) = &job.machine_id
        && let Err(e) = mtcal_domain::landing::diagnosis_landed(store.as_ref(), m).await
    {
        tracing::warn!(machine = %m, %e, "fleet row not refreshed after the diagnosis");
    }
    // A result whose model does not explain its recording: its dataset's diagnosis is
    // queued (once), so that its findings reach the pages and the report.
    if j.state == mtcal_store::JobState::Succeeded
        && job.kind.result_kind() == mtcal_domain::kinds::IDENTIFICATION
        && let Some(r) = &j.result_id
    {
        match mtcal_domain::landing::queue_diagnosis(store.as_ref(), r, cfg.queue.max_attempts)
            .await
        {
            // This worker claims it next (or another one, at its next poll).
            Ok(Some(d)) => {
                tracing::info!(result = %r, job = %d.id, "model misfit: diagnosis queued")
            }
            Ok(None) => {}
            Err(e) => tracing::warn!(result = %r, %e, "the misfit's diagnosis was not queued"),
        }
    }
}

async fn load_input(
    store: &Arc<dyn Store>,
    cfg: &WorkerConfig,
    job: &Job,
) -> Result<JobInput, JobError> {
    let transient = |e: StoreError| match e {
        StoreError::NotFound(w) => JobError::BadInput(format!("{w} not found")),
        e => JobError::Transient(e.to_string()),
    };
    let machine = match &job.machine_id {
        Some(m) => Some(store.get_machine(m).await.map_err(transient)?),
        None => None,
    };
    let dataset = match &job.dataset_id {
        Some(d) => Some((
            store.get_dataset(d).await.map_err(transient)?,
            store.dataset_files(d).await.map_err(transient)?,
        )),
        None => None,
    };
    Ok(JobInput {
        kind: job.kind,
        params: job.params.clone(),
        machine,
        dataset,
        limits: cfg.limits,
    })
}
