//! What a plant acts on, from a stored identification result: its compensation table for
//! a controller (`GET /api/v1/results/{id}/export?format=…`) and its check report (`GET
//! /api/v1/results/{id}/report`, one self-contained HTML page; a cradle result has its
//! own report). Both are thin: the table is [`mtcal_formats::compensation`], the page
//! [`mtcal_views::pages::report`].

use crate::AppState;
use crate::auth::ReadKey;
use crate::error::{ApiError, ApiQuery, ErrorBody};
use axum::extract::{Path, State};
use axum::http::{HeaderValue, header};
use axum::response::{IntoResponse, Response};
use mtcal_formats::compensation::{Compensation, DEFAULT_STEP_MM, ExportError, Format};
use mtcal_solver::cradle::CradleResult;
use mtcal_solver::diagnosis::DiagnosisResult;
use mtcal_solver::identification::IdentificationResult;
use mtcal_solver::positioning_check::DiagnosisDocument;
use mtcal_store::StoredResult;
use mtcal_views::pages::report::{
    CheckReport, CradleCheckReport, PositioningReport, ReportDiagnosis, check_report,
    cradle_report, positioning_report,
};
use serde::Deserialize;
use utoipa::IntoParams;

#[derive(Debug, Deserialize, IntoParams)]
#[into_params(parameter_in = Query)]
pub struct ExportQuery {
    /// `isg` (ISG / Beckhoff volumetric compensation CSV), `etalon` (Etalon exchange
    /// format), `heidenhain` (KinematicsComp-style COM tables), `csv` (plain, ISO 230-1
    /// names, with forward/reverse values where a reversal was found and thermal
    /// coefficients per K) or `linuxcnc` (LinuxCNC joint compensation triplets: nominal,
    /// forward, reverse, `COMP_FILE_TYPE = 0`). Required.
    #[param(pattern = "^(isg|etalon|heidenhain|csv|linuxcnc)$")]
    pub format: Option<String>,
    /// Spacing of the table's positions, mm (default 5, at least 0.001; from the start of
    /// each measured travel, its end always included).
    #[param(minimum = 0.001)]
    pub step_mm: Option<f64>,
    /// Make the table although the result's model does not explain its recording (the
    /// misfit gate): the table's first header line then says why it is not for use
    /// without review. Without it such a result is refused (409, `model_misfit`).
    pub force: Option<bool>,
}

#[utoipa::path(operation_id = "results_export", summary = "Compensation table of an identification result for a controller", get,
    path = "/api/v1/results/{id}/export", tag = "history",
    security(("api_key" = [])), params(("id" = String, Path), ExportQuery),
    responses((status = 200, description = "the table (attachment): the identifiable terms over the measured travel, mm and rad \
                                            (csv: µm and µrad); the header comment states the sign convention (compensation = −error) \
                                            and names the terms left out; the reversal and thermal coefficients a diagnosis of the \
                                            same dataset found go into csv (forward/reverse columns, per-K rows) and linuxcnc \
                                            (triplets), the other formats name them in their header as not carried; text/csv for format csv",
               content((String = "text/plain"), (String = "text/csv"))),
              (status = 400, body = ErrorBody, description = "unknown or missing format (the message names the formats), bad step \
                                                                (linuxcnc: more than 256 triplets per joint), or not an identification result"),
              (status = 404, body = ErrorBody),
              (status = 409, body = ErrorBody, description = "model_misfit: the result's model does not explain its recording \
                                                                (residual above the noise floor by more than the gate's factor); \
                                                                force=true makes the table with the reason in its header"),
              (status = 422, body = ErrorBody, description = "not_identifiable: no term of the result is identifiable \
                                                                (linuxcnc: no axis's error along itself and no reversal)")))]
