//! Jobs: what a job computes, its life cycle, a job as stored and a job to run.

use serde::{Deserialize, Serialize};
use serde_json::Value;

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
    /// A result stored without a run (the store's `import_result`): born succeeded,
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
}

/// A job to run (its schema, with the feature `openapi`: one per kind, below).
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SubmitJob {
    pub kind: JobKind,
    /// The dataset to run on (required by `identify` (a session), `diagnose` (a session,
    /// positioning runs or a drift log) and `cradle` (a rotary point set)).
    pub dataset_id: Option<String>,
    /// The machine, for kinds without a dataset (required by `sensitivity`; the result
    /// is filed under it).
    pub machine_id: Option<String>,
    /// Kind-specific parameters; for `identify` see `IdentifyParams`, for `diagnose`
    /// `DiagnoseParams`, for `sensitivity` `SensitivityRequest`; none for `cradle` and
    /// `standards`.
    #[serde(default)]
    pub params: serde_json::Value,
}

#[cfg(feature = "openapi")]
impl utoipa::PartialSchema for SubmitJob {
    /// One schema per kind (`oneOf`, told apart by `kind`), stating what
    /// the server's `submit_job` requires of each: a dataset for the kinds that run on one
    /// (`identify`, `diagnose`, `cradle`, `standards`), a machine and no dataset for
    /// `sensitivity`, and the kind's parameters (none for `cradle` and `standards`).
    fn schema() -> utoipa::openapi::RefOr<utoipa::openapi::schema::Schema> {
        use serde_json::json;
        let schema = |name: &str| json!({"$ref": format!("#/components/schemas/{name}")});
        let on_dataset = |kinds: &[&str], params: serde_json::Value| {
            json!({
                "type": "object",
                "title": kinds.join(", "),
                "required": ["kind", "dataset_id"],
                "properties": {
                    "kind": {"type": "string", "enum": kinds},
                    "dataset_id": {"type": "string", "description": "The dataset to run on."},
                    "machine_id": {
                        "type": ["string", "null"],
                        "description": "Not used: the job is filed under the dataset's machine."
                    },
                    "params": {"oneOf": [params, {"type": "null"}]},
                },
                "additionalProperties": false,
            })
        };
        let none = json!({"type": "object", "maxProperties": 0,
                          "description": "No parameters (`{}`)."});
        let doc = json!({
            "description": "A job to run: its kind, the dataset it runs on (`identify`: a \
                            session; `diagnose`: a session, positioning runs or a drift log; \
                            `cradle`: a rotary point set; `standards`: a session or \
                            positioning runs) or, for `sensitivity`, the machine its result \
                            is filed under, and the kind's parameters.",
            "oneOf": [
                on_dataset(&["identify"], schema("IdentifyParams")),
                on_dataset(&["diagnose"], schema("DiagnoseParams")),
                on_dataset(&["cradle", "standards"], none),
                {
                    "type": "object",
                    "title": "sensitivity",
                    "required": ["kind", "machine_id", "params"],
                    "properties": {
                        "kind": {"type": "string", "enum": ["sensitivity"]},
                        "machine_id": {"type": "string", "description": "The machine the result is filed under."},
                        "dataset_id": {"type": "null", "description": "None: a sensitivity analysis runs on parameters."},
                        "params": schema("SensitivityRequest"),
                    },
                    "additionalProperties": false,
                },
            ],
        });
        serde_json::from_value(doc).expect("the job schema reads as a schema")
    }
}

#[cfg(feature = "openapi")]
impl utoipa::ToSchema for SubmitJob {
    fn schemas(
        schemas: &mut Vec<(
            String,
            utoipa::openapi::RefOr<utoipa::openapi::schema::Schema>,
        )>,
    ) {
        use mtcal_solver::sensitivity::SensitivityRequest;
        use utoipa::PartialSchema as _;
        schemas.push((
            SensitivityRequest::name().into_owned(),
            SensitivityRequest::schema(),
        ));
        SensitivityRequest::schemas(schemas);
    }
}
