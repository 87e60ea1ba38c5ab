//! `/api/v1/machines`: register, read, update, list.

use crate::AppState;
use crate::audit::{Actor, Change, json};
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
    who: Actor,
    State(s): State<AppState>,
    ApiJson(m): ApiJson<NewMachine>,
) -> Result<(StatusCode, Json<Machine>), ApiError> {
    Ok((
        StatusCode::CREATED,
        Json(create_machine(&s, m, &who).await?),
    ))
}

/// Registers a machine and records it (`POST /api/v1/machines`; the dashboard's form).
/// The machine's site: the one named, else the key's only site, else none (the default
/// site); a key limited to sites or tags registers machines within them only.
pub async fn create_machine(
    s: &AppState,
    mut m: NewMachine,
    who: &Actor,
) -> Result<Machine, ApiError> {
    let within = who.within()?;
    m.site = within.site_for_new(m.site.take())?;
    if !within.0.covers(m.site.as_deref(), &m.tags) {
        return Err(ApiError::InvalidRequest(format!(
            "tags: key {} registers machines with one of its tags {:?} only",
            within.0.prefix, within.0.tags
        )));
    }
    let m = mtcal_domain::machines::create(s.store.as_ref(), m).await?;
    s.fleet_counts.forget();
    let change = Change {
        action: "machine.create",
        target: &m.id,
        machine: Some(&m.id),
        before: None,
        after: json(&m),
    };
    who.record(s.store.as_ref(), change).await?;
    Ok(m)
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
              (status = 409, body = ErrorBody, description = "the baseline named is a result of another machine, or a misfit check (its model does not explain its recording)")))]
pub async fn update(
    _key: WriteKey,
    who: Actor,
    State(s): State<AppState>,
    Path(id): Path<String>,
    ApiJson(p): ApiJson<MachinePatch>,
) -> Result<Json<Machine>, ApiError> {
    Ok(Json(update_machine(&s, &id, p, &who).await?))
}

/// Checks and applies a patch and records it (`PATCH /api/v1/machines/{id}`; the
/// dashboard's baseline form too): `baseline.set` when the patch only moves the
/// baseline, `machine.update` otherwise.
pub async fn update_machine(
    s: &AppState,
    id: &str,
    p: MachinePatch,
    who: &Actor,
) -> Result<Machine, ApiError> {
    let only_baseline = p.baseline_result_id.is_some()
        && MachinePatch {
            baseline_result_id: None,
            ..p.clone()
        } == MachinePatch::default();
    let within = who.within()?;
    let before = within.get_machine(s, id).await?;
    let moved = p
        .site
        .as_ref()
        .is_some_and(|site| before.site.as_ref() != Some(site));
    check_patch_scope(s, &within, &before, &p, moved).await?;
    let after = mtcal_domain::machines::update(s.store.as_ref(), id, p).await?;
    s.fleet_counts.forget();
    let change = Change {
        action: if only_baseline {
            "baseline.set"
        } else if moved {
            "machine.site"
        } else {
            "machine.update"
        },
        target: &after.id,
        machine: Some(&after.id),
        before: json(&before),
        after: json(&after),
    };
    who.record(s.store.as_ref(), change).await?;
    Ok(after)
}

/// The scope rules of a patch by a key (docs/sites.md): moving a machine to another
/// site takes an admin key, and the machine stays within the key's scope; a baseline
/// outside the scope is not found.
async fn check_patch_scope(
    s: &AppState,
    within: &crate::auth::scope::Within<'_>,
    before: &Machine,
    p: &MachinePatch,
    moved: bool,
) -> Result<(), ApiError> {
    let key = within.0;
    // A site that is no site at all is a bad request (400) before any question of role.
    if let Some(site) = &p.site {
        mtcal_store::text::check_line("site", site, mtcal_store::text::SITE_MAX)?;
    }
    if moved && !key.scope.allows(mtcal_store::Scope::Admin) {
        return Err(ApiError::Forbidden(format!(
            "moving a machine to another site needs a key with scope admin; key {} has \
             scope {}",
            key.prefix,
            key.scope.as_str()
        )));
    }
    let site = p.site.as_deref().or(before.site.as_deref());
    let tags = p.tags.as_ref().unwrap_or(&before.tags);
    if !key.covers(site, tags) {
        return Err(ApiError::Forbidden(format!(
            "the change would take machine {} out of the scope of key {} (sites {:?}, \
             tags {:?})",
            before.id, key.prefix, key.sites, key.tags
        )));
    }
    if let Some(b) = &p.baseline_result_id {
        let method = axum::http::Method::GET;
        within
            .check(s, crate::auth::scope::Kind::Result, b, &method)
            .await?;
    }
    Ok(())
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
    ReadKey(key): ReadKey,
    State(s): State<AppState>,
    ApiQuery(q): ApiQuery<ListQuery>,
) -> Result<Json<Vec<Machine>>, ApiError> {
    let limit = mtcal_domain::paging::limit(q.limit, 100, MAX_MACHINES)?;
    let within = crate::auth::scope::Within(&key);
    let mut out = Vec::new();
    let mut after = q.after;
    // A scoped key's page: the next machines within its scope, read a page at a time.
    while out.len() < limit {
        let page = s
            .store
            .list_machines(after.as_deref(), limit as i64)
            .await?;
        let full = page.len() == limit;
        after = page.last().map(|m| m.id.clone());
        out.extend(page.into_iter().filter(|m| within.machine(m)));
        if !full {
            break;
        }
    }
    out.truncate(limit);
    Ok(Json(out))
}
