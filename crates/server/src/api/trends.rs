//! Trends: a term's value at chosen positions over time, summary figures over time, a
//! named figure of the standards over time, and the fleet ranked by drift since each
//! machine's baseline.

use crate::AppState;
use crate::api::history::KIND;
use crate::auth::ReadKey;
use crate::error::{ApiError, ApiQuery, ErrorBody};
use crate::trends::{self, Drift};
use axum::Json;
use axum::extract::{Path, State};
use mtcal_store::{FigurePoint, ResultMeta, SkippedRow};
use serde::{Deserialize, Serialize};
use utoipa::{IntoParams, ToSchema};

#[derive(Debug, Deserialize, IntoParams)]
#[into_params(parameter_in = Query)]
pub struct TermQuery {
    /// ISO 230-1 name of one of the 18 functions, e.g. `EXX`.
    #[param(pattern = "^E[XYZABC][XYZ]$")]
    pub term: String,
    /// Positions, mm, comma-separated, e.g. `50,-50`.
    pub at: String,
}

#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
pub struct TermPoint {
    pub result_id: String,
    pub measured_at: String,
    /// Value at each position (`um` or `urad`); null when the term was not identifiable
    /// in this check or the position lies outside the travel it measured.
    pub values: Vec<Option<f64>>,
    /// Standard uncertainty of each value (from the check's stored covariance); null
    /// where the value is null or no covariance is stored.
    pub u: Vec<Option<f64>>,
}

#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
pub struct TermTrend {
    pub machine_id: String,
    pub term: String,
    pub unit: String,
    pub positions_mm: Vec<f64>,
    /// In time order.
    pub points: Vec<TermPoint>,
    /// Stored results left out because their rows do not decode, one sentence each
    /// naming the result (absent when none).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub warnings: Vec<String>,
}

#[utoipa::path(operation_id = "trends_term", summary = "A term's value at chosen positions over time", get, path = "/api/v1/machines/{id}/trends/term", tag = "trends",
    security(("api_key" = [])), params(("id" = String, Path), TermQuery),
    responses((status = 200, body = TermTrend), (status = 400, body = ErrorBody),
              (status = 404, body = ErrorBody), (status = 422, body = ErrorBody, description = "a position outside the travel every check measured")))]
pub async fn term(
    _key: ReadKey,
    State(s): State<AppState>,
    Path(id): Path<String>,
    ApiQuery(q): ApiQuery<TermQuery>,
) -> Result<Json<TermTrend>, ApiError> {
    Ok(Json(term_trend(&s, &id, q).await?))
}

/// A term at positions over time (`GET …/trends/term`; the dashboard's machine page
/// too).
pub async fn term_trend(s: &AppState, id: &str, q: TermQuery) -> Result<TermTrend, ApiError> {
    let (unit, _) = trends::term_info(&q.term).ok_or_else(|| {
        let hint = if matches!(q.term.as_str(), "EC0Y" | "EB0Z" | "EA0Z") {
            " (a squareness error, a constant: its trend is in \
             GET /api/v1/machines/{id}/trends/summary)"
        } else {
            ""
        };
        ApiError::InvalidRequest(format!(
            "term {:?} is not one of the 18 ISO 230-1 functions{hint}",
            q.term
        ))
    })?;
    let positions =
        q.at.split(',')
            .map(|p| p.trim().parse::<f64>().ok().filter(|x| x.is_finite()))
            .collect::<Option<Vec<_>>>()
            .filter(|v| !v.is_empty() && v.len() <= 1000)
            .ok_or_else(|| {
                ApiError::InvalidRequest(format!(
                    "at {:?}: give 1-1000 comma-separated positions in mm",
                    q.at
                ))
            })?;
    s.store.get_machine(id).await?;
    let (results, skipped) = s.store.list_results_checked(id, KIND).await?;
    let (id, warnings) = (
        id.to_string(),
        skipped.iter().map(SkippedRow::warning).collect(),
    );
    crate::blocking::run::<_, ApiError>(move || {
        evaluate_term(id, q.term, unit, positions, results, warnings)
    })
    .await?
}

