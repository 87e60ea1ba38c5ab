//! Page handlers: each reads through the domain's functions (crates/domain), as the API
//! routes do, or the service functions of the API routes for jobs, uploads and machine
//! updates (`crate::api::*`), and hands plain view data to crates/views.

use super::session::{Session, WebState};
use super::{PageResult, WebError, html};
use crate::AppState;
use crate::api::jobs::{self as api_jobs, SubmitJob};
use crate::error::ApiError;
use crate::jobs::JobKind;
use axum::extract::{Form, FromRequest, Multipart, Path, Query, Request, State};
use axum::response::{IntoResponse, Redirect};
use mtcal_domain::alerts::{self, AlertQuery, AlertView, MAX_ALERTS};
use mtcal_domain::fleet::page as domain_fleet;
use mtcal_domain::history::{self, DiffQuery};
use mtcal_domain::kinds::IDENTIFICATION as KIND;
use mtcal_domain::trends::{self as domain_trends, TermQuery};
use mtcal_domain::verdicts;
use mtcal_solver::identification::IdentificationResult;
use mtcal_store::{Job, Machine, MachinePatch, ResultMeta, StoredResult};
use mtcal_views::pages::alerts::{self as valerts, AlertRow};
use mtcal_views::pages::{
    self as views, compare, fleet as vfleet, jobs as vjobs, machine as vmachine, result as vresult,
};
use mtcal_views::plots::{TrendPoint, TrendSeries};
use serde::Deserialize;

/// What a diagnosis found, as the pages show it.
fn findings_view(d: mtcal_domain::fleet::entry::DiagnosisSummary) -> views::DiagnosisFindings {
    views::DiagnosisFindings {
        result_id: d.result_id,
        verdict: d.verdict.map(|v| v.as_str().to_string()),
        findings: d.findings,
        more: d.more,
    }
}

/// Result kinds shown on a machine page, in this order.
const KINDS: [&str; 4] = ["identification", "diagnosis", "cradle", "sensitivity"];

/// Machines per fleet page.
pub const FLEET_PAGE_ROWS: usize = domain_fleet::DEFAULT_LIMIT;

/// What check job `j` belongs to: its dataset's kind, files and measurement time (None
/// without a dataset, or when it cannot be read: the row then names the machine only).
async fn job_check(app: &AppState, j: &Job) -> Option<vjobs::JobCheck> {
    let ds = app.store.get_dataset(j.dataset_id.as_deref()?).await.ok()?;
    Some(vjobs::JobCheck {
        dataset_id: ds.id,
        kind: ds.kind,
        files: ds.files.into_iter().map(|f| f.name).collect(),
        measured_at: ds.measured_at,
    })
}

/// Jobs as their rows show them, each with the check it belongs to (a dataset read once
/// however many jobs ran on it).
async fn job_rows(app: &AppState, jobs: &[Job]) -> Vec<vjobs::JobRow> {
    let mut checks: std::collections::HashMap<String, Option<vjobs::JobCheck>> =
        std::collections::HashMap::new();
    let mut rows = Vec::with_capacity(jobs.len());
    for j in jobs {
        let check = match &j.dataset_id {
            Some(d) => match checks.get(d) {
                Some(c) => c.clone(),
                None => {
                    let c = job_check(app, j).await;
                    checks.insert(d.clone(), c.clone());
                    c
                }
            },
            None => None,
        };
        rows.push(vjobs::JobRow {
            check,
            ..job_row(j)
        });
    }
    rows
}

fn job_row(j: &Job) -> vjobs::JobRow {
    vjobs::JobRow {
        id: j.id.clone(),
        kind: j.kind.as_str().into(),
        machine_id: j.machine_id.clone(),
        state: j.state.as_str().into(),
        progress: j.progress,
        progress_message: j.progress_message.clone(),
        error_code: j.error_code.clone(),
        error_message: j.error_message.clone(),
        result_id: j.result_id.clone(),
        created_at: j.created_at.clone(),
        check: None,
    }
}

fn alert_row(a: &AlertView) -> AlertRow {
    AlertRow {
        id: a.raised.id.clone(),
        machine_id: a.raised.machine_id.clone(),
        result_id: a.raised.result_id.clone(),
        raised_at: a.raised.raised_at.clone(),
        message: a.raised.message.clone(),
        compare_href: Some(format!(
            "/compare?a={}&b={}",
            views::encode(&a.raised.baseline_result_id),
            views::encode(&a.raised.result_id)
        )),
        acknowledged: !a.active,
        acknowledged_at: a.acknowledged_at.clone(),
        acknowledged_by: a.acknowledged_by.clone(),
        comment: a.acknowledgement_comment.clone(),
    }
}

