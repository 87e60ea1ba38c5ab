//! `/api/v1/machines`: register, read, update, list.

use crate::AppState;
use crate::auth::{ReadKey, WriteKey};
use crate::error::{ApiError, ApiJson, ApiQuery, ErrorBody};
use axum::Json;
use axum::extract::{Path, State};
use axum::http::StatusCode;
use mtcal_solver::axis::Topology;
use mtcal_store::{Machine, MachinePatch};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use utoipa::{IntoParams, ToSchema};

/// A machine to register.
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct NewMachine {
    /// 1–64 characters: letters, digits, '.', '_', '-' (not `.` or `..`).
    #[schema(pattern = "^(?!\\.{1,2}$)[A-Za-z0-9._-]{1,64}$")]
    pub id: String,
    /// Not blank, at most 200 characters, no control character.
    #[schema(
        max_length = 200,
        pattern = "^[^\\u0000-\\u001f\\u007f-\\u009f]*[^\\s\\u0000-\\u001f\\u007f-\\u009f][^\\u0000-\\u001f\\u007f-\\u009f]*$"
    )]
    pub name: String,
    /// Axes on the workpiece and tool sides (default `{"workpiece": ["X", "Y"], "tool": ["Z"]}`).
    #[schema(value_type = Option<Object>)]
    pub topology: Option<serde_json::Value>,
    /// Travel per axis, mm, e.g. `{"X": [-250, 250]}`.
    #[serde(default)]
    pub travel_mm: BTreeMap<String, [f64; 2]>,
    /// Not blank, at most 100 characters, no control character.
    #[schema(
        max_length = 100,
        pattern = "^[^\\u0000-\\u001f\\u007f-\\u009f]*[^\\s\\u0000-\\u001f\\u007f-\\u009f][^\\u0000-\\u001f\\u007f-\\u009f]*$"
    )]
    pub site: Option<String>,
    /// At most 32, each not blank, at most 64 characters, none twice.
    #[serde(default)]
    #[schema(max_items = 32)]
    pub tags: Vec<String>,
}

/// Checks and normalises a topology given as JSON.
fn topology(v: Option<&serde_json::Value>) -> Result<serde_json::Value, ApiError> {
    let t: Topology = match v {
        None => Topology::default(),
        Some(v) => serde_json::from_value(v.clone())
            .map_err(|e| ApiError::InvalidRequest(format!("topology: {e}")))?,
    };
    let mut all: Vec<_> = t.workpiece.iter().chain(&t.tool).collect();
    all.sort();
    all.dedup();
    if all.len() != 3 || t.workpiece.len() + t.tool.len() != 3 {
        return Err(ApiError::InvalidRequest(
            "topology: X, Y and Z must each appear exactly once".into(),
        ));
    }
    Ok(serde_json::to_value(t).expect("topology serialises"))
}

/// Largest |travel end| accepted, mm (100 m: beyond any machine tool's axis).
pub const MAX_TRAVEL_MM: f64 = 100_000.0;

fn check_travel(travel: &BTreeMap<String, [f64; 2]>) -> Result<(), ApiError> {
    for (axis, [lo, hi]) in travel {
        let ordered = lo.is_finite() && hi.is_finite() && lo < hi;
        let bounded = lo.abs() <= MAX_TRAVEL_MM && hi.abs() <= MAX_TRAVEL_MM;
        if !matches!(axis.as_str(), "X" | "Y" | "Z") || !ordered || !bounded {
            return Err(ApiError::InvalidRequest(format!(
                "travel_mm.{axis}: needs axis X, Y or Z and finite [min, max] with min < max \
                 and |min|, |max| <= {MAX_TRAVEL_MM} mm"
            )));
        }
    }
    Ok(())
}

#[utoipa::path(operation_id = "machines_create", summary = "Register a machine", post, path = "/api/v1/machines", tag = "machines", request_body = NewMachine,
    security(("api_key" = ["write"])),
    responses((status = 201, body = Machine), (status = 400, body = ErrorBody),
               (status = 409, body = ErrorBody)))]
