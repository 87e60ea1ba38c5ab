//! Plain records the store reads and writes. Times are RFC 3339 UTC strings.

use serde::{Deserialize, Serialize};
use serde_json::Value;
use std::collections::BTreeMap;

pub use crate::limits::MAX_TRAVEL_MM;

/// A registered machine tool.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct Machine {
    pub id: String,
    pub name: String,
    /// `{"workpiece": ["X", "Y"], "tool": ["Z"]}` (kinematics contract).
    #[cfg_attr(feature = "openapi", schema(value_type = Object))]
    pub topology: Value,
    /// Travel range per axis, mm: `{"X": [-250, 250], ...}`.
    pub travel_mm: BTreeMap<String, [f64; 2]>,
    pub site: Option<String>,
    pub tags: Vec<String>,
    /// Result that drift is measured from; `None` means the machine's first result.
    pub baseline_result_id: Option<String>,
    pub created_at: String,
    pub updated_at: String,
}

/// Fields of a machine that an update may change (`None`: keep).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct MachinePatch {
    /// Not blank, at most 200 characters, no control character.
    #[cfg_attr(feature = "openapi", schema(schema_with = crate::schemas::name_or_null))]
    pub name: Option<String>,
    #[cfg_attr(feature = "openapi", schema(schema_with = crate::schemas::topology))]
    pub topology: Option<Value>,
    #[cfg_attr(feature = "openapi", schema(schema_with = crate::schemas::travel_or_null))]
    pub travel_mm: Option<BTreeMap<String, [f64; 2]>>,
    /// Not blank, at most 100 characters, no control character.
    #[cfg_attr(feature = "openapi", schema(schema_with = crate::schemas::site_or_null))]
    pub site: Option<String>,
    #[cfg_attr(feature = "openapi", schema(schema_with = crate::schemas::tags_or_null))]
    pub tags: Option<Vec<String>>,
    pub baseline_result_id: Option<String>,
}

/// One stored file of a dataset, as uploaded.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct FileMeta {
    pub name: String,
    pub sha256: String,
    pub size: i64,
}

/// A dataset's metadata (the bytes are read with [`crate::Datasets::dataset_file`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct Dataset {
    pub id: String,
    pub machine_id: String,
    /// `session`, `rotary_points`, `positioning` or `drift_log` (datasets contract).
    pub kind: String,
    pub measured_at: String,
    pub uploaded_at: String,
    pub samples: i64,
    pub total_bytes: i64,
    /// SHA-256 over the sorted list of `name:sha256` lines of its files.
    pub sha256: String,
    pub files: Vec<FileMeta>,
    /// Set when the dataset was excluded ([`Exclusion`]): no new job runs on it, default
    /// listings leave it out, and the results computed from it are excluded with this
    /// same record.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub excluded: Option<Exclusion>,
    /// Set when the dataset's raw bytes were deleted (who, when, why: the same record
    /// shape as an exclusion). The files' names, sizes and checksums stay; their bytes are
    /// gone. A deleted dataset is always excluded too.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub deleted: Option<Exclusion>,
}

/// A dataset to insert: metadata plus every file's bytes.
#[derive(Debug, Clone)]
pub struct NewDataset {
    pub machine_id: String,
    pub kind: String,
    pub measured_at: String,
    pub samples: i64,
    pub files: Vec<(String, Vec<u8>)>,
}

/// Life cycle of a job.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
#[serde(rename_all = "lowercase")]
pub enum JobState {
    Queued,
    Running,
    Succeeded,
    Failed,
    Cancelled,
}

impl JobState {
    pub fn as_str(self) -> &'static str {
        match self {
            JobState::Queued => "queued",
            JobState::Running => "running",
            JobState::Succeeded => "succeeded",
            JobState::Failed => "failed",
            JobState::Cancelled => "cancelled",
        }
    }

    pub fn parse(s: &str) -> Option<JobState> {
        Some(match s {
            "queued" => JobState::Queued,
            "running" => JobState::Running,
            "succeeded" => JobState::Succeeded,
            "failed" => JobState::Failed,
            "cancelled" => JobState::Cancelled,
            _ => return None,
        })
    }

    pub fn is_terminal(self) -> bool {
        matches!(
            self,
            JobState::Succeeded | JobState::Failed | JobState::Cancelled
        )
    }
}