/// The term trend's arithmetic (blocking): term `term` (in `unit`) of each of the
/// machine's `results` at `positions`, refused where no check with the term measured.
fn evaluate_term(
    id: String,
    term: String,
    unit: &str,
    positions: Vec<f64>,
    results: Vec<ResultMeta>,
    warnings: Vec<String>,
) -> Result<TermTrend, ApiError> {
    // A position no check with this term measured is refused, saying where they measured.
    let axis = trends::term_info(&term).map_or('X', |(_, a)| a);
    let with_term: Vec<_> = results
        .iter()
        .filter(|r| r.scalars.term_coefficients.contains_key(&term))
        .collect();
    for &p in &positions {
        let inside = |r: &&ResultMeta| trends::measured_at(&r.scalars, axis, p);
        if !with_term.is_empty() && !with_term.iter().any(inside) {
            let latest = with_term.last().expect("not empty");
            return Err(ApiError::OutsideTravel(format!(
                "{} at {p} mm: outside the travel every check of machine {id} measured (in the \
                 latest, {}); terms are not evaluated where they were not measured",
                term,
                trends::travel_sentence(&latest.scalars, axis)
            )));
        }
    }
    let points = results
        .into_iter()
        .map(|r| {
            let at: Vec<_> = positions
                .iter()
                .map(|&p| trends::value(&r.scalars, &term, p))
                .collect();
            TermPoint {
                values: at.iter().map(|v| Some(v.as_ref()?.value)).collect(),
                u: at.iter().map(|v| v.as_ref()?.u).collect(),
                result_id: r.id,
                measured_at: r.measured_at,
            }
        })
        .collect();
    Ok(TermTrend {
        machine_id: id,
        term,
        unit: unit.into(),
        positions_mm: positions,
        points,
        warnings,
    })
}

#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
pub struct SummaryPoint {
    pub result_id: String,
    pub measured_at: String,
    pub residual_rms_um: Option<f64>,
    pub condition_number: Option<f64>,
    pub rank: Option<i64>,
    pub ec0y_urad: Option<f64>,
    pub eb0z_urad: Option<f64>,
    pub ea0z_urad: Option<f64>,
    /// Standard uncertainties of the three squareness errors, µrad (from the check's
    /// stored covariance; null where none is stored).
    pub ec0y_u_urad: Option<f64>,
    pub eb0z_u_urad: Option<f64>,
    pub ea0z_u_urad: Option<f64>,
}

#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
pub struct SummaryTrend {
    pub machine_id: String,
    /// In time order.
    pub points: Vec<SummaryPoint>,
    /// Stored results left out because their rows do not decode, one sentence each
    /// naming the result (absent when none).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub warnings: Vec<String>,
}

#[utoipa::path(operation_id = "trends_summary", summary = "Summary figures and squareness over time", get, path = "/api/v1/machines/{id}/trends/summary", tag = "trends",
    security(("api_key" = [])), params(("id" = String, Path)),
    responses((status = 200, body = SummaryTrend), (status = 404, body = ErrorBody)))]
pub async fn summary(
    _key: ReadKey,
    State(s): State<AppState>,
    Path(id): Path<String>,
) -> Result<Json<SummaryTrend>, ApiError> {
    Ok(Json(summary_trend(&s, &id).await?))
}

/// Residual, conditioning, rank and squareness over time (`GET …/trends/summary`; the
/// dashboard's machine page too).
pub async fn summary_trend(s: &AppState, id: &str) -> Result<SummaryTrend, ApiError> {
    s.store.get_machine(id).await?;
    let (results, skipped) = s.store.list_results_checked(id, KIND).await?;
    let points = results
        .into_iter()
        .map(|r| SummaryPoint {
            result_id: r.id,
            measured_at: r.measured_at,
            residual_rms_um: r.scalars.residual_rms_um,
            condition_number: r.scalars.condition_number,
            rank: r.scalars.rank,
            ec0y_urad: r.scalars.ec0y_urad,
            eb0z_urad: r.scalars.eb0z_urad,
            ea0z_urad: r.scalars.ea0z_urad,
            ec0y_u_urad: crate::trends::squareness_u(&r.scalars, "EC0Y"),
            eb0z_u_urad: crate::trends::squareness_u(&r.scalars, "EB0Z"),
            ea0z_u_urad: crate::trends::squareness_u(&r.scalars, "EA0Z"),
        })
        .collect();
    Ok(SummaryTrend {
        machine_id: id.to_string(),
        points,
        warnings: skipped.iter().map(SkippedRow::warning).collect(),
    })
}

#[derive(Debug, Deserialize, IntoParams)]
#[into_params(parameter_in = Query)]
pub struct FigureQuery {
    /// Figure name, e.g. `iso230_2.X.E_um` or `iso230_4.XY.bi.H_um` (docs/standards.md);
    /// absent: list the names stored for the machine.
    #[param(pattern = "^[A-Za-z0-9_.]{1,128}$")]
    pub name: Option<String>,
}

#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
pub struct FigureTrend {
    pub machine_id: String,
    /// The figure, or null when the names are listed.
    pub name: Option<String>,
    /// In time order, from results of every kind that carry the figure
    /// (`identification`, `standards`).
    pub points: Vec<FigurePoint>,
    /// Every figure name stored for the machine (when no name was given).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub names: Vec<String>,
}

