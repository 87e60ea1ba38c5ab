//! Prometheus metrics of one process, served at `GET /metrics` (text exposition format
//! of OpenMetrics: counts and durations only, never a machine id or a secret). The counts
//! are the whole group's (every site's jobs and requests), so the route needs the
//! process's metrics token (`MTCAL_METRICS_TOKEN`, read without the database: the
//! metrics answer during an outage) or an `admin` key of the whole group (docs/sites.md);
//! a key of sites or tags, or a lower role, gets 403, nothing or a wrong token 401. A
//! scraper sends either as `Authorization: Bearer …`.
//!
//! - `mtcal_http_requests_total{method, route, status}` and
//!   `mtcal_http_request_duration_seconds{method, route}`: every request that matched a
//!   route, by the route's template (`/api/v1/machines/{id}`), not the raw URI, so the
//!   label set stays bounded.
//! - `mtcal_jobs{kind, state}`: jobs in the database by kind and state, read from the
//!   store at each scrape (the same from every process sharing the database).
//! - `mtcal_job_duration_seconds{kind, outcome}` (claim to outcome) and
//!   `mtcal_job_queue_wait_seconds{kind}` (submission to claim): recorded by this
//!   process's workers.
//! - `mtcal_uploads_reading`: uploads this process is reading now (each holds one of the
//!   `MAX_CONCURRENT_UPLOADS` slots of `crate::router`; the others wait for one).
//! - `mtcal_database_up` (1 or 0) and `mtcal_database_unavailable_total` (requests
//!   answered 503 because the database could not be reached), kept by the outage guard.

use crate::error::ApiError;
use axum::extract::{MatchedPath, Request, State};
use axum::http::header;
use axum::middleware::Next;
use axum::response::{IntoResponse, Response};
use prometheus_client::encoding::EncodeLabelSet;
use prometheus_client::metrics::counter::Counter;
use prometheus_client::metrics::family::Family;
use prometheus_client::metrics::gauge::Gauge;
use prometheus_client::metrics::histogram::{Histogram, exponential_buckets};
use prometheus_client::registry::Registry;
use std::sync::OnceLock;
use std::time::Instant;

#[derive(Clone, Debug, Hash, PartialEq, Eq, EncodeLabelSet)]
struct RequestLabels {
    method: String,
    route: String,
    status: u16,
}

#[derive(Clone, Debug, Hash, PartialEq, Eq, EncodeLabelSet)]
struct RouteLabels {
    method: String,
    route: String,
}

#[derive(Clone, Debug, Hash, PartialEq, Eq, EncodeLabelSet)]
struct JobLabels {
    kind: String,
    state: String,
}

#[derive(Clone, Debug, Hash, PartialEq, Eq, EncodeLabelSet)]
struct OutcomeLabels {
    kind: String,
    outcome: String,
}

#[derive(Clone, Debug, Hash, PartialEq, Eq, EncodeLabelSet)]
struct KindLabels {
    kind: String,
}

/// The process's metrics and their registry.
pub struct Metrics {
    registry: Registry,
    requests: Family<RequestLabels, Counter>,
    latency: Family<RouteLabels, Histogram>,
    jobs: Family<JobLabels, Gauge>,
    job_duration: Family<OutcomeLabels, Histogram>,
    queue_wait: Family<KindLabels, Histogram>,
    uploads_reading: Gauge,
    database_up: Gauge,
    database_unavailable: Counter,
}

/// The metrics of this process.
pub fn metrics() -> &'static Metrics {
    static METRICS: OnceLock<Metrics> = OnceLock::new();
    METRICS.get_or_init(Metrics::new)
}

impl Metrics {
    fn new() -> Metrics {
        let mut registry = Registry::with_prefix("mtcal");
        let requests = Family::<RequestLabels, Counter>::default();
        // 1 ms … 65 s for requests; 0.1 s … 1.8 h for jobs and queue waits.
        let latency = Family::<RouteLabels, Histogram>::new_with_constructor(|| {
            Histogram::new(exponential_buckets(0.001, 2.0, 17))
        });
        let jobs = Family::<JobLabels, Gauge>::default();
        let job_duration = Family::<OutcomeLabels, Histogram>::new_with_constructor(|| {
            Histogram::new(exponential_buckets(0.1, 2.0, 17))
        });
        let queue_wait = Family::<KindLabels, Histogram>::new_with_constructor(|| {
            Histogram::new(exponential_buckets(0.1, 2.0, 17))
        });
        registry.register(
            "http_requests",
            "HTTP requests by method, route template and status",
            requests.clone(),
        );
        registry.register(
            "http_request_duration_seconds",
            "HTTP request latency by method and route template",
            latency.clone(),
        );
        registry.register(
            "jobs",
            "Jobs in the database by kind and state",
            jobs.clone(),
        );
        registry.register(
            "job_duration_seconds",
            "Job run time, from claim to outcome, by kind and outcome",
            job_duration.clone(),
        );
        registry.register(
            "job_queue_wait_seconds",
            "Time a job waited in the queue, from submission to claim, by kind",
            queue_wait.clone(),
        );
        let uploads_reading = Gauge::default();
        registry.register(
            "uploads_reading",
            "Uploads being read now (each holds one of the process's upload slots)",
            uploads_reading.clone(),
        );
        let database_up = Gauge::default();
        database_up.set(1);
        registry.register(
            "database_up",
            "1 while the database answers, 0 while it cannot be reached (requests get 503)",
            database_up.clone(),
        );
        let database_unavailable = Counter::default();
        registry.register(
            "database_unavailable",
            "Requests answered 503 because the database could not be reached",
            database_unavailable.clone(),
        );
        Metrics {
            database_up,
            database_unavailable,
            registry,
            requests,
            latency,
            jobs,
            job_duration,
            queue_wait,
            uploads_reading,
        }
    }