/// A job as stored.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct Job {
    pub id: String,
    pub kind: JobKind,
    pub machine_id: Option<String>,
    pub dataset_id: Option<String>,
    #[cfg_attr(feature = "openapi", schema(value_type = Object))]
    pub params: Value,
    pub state: JobState,
    /// 0 … 1.
    pub progress: f64,
    pub progress_message: Option<String>,
    pub attempts: i64,
    pub max_attempts: i64,
    pub error_code: Option<String>,
    pub error_message: Option<String>,
    pub result_id: Option<String>,
    pub created_at: String,
    pub started_at: Option<String>,
    pub finished_at: Option<String>,
}

/// A job to enqueue.
#[derive(Debug, Clone)]
pub struct NewJob {
    pub kind: JobKind,
    pub machine_id: Option<String>,
    pub dataset_id: Option<String>,
    pub params: Value,
    pub max_attempts: i64,
}

/// Scalar figures of a result kept in their own columns for trend queries.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct ResultScalars {
    /// Residual, conditioning, rank and squareness (their own JSON fields).
    #[serde(flatten)]
    pub summary: ResultSummary,
    /// Monomial coefficients of the identifiable terms (element i ↔ q^(i+1)).
    pub term_coefficients: BTreeMap<String, Vec<f64>>,
    /// Travel each axis measured, [min, max] mm, by axis letter: the terms are determined
    /// there only. Empty when unknown (results stored before it was recorded).
    #[serde(default)]
    pub measured_travel_mm: BTreeMap<String, [f64; 2]>,
    /// Covariance of each identifiable term's coefficients (n × n, same order), and the
    /// variance of each squareness value as a 1 × 1 matrix under its name.
    #[serde(default)]
    pub term_covariance: BTreeMap<String, Vec<Vec<f64>>>,
}

/// The summary figures of an identification, each in its own column (absent for other
/// kinds of result): what the summary trend shows over a machine's checks.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct ResultSummary {
    /// RMS of the fit's residual, µm.
    pub residual_rms_um: Option<f64>,
    /// Condition number and rank of the identification (its observability's).
    pub condition_number: Option<f64>,
    pub rank: Option<i64>,
    /// Squareness error EC0Y, µrad.
    pub ec0y_urad: Option<f64>,
    /// Squareness error EB0Z, µrad.
    pub eb0z_urad: Option<f64>,
    /// Squareness error EA0Z, µrad.
    pub ea0z_urad: Option<f64>,
}

impl ResultSummary {
    /// The stored value of squareness `name` (`EC0Y`, `EB0Z`, `EA0Z`; `None` inside where
    /// the result has none); `None` when `name` is not one of them.
    pub fn squareness(&self, name: &str) -> Option<Option<f64>> {
        match name {
            "EC0Y" => Some(self.ec0y_urad),
            "EB0Z" => Some(self.eb0z_urad),
            "EA0Z" => Some(self.ea0z_urad),
            _ => None,
        }
    }
}

/// One named scalar figure of a result (the standards' figures, e.g. `iso230_2.X.E_um`,
/// `iso230_4.XY.bi.H_um`): stored in its own table so that it trends and takes
/// tolerances. Names: letters, digits, `_` and `.`, at most [`FIGURE_NAME_MAX`] bytes.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct Figure {
    pub name: String,
    /// Value in the unit its name ends with (`_um`: µm).
    pub value: f64,
    /// Standard uncertainty (k = 1), when known.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub u: Option<f64>,
}

/// Longest figure name accepted, bytes.
pub const FIGURE_NAME_MAX: usize = 128;

/// One result's value of a figure, for a trend.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct FigurePoint {
    pub result_id: String,
    pub measured_at: String,
    pub value: f64,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub u: Option<f64>,
}

/// A result to store on completion of a job.
#[derive(Debug, Clone)]
pub struct NewResult {
    pub machine_id: String,
    pub dataset_id: Option<String>,
    pub kind: String,
    pub measured_at: String,
    pub document: Value,
    pub scalars: ResultScalars,
    /// Named scalar figures ([`Figure`]); empty for kinds that have none.
    pub figures: Vec<Figure>,
}

/// A stored result, without its document.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct ResultMeta {
    pub id: String,
    pub job_id: String,
    pub machine_id: String,
    pub dataset_id: Option<String>,
    pub kind: String,
    pub measured_at: String,
    pub created_at: String,
    pub scalars: ResultScalars,
    /// Set when the result was excluded from the history (see [`Exclusion`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub excluded: Option<Exclusion>,
}