#[utoipa::path(operation_id = "trends_figure", summary = "One figure of the standards over time", get, path = "/api/v1/machines/{id}/trends/figure", tag = "trends",
    security(("api_key" = [])), params(("id" = String, Path), FigureQuery),
    responses((status = 200, body = FigureTrend), (status = 400, body = ErrorBody),
              (status = 404, body = ErrorBody)))]
pub async fn figure(
    _key: ReadKey,
    State(s): State<AppState>,
    Path(id): Path<String>,
    ApiQuery(q): ApiQuery<FigureQuery>,
) -> Result<Json<FigureTrend>, ApiError> {
    s.store.get_machine(&id).await?;
    let Some(name) = q.name else {
        return Ok(Json(FigureTrend {
            names: s.store.figure_names(&id).await?,
            machine_id: id,
            name: None,
            points: vec![],
        }));
    };
    if !mtcal_store::rules::valid_figure_name(&name) {
        return Err(ApiError::InvalidRequest(format!(
            "name {name:?}: a figure name such as iso230_2.X.E_um"
        )));
    }
    Ok(Json(FigureTrend {
        points: s.store.figure_trend(&id, &name).await?,
        machine_id: id,
        name: Some(name),
        names: vec![],
    }))
}

#[derive(Debug, Deserialize, IntoParams)]
#[into_params(parameter_in = Query)]
pub struct FleetQuery {
    /// `um` (translational drift, default) or `urad` (angular and squareness).
    #[param(pattern = "^(um|urad)$")]
    pub by: Option<String>,
    /// At most this many machines (default 50).
    pub limit: Option<usize>,
}

#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
pub struct FleetEntry {
    pub machine_id: String,
    pub name: String,
    pub site: Option<String>,
    pub baseline_result_id: String,
    pub latest_result_id: String,
    pub latest_measured_at: String,
    pub results: i64,
    #[serde(flatten)]
    pub drift: Drift,
    /// The latest result's verdict against the machine's tolerance profile (null: no
    /// profile applies, or none of its limits applies to the result).
    #[serde(default)]
    pub verdict: Option<mtcal_solver::tolerance::Decision>,
    /// The tolerance profile the verdict is against.
    #[serde(default)]
    pub tolerance_profile_id: Option<String>,
    /// The worst µm term's value in each check, in time order, at the end of the latest
    /// check's measured travel where it changed more (null: not identified or not
    /// measured there); the fleet page's sparkline.
    #[serde(default)]
    pub sparkline: Vec<Option<f64>>,
}

#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
pub struct FleetDrift {
    /// How drift is measured (see the trends module).
    pub definition: String,
    pub ranked_by: String,
    pub machines: Vec<FleetEntry>,
    /// Machines left out because their stored drift does not decode, one sentence each
    /// naming the result (absent when none).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub warnings: Vec<String>,
}

#[utoipa::path(operation_id = "trends_fleet", summary = "The fleet ranked by drift since each machine's baseline", get, path = "/api/v1/fleet/drift", tag = "trends",
    security(("api_key" = [])), params(FleetQuery),
    responses((status = 200, body = FleetDrift), (status = 400, body = ErrorBody)))]
pub async fn fleet(
    _key: ReadKey,
    State(s): State<AppState>,
    ApiQuery(q): ApiQuery<FleetQuery>,
) -> Result<Json<FleetDrift>, ApiError> {
    Ok(Json(fleet_drift(&s, q).await?))
}

/// How drift is measured, in words (the fleet route and page say it).
pub const DRIFT_DEFINITION: &str = "largest change since the baseline result (the machine's \
     chosen baseline, else its first) of any term over 41 points of the travel both checks \
     measured, with its standard uncertainty there";

/// The fleet ranked by drift (`GET /api/v1/fleet/drift`).
pub async fn fleet_drift(s: &AppState, q: FleetQuery) -> Result<FleetDrift, ApiError> {
    let by = q.by.unwrap_or_else(|| "um".into());
    if by != "um" && by != "urad" {
        return Err(ApiError::InvalidRequest("by: `um` or `urad`".into()));
    }
    // Maintained as results land and baselines change (crate::fleet); ranked by the
    // database.
    // A stored entry that does not decode (written by an older version) is left out
    // and named, not a 500 for the whole fleet.
    let (mut machines, mut warnings) = (Vec::new(), Vec::new());
    for (row, name, site) in s
        .store
        .fleet_drift_ranked(by == "um", q.limit.unwrap_or(50).clamp(1, 100_000))
        .await?
    {
        match serde_json::from_value::<FleetEntry>(row.entry) {
            Ok(mut e) => {
                e.name = name;
                e.site = site;
                machines.push(e);
            }
            Err(e) => warnings.push(format!(
                "machine {} skipped: its stored drift does not decode ({e})",
                row.machine_id
            )),
        }
    }
    Ok(FleetDrift {
        definition: DRIFT_DEFINITION.into(),
        ranked_by: by,
        machines,
        warnings,
    })
}
