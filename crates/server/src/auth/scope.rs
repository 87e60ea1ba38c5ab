//! Sites and roles: a key (and a dashboard session, which acts as its key) covers the
//! whole group or a list of sites, optionally only their machines with one of a list of
//! tags (`ApiKey::covers`). Outside its scope the service answers 404, as it answers a
//! missing id, so that ids do not leak (docs/sites.md).
//!
//! Two pieces:
//! * [`guard`] (and the dashboard's own), middlewares in front of every API route and dashboard
//!   page: every id a route names, in its path (`/machines/{id}`, `/results/{id}/…`) or
//!   in its query (a `machine` parameter, any `res_…`, `ds_…`, `job_…`, `alert_…`,
//!   `key_…` or `tol_…` value), is resolved to its machine and checked before the
//!   handler runs. A route with an id of an unknown kind is refused to a scoped key
//!   (404), so a new route cannot open a hole.
//! * [`Within`], the filter of listings, figures and bodies, for the handlers.

use crate::AppState;
use crate::error::ApiError;
use axum::extract::{FromRequestParts, MatchedPath, Query, RawPathParams, Request, State};
use axum::http::Method;
use axum::http::request::Parts;
use axum::middleware::Next;
use axum::response::{IntoResponse, Response};
use mtcal_store::{ApiKey, Machine, StoreError};
use std::collections::HashMap;

/// The 404 of an id outside the scope: the words of a missing one.
fn not_found(what: &str, id: &str) -> ApiError {
    StoreError::NotFound(format!("{what} {id}")).into()
}

/// A key's scope as the handlers apply it to what they read.
#[derive(Debug, Clone)]
pub struct Within<'a>(pub &'a ApiKey);

impl Within<'_> {
    /// Whether `m` is in the scope.
    pub fn machine(&self, m: &Machine) -> bool {
        self.0.covers(m.site.as_deref(), &m.tags)
    }

    /// The machines in the scope (None: the whole group, every machine).
    pub async fn machine_ids(
        &self,
        s: &AppState,
    ) -> Result<Option<std::collections::HashSet<String>>, ApiError> {
        if self.0.is_group() {
            return Ok(None);
        }
        let mut ids = std::collections::HashSet::new();
        let mut after: Option<String> = None;
        loop {
            let page = s.store.list_machines(after.as_deref(), 1000).await?;
            let Some(last) = page.last() else { break };
            after = Some(last.id.clone());
            ids.extend(
                page.iter()
                    .filter(|m| self.machine(m))
                    .map(|m| m.id.clone()),
            );
        }
        Ok(Some(ids))
    }

    /// Machine `id`, or 404 when it is missing or outside the scope.
    pub async fn get_machine(&self, s: &AppState, id: &str) -> Result<Machine, ApiError> {
        let m = s.store.get_machine(id).await?;
        if self.machine(&m) {
            Ok(m)
        } else {
            Err(not_found("machine", id))
        }
    }

    /// Checks machine `id` (404 outside the scope); a group key skips the read.
    pub async fn check_machine(&self, s: &AppState, id: &str) -> Result<(), ApiError> {
        if !self.0.is_group() {
            self.get_machine(s, id).await?;
        }
        Ok(())
    }

    /// Checks an optional machine (a job without one is the group's: 404 to a scoped key).
    async fn check_owner(
        &self,
        s: &AppState,
        machine: Option<&str>,
        what: &str,
        id: &str,
    ) -> Result<(), ApiError> {
        match machine {
            Some(m) => self.check_machine(s, m).await.map_err(|e| match e {
                ApiError::NotFound(_) => not_found(what, id),
                e => e,
            }),
            None if self.0.is_group() => Ok(()),
            None => Err(not_found(what, id)),
        }
    }

    /// Checks the resource `kind` `id` names (its machine in the scope), for a request
    /// of `method`: 404 outside the scope or when it does not exist.
    pub async fn check(
        &self,
        s: &AppState,
        kind: Kind,
        id: &str,
        method: &Method,
    ) -> Result<(), ApiError> {
        if self.0.is_group() {
            return Ok(());
        }
        match kind {
            Kind::Machine => self.check_machine(s, id).await,
            Kind::Result => {
                let r = s.store.get_result(id).await?;
                self.check_owner(s, Some(&r.meta.machine_id), "result", id)
                    .await
            }
            Kind::Dataset => {
                let d = s.store.get_dataset(id).await?;
                self.check_owner(s, Some(&d.machine_id), "dataset", id)
                    .await
            }
            Kind::Job => {
                let j = s.store.get_job(id).await?;
                self.check_owner(s, j.machine_id.as_deref(), "job", id)
                    .await
            }
            Kind::Alert => {
                let a = s.store.get_alert(id).await?;
                self.check_owner(s, Some(&a.raised.machine_id), "alert", id)
                    .await
            }
            Kind::Profile => {
                let p = s.store.get_tolerance(id).await?;
                // Its machine outside the scope: the profile's own 404, not the machine's.
                self.profile(s, &p.scope, &p.target, method)
                    .await
                    .map_err(|e| match e {
                        ApiError::NotFound(_) => not_found("tolerance profile", id),
                        e => e,
                    })
            }
            Kind::Key => {
                let keys = s.store.list_keys().await?;
                match keys.iter().find(|k| k.id == id) {
                    Some(k) if self.0.contains(&k.sites, &k.tags) => Ok(()),
                    _ => Err(not_found("key", id)),
                }
            }
            Kind::Unknown => Err(ApiError::NotFound(format!("{id} not found"))),
        }
    }

    /// Checks a tolerance profile of `scope` and `target`: a machine's follows its
    /// machine (404 outside); a tag's is the group's, read by every key and changed by a
    /// key of the whole group only (403).
    pub async fn profile(
        &self,
        s: &AppState,
        scope: &str,
        target: &str,
        method: &Method,
    ) -> Result<(), ApiError> {
        if self.0.is_group() {
            return Ok(());
        }
        if scope == "machine" {
            return self.check_machine(s, target).await;
        }
        if matches!(*method, Method::GET | Method::HEAD) {
            Ok(())
        } else {
            Err(ApiError::Forbidden(format!(
                "a tag's tolerance profile is the whole group's: changing it needs a key of \
                 the whole group; key {} is limited to sites {:?}, tags {:?}",
                self.0.prefix, self.0.sites, self.0.tags
            )))
        }
    }

    /// The site a machine registered by this key is in: the one named, which must be in
    /// the scope (404 otherwise, as a site the key cannot see), else the key's only site,
    /// else the default site for a key of several sites or the whole group (then
    /// checked like any other).
    pub fn site_for_new(&self, given: Option<String>) -> Result<Option<String>, ApiError> {
        let site = match given {
            Some(s) => Some(s),
            None if self.0.sites.len() == 1 => Some(self.0.sites[0].clone()),
            None => None,
        };
        if self.0.sites.is_empty()
            || self
                .0
                .sites
                .iter()
                .any(|s| s == mtcal_api::keys::site_of(site.as_deref()))
        {
            Ok(site)
        } else {
            Err(not_found("site", mtcal_api::keys::site_of(site.as_deref())))
        }
    }
}