/// Who sets a record aside and why, as asked of the store (an exclusion of a result or a
/// dataset, the deletion of a dataset's bytes); checked by [`crate::text::check_record`].
/// The store adds the time and keeps it as an [`Exclusion`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SetAside<'a> {
    /// The API key (or the operator) that does it.
    pub by: &'a str,
    pub reason: &'a str,
}

/// Why and by whom a record was set aside: a result excluded from the history (it stays
/// stored and readable by id, but no list, trend, difference, drift or figure trend uses
/// it), a dataset excluded (its results with it, same record) or a dataset's bytes
/// deleted.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct Exclusion {
    /// RFC 3339.
    pub at: String,
    /// The API key (or the operator) that did it.
    pub by: String,
    pub reason: String,
}

/// A stored result with its document.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct StoredResult {
    pub meta: ResultMeta,
    #[cfg_attr(feature = "openapi", schema(value_type = Object))]
    pub document: Value,
}

/// For the fleet ranking: each machine's baseline and latest identification scalars.
#[derive(Debug, Clone, PartialEq)]
pub struct BaselinePair {
    pub machine: Machine,
    pub baseline: ResultMeta,
    pub latest: ResultMeta,
    pub results: i64,
}

/// A machine's drift since its baseline as the fleet ranking stores it (computed by the
/// service when a result lands or the baseline changes).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FleetDriftRow {
    pub machine_id: String,
    /// When the results it was computed from were read (ms since the epoch): a row from
    /// an older read never replaces a newer one.
    pub read_at_ms: i64,
    pub drift_um: f64,
    pub drift_urad: f64,
    /// The ranking's entry for the machine (ids, result count, drift, uncertainty).
    pub entry: serde_json::Value,
    /// When the latest result was measured (the fleet page sorts by it).
    #[serde(default)]
    pub latest_measured_at: Option<String>,
    /// What the row was computed from, as the service names it (None: written by an
    /// older version); a refresh skips the rows whose basis is still current.
    #[serde(default)]
    pub basis: Option<String>,
}

/// The orders of the fleet page.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FleetSort {
    /// Largest drift in µm first.
    DriftUm,
    /// Largest drift in µrad first.
    DriftUrad,
    /// By machine id.
    Name,
    /// Most recent check first.
    LastCheck,
}

/// One page of the fleet: machines filtered by site and tag, those with active alerts
/// first, then in `sort` order.
#[derive(Debug, Clone, PartialEq)]
pub struct FleetPageQuery {
    pub site: Option<String>,
    pub tag: Option<String>,
    pub sort: FleetSort,
    pub offset: i64,
    pub limit: i64,
}

/// A stored result named by id, kind and time.
// A machine's last check: the one struct the store reads, the fleet routes answer and
// the fleet page is given (converted to the view's own type in crates/server/src/web).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct LastCheck {
    pub result_id: String,
    /// `identification`, `diagnosis`, `cradle` or `sensitivity`.
    pub kind: String,
    pub measured_at: String,
}

/// A machine on the fleet page: its drift row (None before its first identification)
/// and how many active alerts it has.
#[derive(Debug, Clone, PartialEq)]
pub struct FleetPageRow {
    pub machine: Machine,
    pub drift: Option<FleetDriftRow>,
    pub active_alerts: i64,
    /// For a machine without a drift row (no identification): its latest result of any
    /// other kind that is not excluded (None: it has no result, or it has a drift row,
    /// whose entry names its latest identification).
    pub other_check: Option<LastCheck>,
}

/// A fleet page and how many machines match the filter in all.
#[derive(Debug, Clone, PartialEq)]
pub struct FleetPage {
    pub rows: Vec<FleetPageRow>,
    pub total: i64,
    /// Every site and every tag of the fleet, sorted (the filters' choices).
    pub sites: Vec<String>,
    pub tags: Vec<String>,
}

/// A tolerance profile as stored: the limits a machine's results are judged against,
/// for one machine (`scope` `machine`, `target` its id) or for every machine with a tag
/// (`scope` `tag`, `target` the tag). `limits` is the JSON of the solver's
/// `tolerance::Limits` (the service validates it); `webhook_url` (tag profiles) receives
/// the drift alerts of the tag's machines, signed with `webhook_secret`.
#[derive(Clone, PartialEq, Serialize, Deserialize)]
pub struct ToleranceProfile {
    pub id: String,
    pub scope: String,
    pub target: String,
    pub limits: Value,
    pub webhook_url: Option<String>,
    /// The key of the webhook's signatures: never shown, serialised or printed.
    #[serde(skip_serializing, default)]
    pub webhook_secret: Option<String>,
    pub created_at: String,
    pub updated_at: String,
}