pub async fn export(
    _key: ReadKey,
    who: crate::audit::Actor,
    State(s): State<AppState>,
    Path(id): Path<String>,
    ApiQuery(q): ApiQuery<ExportQuery>,
) -> Result<Response, ApiError> {
    let format = Format::parse(q.format.as_deref().unwrap_or_default()).map_err(|_| {
        ApiError::InvalidRequest(format!(
            "format `{}`: use one of {}",
            q.format.as_deref().unwrap_or(""),
            Format::names()
        ))
    })?;
    let r = s.store.get_result(&id).await?;
    let name = format!(
        "{}-{}.{}.{}",
        file_safe(&r.meta.machine_id),
        file_safe(&r.meta.id),
        format.name(),
        format.extension()
    );
    let step = q.step_mm.unwrap_or(DEFAULT_STEP_MM);
    let force = q.force.unwrap_or(false);
    identification_kind(&r)?;
    // The physics a diagnosis of the same dataset found (reversal, thermal coefficients).
    let findings = match diagnosis_of(&s, &r).await? {
        Some(ReportDiagnosis { doc: Ok(d), .. }) => d.findings,
        _ => vec![],
    };
    let (result_id, machine_id) = (r.meta.id.clone(), r.meta.machine_id.clone());
    let text = crate::blocking::run::<_, ApiError>(move || {
        let doc = identification(&r)?;
        let refused = |e| match e {
            ExportError::BadStep(m) => ApiError::InvalidRequest(format!("step_mm: {m}")),
            e @ ExportError::NothingIdentifiable(_) => ApiError::NotIdentifiable(e.to_string()),
            e @ ExportError::ModelMisfit(_) => ApiError::ModelMisfit(e.to_string()),
        };
        // A result of the explained model: its own fitted physics.
        let findings = match &doc.explained {
            Some(m) => mtcal_formats::compensation::physics::explained_findings(m),
            None => findings,
        };
        let table = Compensation::from_result(&doc, step, force)
            .map_err(refused)?
            .with_findings(&findings);
        format.check(&table).map_err(refused)?;
        Ok::<_, ApiError>(format.write(&table))
    })
    .await??;
    if force {
        // A table made past the misfit gate (or asked to be): who took that decision.
        let change = crate::audit::Change {
            action: "export.forced",
            target: &result_id,
            machine: Some(&machine_id),
            before: None,
            after: Some(serde_json::json!({"format": format.name(), "step_mm": step})),
        };
        who.record(s.store.as_ref(), change).await?;
    }
    Ok(attachment(text, format.content_type(), Some(&name)))
}

#[utoipa::path(operation_id = "results_report", summary = "Check report of an identification result, a positioning-run diagnosis or a cradle result (self-contained HTML, prints on A4)", get,
    path = "/api/v1/results/{id}/report", tag = "history",
    security(("api_key" = [])), params(("id" = String, Path)),
    responses((status = 200, description = "one self-contained HTML page: machine, date, instrument and plan, the standards' figures \
                                            (verdicts when a tolerance profile applies, else \"no tolerance\"), the 21 terms with ±2σ bands \
                                            and identifiability, circle polar plots, the findings of a diagnosis of the same dataset, \
                                            the compensation table's summary and what the data could not determine; of a positioning-run \
                                            diagnosis: the ISO 230-2 figures (the standard's, and without the readings its outlier test set aside), \
                                            the findings with their held-out figures; of a cradle result: \
                                            its facts, the chosen model, the compliance against A with ±2σ bands, what the ball data can \
                                            separate, the location errors and what the data could not determine",
               content_type = "text/html", body = String),
              (status = 400, body = ErrorBody, description = "neither an identification result, a positioning-run diagnosis nor a cradle result"),
              (status = 404, body = ErrorBody)))]