/// The overall verdict of result `id` as a badge word (None: no profile or no limit
/// applies).
async fn verdict_word(app: &AppState, id: &str) -> Result<Option<String>, ApiError> {
    let v = verdicts::result_verdict(app.store.as_ref(), id).await?;
    Ok(v.verdict
        .and_then(|v| v.decision)
        .map(|d| d.as_str().to_string()))
}

#[derive(Debug, Deserialize, Default)]
pub struct FleetPageParams {
    site: Option<String>,
    tag: Option<String>,
    sort: Option<String>,
    /// 1-based.
    page: Option<usize>,
}

/// `/`: the fleet, one page of [`FLEET_PAGE_ROWS`] machines, from the fleet route of the
/// API (`GET /api/v1/fleet`, [`domain_fleet::page`]: machines with active alerts
/// first, then in the order chosen; filtered, sorted and counted by the database from
/// the maintained rows, so that a page costs the same at 10 000 machines as at 10), and
/// the active alerts from the alert list route.
pub async fn fleet(
    session: Session,
    State(s): State<WebState>,
    Query(q): Query<FleetPageParams>,
) -> PageResult {
    let app = &s.app;
    let page_no = q.page.unwrap_or(1).max(1);
    let started = std::time::Instant::now();
    let found = domain_fleet::page(
        app.store.as_ref(),
        &app.fleet_counts,
        &domain_fleet::FleetParams {
            site: q.site,
            tag: q.tag,
            sort: q.sort,
            offset: Some((page_no - 1) * FLEET_PAGE_ROWS),
            limit: Some(FLEET_PAGE_ROWS),
        },
        &session.key,
    )
    .await?;
    let read_page = started.elapsed();
    let alerts = crate::api::alerts::list_within(
        app,
        &AlertQuery {
            active: Some(true),
            limit: Some(MAX_ALERTS),
            ..AlertQuery::default()
        },
        &session.key,
    )
    .await?;
    let read_alerts = started.elapsed();
    let drift = |value: f64, std: Option<f64>, unit: &str, term: &Option<String>| vfleet::Drift {
        value,
        std,
        unit: unit.into(),
        term: term.clone(),
        at_mm: None,
    };
    let rows = found
        .machines
        .into_iter()
        .map(|m| vfleet::FleetRow {
            last_check: m.last_check.map(|c| vfleet::Check {
                result_id: c.result_id,
                kind: c.kind,
                measured_at: c.measured_at,
            }),
            verdict: m.verdict.map(|d| d.as_str().to_string()),
            verdict_counts: m.verdict_summary.as_ref().map(|v| vfleet::VerdictCounts {
                items: v.items,
                failed: v.failed,
                undecided: v.undecided,
                misfit: v.misfit,
            }),
            verdict_reasons: m.verdict_summary.map(|v| v.reasons).unwrap_or_default(),
            profile: m.tolerance_profile.map(|p| match p.scope.as_str() {
                "tag" => format!("tag {}", p.target),
                _ => "the machine's own".to_string(),
            }),
            results: usize::try_from(m.results).unwrap_or(0),
            drift_um: m
                .drift
                .as_ref()
                .map(|d| drift(d.drift_um, d.drift_um_u, "um", &d.worst_term_um)),
            drift_urad: m
                .drift
                .as_ref()
                .map(|d| drift(d.drift_urad, d.drift_urad_u, "urad", &d.worst_term_urad)),
            drift_note: m.drift_note,
            worst_trend: m.sparkline.iter().map(|v| v.unwrap_or(f64::NAN)).collect(),
            active_alerts: usize::try_from(m.active_alerts).unwrap_or(0),
            misfit: m.misfit.map(|c| c.statement),
            explained_model: m.explained_model,
            diagnosis: m.diagnosis.map(findings_view),
            machine_id: m.machine_id,
            name: m.name,
            site: m.site,
            tags: m.tags,
        })
        .collect();
    let page = vfleet::FleetPage {
        rows,
        alerts: alerts.iter().map(alert_row).collect(),
        sites: found.sites,
        tags: found.tags,
        site: found.site,
        tag: found.tag,
        sort: found.sort,
        definition: found.definition,
        total: found.total,
        page: page_no,
        pages: found.total.div_ceil(FLEET_PAGE_ROWS).max(1),
    };
    let mut response = html(vfleet::fleet_page(&session.viewer(), &page));
    // Where the time went (shown by browsers' developer tools; the load generator
    // reports it): the page's rows, the alert list, building and rendering the page.
    let ms = |d: std::time::Duration| d.as_secs_f64() * 1e3;
    let timing = format!(
        "page;dur={:.2}, alerts;dur={:.2}, render;dur={:.2}",
        ms(read_page),
        ms(read_alerts - read_page),
        ms(started.elapsed() - read_alerts)
    );
    if let Ok(v) = axum::http::HeaderValue::from_str(&timing) {
        response.headers_mut().insert("server-timing", v);
    }
    Ok(response)
}

