//! The webhook outbox as the API shows it: each drift alert's deliveries with their
//! state (rules: [`mtcal_domain::webhooks`]).

use crate::AppState;
use crate::auth::WriteKey;
use crate::error::{ApiError, ApiQuery, ErrorBody};
use axum::Json;
use axum::extract::State;
pub use mtcal_domain::webhooks::{DeliveryQuery, DeliveryState, DeliveryView};

#[utoipa::path(operation_id = "webhook_deliveries", summary = "Webhook deliveries of drift alerts, newest first, with their state", get, path = "/api/v1/webhooks/deliveries", tag = "alerts",
    security(("api_key" = ["write"])), params(DeliveryQuery),
    responses((status = 200, body = Vec<DeliveryView>), (status = 400, body = ErrorBody), (status = 401, body = ErrorBody),
              (status = 403, body = ErrorBody)))]
pub async fn deliveries(
    _key: WriteKey,
    State(s): State<AppState>,
    ApiQuery(q): ApiQuery<DeliveryQuery>,
) -> Result<Json<Vec<DeliveryView>>, ApiError> {
    Ok(Json(
        mtcal_domain::webhooks::list(s.store.as_ref(), &q).await?,
    ))
}
