//! Job kinds and what each runs. A kind is one [`JobKind`] variant (in the store's queue)
//! plus one arm in [`execute`] taking its inputs (a dataset, or parameters) to a JSON result document.
//!
//! Wired: `identify` (`mtcal_solver::identification::identify`, a session dataset),
//! `diagnose` (`mtcal_solver::diagnosis::diagnose_session` on a session,
//! `diagnosis::series::{diagnose_positioning, diagnose_drift_log}` on positioning runs or
//! a drift log), `cradle` (`mtcal_solver::cradle::check_cradle`, a rotary point set),
//! `standards` (`mtcal_solver::standards`, a session or positioning runs) and
//! `sensitivity` (`mtcal_solver::sensitivity::analyse`, parameters only).

use crate::ingest::{self, DatasetData, UploadLimits};
use mtcal_solver::axis::Topology;
use mtcal_solver::basis::BasisKind;
use mtcal_solver::cradle::{self, CradleOptions};
use mtcal_solver::diagnosis::series::{self, SeriesOptions};
use mtcal_solver::diagnosis::{self, DiagnoseOptions, DiagnosisResult};
use mtcal_solver::identification::{self, IdentificationResult, IdentifyOptions, Method};
use mtcal_solver::positioning_check::{DiagnosisDocument, check_positioning};
use mtcal_solver::sensitivity::{self, SensitivityRequest};
use mtcal_solver::standards::{self, Standards, StandardsResult};
use mtcal_store::{Dataset, Figure, Machine, ResultScalars, ResultSummary};
use serde::{Deserialize, Serialize};
use serde_json::Value;
use utoipa::ToSchema;

/// What a job computes: the queue's typed kind (`mtcal_store::queue`), re-used here.
pub use mtcal_store::JobKind;

/// Parameters of an `identify` job (all optional; defaults of `mtcal identify`).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct IdentifyParams {
    /// `joint` (default) or `stepwise`.
    pub method: Option<Method>,
    /// `polynomial` (default) or `legendre`.
    pub basis: Option<BasisKind>,
    /// Polynomial order (default 3).
    pub order: Option<usize>,
    /// Reporting grid step, mm (default 5).
    pub grid_step_mm: Option<f64>,
}

impl IdentifyParams {
    /// Solver options; the machine's registered topology fills in for a session without one.
    pub fn options(&self, machine: Option<&Machine>) -> Result<IdentifyOptions, JobError> {
        let d = IdentifyOptions::default();
        let topology = machine_topology(machine)?;
        Ok(IdentifyOptions {
            method: self.method.unwrap_or(d.method),
            basis: self.basis.unwrap_or(d.basis),
            order: self.order.unwrap_or(d.order),
            grid_step_mm: self.grid_step_mm.unwrap_or(d.grid_step_mm),
            topology,
        })
    }
}

/// Parameters of a `diagnose` job (all optional; defaults of `mtcal diagnose`).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct DiagnoseParams {
    /// Drift logs only: fraction of the recording the models are fitted on, from the
    /// start, in [0.2, 0.9] (default 0.6); the rest is held out to judge them.
    #[schema(minimum = 0.2, maximum = 0.9)]
    pub fit_fraction: Option<f64>,
}

impl DiagnoseParams {
    fn parse(params: &Value) -> Result<DiagnoseParams, String> {
        let p: DiagnoseParams =
            serde_json::from_value(params.clone()).map_err(|e| format!("params: {e}"))?;
        if let Some(f) = p.fit_fraction
            && !(0.2..=0.9).contains(&f)
        {
            return Err(format!("params: fit_fraction {f} must lie in [0.2, 0.9]"));
        }
        Ok(p)
    }

    /// Series options for a drift log.
    fn series_options(&self) -> SeriesOptions {
        let d = SeriesOptions::default();
        SeriesOptions {
            train_fraction: self.fit_fraction.unwrap_or(d.train_fraction),
            ..d
        }
    }
}

/// Checks a job's parameters at submission, so bad ones are rejected before queueing.
pub fn validate_params(kind: JobKind, params: &Value) -> Result<(), String> {
    match kind {
        JobKind::Identify => serde_json::from_value::<IdentifyParams>(params.clone())
            .map(|_| ())
            .map_err(|e| format!("params: {e}")),
        JobKind::Sensitivity => serde_json::from_value::<SensitivityRequest>(params.clone())
            .map(|_| ())
            .map_err(|e| format!("params: {e}")),
        JobKind::Diagnose => DiagnoseParams::parse(params).map(|_| ()),
        JobKind::Cradle | JobKind::Standards => match params {
            Value::Object(m) if m.is_empty() => Ok(()),
            _ => Err(format!(
                "params: a {} job takes no parameters (send {{}})",
                kind.as_str()
            )),
        },
        JobKind::Import => Err("import jobs are made by imports, not submitted".into()),
    }
}