#[derive(Debug, Deserialize, Default)]
pub struct MachineParams {
    term: Option<String>,
    at: Option<String>,
    /// Jobs just submitted (comma-separated ids).
    jobs: Option<String>,
    notice: Option<String>,
}

/// One line about a stored result for the checks table.
fn summary(r: &ResultMeta) -> String {
    let sc = &r.scalars;
    let mut parts = vec![];
    if let Some(v) = sc.summary.residual_rms_um {
        parts.push(format!("residual {} µm", views::num(v)));
    }
    if let Some(k) = sc.summary.rank {
        parts.push(format!("rank {k}"));
    }
    parts.join(", ")
}

/// Positions of the term trend when none are given: the ends of the term's reported
/// grid in the latest identification (inside its measured travel).
fn default_positions(latest: Option<&IdentificationResult>, term: &str) -> String {
    let grid = latest
        .and_then(|d| d.terms.get(term))
        .map(|t| t.positions_mm.clone())
        .unwrap_or_default();
    match (grid.first(), grid.last()) {
        (Some(a), Some(b)) if a != b => format!(
            "{},{}",
            mtcal_views::plots::tick_label(*a),
            mtcal_views::plots::tick_label(*b)
        ),
        _ => "0".into(),
    }
}

/// The jobs of machine `id` named in the page's `jobs` parameter (at most 10).
async fn named_jobs(app: &AppState, id: &str, jobs: Option<&str>) -> Vec<vjobs::JobRow> {
    let mut found = vec![];
    for j in jobs
        .unwrap_or("")
        .split(',')
        .filter(|j| !j.is_empty())
        .take(10)
    {
        if let Ok(job) = app.store.get_job(j).await
            && job.machine_id.as_deref() == Some(id)
        {
            found.push(job);
        }
    }
    job_rows(app, &found).await
}

/// A machine's stored results of the kinds its page shows, as the checks table lists
/// them, and what the rest of the page needs of them.
struct MachineChecks {
    /// Newest first.
    rows: Vec<vmachine::CheckRow>,
    /// Its identifications in time order.
    identifications: Vec<ResultMeta>,
    /// Those of them that are misfits or decided on the explained model.
    models: domain_trends::CheckModels,
    baseline: Option<String>,
    /// The tolerance profile that applies (`scope target (id)`).
    tolerance: Option<String>,
}

/// The verdict word of identification `r` of machine `m` against `profiles` (None when
/// none applies); a stored document that does not read is this row's verdict
/// ("unreadable"), not the page's failure.
async fn row_verdict(
    app: &AppState,
    profiles: &[mtcal_store::ToleranceProfile],
    m: &Machine,
    r: &ResultMeta,
) -> Result<Option<String>, ApiError> {
    let stored = app.store.get_result(&r.id).await?;
    match verdicts::verdict(app.store.as_ref(), profiles, m, &stored).await {
        Ok(v) => Ok(v
            .and_then(|(_, v)| v.decision)
            .map(|d| d.as_str().to_string())),
        Err(mtcal_store::StoreError::Conflict(_)) => Ok(Some("unreadable".to_string())),
        Err(e) => Err(e.into()),
    }
}