impl std::fmt::Debug for ToleranceProfile {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ToleranceProfile")
            .field("id", &self.id)
            .field("scope", &self.scope)
            .field("target", &self.target)
            .field("limits", &self.limits)
            .field("webhook_url", &self.webhook_url)
            .field(
                "webhook_secret",
                &self.webhook_secret.as_ref().map(|_| "(set)"),
            )
            .field("created_at", &self.created_at)
            .field("updated_at", &self.updated_at)
            .finish()
    }
}

/// What raised a drift alert: the landed result `result_id` of `machine_id` changed since
/// `baseline_result_id` beyond the drift threshold of `profile_id`, at `raised_at`. Held
/// by the stored alert ([`Alert`]) and by the alert the API shows, alike.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct AlertRaised {
    pub id: String,
    pub machine_id: String,
    /// The landed result whose change raised it.
    pub result_id: String,
    /// The baseline the change is measured from.
    pub baseline_result_id: String,
    /// The tolerance profile whose drift threshold was exceeded.
    pub profile_id: String,
    /// RFC 3339.
    pub raised_at: String,
    /// One line saying what changed, by how much, against which threshold.
    pub message: String,
}

/// A drift alert as stored: raised when `result_id` landed with a change since
/// `baseline_result_id` beyond the drift threshold of `profile_id` by more than the
/// expanded uncertainty. `items` is the JSON of the alerting verdict items. Active until
/// acknowledged.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Alert {
    #[serde(flatten)]
    pub raised: AlertRaised,
    pub items: Value,
    /// What each change is the difference of, with the dates (JSON; `None` for alerts
    /// raised by an older version).
    #[serde(default)]
    pub details: Option<Value>,
    pub acknowledged_at: Option<String>,
    /// The key that acknowledged it (`key <id> (<label>)`).
    pub acknowledged_by: Option<String>,
    /// What the person who acknowledged it wrote (why, what was done).
    #[serde(default)]
    pub acknowledgement_comment: Option<String>,
}

/// The states of a webhook delivery of the outbox: `pending` (to be tried, at
/// `next_attempt_ms` of the database's clock), `delivered` (a try was answered 2xx),
/// `failed` (its tries are used up, or its target was refused).
pub const DELIVERY_STATES: [&str; 3] = ["pending", "delivered", "failed"];

/// A webhook delivery of the outbox: alert `alert_id` POSTed to the webhook of profile
/// `profile_id` at `url`, `body` the exact bytes sent (and signed). Written with its
/// alert, in the same transaction; tried by the workers.
#[derive(Clone, PartialEq, Eq)]
pub struct WebhookDelivery {
    pub id: String,
    pub alert_id: String,
    pub profile_id: String,
    pub url: String,
    pub body: String,
    /// One of [`DELIVERY_STATES`].
    pub state: String,
    /// Tries made (a claimed try counts).
    pub attempts: i64,
    /// When it is tried next, or was last claimed (database clock, ms since the epoch).
    pub next_attempt_ms: i64,
    /// Why the last try failed.
    pub last_error: Option<String>,
    pub created_at: String,
    pub updated_at: String,
}

impl std::fmt::Debug for WebhookDelivery {
    /// Without the URL (its query may hold a token) or the body.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("WebhookDelivery")
            .field("id", &self.id)
            .field("alert_id", &self.alert_id)
            .field("profile_id", &self.profile_id)
            .field("state", &self.state)
            .field("attempts", &self.attempts)
            .field("next_attempt_ms", &self.next_attempt_ms)
            .field("last_error", &self.last_error)
            .finish_non_exhaustive()
    }
}

/// What became of a claimed try of a webhook delivery.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum DeliveryOutcome {
    Delivered,
    /// Try again `after_ms` from now (database clock).
    Retry {
        after_ms: i64,
        error: String,
    },
    /// No more tries.
    Failed {
        error: String,
    },
}

/// A stored row a list left out because it does not decode, and why: the rest of the
/// list is served (one bad row must not fail every reader of a machine's history).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct SkippedRow {
    /// The row's id (a result id), or `?` when even that does not read.
    pub id: String,
    pub reason: String,
}

impl SkippedRow {
    /// The warning sentence readers return with the rows they served.
    pub fn warning(&self) -> String {
        format!(
            "result {} skipped: its stored row does not decode ({})",
            self.id, self.reason
        )
    }
}

