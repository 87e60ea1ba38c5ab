//! The scope matrix of sites and roles: every route of the API (generated from the
//! OpenAPI document, so that a new route cannot be left out) and every page of the
//! dashboard (read from the dashboard's router, likewise) is sent by keys of one site
//! (read, write, admin; and one limited to a tag) with the ids of another site's
//! machine, dataset, result, job, alert, tolerance profile and key. Each answer must be:
//!
//! * for a route that names an id of the other site (in its path or its query): 404, with
//!   the very body a missing id of that kind gets (the id apart), so that the answer does
//!   not tell an id of another site from one that does not exist;
//! * for a listing, a figure or an export: no id of the other site and not its name
//!   anywhere in the body;
//! * for a creation that names the other site or its machine: 404 (or 403 for a key
//!   wider than the creator's own), and nothing created.
//!
//! Each case is also sent by a key of the whole group, which must see the other site's
//! ids where the case reads them: the 404s come from the scope, not from missing data.
//! Runs on SQLite and, when `MTCAL_TEST_PG` names a server, on PostgreSQL.

use crate::common::routes::{
    Auth, Ids, api_routes, call, fill, missing, page_routes, send_as, session_of,
};
use crate::common::{app_on, identification};
use axum::http::StatusCode;
use mtcal_store::{
    Alert, AlertRaised, JobKind, NewDataset, NewJob, Store, WebhookDelivery, rules::new_id,
};
use serde_json::{Value, json};
use std::sync::Arc;

/// The foreign site and its machine: distinctive words, so that a body holding them is
/// a leak and nothing else.
const FOREIGN_SITE: &str = "site-south-q7";
const OWN_SITE: &str = "site-north-k2";
const FOREIGN_MACHINE: &str = "SOUTH-M7";
const OWN_MACHINE: &str = "NORTH-M2";

/// A site: a machine of it with a dataset, a result, a job, a tolerance profile, an
/// alert with a webhook delivery, and a read key of the site (created through the API
/// by the group's admin key, so that the audit trail has its events).
async fn seed(app: &axum::Router, store: &Arc<dyn Store>, admin: &str, site: &str, m: &str) -> Ids {
    let body = json!({"id": m, "name": m, "site": site, "tags": ["vmc"]});
    let (s, b) = call(app, "POST", "/api/v1/machines", Some(&body), admin).await;
    assert_eq!(s, StatusCode::CREATED, "{b}");
    let dataset = store
        .insert_dataset(NewDataset {
            machine_id: m.into(),
            kind: "session".into(),
            measured_at: "2026-01-01T00:00:00Z".into(),
            samples: 1,
            files: vec![("session.json".into(), b"{}".to_vec())],
        })
        .await
        .unwrap();
    let result = store
        .import_result(identification(m, "2026-01-02T00:00:00Z", 1.0, 0.01))
        .await
        .unwrap();
    let job = store
        .enqueue(NewJob {
            kind: JobKind::Identify,
            machine_id: Some(m.into()),
            dataset_id: Some(dataset.id.clone()),
            params: json!({}),
            max_attempts: 3,
        })
        .await
        .unwrap();
    let profile = json!({"scope": "machine", "target": m, "limits": {"drift_um": 5.0}});
    let (s, b) = call(app, "POST", "/api/v1/tolerances", Some(&profile), admin).await;
    assert_eq!(s, StatusCode::CREATED, "{b}");
    let profile: Value = serde_json::from_str(&b).unwrap();
    let profile = profile["id"].as_str().unwrap().to_string();
    let alert = Alert {
        raised: AlertRaised {
            id: new_id("alert"),
            machine_id: m.into(),
            result_id: result.id.clone(),
            baseline_result_id: result.id.clone(),
            profile_id: profile.clone(),
            raised_at: "2026-01-03T00:00:00Z".into(),
            message: "EXX changed".into(),
        },
        items: json!([]),
        details: None,
        acknowledged_at: None,
        acknowledged_by: None,
        acknowledgement_comment: None,
    };
    let delivery = WebhookDelivery {
        id: new_id("whd"),
        alert_id: alert.raised.id.clone(),
        profile_id: profile.clone(),
        url: "https://hooks.invalid/x".into(),
        body: "{}".into(),
        state: "failed".into(),
        attempts: 1,
        next_attempt_ms: 0,
        last_error: None,
        created_at: String::new(),
        updated_at: String::new(),
    };
    store
        .raise_alert(&alert, std::slice::from_ref(&delivery))
        .await
        .unwrap();
    let k = json!({"scope": "read", "label": format!("{site} reader"), "sites": [site]});
    let (s, b) = call(app, "POST", "/api/v1/keys", Some(&k), admin).await;
    assert_eq!(s, StatusCode::CREATED, "{b}");
    let created: Value = serde_json::from_str(&b).unwrap();
    Ids {
        machine: m.into(),
        dataset: dataset.id,
        result: result.id,
        job: job.id,
        alert: alert.raised.id,
        profile,
        delivery: delivery.id,
        key: created["key"]["id"].as_str().unwrap().into(),
        site: site.into(),
    }
}