/// Machine `m`'s checks ([`MachineChecks`]): every result of [`KINDS`], newest first,
/// each identification with its verdict (read only when a profile applies) and its
/// misfit gate.
async fn machine_checks(app: &AppState, m: &Machine) -> Result<MachineChecks, ApiError> {
    let mut checks = vec![];
    let mut identifications = vec![];
    for kind in KINDS {
        let list = history::results(app.store.as_ref(), &m.id, Some(kind)).await?;
        if kind == KIND {
            identifications = list.clone();
        }
        checks.extend(list);
    }
    checks.sort_by(|a, b| {
        b.measured_at
            .cmp(&a.measured_at)
            .then(b.created_at.cmp(&a.created_at))
    });
    let models = domain_trends::check_models(app.store.as_ref(), &identifications).await?;
    let baseline = history::baseline_among(m, &identifications, &models).map(|r| r.id.clone());
    let profiles = app.store.list_tolerances().await?;
    let tolerance = mtcal_domain::profiles::applicable(&profiles, m)
        .map(|p| format!("{} {} ({})", p.scope, p.target, p.id));
    let mut rows = Vec::with_capacity(checks.len());
    for r in &checks {
        let verdict = if tolerance.is_some() && r.kind == KIND {
            row_verdict(app, &profiles, m, r).await?
        } else {
            None
        };
        rows.push(vmachine::CheckRow {
            result_id: r.id.clone(),
            kind: r.kind.clone(),
            measured_at: r.measured_at.clone(),
            verdict,
            summary: summary(r),
            is_baseline: baseline.as_deref() == Some(r.id.as_str()),
            misfit: models.get(&r.id).is_some_and(|m| m.misfit),
        });
    }
    Ok(MachineChecks {
        rows,
        identifications,
        models,
        baseline,
        tolerance,
    })
}

/// The trend of `term` at positions `at` over machine `id`'s identifications, misfit
/// checks marked; or why it cannot be drawn (a position outside the measured travel).
async fn term_trend_view(
    app: &AppState,
    id: &str,
    term: &str,
    at: &str,
    models: &domain_trends::CheckModels,
) -> Result<(Option<vmachine::TermTrend>, Option<String>), ApiError> {
    let query = TermQuery {
        term: term.to_string(),
        at: at.to_string(),
    };
    let t = match domain_trends::term_trend(app.store.as_ref(), id, query, Some(models)).await {
        Ok(t) => t,
        Err(mtcal_domain::DomainError::Invalid(msg)) => return Ok((None, Some(msg))),
        Err(e) => return Err(e.into()),
    };
    let series = t
        .positions_mm
        .iter()
        .enumerate()
        .map(|(i, q)| TrendSeries {
            name: format!("{} at {} mm", t.term, mtcal_views::plots::tick_label(*q)),
            points: t
                .points
                .iter()
                .map(|p| TrendPoint {
                    measured_at: p.measured_at.clone(),
                    value: p.values[i],
                    std: p.u[i],
                    misfit: p.model.misfit,
                })
                .collect(),
        })
        .collect();
    Ok((
        Some(vmachine::TermTrend {
            term: t.term,
            unit: t.unit,
            series,
        }),
        None,
    ))
}

/// EC0Y, EB0Z and EA0Z over machine `id`'s identifications, misfit checks marked.
async fn squareness_trend(
    app: &AppState,
    id: &str,
    models: &domain_trends::CheckModels,
) -> Result<Vec<TrendSeries>, ApiError> {
    let summary = domain_trends::summary_trend(app.store.as_ref(), id, Some(models)).await?;
    type Pick = fn(&domain_trends::SummaryPoint) -> (Option<f64>, Option<f64>);
    Ok([
        ("EC0Y", (|p| (p.summary.ec0y_urad, p.ec0y_u_urad)) as Pick),
        ("EB0Z", |p| (p.summary.eb0z_urad, p.eb0z_u_urad)),
        ("EA0Z", |p| (p.summary.ea0z_urad, p.ea0z_u_urad)),
    ]
    .iter()
    .map(|(name, f)| TrendSeries {
        name: name.to_string(),
        points: summary
            .points
            .iter()
            .map(|p| {
                let (value, std) = f(p);
                TrendPoint {
                    measured_at: p.measured_at.clone(),
                    value,
                    std,
                    misfit: p.model.misfit,
                }
            })
            .collect(),
    })
    .collect())
}