pub async fn report(
    _key: ReadKey,
    State(s): State<AppState>,
    Path(id): Path<String>,
) -> Result<Response, ApiError> {
    let r = s.store.get_result(&id).await?;
    let now = mtcal_store::now_rfc3339();
    if r.meta.kind == "cradle" {
        let page = crate::blocking::run::<_, ApiError>(move || {
            let doc: CradleResult = serde_json::from_value(r.document.clone()).map_err(|e| {
                ApiError::Conflict(format!(
                    "result {} does not read as a cradle result: {e}; exclude it and run the \
                     check again",
                    r.meta.id
                ))
            })?;
            Ok::<_, ApiError>(
                cradle_report(&CradleCheckReport {
                    doc: &doc,
                    result_id: Some(&r.meta.id),
                    generated_at: &now,
                })
                .into_string(),
            )
        })
        .await??;
        return Ok(attachment(page, "text/html; charset=utf-8", None));
    }
    if r.meta.kind == "diagnosis" {
        // A positioning-run check: its diagnosis and its ISO 230-2 figures.
        let page = crate::blocking::run::<_, ApiError>(move || {
            let doc: DiagnosisDocument = serde_json::from_value(r.document.clone())
                .map_err(|e| ApiError::Internal(format!("result {}: {e}", r.meta.id)))?;
            if doc.diagnosis.source != "positioning" {
                return Err(ApiError::InvalidRequest(format!(
                    "result {} is a diagnosis of a {}; reports are made from identification results, positioning-run diagnoses and cradle results",
                    r.meta.id, doc.diagnosis.source
                )));
            }
            Ok(positioning_report(&PositioningReport {
                doc: &doc,
                result_id: Some(&r.meta.id),
                measured_at: &r.meta.measured_at,
                generated_at: &now,
            })
            .into_string())
        })
        .await??;
        return Ok(attachment(page, "text/html; charset=utf-8", None));
    }
    identification_kind(&r)?;
    let diagnosis = diagnosis_of(&s, &r).await?;
    // The verdict against the tolerance profile that applies to the machine, as
    // `GET /api/v1/results/{id}/verdict` gives it ("no tolerance" when none applies).
    let verdict = mtcal_domain::verdicts::result_verdict(s.store.as_ref(), &r.meta.id)
        .await?
        .verdict;
    let page = crate::blocking::run::<_, ApiError>(move || {
        let doc = identification(&r)?;
        let page = check_report(&CheckReport {
            doc: &doc,
            result_id: Some(&r.meta.id),
            generated_at: &now,
            verdict: verdict.as_ref(),
            diagnosis: diagnosis.as_ref(),
        });
        Ok::<_, ApiError>(page.into_string())
    })
    .await??;
    let mut resp = attachment(page, "text/html; charset=utf-8", None);
    resp.headers_mut().insert(
        axum::http::header::CONTENT_SECURITY_POLICY,
        axum::http::HeaderValue::from_static(crate::edge::PRINT_CSP),
    );
    Ok(resp)
}

/// 400 unless `r` is an identification result.
fn identification_kind(r: &StoredResult) -> Result<(), ApiError> {
    if r.meta.kind != "identification" {
        return Err(ApiError::InvalidRequest(format!(
            "result {} is a {} result; exports and reports are made from identification results (and reports from positioning-run diagnoses and cradle results)",
            r.meta.id, r.meta.kind
        )));
    }
    Ok(())
}

/// The identification document of a stored result (400 for another kind).
fn identification(r: &StoredResult) -> Result<IdentificationResult, ApiError> {
    identification_kind(r)?;
    serde_json::from_value(r.document.clone()).map_err(|e| {
        ApiError::Conflict(format!(
            "result {} does not read as an identification: {e}; exclude it and run the \
             check again",
            r.meta.id
        ))
    })
}

/// The diagnosis of the check, when one was run: the one an explained model names (whose
/// findings it adds), else the latest of the same dataset; its document, or why the stored
/// document does not read (the report says so with its id, never "no diagnosis").
async fn diagnosis_of(s: &AppState, r: &StoredResult) -> Result<Option<ReportDiagnosis>, ApiError> {
    let named = r
        .document
        .pointer("/explained/diagnosis_result_id")
        .and_then(|v| v.as_str());
    // A named diagnosis no longer stored falls back to the dataset's.
    let mut found = match named {
        Some(id) => s.store.get_result(id).await.ok(),
        None => None,
    };
    if found.is_none()
        && let Some(dataset) = &r.meta.dataset_id
        && let Some(m) = mtcal_domain::history::diagnosis_of_dataset(
            s.store.as_ref(),
            &r.meta.machine_id,
            dataset,
        )
        .await?
    {
        found = Some(s.store.get_result(&m.id).await?);
    }
    Ok(found.map(|d| ReportDiagnosis {
        id: d.meta.id.clone(),
        stored: true,
        doc: serde_json::from_value::<DiagnosisResult>(d.document)
            .map_err(|e| format!("its document does not read: {e}")),
    }))
}

/// A text body with its content type, as an attachment named `name` when given.
pub(crate) fn attachment(body: String, content_type: &'static str, name: Option<&str>) -> Response {
    let mut resp = body.into_response();
    let h = resp.headers_mut();
    h.insert(header::CONTENT_TYPE, HeaderValue::from_static(content_type));
    if let Some(v) =
        name.and_then(|n| HeaderValue::from_str(&format!("attachment; filename=\"{n}\"")).ok())
    {
        h.insert(header::CONTENT_DISPOSITION, v);
    }
    resp
}

/// Letters, digits, `-`, `_` and `.` of `s`; anything else becomes `_` (a file name in a
/// header).
fn file_safe(s: &str) -> String {
    s.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || "-_.".contains(c) {
                c
            } else {
                '_'
            }
        })
        .collect()
}