/// What an id names.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    Machine,
    Result,
    Dataset,
    Job,
    Alert,
    Profile,
    Key,
    Unknown,
}

impl Kind {
    /// The kind of the `{id}` of a route whose path has `segment` just before it
    /// (`/api/v1/results/{id}` → `results`).
    pub fn of_segment(segment: &str) -> Kind {
        match segment {
            "machines" => Kind::Machine,
            "results" => Kind::Result,
            "datasets" => Kind::Dataset,
            "jobs" => Kind::Job,
            "alerts" => Kind::Alert,
            "tolerances" => Kind::Profile,
            "keys" => Kind::Key,
            _ => Kind::Unknown,
        }
    }

    /// The kind of an id given as a query value, by its prefix (None: not an id).
    pub fn of_value(name: &str, value: &str) -> Option<Kind> {
        if matches!(name, "machine" | "machine_id") {
            return Some(Kind::Machine);
        }
        let (prefix, _) = value.split_once('_')?;
        Some(match prefix {
            "res" => Kind::Result,
            "ds" => Kind::Dataset,
            "job" => Kind::Job,
            "alert" => Kind::Alert,
            "key" => Kind::Key,
            "tol" => Kind::Profile,
            _ => return None,
        })
    }
}

/// Every id a request names: the path's (by the segment before each parameter of the
/// matched route) and the query's.
fn named_ids(parts: &Parts, params: Option<&RawPathParams>) -> Vec<(Kind, String)> {
    let mut out = Vec::new();
    let route = parts
        .extensions
        .get::<MatchedPath>()
        .map(|m| m.as_str().to_string())
        .unwrap_or_default();
    if let Some(params) = params {
        let values: HashMap<&str, &str> = params.iter().collect();
        let segments: Vec<&str> = route.split('/').collect();
        for (i, seg) in segments.iter().enumerate() {
            let Some(name) = seg.strip_prefix('{').and_then(|s| s.strip_suffix('}')) else {
                continue;
            };
            // A file's name names no resource of its own (its dataset does).
            if name == "name" {
                continue;
            }
            let before = if i == 0 { "" } else { segments[i - 1] };
            if let Some(v) = values.get(name) {
                out.push((Kind::of_segment(before), v.to_string()));
            }
        }
    }
    if let Ok(Query(q)) = Query::<Vec<(String, String)>>::try_from_uri(&parts.uri) {
        // A value may list ids (the machine page's `jobs=a,b`).
        for (k, list) in q {
            for v in list.split(',').filter(|v| !v.is_empty()) {
                if let Some(kind) = Kind::of_value(&k, v) {
                    out.push((kind, v.to_string()));
                }
            }
        }
    }
    out
}

/// Checks every id a request names against `key`'s scope (404 outside it).
pub async fn check_request(s: &AppState, key: &ApiKey, parts: &mut Parts) -> Result<(), ApiError> {
    if key.is_group() {
        return Ok(());
    }
    let params = RawPathParams::from_request_parts(parts, s).await.ok();
    let within = Within(key);
    for (kind, id) in named_ids(parts, params.as_ref()) {
        within.check(s, kind, &id, &parts.method).await?;
    }
    Ok(())
}

/// Middleware of the API routes, inside [`super::authenticate`]: 404 for an id outside
/// the request's key's scope.
pub async fn guard(State(s): State<AppState>, req: Request, next: Next) -> Response {
    let (mut parts, body) = req.into_parts();
    if let Some(key) = parts.extensions.get::<ApiKey>().cloned()
        && let Err(e) = check_request(&s, &key, &mut parts).await
    {
        return e.into_response();
    }
    next.run(Request::from_parts(parts, body)).await
}