/// `/machines/{id}`: the machine, its checks with their verdicts, the trends of a term
/// and of squareness, its alerts, latest diagnosis and verification, the jobs just
/// submitted.
pub async fn machine(
    session: Session,
    State(s): State<WebState>,
    Path(id): Path<String>,
    Query(q): Query<MachineParams>,
) -> PageResult {
    let app = &s.app;
    let m = app.store.get_machine(&id).await?;
    // The jobs are read before the checks: a job already ended has its result in the
    // list below (a job's result and its end are one commit), and a job still running
    // is polled by the page script, which reloads the page when it ends. Read after the
    // checks, a job ending in between would show as ended above a list without its
    // result, and the page would never reload.
    let jobs = named_jobs(app, &id, q.jobs.as_deref()).await;
    let checks = machine_checks(app, &m).await?;
    let alerts = alerts::list(
        app.store.as_ref(),
        &AlertQuery {
            machine: Some(id.clone()),
            ..AlertQuery::default()
        },
    )
    .await?;
    let latest = match checks.identifications.last() {
        Some(r) => serde_json::from_value::<IdentificationResult>(
            app.store.get_result(&r.id).await?.document,
        )
        .ok(),
        None => None,
    };
    let term = q
        .term
        .filter(|t| domain_trends::term_info(t).is_some())
        .unwrap_or_else(|| "EXX".into());
    let at =
        q.at.filter(|a| !a.trim().is_empty())
            .unwrap_or_else(|| default_positions(latest.as_ref(), &term));
    let (term_trend, trend_error) = if checks.identifications.is_empty() {
        (None, None)
    } else {
        term_trend_view(app, &id, &term, &at, &checks.models).await?
    };
    let verification = latest_verification(app, &id).await?;
    let page = vmachine::MachinePage {
        machine: vmachine::MachineInfo {
            id: m.id.clone(),
            name: m.name.clone(),
            site: m.site.clone(),
            tags: m.tags.clone(),
            travel_mm: m.travel_mm.iter().map(|(k, v)| (k.clone(), *v)).collect(),
            baseline_result_id: checks.baseline,
        },
        checks: checks.rows,
        term,
        at,
        term_trend,
        trend_error,
        squareness: squareness_trend(app, &id, &checks.models).await?,
        jobs,
        notice: q.notice,
        alerts: alerts.iter().map(alert_row).collect(),
        tolerance: checks.tolerance,
        diagnosis: mtcal_domain::history::latest_diagnosis(app.store.as_ref(), &id)
            .await?
            .map(|(meta, doc)| vmachine::LatestDiagnosis {
                result_id: meta.id,
                measured_at: meta.measured_at,
                doc,
            }),
        verification: verification.as_ref().map(|v| v.0.clone()),
        verified_against: verification.and_then(|v| v.1),
        explained_checks: checks
            .identifications
            .iter()
            .filter(|r| {
                checks
                    .models
                    .get(&r.id)
                    .is_some_and(|m| m.explained_model.is_some())
            })
            .map(|r| r.measured_at.clone())
            .collect(),
        explained_model: latest
            .as_ref()
            .map(|d| d.model_check())
            .filter(|c| c.explained_model.is_some())
            .map(|c| c.statement),
    };
    Ok(html(vmachine::machine_page(&session.viewer(), &page)))
}

/// The machine's latest check verified against the check before it, when there is
/// something to verify: its sentence and one line per finding, and the check before it
/// (result id, when measured).
async fn latest_verification(app: &AppState, id: &str) -> Result<Option<Verified>, ApiError> {
    let latest = mtcal_domain::verification::latest(app.store.as_ref(), id).await?;
    Ok(latest.map(|v| {
        (
            (
                v.statement,
                v.findings.into_iter().map(|f| f.statement).collect(),
            ),
            v.previous_result_id.zip(v.previous_measured_at),
        )
    }))
}

/// A verification as the machine page shows it: (sentence, lines), and the check it
/// compares with.
type Verified = ((String, Vec<String>), Option<(String, String)>);

#[derive(Debug, Deserialize)]
pub struct BaselineForm {
    /// Missing reads as empty: refused by the token check (403), like a wrong one.
    #[serde(default)]
    csrf: String,
    result_id: String,
}