/// Why a job did not produce a result.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum JobError {
    /// The input cannot give a result however often it is retried.
    #[error("{0}")]
    BadInput(String),
    /// Worth retrying (storage busy, worker panicked, …).
    #[error("{0}")]
    Transient(String),
}

/// A dataset's files as uploaded: (name, bytes).
pub type Files = Vec<(String, Vec<u8>)>;

/// Everything a job reads, loaded before the blocking work starts.
pub struct JobInput {
    pub kind: JobKind,
    pub params: Value,
    pub machine: Option<Machine>,
    pub dataset: Option<(Dataset, Files)>,
    pub limits: UploadLimits,
}

/// A result document with the scalar figures trend queries need.
pub struct JobOutput {
    pub document: Value,
    pub scalars: ResultScalars,
    /// Named figures (the standards'), stored in their own table.
    pub figures: Vec<Figure>,
    pub measured_at: String,
}

/// Runs a job's solver work. Blocking: call it off the async threads.
pub fn execute(input: &JobInput) -> Result<JobOutput, JobError> {
    execute_with_progress(input, &mut |_, _| {})
}

/// [`execute`], reporting `progress(fraction, phase)` as the solver advances (fractions
/// in [0, 1], never decreasing; today a session diagnosis reports its phases, the other
/// kinds only their end).
pub fn execute_with_progress(
    input: &JobInput,
    progress: &mut dyn FnMut(f64, &str),
) -> Result<JobOutput, JobError> {
    let out = run(input, progress);
    if out.is_ok() {
        progress(1.0, "done");
    }
    out
}