/// A new sign-in session: its token (for the cookie; shown once, stored as its SHA-256)
/// and the CSRF token of its forms.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct NewSession {
    pub token: String,
    pub csrf: String,
}

/// A live sign-in session: its key (not revoked) and its forms' CSRF token.
#[derive(Debug, Clone, PartialEq)]
pub struct SessionRecord {
    pub key: crate::ApiKey,
    pub csrf: String,
}

/// Row counts of every table (for tests and the admin view).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct RowCounts {
    pub machines: i64,
    pub datasets: i64,
    pub dataset_files: i64,
    pub jobs: i64,
    pub results: i64,
    pub result_figures: i64,
    pub api_keys: i64,
}

/// What a job computes. `import` marks a result stored without a run; it cannot be
/// submitted.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
#[serde(rename_all = "lowercase")]
pub enum JobKind {
    /// 21-term identification of a session dataset; result kind `identification`.
    Identify,
    /// Error-source ranking (Cheng et al. 2012) from parameters only; result kind
    /// `sensitivity`.
    Sensitivity,
    /// Diagnosis (default options) of a session, positioning-run or drift-log dataset;
    /// result kind `diagnosis`.
    Diagnose,
    /// Cradle (A/C) check of a rotary point set (default options); result kind `cradle`.
    Cradle,
    /// Figures of ISO 230-2 (positioning runs, or the line passes of a session) and ISO
    /// 230-4 (the circles of a session); result kind `standards`.
    Standards,
    /// A result stored without a run ([`crate::Results::import_result`]): born succeeded,
    /// never claimed, never submitted through the API.
    Import,
}

impl JobKind {
    /// Every kind a worker runs (all but [`JobKind::Import`]).
    pub const RUNNABLE: [JobKind; 5] = [
        JobKind::Identify,
        JobKind::Sensitivity,
        JobKind::Diagnose,
        JobKind::Cradle,
        JobKind::Standards,
    ];

    pub fn as_str(self) -> &'static str {
        match self {
            JobKind::Identify => "identify",
            JobKind::Sensitivity => "sensitivity",
            JobKind::Diagnose => "diagnose",
            JobKind::Cradle => "cradle",
            JobKind::Standards => "standards",
            JobKind::Import => "import",
        }
    }

    pub fn parse(s: &str) -> Option<JobKind> {
        match s {
            "identify" => Some(JobKind::Identify),
            "sensitivity" => Some(JobKind::Sensitivity),
            "diagnose" => Some(JobKind::Diagnose),
            "cradle" => Some(JobKind::Cradle),
            "standards" => Some(JobKind::Standards),
            "import" => Some(JobKind::Import),
            _ => None,
        }
    }

    /// The `kind` of the result document it produces (an import keeps the kind it was
    /// given).
    pub fn result_kind(self) -> &'static str {
        match self {
            JobKind::Identify => "identification",
            JobKind::Sensitivity => "sensitivity",
            JobKind::Diagnose => "diagnosis",
            JobKind::Cradle => "cradle",
            JobKind::Standards => "standards",
            JobKind::Import => "import",
        }
    }

    /// Whether it runs on a dataset of this stored kind (`session`, `rotary_points`,
    /// `positioning`, `drift_log`).
    pub fn accepts(self, dataset_kind: &str) -> bool {
        match self {
            JobKind::Identify => dataset_kind == "session",
            JobKind::Diagnose => matches!(dataset_kind, "session" | "positioning" | "drift_log"),
            JobKind::Cradle => dataset_kind == "rotary_points",
            JobKind::Standards => matches!(dataset_kind, "session" | "positioning"),
            JobKind::Sensitivity | JobKind::Import => false,
        }
    }

    /// Whether the kind reads a dataset (else only its parameters).
    pub fn needs_dataset(self) -> bool {
        match self {
            JobKind::Identify | JobKind::Diagnose | JobKind::Cradle | JobKind::Standards => true,
            JobKind::Sensitivity | JobKind::Import => false,
        }
    }

    /// Whether clients may submit it (every kind but [`JobKind::Import`]).
    pub fn is_runnable(self) -> bool {
        self != JobKind::Import
    }

    /// `'identify', 'sensitivity', …`: the runnable kinds as an SQL list (constants only,
    /// never user input), for the claim query of every backend.
    pub fn runnable_sql_list() -> String {
        JobKind::RUNNABLE
            .iter()
            .map(|k| format!("'{}'", k.as_str()))
            .collect::<Vec<_>>()
            .join(", ")
    }
}