/// `POST /machines/{id}/baseline`: the machine update of the API with
/// `baseline_result_id`.
pub async fn set_baseline(
    session: Session,
    client: crate::audit::Client,
    State(s): State<WebState>,
    Path(id): Path<String>,
    Form(f): Form<BaselineForm>,
) -> PageResult {
    session.check_csrf(&f.csrf)?;
    session.require_write()?;
    let r = s.app.store.get_result(&f.result_id).await?;
    if r.meta.machine_id != id || r.meta.kind != KIND {
        return Err(WebError(ApiError::InvalidRequest(format!(
            "result {} is not an identification of machine {id}",
            f.result_id
        ))));
    }
    crate::api::machines::update_machine(
        &s.app,
        &id,
        MachinePatch {
            baseline_result_id: Some(f.result_id),
            ..MachinePatch::default()
        },
        &session.actor(client),
    )
    .await?;
    Ok(Redirect::to(&format!(
        "{}?notice={}",
        views::machine_href(&id),
        views::encode("baseline set")
    ))
    .into_response())
}

fn bad_document(r: &StoredResult, e: serde_json::Error) -> WebError {
    WebError(ApiError::Conflict(format!(
        "result {} of kind {} does not read as its document: {e}; exclude it and run the \
         check again",
        r.meta.id, r.meta.kind
    )))
}

/// `/results/{id}`.
pub async fn result(
    session: Session,
    State(s): State<WebState>,
    Path(id): Path<String>,
) -> PageResult {
    let app = &s.app;
    let r = app.store.get_result(&id).await?;
    let m = app.store.get_machine(&r.meta.machine_id).await?;
    let ids = history::results(app.store.as_ref(), &m.id, None).await?;
    let verdict = verdicts::result_verdict(app.store.as_ref(), &id).await?;
    let verdict_table = verdict
        .verdict
        .as_ref()
        .map(vresult::verdict_rows)
        .unwrap_or_default();
    let mut header = vresult::ResultHeader {
        id: r.meta.id.clone(),
        machine_id: r.meta.machine_id.clone(),
        kind: r.meta.kind.clone(),
        measured_at: r.meta.measured_at.clone(),
        created_at: r.meta.created_at.clone(),
        dataset_id: r.meta.dataset_id.clone(),
        is_baseline: r.meta.kind == KIND
            && history::baseline(app.store.as_ref(), &m, &ids)
                .await?
                .is_some_and(|b| b.id == id),
        verdict: verdict
            .verdict
            .as_ref()
            .and_then(|v| v.decision)
            .map(|d| d.as_str().to_string()),
        profile: verdict
            .profile
            .as_ref()
            .map(|p| format!("{} {}", p.scope, p.target)),
        diagnosis: None,
    };
    let doc = &r.document;
    let viewer = session.viewer();
    let page = match r.meta.kind.as_str() {
        "identification" => {
            let stored = vresult::StoredIdentification::read(doc.clone())
                .map_err(|e| bad_document(&r, e))?;
            // A misfit's banner says what the diagnosis of its recording found: read only
            // then.
            if stored.doc.model_check().is_misfit()
                && let Some(ds) = &r.meta.dataset_id
                && let Some(d) =
                    history::diagnosis_of_dataset(app.store.as_ref(), &m.id, ds).await?
            {
                let doc = app.store.get_result(&d.id).await?.document;
                header.diagnosis = Some(findings_view(
                    mtcal_domain::fleet::entry::DiagnosisSummary::of(&d.id, doc),
                ));
            }
            let body =
                vresult::ResultBody::Identification(stored.view().with_limits(&verdict_table));
            vresult::result_page(&viewer, &header, &verdict_table, &body)
        }
        "diagnosis" => {
            // A positioning-run diagnosis carries its ISO 230-2 figures beside it.
            let d: mtcal_solver::positioning_check::DiagnosisDocument =
                serde_json::from_value(doc.clone()).map_err(|e| bad_document(&r, e))?;
            vresult::result_page(
                &viewer,
                &header,
                &verdict_table,
                &vresult::ResultBody::Diagnosis(&d),
            )
        }
        "cradle" => {
            let d = serde_json::from_value(doc.clone()).map_err(|e| bad_document(&r, e))?;
            vresult::result_page(
                &viewer,
                &header,
                &verdict_table,
                &vresult::ResultBody::Cradle(&d),
            )
        }
        "sensitivity" => {
            let d = serde_json::from_value(doc.clone()).map_err(|e| bad_document(&r, e))?;
            vresult::result_page(
                &viewer,
                &header,
                &verdict_table,
                &vresult::ResultBody::Sensitivity(&d),
            )
        }
        other => {
            return Err(WebError(ApiError::NotFound(format!(
                "no page for results of kind {other}"
            ))));
        }
    };
    Ok(html(page))
}

