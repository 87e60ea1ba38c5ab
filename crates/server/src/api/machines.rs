//! `/api/v1/machines`: register, read, update, list.

use crate::AppState;
use crate::auth::{ReadKey, WriteKey};
use crate::error::{ApiError, ApiJson, ApiQuery, ErrorBody};
use axum::Json;
use axum::extract::{Path, State};
use axum::http::StatusCode;
use mtcal_store::{Machine, MachinePatch};
use serde::Deserialize;
use utoipa::IntoParams;

pub use mtcal_domain::machines::{MAX_TRAVEL_MM, NewMachine};

#[utoipa::path(operation_id = "machines_create", summary = "Register a machine", post, path = "/api/v1/machines", tag = "machines", request_body = NewMachine,
    security(("api_key" = ["write"])),
    responses((status = 201, body = Machine), (status = 400, body = ErrorBody),
               (status = 409, body = ErrorBody)))]
pub async fn create(
    _key: WriteKey,
    State(s): State<AppState>,
    ApiJson(m): ApiJson<NewMachine>,
) -> Result<(StatusCode, Json<Machine>), ApiError> {
    Ok((
        StatusCode::CREATED,
        Json(mtcal_domain::machines::create(s.store.as_ref(), m).await?),
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
pub async fn update_machine(s: &AppState, id: &str, p: MachinePatch) -> Result<Machine, ApiError> {
    Ok(mtcal_domain::machines::update(s.store.as_ref(), id, p).await?)
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
