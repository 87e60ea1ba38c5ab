//! The webhook outbox as the API shows it: each drift alert's deliveries with their
//! state (rules: [`mtcal_domain::webhooks`]).

use crate::AppState;
use crate::auth::WriteKey;
use crate::error::{ApiError, ApiQuery, ErrorBody};
use axum::Json;
use axum::extract::State;
pub use mtcal_domain::webhooks::{DeliveryQuery, DeliveryState, DeliveryView, MAX_DELIVERIES};

#[utoipa::path(operation_id = "webhook_deliveries", summary = "Webhook deliveries of drift alerts, newest first, with their state", get, path = "/api/v1/webhooks/deliveries", tag = "alerts",
    security(("api_key" = ["write"])), params(DeliveryQuery),
    responses((status = 200, body = Vec<DeliveryView>), (status = 400, body = ErrorBody), (status = 401, body = ErrorBody),
              (status = 403, body = ErrorBody)))]
pub async fn deliveries(
    WriteKey(key): WriteKey,
    State(s): State<AppState>,
    ApiQuery(q): ApiQuery<DeliveryQuery>,
) -> Result<Json<Vec<DeliveryView>>, ApiError> {
    let Some(ids) = crate::auth::scope::Within(&key).machine_ids(&s).await? else {
        return Ok(Json(
            mtcal_domain::webhooks::list(s.store.as_ref(), &q).await?,
        ));
    };
    // A scoped key: the deliveries of its machines' alerts among the newest.
    let limit = mtcal_domain::paging::limit(q.limit, 100, MAX_DELIVERIES)?;
    let wide = DeliveryQuery {
        limit: Some(MAX_DELIVERIES),
        ..q.clone()
    };
    let mut mine = std::collections::HashMap::new();
    let mut out = Vec::new();
    for d in mtcal_domain::webhooks::list(s.store.as_ref(), &wide).await? {
        if !mine.contains_key(&d.alert_id) {
            let a = s.store.get_alert(&d.alert_id).await?;
            mine.insert(d.alert_id.clone(), ids.contains(&a.raised.machine_id));
        }
        if mine[&d.alert_id] && out.len() < limit {
            out.push(d);
        }
    }
    Ok(Json(out))
}