/// A key of the own site (the secret), created by the group's admin key.
async fn site_key(app: &axum::Router, admin: &str, scope: &str, tags: &[&str]) -> String {
    let k = json!({"scope": scope, "label": format!("north {scope}"), "sites": [OWN_SITE], "tags": tags});
    let (s, b) = call(app, "POST", "/api/v1/keys", Some(&k), admin).await;
    assert_eq!(s, StatusCode::CREATED, "{b}");
    let created: Value = serde_json::from_str(&b).unwrap();
    created["secret"].as_str().unwrap().into()
}

/// The ids of `ids` a body holds, leaving out those of `asked` (the request's own).
fn leaks(body: &str, ids: &Ids, asked: &str) -> Vec<String> {
    ids.tokens()
        .into_iter()
        .filter(|t| body.contains(*t) && !asked.contains(*t))
        .map(str::to_string)
        .collect()
}

/// What the matrix sent and found.
#[derive(Default)]
struct Tally {
    cases: usize,
    failures: Vec<String>,
}

impl Tally {
    fn check(&mut self, ok: bool, what: impl FnOnce() -> String) {
        self.cases += 1;
        if !ok {
            self.failures.push(what());
        }
    }
}

/// What a case must get from a key of the own site.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Expect {
    /// Any answer but a 5xx, without the other site's ids.
    NoLeak,
    /// 404 (an id of the other site named), without its other ids.
    NotFound,
    /// 403 or 404 (a creation reaching the other site, or wider than the key), nothing
    /// created.
    Refused,
}

/// A request of a route without an id in its path.
struct Case {
    method: &'static str,
    uri: String,
    body: Option<Value>,
    expect: Expect,
    /// Whether a key of the whole group sees the other site's ids in the answer (the
    /// control: the data is there).
    group_sees: bool,
}

fn case(
    method: &'static str,
    uri: &str,
    body: Option<Value>,
    expect: Expect,
    group_sees: bool,
) -> Case {
    Case {
        method,
        uri: uri.into(),
        body,
        expect,
        group_sees,
    }
}