pub async fn create(
    _key: WriteKey,
    State(s): State<AppState>,
    ApiJson(m): ApiJson<NewMachine>,
) -> Result<(StatusCode, Json<Machine>), ApiError> {
    mtcal_store::text::check_id("id", &m.id)?;
    check_travel(&m.travel_mm)?;
    let machine = Machine {
        id: m.id,
        name: m.name,
        topology: topology(m.topology.as_ref())?,
        travel_mm: m.travel_mm,
        site: m.site,
        tags: m.tags,
        baseline_result_id: None,
        created_at: String::new(),
        updated_at: String::new(),
    };
    Ok((
        StatusCode::CREATED,
        Json(s.store.create_machine(&machine).await?),
    ))
}

#[utoipa::path(operation_id = "machines_get", summary = "A machine", get, path = "/api/v1/machines/{id}", tag = "machines",
    security(("api_key" = [])), params(("id" = String, Path)),
    responses((status = 200, body = Machine), (status = 404, body = ErrorBody)))]
pub async fn get(
    _key: ReadKey,
    State(s): State<AppState>,
    Path(id): Path<String>,
) -> Result<Json<Machine>, ApiError> {
    Ok(Json(s.store.get_machine(&id).await?))
}

#[utoipa::path(operation_id = "machines_update", summary = "Update a machine (name, travel, site, tags, baseline)", patch, path = "/api/v1/machines/{id}", tag = "machines", request_body = MachinePatch,
    security(("api_key" = ["write"])), params(("id" = String, Path)),
    responses((status = 200, body = Machine), (status = 404, body = ErrorBody),
              (status = 409, body = ErrorBody, description = "the baseline named is a result of another machine")))]
pub async fn update(
    _key: WriteKey,
    State(s): State<AppState>,
    Path(id): Path<String>,
    ApiJson(p): ApiJson<MachinePatch>,
) -> Result<Json<Machine>, ApiError> {
    Ok(Json(update_machine(&s, &id, p).await?))
}

/// Checks and applies a patch (`PATCH /api/v1/machines/{id}`; the dashboard's baseline
/// form too).
pub async fn update_machine(
    s: &AppState,
    id: &str,
    mut p: MachinePatch,
) -> Result<Machine, ApiError> {
    if let Some(t) = &p.topology {
        p.topology = Some(topology(Some(t))?);
    }
    if let Some(t) = &p.travel_mm {
        check_travel(t)?;
    }
    // The fleet row depends on the baseline, the tags (which tolerance profile applies)
    // and the name and site its entry repeats.
    let row_changes =
        p.baseline_result_id.is_some() || p.tags.is_some() || p.name.is_some() || p.site.is_some();
    let m = s.store.update_machine(id, &p).await?;
    if row_changes {
        mtcal_domain::fleet::refresh_machine(s.store.as_ref(), id).await?;
    }
    Ok(m)
}

/// Most machines one list returns.
pub const MAX_MACHINES: usize = 1000;

#[derive(Debug, Deserialize, IntoParams)]
#[into_params(parameter_in = Query)]
pub struct ListQuery {
    /// Return machines whose id sorts after this one (pagination).
    pub after: Option<String>,
    /// At most this many (default 100, at most 1000).
    #[param(minimum = 1, maximum = 1000)]
    pub limit: Option<usize>,
}

#[utoipa::path(operation_id = "machines_list", summary = "List machines (keyset pagination)", get, path = "/api/v1/machines", tag = "machines", params(ListQuery),
    security(("api_key" = [])),
    responses((status = 200, body = Vec<Machine>)))]
pub async fn list(
    _key: ReadKey,
    State(s): State<AppState>,
    ApiQuery(q): ApiQuery<ListQuery>,
) -> Result<Json<Vec<Machine>>, ApiError> {
    let limit = mtcal_domain::paging::limit(q.limit, 100, MAX_MACHINES)?;
    Ok(Json(
        s.store
            .list_machines(q.after.as_deref(), limit as i64)
            .await?,
    ))
}