#[derive(Debug, Deserialize)]
pub struct CompareParams {
    a: String,
    b: String,
}

/// `/compare?a=&b=`: the diff route with `baseline=a&against=b`.
pub async fn compare(
    session: Session,
    State(s): State<WebState>,
    Query(q): Query<CompareParams>,
) -> PageResult {
    let app = &s.app;
    let a = app.store.get_result(&q.a).await?.meta;
    let d = history::diff(
        app.store.as_ref(),
        &a.machine_id,
        &DiffQuery {
            baseline: Some(q.a.clone()),
            against: Some(q.b.clone()),
            step_mm: None,
        },
    )
    .await?;
    let (va, vb) = (
        verdict_word(app, &d.baseline.id).await?,
        verdict_word(app, &d.against.id).await?,
    );
    let side = |r: &ResultMeta, verdict: Option<String>| compare::Side {
        result_id: r.id.clone(),
        measured_at: r.measured_at.clone(),
        residual_rms_um: r.scalars.summary.residual_rms_um,
        rank: r.scalars.summary.rank,
        verdict,
    };
    let sq = |r: &ResultMeta, name: &str| r.scalars.summary.squareness(name).flatten();
    let page = compare::ComparePage {
        machine_id: d.machine_id.clone(),
        a: side(&d.baseline, va),
        b: side(&d.against, vb),
        terms: d
            .terms
            .iter()
            .map(|(name, t)| compare::TermDiff {
                name: name.clone(),
                unit: t.unit.clone(),
                positions_mm: t.positions_mm.clone(),
                diff: t.delta.clone(),
                std: if t.u.len() == t.delta.len() {
                    t.u.clone()
                } else {
                    vec![f64::NAN; t.delta.len()]
                },
                not_compared: (!t.identifiable)
                    .then(|| "not identifiable in one of the two checks".to_string()),
            })
            .collect(),
        squareness: ["EC0Y", "EB0Z", "EA0Z"]
            .iter()
            .map(|n| {
                let (ua, ub) = (
                    domain_trends::squareness_u(&d.baseline.scalars, n),
                    domain_trends::squareness_u(&d.against.scalars, n),
                );
                compare::SquarenessDiff {
                    name: n.to_string(),
                    a: (sq(&d.baseline, n), ua),
                    b: (sq(&d.against, n), ub),
                    diff: (
                        d.squareness.get(*n).copied().flatten(),
                        ua.zip(ub).map(|(a, b)| a.hypot(b)),
                    ),
                }
            })
            .collect(),
    };
    Ok(html(compare::compare_page(&session.viewer(), &page)))
}

/// `POST /machines/{id}/upload` (multipart: `csrf` first, then `files`, optionally
/// `diagnose`): the dataset upload of the API, then the job its kind calls for
/// (`identify` for a session, and `diagnose` too when asked; `cradle` for a rotary point
/// set; `diagnose` for positioning runs and drift logs), then back to the machine page
/// watching the jobs.
pub async fn upload(
    session: Session,
    State(s): State<WebState>,
    Path(id): Path<String>,
    req: Request,
) -> PageResult {
    let app = &s.app;
    let mut mp = Multipart::from_request(req, &s)
        .await
        .map_err(|r| ApiError::from_rejection(r.status(), r.body_text()))?;
    let bad = |e: axum::extract::multipart::MultipartError| {
        WebError(ApiError::from_rejection(e.status(), e.body_text()))
    };
    // The token comes first in the form: nothing else is read without it.
    let first = mp.next_field().await.map_err(bad)?;
    let token = match first {
        Some(f) if f.name() == Some("csrf") => f.text().await.map_err(bad)?,
        _ => String::new(),
    };
    session.check_csrf(&token)?;
    session.require_write()?;
    let machine = app.store.get_machine(&id).await?;
    let mut files = vec![];
    let mut diagnose = false;
    let mut dialect = mtcal_formats::CsvDialect::Plain;
    while let Some(field) = mp.next_field().await.map_err(bad)? {
        match field.name() {
            Some("diagnose") => diagnose = true,
            Some("csv_dialect") => {
                let text = field.text().await.map_err(bad)?;
                dialect = mtcal_formats::CsvDialect::parse(&text).ok_or_else(|| {
                    WebError(ApiError::InvalidRequest(format!(
                        "csv_dialect: {text:?} is neither plain nor excel"
                    )))
                })?;
            }
            Some("files") => {
                let name = field.file_name().unwrap_or_default().to_string();
                let bytes = field.bytes().await.map_err(bad)?;
                if !name.is_empty() {
                    files.push((name, bytes.to_vec()));
                }
            }
            _ => {}
        }
    }
    if files.is_empty() {
        return Err(WebError(ApiError::InvalidRequest(
            "choose the files of one dataset to upload".into(),
        )));
    }
    let dataset = crate::api::datasets::store_upload(app, machine, files, dialect).await?;
    let kinds: Vec<JobKind> = match dataset.kind.as_str() {
        "session" if diagnose => vec![JobKind::Identify, JobKind::Diagnose],
        "session" => vec![JobKind::Identify],
        "rotary_points" => vec![JobKind::Cradle],
        _ => vec![JobKind::Diagnose],
    };
    let mut ids = vec![];
    for kind in kinds {
        let job = api_jobs::submit_job(
            app,
            SubmitJob {
                kind,
                dataset_id: Some(dataset.id.clone()),
                machine_id: None,
                params: serde_json::Value::Null,
            },
            &session.key,
        )
        .await?;
        ids.push(job.id);
    }
    Ok(Redirect::to(&format!(
        "{}?jobs={}",
        views::machine_href(&id),
        views::encode(&ids.join(","))
    ))
    .into_response())
}