/// The cases of an API route without an id in its path; every such route of the
/// document must have some (a new one fails here until it is given its cases).
fn api_cases(method: &str, path: &str, f: &Ids, own: &Ids) -> Vec<Case> {
    use Expect::*;
    // A listing (the group sees the other site in it), and one naming another's id.
    let listing = || case("GET", path, None, NoLeak, true);
    let naming = |param: &str, id: &str| {
        let uri = format!("{path}?{param}={id}");
        case("GET", &uri, None, NotFound, false)
    };
    let create = |body: Value| case("POST", path, Some(body), Refused, false);
    match (method, path) {
        ("GET", "/health" | "/ready") => vec![],
        ("GET", "/api/v1/machines" | "/api/v1/jobs" | "/api/v1/tolerances" | "/api/v1/keys") => {
            vec![listing()]
        }
        ("GET", "/api/v1/audit" | "/api/v1/audit/export") => vec![
            listing(),
            naming("machine", &f.machine),
            naming("actor", &f.key),
        ],
        ("GET", "/api/v1/alerts") => vec![listing(), naming("machine", &f.machine)],
        ("GET", "/api/v1/webhooks/deliveries") => vec![listing(), naming("alert_id", &f.alert)],
        ("GET", "/api/v1/fleet") => vec![
            listing(),
            case(
                "GET",
                &format!("{path}?site={}", f.site),
                None,
                NoLeak,
                true,
            ),
            case("GET", &format!("{path}?tag=vmc"), None, NoLeak, true),
        ],
        // The ranking holds machines with a drift row: none here, so no control.
        ("GET", "/api/v1/fleet/drift") => vec![case("GET", path, None, NoLeak, false)],
        ("POST", "/api/v1/machines") => {
            vec![create(
                json!({"id": "X-NEW-1", "name": "x", "site": f.site}),
            )]
        }
        ("POST", "/api/v1/jobs") => vec![
            create(json!({"kind": "identify", "dataset_id": f.dataset})),
            create(json!({"kind": "identify", "machine_id": f.machine})),
        ],
        ("POST", "/api/v1/tolerances") => vec![create(
            json!({"scope": "machine", "target": f.machine, "limits": {"drift_um": 5.0}}),
        )],
        ("POST", "/api/v1/keys") => vec![
            create(json!({"scope": "read", "label": "x", "sites": [f.site]})),
            create(json!({"scope": "read", "label": "whole group"})),
            create(json!({"scope": "read", "label": "x", "sites": [own.site, f.site]})),
        ],
        (m, p) => panic!("{m} {p}: a route without an id that this matrix has no case for"),
    }
}

/// Extra cases of routes with an id: the own machine's, with another site's id in the
/// query.
fn query_cases(f: &Ids, own: &Ids) -> Vec<Case> {
    let diff = format!("/api/v1/machines/{}/results/diff", own.machine);
    let naming = |p: &str| {
        case(
            "GET",
            &format!("{diff}?{p}={}", f.result),
            None,
            Expect::NotFound,
            false,
        )
    };
    let machine = format!("/api/v1/machines/{}", own.machine);
    let patch = |body: Value| case("PATCH", &machine, Some(body), Expect::Refused, false);
    vec![
        naming("baseline"),
        naming("against"),
        // Another site's baseline, or a move there (a read key: 403 before the body).
        patch(json!({"baseline_result_id": f.result})),
        patch(json!({"site": f.site})),
    ]
}

/// The cases of a dashboard page without an id in its path.
fn page_cases(method: &str, path: &str, f: &Ids) -> Vec<Case> {
    use Expect::*;
    let q = |p: &str| format!("{path}?{p}");
    match (method, path) {
        // Signing in and out reads no site's data (and signing out would end the session).
        ("GET" | "POST", "/signin") | ("POST", "/signout") => vec![],
        ("GET", "/" | "/jobs" | "/audit") => vec![case("GET", path, None, NoLeak, true)],
        ("GET", "/alerts") => vec![
            case("GET", path, None, NoLeak, true),
            case(
                "GET",
                &q(&format!("machine={}", f.machine)),
                None,
                NotFound,
                false,
            ),
        ],
        ("GET", "/compare") => vec![case(
            "GET",
            &q(&format!("a={}&b={}", f.result, f.result)),
            None,
            NotFound,
            false,
        )],
        ("POST", "/machines") => vec![case(
            "POST",
            path,
            Some(json!(format!("id=X-NEW-2&name=x&site={}", f.site))),
            Refused,
            false,
        )],
        (m, p) => panic!("{m} {p}: a page without an id that this matrix has no case for"),
    }
}

/// `body` with every id of `a` and `b` written as `ID` (answers compared apart from the
/// id they were asked about).
fn without_ids(body: &str, a: &Ids, b: &Ids) -> String {
    let mut out = body.to_string();
    for t in a.tokens().into_iter().chain(b.tokens()) {
        out = out.replace(t, "ID");
    }
    out
}

/// The matrix world: the app, the other site's ids, the own site's, the scoped callers
/// (named) and the group's.
struct World {
    app: axum::Router,
    foreign: Ids,
    own: Ids,
    scoped: Vec<(String, Auth)>,
    group: Auth,
}