fn run(input: &JobInput, progress: &mut dyn FnMut(f64, &str)) -> Result<JobOutput, JobError> {
    match input.kind {
        JobKind::Identify => {
            let params: IdentifyParams = serde_json::from_value(input.params.clone())
                .map_err(|e| JobError::BadInput(format!("params: {e}")))?;
            let (dataset, data) = load_dataset(input)?;
            let DatasetData::Session(session) = data else {
                return Err(wrong_kind(input.kind, &data));
            };
            let opts = params.options(input.machine.as_ref())?;
            let result = identification::identify(&session, &opts)
                .map_err(|e| JobError::BadInput(format!("identification: {e}")))?;
            identification_output(&result, dataset)
        }
        JobKind::Sensitivity => {
            let mut req: SensitivityRequest = serde_json::from_value(input.params.clone())
                .map_err(|e| JobError::BadInput(format!("params: {e}")))?;
            if let Some(m) = &input.machine {
                req.machine_id = m.id.clone();
            }
            let result = sensitivity::analyse(&req)
                .map_err(|e| JobError::BadInput(format!("sensitivity: {e}")))?;
            Ok(JobOutput {
                document: stored(&result)?,
                scalars: ResultScalars::default(),
                figures: vec![],
                measured_at: mtcal_store::now_rfc3339(),
            })
        }
        JobKind::Diagnose => {
            let params = DiagnoseParams::parse(&input.params).map_err(JobError::BadInput)?;
            let (dataset, data) = load_dataset(input)?;
            if params.fit_fraction.is_some() && !matches!(data, DatasetData::DriftLog(_)) {
                return Err(JobError::BadInput(
                    "params: fit_fraction applies to drift logs only".into(),
                ));
            }
            // A positioning-run diagnosis is stored with the ISO 230-2 figures of the same
            // runs beside it (`mtcal_solver::positioning_check`).
            let document: DiagnosisDocument = match &data {
                DatasetData::Session(session) => {
                    let opts = DiagnoseOptions {
                        topology: machine_topology(input.machine.as_ref())?,
                        ..DiagnoseOptions::default()
                    };
                    diagnosis::diagnose_session_with_progress(
                        session,
                        &opts,
                        &mut |phase: &str, f: f64| progress(f, phase),
                    )
                    .map(DiagnosisDocument::from)
                }
                DatasetData::Positioning(runs) => check_positioning(
                    runs,
                    &dataset.machine_id,
                    &SeriesOptions::default(),
                    &mut |phase: &str, f: f64| progress(f, phase),
                ),
                DatasetData::DriftLog(log) => series::drift::diagnose_drift_log_with_progress(
                    log,
                    &dataset.machine_id,
                    &params.series_options(),
                    &mut |phase: &str, f: f64| progress(f, phase),
                )
                .map(|(r, _)| r.into()),
                DatasetData::RotaryPoints(_) => return Err(wrong_kind(input.kind, &data)),
            }
            .map_err(|e| JobError::BadInput(format!("diagnosis: {e}")))?;
            Ok(JobOutput {
                document: stored(&document)?,
                scalars: diagnosis_scalars(&document.diagnosis),
                figures: vec![],
                measured_at: dataset.measured_at.clone(),
            })
        }
        JobKind::Cradle => {
            let (dataset, data) = load_dataset(input)?;
            let DatasetData::RotaryPoints(set) = data else {
                return Err(wrong_kind(input.kind, &data));
            };
            let result = cradle::check_cradle(&set, &CradleOptions::default())
                .map_err(|e| JobError::BadInput(format!("cradle: {e}")))?;
            Ok(JobOutput {
                document: stored(&result)?,
                scalars: ResultScalars::default(),
                figures: vec![],
                measured_at: dataset.measured_at.clone(),
            })
        }
        JobKind::Standards => {
            let (dataset, data) = load_dataset(input)?;
            let (source, st) = match &data {
                DatasetData::Session(session) => ("session", standards::from_session(session)),
                DatasetData::Positioning(runs) => {
                    ("positioning", standards::from_positioning_runs(runs))
                }
                _ => return Err(wrong_kind(input.kind, &data)),
            };
            if st.iso230_2.is_empty() && st.iso230_4.is_empty() {
                let why: Vec<String> = st
                    .not_evaluated
                    .iter()
                    .map(|n| format!("{} {}: {}", n.standard, n.what, n.reason))
                    .collect();
                return Err(JobError::BadInput(format!(
                    "standards: nothing could be evaluated{}{}",
                    if why.is_empty() { "" } else { ": " },
                    why.join("; ")
                )));
            }
            let figures = figures(&st);
            let result = StandardsResult::new(&dataset.machine_id, source, st);
            Ok(JobOutput {
                document: stored(&result)?,
                scalars: ResultScalars::default(),
                figures,
                measured_at: dataset.measured_at.clone(),
            })
        }
        JobKind::Import => Err(JobError::BadInput(
            "an import job has nothing to run".into(),
        )),
    }
}

/// An identification result as a job's output (document, scalars, figures).
fn identification_output(
    result: &IdentificationResult,
    dataset: &Dataset,
) -> Result<JobOutput, JobError> {
    Ok(JobOutput {
        document: stored(result)?,
        scalars: identification_scalars(result),
        figures: figures(&result.standards),
        measured_at: dataset.measured_at.clone(),
    })
}

/// Which stored results an explained model links: the check of the 21-term model alone
/// and the diagnosis whose findings it adds (ids).
#[derive(Debug, Clone, Copy)]
pub struct ExplainedLink<'a> {
    pub original: &'a str,
    pub diagnosis: &'a str,
}

/// The explained model of an identification's input (`input.params` its identify
/// parameters, its dataset a session): the 21 terms fitted jointly with the findings of
/// `diagnosis`, a diagnosis of the same session (`mtcal_solver::explained::explain`),
/// its document linked to the results of `link`. Blocking.
pub fn explain(
    input: &JobInput,
    diagnosis: &DiagnosisResult,
    link: ExplainedLink<'_>,
) -> Result<JobOutput, JobError> {
    let params: IdentifyParams = serde_json::from_value(input.params.clone())
        .map_err(|e| JobError::BadInput(format!("params: {e}")))?;
    let (dataset, data) = load_dataset(input)?;
    let DatasetData::Session(session) = data else {
        return Err(wrong_kind(JobKind::Identify, &data));
    };
    let opts = params.options(input.machine.as_ref())?;
    let mut result = mtcal_solver::explained::explain(&session, &opts, diagnosis)
        .map_err(|e| JobError::BadInput(format!("explained model: {e}")))?;
    if let Some(m) = &mut result.explained {
        m.original_result_id = Some(link.original.to_string());
        m.diagnosis_result_id = Some(link.diagnosis.to_string());
    }
    identification_output(&result, dataset)
}