    /// Records a job's run (claim to `outcome`: succeeded, failed, retry, cancelled,
    /// handed_back, lost).
    pub fn job_finished(&self, kind: &str, outcome: &str, seconds: f64) {
        self.job_duration
            .get_or_create(&OutcomeLabels {
                kind: kind.into(),
                outcome: outcome.into(),
            })
            .observe(seconds);
    }

    /// Records how long a job waited before it was claimed.
    pub fn job_claimed(&self, kind: &str, waited_seconds: f64) {
        self.queue_wait
            .get_or_create(&KindLabels { kind: kind.into() })
            .observe(waited_seconds.max(0.0));
    }

    /// Sets `mtcal_database_up`.
    pub fn set_database_up(&self, up: bool) {
        self.database_up.set(i64::from(up));
    }

    /// Counts a request refused because the database could not be reached.
    pub fn database_unavailable(&self) {
        self.database_unavailable.inc();
    }

    /// Sets the job gauges to `counts` (kinds and states not listed are dropped).
    pub fn set_job_counts(&self, counts: &[mtcal_store::JobCount]) {
        self.jobs.clear();
        for c in counts {
            self.jobs
                .get_or_create(&JobLabels {
                    kind: c.kind.clone(),
                    state: c.state.clone(),
                })
                .set(c.count);
        }
    }

    /// The text exposition of every metric.
    pub fn encode(&self) -> String {
        let mut out = String::new();
        prometheus_client::encoding::text::encode(&mut out, &self.registry)
            .expect("writing to a String cannot fail");
        out
    }
}

/// Middleware (a route layer): counts and times every request by its route template.
pub async fn track(req: Request, next: Next) -> Response {
    let route = req
        .extensions()
        .get::<MatchedPath>()
        .map_or_else(|| "(unmatched)".to_string(), |p| p.as_str().to_string());
    let method = req.method().as_str().to_string();
    let t0 = Instant::now();
    let resp = next.run(req).await;
    let m = metrics();
    m.latency
        .get_or_create(&RouteLabels {
            method: method.clone(),
            route: route.clone(),
        })
        .observe(t0.elapsed().as_secs_f64());
    m.requests
        .get_or_create(&RequestLabels {
            method,
            route,
            status: resp.status().as_u16(),
        })
        .inc();
    resp
}

/// Middleware inside the upload route's concurrency limit: counts the upload as being
/// read ([`Metrics`], `mtcal_uploads_reading`) from the moment it has a slot until its
/// answer, or until it is dropped (a client gone, a time limit).
pub async fn reading_upload(req: Request, next: Next) -> Response {
    struct Reading(&'static Gauge);
    impl Drop for Reading {
        fn drop(&mut self) {
            self.0.dec();
        }
    }
    let gauge = &metrics().uploads_reading;
    gauge.inc();
    let _reading = Reading(gauge);
    next.run(req).await
}

/// `GET /metrics`: the job gauges refreshed from the store, then every metric. When the
/// store does not answer, the gauges keep their last values (the HTTP and job metrics
/// are this process's own and still valid).
pub async fn serve_metrics(
    State(s): State<crate::AppState>,
    headers: header::HeaderMap,
) -> Result<Response, ApiError> {
    may_read(&s, &headers).await?;
    let m = metrics();
    match tokio::time::timeout(std::time::Duration::from_secs(3), s.store.job_counts()).await {
        Ok(Ok(counts)) => {
            m.set_job_counts(&counts);
            s.database.mark_up();
        }
        Ok(Err(mtcal_store::StoreError::Unavailable(_))) | Err(_) => s.database.mark_down(),
        Ok(Err(_)) => {}
    }
    Ok((
        [(
            header::CONTENT_TYPE,
            "application/openmetrics-text; version=1.0.0; charset=utf-8",
        )],
        m.encode(),
    )
        .into_response())
}

/// Whether a request may read `/metrics` (module docs): the metrics token, compared by
/// its SHA-256, else an admin key of the whole group.
async fn may_read(s: &crate::AppState, headers: &header::HeaderMap) -> Result<(), ApiError> {
    let sent = crate::auth::presented(headers);
    if let (Some(token), Some(sent)) = (&s.settings.metrics_token, sent) {
        let hash = mtcal_store::keys::hash_secret;
        if hash(token) == hash(sent) {
            return Ok(());
        }
    }
    let key = crate::auth::key_of(s, headers).await?;
    if !key.scope.allows(mtcal_store::Scope::Admin) || !key.is_group() {
        return Err(ApiError::Forbidden(format!(
            "/metrics counts the whole group's jobs and requests: it needs the metrics token \
             or an admin key of the whole group; key {} has scope {}{}",
            key.prefix,
            key.scope.as_str(),
            if key.is_group() {
                ""
            } else {
                " and is limited to sites or tags"
            }
        )));
    }
    Ok(())
}

/// Seconds between two RFC 3339 times (`None` if either does not parse).
pub fn seconds_between(from: &str, to: &str) -> Option<f64> {
    let parse = |s: &str| {
        time::OffsetDateTime::parse(s, &time::format_description::well_known::Rfc3339).ok()
    };
    Some((parse(to)? - parse(from)?).as_seconds_f64())
}