/// One route with ids in its path: 404 to every scoped caller, the body of a missing
/// id, no other id; a GET of the group's key finds it.
async fn id_route(w: &World, t: &mut Tally, method: &str, template: &str) {
    let (uri, absent) = (fill(template, &w.foreign), fill(template, &missing()));
    let body = (method != "GET" && method != "DELETE").then(|| json!({}));
    for (name, who) in &w.scoped {
        let (s, b) = send_as(&w.app, who, method, &uri, body.as_ref()).await;
        let (sm, bm) = send_as(&w.app, who, method, &absent, body.as_ref()).await;
        let what = || format!("{name}: {method} {uri}: {s} {b:.300}");
        t.check(s == StatusCode::NOT_FOUND, what);
        t.check(sm == s, || {
            format!("{name}: {method} {absent}: {sm} vs {s}")
        });
        let (x, y) = (
            without_ids(&b, &w.foreign, &missing()),
            without_ids(&bm, &w.foreign, &missing()),
        );
        t.check(x == y, || {
            format!("{name}: {method} {uri}: {b:.200} vs {bm:.200}")
        });
        let leaked = leaks(&b, &w.foreign, &uri);
        t.check(leaked.is_empty(), || {
            format!("{name}: {method} {uri} leaks {leaked:?}")
        });
    }
    if method == "GET" {
        let (s, b) = send_as(&w.app, &w.group, method, &uri, None).await;
        t.check(s != StatusCode::NOT_FOUND, || {
            format!("group: GET {uri}: {s} {b:.200}")
        });
    }
}

/// One case of a route without an id in its path.
async fn plain_case(w: &World, t: &mut Tally, c: &Case) {
    for (name, who) in &w.scoped {
        let (s, b) = send_as(&w.app, who, c.method, &c.uri, c.body.as_ref()).await;
        let what = format!("{name}: {} {} {:?}: {s} {b:.300}", c.method, c.uri, c.body);
        let status_ok = match c.expect {
            Expect::NoLeak => !s.is_server_error(),
            Expect::NotFound => s == StatusCode::NOT_FOUND,
            Expect::Refused => s == StatusCode::NOT_FOUND || s == StatusCode::FORBIDDEN,
        };
        t.check(status_ok, || what.clone());
        // What the request sent itself may come back; nothing else of the other site.
        let asked = format!("{} {:?}", c.uri, c.body);
        let leaked = leaks(&b, &w.foreign, &asked);
        t.check(leaked.is_empty(), || format!("{what} leaks {leaked:?}"));
    }
    if c.group_sees {
        let (s, b) = send_as(&w.app, &w.group, c.method, &c.uri, c.body.as_ref()).await;
        let seen = !leaks(&b, &w.foreign, "").is_empty();
        t.check(s.is_success() && seen, || {
            format!(
                "group: {} {}: {s}, sees no id of the other site: {b:.300}",
                c.method, c.uri
            )
        });
    }
}

/// Runs the matrix on the store `url` names; returns (API routes, pages, callers, cases).
async fn matrix(url: &str) -> (usize, usize, usize, usize) {
    let (app, keys, store) = app_on(url).await;
    let foreign = seed(&app, &store, &keys.admin, FOREIGN_SITE, FOREIGN_MACHINE).await;
    let own = seed(&app, &store, &keys.admin, OWN_SITE, OWN_MACHINE).await;
    let mut api = vec![];
    let mut pages = vec![];
    for scope in ["read", "write", "admin"] {
        let secret = site_key(&app, &keys.admin, scope, &[]).await;
        pages.push((format!("page {scope}"), session_of(&store, &secret).await));
        api.push((format!("api {scope}"), Auth::Key(secret)));
    }
    let tagged = site_key(&app, &keys.admin, "admin", &["lathe"]).await;
    api.push(("api admin tag lathe".into(), Auth::Key(tagged)));
    let callers = api.len() + pages.len();
    let mut t = Tally::default();
    let w = World {
        app: app.clone(),
        foreign: foreign.clone(),
        own: own.clone(),
        scoped: api,
        group: Auth::Key(keys.admin.clone()),
    };
    let routes = api_routes();
    for (method, path) in &routes {
        if path.contains('{') {
            id_route(&w, &mut t, method, path).await;
        }
        for c in api_cases_of(method, path, &w) {
            plain_case(&w, &mut t, &c).await;
        }
    }
    for c in query_cases(&foreign, &own) {
        plain_case(&w, &mut t, &c).await;
    }
    let group_page = session_of(&store, &keys.admin).await;
    let w = World {
        scoped: pages,
        group: group_page,
        ..w
    };
    let page_list: Vec<_> = page_routes()
        .into_iter()
        .filter(|(_, p)| !p.starts_with("/static/"))
        .collect();
    for (method, path) in &page_list {
        if path.contains('{') {
            id_route(&w, &mut t, method, path).await;
        } else {
            for c in page_cases(method, path, &foreign) {
                plain_case(&w, &mut t, &c).await;
            }
        }
    }
    nothing_changed(&app, &keys.admin, &foreign, &mut t).await;
    assert!(
        t.failures.is_empty(),
        "{} of {} checks failed on {}:\n{}",
        t.failures.len(),
        t.cases,
        url.split(':').next().unwrap_or(url),
        t.failures.join("\n")
    );
    (routes.len(), page_list.len(), callers, t.cases)
}

