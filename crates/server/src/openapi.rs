//! The OpenAPI document of API v1 ([`ApiDoc`], generated from the handlers by utoipa).

use crate::contract::Statuses;
use crate::{api, error, jobs};
use utoipa::OpenApi;
use utoipa::openapi::security::{HttpAuthScheme, HttpBuilder, SecurityScheme};

struct SecurityAddon;

impl utoipa::Modify for SecurityAddon {
    fn modify(&self, openapi: &mut utoipa::openapi::OpenApi) {
        let c = openapi.components.get_or_insert_with(Default::default);
        c.add_security_scheme(
            "api_key",
            SecurityScheme::Http(
                HttpBuilder::new()
                    .scheme(HttpAuthScheme::Bearer)
                    .description(Some("API key created with `mtcal admin create-key`"))
                    .build(),
            ),
        );
    }
}

/// The OpenAPI document of API v1.
#[derive(OpenApi)]
#[openapi(
    info(title = "mtcal calibration service", version = "1",
         description = "Machines, measurement datasets, jobs (identification), results, history and trends. \
                        Errors: `{\"error\": {\"code\", \"message\"}}` with stable codes (docs/api.md)."),
    paths(
        api::health,
        api::machines::create, api::machines::get, api::machines::update, api::machines::list,
        api::datasets::upload, api::datasets::list, api::datasets::get, api::datasets::file,
        api::datasets::exclude, api::datasets::delete_files,
        api::jobs::submit, api::jobs::list, api::jobs::get, api::jobs::result, api::jobs::cancel,
        api::history::list, api::history::latest, api::history::get, api::history::diff,
        api::history::figures, api::history::exclude, api::history::verification,
        api::exports::export, api::exports::report,
        api::trends::term, api::trends::summary, api::trends::verification, api::trends::figure, api::trends::fleet,
        api::fleet::list,
        api::keys::create, api::keys::list, api::keys::revoke,
        api::ready,
        api::tolerances::create, api::tolerances::list, api::tolerances::get,
        api::tolerances::replace, api::tolerances::delete, api::tolerances::verdict,
        api::alerts::list, api::alerts::ack, api::webhooks::deliveries,
    ),
    components(schemas(jobs::IdentifyParams, jobs::DiagnoseParams, error::ErrorBody)),
    modifiers(&SecurityAddon, &Statuses),
    tags((name = "machines"), (name = "datasets"), (name = "jobs"), (name = "history"),
         (name = "trends"), (name = "keys"), (name = "service"),
         (name = "tolerances", description = "Tolerance profiles and verdicts (ISO 14253-1 decision rule, U = 2u)"),
         (name = "alerts", description = "Drift alerts raised when a result lands"))
)]
pub struct ApiDoc;

/// The committed form of the OpenAPI document (`openapi/openapi.json`).
pub fn openapi_json() -> String {
    let mut s = ApiDoc::openapi()
        .to_pretty_json()
        .expect("the OpenAPI document serialises");
    s.push('\n');
    s
}