#[derive(Debug, Deserialize, Default)]
pub struct AlertsParams {
    machine: Option<String>,
    /// `active` (default), `acknowledged` or `all`.
    state: Option<String>,
}

/// `/alerts`: the alert list route.
pub async fn alerts(
    session: Session,
    State(s): State<WebState>,
    Query(q): Query<AlertsParams>,
) -> PageResult {
    let machine = q.machine.filter(|m| !m.trim().is_empty());
    let state = q.state.unwrap_or_else(|| "active".into());
    let active = match state.as_str() {
        "active" => Some(true),
        "acknowledged" => Some(false),
        "all" => None,
        other => {
            return Err(WebError(ApiError::InvalidRequest(format!(
                "state: active, acknowledged or all, got {other:?}"
            ))));
        }
    };
    let list = crate::api::alerts::list_within(
        &s.app,
        &AlertQuery {
            machine: machine.clone(),
            active,
            limit: Some(MAX_ALERTS),
        },
        &session.key,
    )
    .await?;
    let page = valerts::AlertsPage {
        alerts: list.iter().map(alert_row).collect(),
        machine,
        state,
    };
    Ok(html(valerts::alerts_page(&session.viewer(), &page)))
}

#[derive(Debug, Deserialize)]
pub struct AckForm {
    /// Missing reads as empty: refused by the token check (403), like a wrong one.
    #[serde(default)]
    csrf: String,
    next: Option<String>,
    /// Why, what was done (optional).
    comment: Option<String>,
}

/// `POST /alerts/{id}/ack`: the acknowledge route of the API, then back to `next`.
pub async fn ack_alert(
    session: Session,
    client: crate::audit::Client,
    State(s): State<WebState>,
    Path(id): Path<String>,
    Form(f): Form<AckForm>,
) -> PageResult {
    session.check_csrf(&f.csrf)?;
    session.require_write()?;
    let who = session.actor(client);
    crate::api::alerts::acknowledge(&s.app, &id, &who, f.comment.as_deref()).await?;
    Ok(Redirect::to(&super::local_path(f.next.as_deref())).into_response())
}

#[derive(Debug, Deserialize, Default)]
pub struct JobsParams {
    state: Option<String>,
}

/// `/jobs`: the job list route (newest first, by state).
pub async fn jobs(
    session: Session,
    State(s): State<WebState>,
    Query(q): Query<JobsParams>,
) -> PageResult {
    let state = q.state.unwrap_or_default();
    let list = api_jobs::list_jobs(
        &s.app,
        &api_jobs::JobListQuery {
            state: Some(state.clone()),
            limit: Some(api_jobs::MAX_JOBS),
        },
        &session.key,
    )
    .await?;
    let rows = job_rows(&s.app, &list).await;
    Ok(html(vjobs::jobs_page(&session.viewer(), &rows, &state)))
}