/// A result as its stored document, refused unless it reads back as its type: a number
/// the JSON cannot carry (a NaN or an infinity, written as `null`) would make every page,
/// report and export of the result fail, so such a result is never stored and the job
/// fails with the reason (nothing stored that cannot be read back).
fn stored<T: serde::Serialize + serde::de::DeserializeOwned>(
    result: &T,
) -> Result<serde_json::Value, JobError> {
    let document = serde_json::to_value(result).map_err(|e| JobError::Transient(e.to_string()))?;
    serde_json::from_value::<T>(document.clone()).map_err(|e| {
        JobError::BadInput(format!(
            "the result does not read back as stored ({e}): a figure is not a finite \
             number; check the dataset's stated conditions and offsets for absurd values"
        ))
    })?;
    Ok(document)
}

/// The job's dataset, parsed again with the reader of its kind (files stored verbatim).
fn load_dataset(input: &JobInput) -> Result<(&Dataset, DatasetData), JobError> {
    let (dataset, files) = input.dataset.as_ref().ok_or_else(|| {
        JobError::BadInput(format!("a {} job needs a dataset", input.kind.as_str()))
    })?;
    // Files are stored as uploaded: one accepted in the Excel dialect is read in it.
    let limits = input
        .limits
        .with_dialect(mtcal_formats::sniff::stored_dialect(files));
    let data =
        ingest::read_dataset(files, &limits).map_err(|e| JobError::BadInput(e.to_string()))?;
    Ok((dataset, data.data))
}

/// The job kind cannot run on this dataset kind.
fn wrong_kind(kind: JobKind, data: &DatasetData) -> JobError {
    JobError::BadInput(format!(
        "a {} job cannot run on a {} dataset",
        kind.as_str(),
        data.kind()
    ))
}

/// The machine's registered topology (stands in for a session that declares none).
fn machine_topology(machine: Option<&Machine>) -> Result<Option<Topology>, JobError> {
    machine
        .map(|m| {
            serde_json::from_value::<Topology>(m.topology.clone())
                .map_err(|e| JobError::BadInput(format!("machine {} topology: {e}", m.id)))
        })
        .transpose()
}

/// The stored figures of the standards (`iso230_2.<axis>.<figure>`,
/// `iso230_4.<plane>.<direction>.<figure>`).
pub fn figures(st: &Standards) -> Vec<Figure> {
    st.scalar_figures()
        .into_iter()
        .map(|f| Figure {
            name: f.name,
            value: f.value,
            u: f.u,
        })
        .collect()
}

/// The scalar columns of a diagnosis: the rigid model's residual RMS (baseline).
pub fn diagnosis_scalars(r: &DiagnosisResult) -> ResultScalars {
    ResultScalars {
        summary: ResultSummary {
            residual_rms_um: Some(r.baseline.residual_rms_um).filter(|v| v.is_finite()),
            ..ResultSummary::default()
        },
        ..ResultScalars::default()
    }
}

/// The scalar columns of an identification result.
pub fn identification_scalars(r: &IdentificationResult) -> ResultScalars {
    let sq = |n: &str| r.squareness.get(n).and_then(|s| s.value_urad);
    ResultScalars {
        summary: ResultSummary {
            residual_rms_um: Some(r.fit.residual_rms_um),
            condition_number: Some(r.observability.condition_number).filter(|c| c.is_finite()),
            rank: Some(r.observability.rank as i64),
            ec0y_urad: sq("EC0Y"),
            eb0z_urad: sq("EB0Z"),
            ea0z_urad: sq("EA0Z"),
        },
        term_coefficients: r
            .terms
            .iter()
            .filter(|(_, t)| t.identifiable && !t.coefficients.is_empty())
            .map(|(n, t)| (n.clone(), t.coefficients.clone()))
            .collect(),
        measured_travel_mm: r.model.measured_travel_mm.clone(),
        term_covariance: r
            .terms
            .iter()
            .filter(|(_, t)| {
                t.identifiable
                    && !t.coefficients.is_empty()
                    && t.coefficient_covariance.len() == t.coefficients.len()
            })
            .map(|(n, t)| (n.clone(), t.coefficient_covariance.clone()))
            .chain(r.squareness.iter().filter_map(|(n, s)| {
                s.value_urad?;
                Some((n.clone(), vec![vec![s.std_urad?.powi(2)]]))
            }))
            .collect(),
    }
}