fn api_cases_of(method: &str, path: &str, w: &World) -> Vec<Case> {
    if path.contains('{') {
        return vec![];
    }
    api_cases(method, path, &w.foreign, &w.own)
}

/// The other site's data is as it was, and nothing was created for it.
async fn nothing_changed(app: &axum::Router, admin: &str, f: &Ids, t: &mut Tally) {
    let get = |uri: String| async move {
        let (s, b) = call(app, "GET", &uri, None, admin).await;
        (s, serde_json::from_str::<Value>(&b).unwrap_or_default())
    };
    // The record of id `id` in the list `uri` answers.
    let find = |uri: &'static str, id: String| async move {
        let (_, list) = get(uri.to_string()).await;
        let list = list.as_array().cloned().unwrap_or_default();
        list.into_iter().find(|v| v["id"] == id.as_str())
    };
    for m in ["X-NEW-1", "X-NEW-2"] {
        let (s, _) = get(format!("/api/v1/machines/{m}")).await;
        t.check(s == StatusCode::NOT_FOUND, || {
            format!("machine {m} was created")
        });
    }
    let (s, _) = get(format!("/api/v1/tolerances/{}", f.profile)).await;
    t.check(s == StatusCode::OK, || {
        format!("profile {} is gone: {s}", f.profile)
    });
    let key = find("/api/v1/keys", f.key.clone()).await;
    let kept = key.is_some_and(|k| k["revoked_at"].is_null());
    t.check(kept, || format!("key {} revoked", f.key));
    let (_, ds) = get(format!("/api/v1/datasets/{}", f.dataset)).await;
    t.check(ds["excluded"].is_null(), || {
        format!("dataset excluded: {ds}")
    });
    let alert = find("/api/v1/alerts", f.alert.clone()).await;
    let active = alert.is_some_and(|a| a["acknowledged_at"].is_null());
    t.check(active, || "alert acknowledged".into());
    let (_, keys) = get("/api/v1/keys".into()).await;
    let wide = keys.as_array().into_iter().flatten();
    let made = wide
        .filter(|k| k["label"] == "whole group" || k["label"] == "x")
        .count();
    t.check(made == 0, || {
        "a scoped admin created a key wider than its own".into()
    });
}

#[tokio::test]
async fn no_route_reaches_another_site_on_sqlite() {
    let (api, pages, callers, cases) = matrix("sqlite::memory:").await;
    eprintln!(
        "scope matrix on SQLite: ({api} API routes + {pages} pages) x {callers} scoped callers: \
         {cases} checks, no leak"
    );
}

#[tokio::test]
async fn no_route_reaches_another_site_on_postgres() {
    let name = "no_route_reaches_another_site_on_postgres";
    let Some(pg) = mtcal_store::testing::ScratchPg::create(name).await.unwrap() else {
        eprintln!("{name}: skipped (MTCAL_TEST_PG is not set)");
        return;
    };
    let (api, pages, callers, cases) = matrix(&pg.url).await;
    eprintln!(
        "scope matrix on PostgreSQL: ({api} API routes + {pages} pages) x {callers} scoped \
         callers: {cases} checks, no leak"
    );
    pg.drop_schema().await.unwrap();
}
