//! Trends: a term's value at chosen positions over time, summary figures over time, a
//! named figure of the standards over time, and the fleet ranked by drift since each
//! machine's baseline (rules: [`mtcal_domain::trends`], [`mtcal_domain::fleet`]).

use crate::AppState;
use crate::auth::ReadKey;
use crate::error::{ApiError, ApiQuery, ErrorBody};
use axum::Json;
use axum::extract::{Path, State};
pub use mtcal_domain::fleet::{FleetDrift, FleetEntry, FleetQuery};
use mtcal_domain::trends;
pub use mtcal_domain::trends::{
    DRIFT_DEFINITION, SummaryPoint, SummaryTrend, TermPoint, TermQuery, TermTrend,
};
use mtcal_store::FigurePoint;
use serde::{Deserialize, Serialize};
use utoipa::{IntoParams, ToSchema};

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
    Ok(Json(
        trends::term_trend(s.store.as_ref(), &id, q, None).await?,
    ))
}

#[utoipa::path(operation_id = "trends_verification", summary = "Each check verified against the predictions of the check before it, over time", get, path = "/api/v1/machines/{id}/trends/verification", tag = "trends",
    security(("api_key" = [])), params(("id" = String, Path)),
    responses((status = 200, body = Vec<crate::api::history::Verification>, description = "in time order, the checks whose previous check had a finding \
                                                                                          with a predicted residual after compensation"),
              (status = 404, body = ErrorBody)))]
pub async fn verification(
    _key: ReadKey,
    State(s): State<AppState>,
    Path(id): Path<String>,
) -> Result<Json<Vec<crate::api::history::Verification>>, ApiError> {
    Ok(Json(
        mtcal_domain::verification::verifications(s.store.as_ref(), &id).await?,
    ))
}

#[utoipa::path(operation_id = "trends_summary", summary = "Summary figures and squareness over time", get, path = "/api/v1/machines/{id}/trends/summary", tag = "trends",
    security(("api_key" = [])), params(("id" = String, Path)),
    responses((status = 200, body = SummaryTrend), (status = 404, body = ErrorBody)))]
pub async fn summary(
    _key: ReadKey,
    State(s): State<AppState>,
    Path(id): Path<String>,
) -> Result<Json<SummaryTrend>, ApiError> {
    Ok(Json(
        trends::summary_trend(s.store.as_ref(), &id, None).await?,
    ))
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
    pub points: Vec<FigureTrendPoint>,
    /// Every figure name stored for the machine (when no name was given).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub names: Vec<String>,
}

/// One result's value of a figure, and what it says of its check's model (an
/// identification's; a `standards` result has no model and says nothing).
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
pub struct FigureTrendPoint {
    #[serde(flatten)]
    pub point: FigurePoint,
    /// A misfit, or decided on the explained model.
    #[serde(flatten)]
    pub model: mtcal_domain::trends::CheckModel,
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
    let points = s.store.figure_trend(&id, &name).await?;
    let checks = s
        .store
        .list_results(&id, mtcal_domain::kinds::IDENTIFICATION)
        .await?;
    let carry: std::collections::HashSet<&str> =
        points.iter().map(|p| p.result_id.as_str()).collect();
    let checks: Vec<_> = checks
        .into_iter()
        .filter(|c| carry.contains(c.id.as_str()))
        .collect();
    let models = mtcal_domain::trends::check_models(s.store.as_ref(), &checks).await?;
    let points = points
        .into_iter()
        .map(|point| FigureTrendPoint {
            model: models.get(&point.result_id).cloned().unwrap_or_default(),
            point,
        })
        .collect();
    Ok(Json(FigureTrend {
        points,
        machine_id: id,
        name: Some(name),
        names: vec![],
    }))
}

#[utoipa::path(operation_id = "trends_fleet", summary = "The fleet ranked by drift since each machine's baseline", get, path = "/api/v1/fleet/drift", tag = "trends",
    security(("api_key" = [])), params(FleetQuery),
    responses((status = 200, body = FleetDrift), (status = 400, body = ErrorBody)))]
pub async fn fleet(
    ReadKey(key): ReadKey,
    State(s): State<AppState>,
    ApiQuery(q): ApiQuery<FleetQuery>,
) -> Result<Json<FleetDrift>, ApiError> {
    let within = crate::auth::scope::Within(&key).machine_ids(&s).await?;
    Ok(Json(
        mtcal_domain::fleet::entry::ranked(s.store.as_ref(), q, within.as_ref()).await?,
    ))
}
