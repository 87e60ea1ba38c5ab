//! `GET /api/v1/fleet`: the fleet as the dashboard's fleet page shows it, a page at a
//! time ([`mtcal_domain::fleet::page`]: every machine with its last check, its verdict,
//! its drift with the uncertainty, its sparkline and its active alerts; filtered by site
//! and tag; machines with active alerts first, then in the order asked).

use crate::AppState;
use crate::auth::ReadKey;
use crate::error::{ApiError, ApiQuery, ErrorBody};
use axum::Json;
use axum::extract::State;
pub use mtcal_domain::fleet::page::{DEFAULT_LIMIT, MAX_LIMIT};
pub use mtcal_domain::fleet::{FleetList, FleetMachine, FleetParams, LastCheck};

#[utoipa::path(operation_id = "fleet_list", summary = "The fleet, a page at a time: machines with active alerts first, filtered by site and tag, sorted", get, path = "/api/v1/fleet", tag = "trends",
    security(("api_key" = [])), params(FleetParams),
    responses((status = 200, body = FleetList), (status = 400, body = ErrorBody)))]
pub async fn list(
    ReadKey(key): ReadKey,
    State(s): State<AppState>,
    ApiQuery(q): ApiQuery<FleetParams>,
) -> Result<Json<FleetList>, ApiError> {
    Ok(Json(
        mtcal_domain::fleet::page::page(s.store.as_ref(), &s.fleet_counts, &q, &key).await?,
    ))
}
