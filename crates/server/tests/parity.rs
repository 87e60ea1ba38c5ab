//! Both backends answer alike on every input: the same hostile requests (NUL bytes and
//! other control characters in paths, queries and JSON strings; fields far over their
//! length caps; too many, empty or repeated tags; ids that name no reachable path;
//! limits out of range) are sent to the service on SQLite and on PostgreSQL, and each
//! gets the same status on both, the one expected, never a 5xx, and nothing is stored by
//! a refused request. Without `MTCAL_TEST_PG` the PostgreSQL half says it skipped.

use crate::common::{Keys, app_on, identification, machine, request, send};
use mtcal_store::Store;
use serde_json::{Value, json};
use std::sync::Arc;

/// Who sends a case.
#[derive(Clone, Copy)]
enum Who {
    Read,
    Write,
    Admin,
}

/// One hostile request and the status it must get.
struct Case {
    what: String,
    method: &'static str,
    uri: String,
    body: Option<Value>,
    who: Who,
    status: u16,
}

fn case(what: &str, method: &'static str, uri: &str, body: Option<Value>, status: u16) -> Case {
    Case {
        what: what.into(),
        method,
        uri: uri.into(),
        body,
        who: Who::Write,
        status,
    }
}

fn cases(result: &str) -> Vec<Case> {
    let long = "x".repeat(3000);
    let many: Vec<String> = (0..10_000).map(|i| format!("t{i}")).collect();
    let nul = "x\u{0}y";
    let mut c = vec![
        // NUL and other control characters in paths and queries.
        case("NUL in a path", "GET", "/api/v1/machines/a%00b", None, 400),
        case("tab in a path", "GET", "/api/v1/machines/a%09b", None, 400),
        case("NUL in site", "GET", "/api/v1/fleet?site=%00", None, 400),
        case("NUL in tag", "GET", "/api/v1/fleet?tag=a%00", None, 400),
        case(
            "NUL in after",
            "GET",
            "/api/v1/machines?after=%00",
            None,
            400,
        ),
        case(
            "NUL in alert machine",
            "GET",
            "/api/v1/alerts?machine=%00",
            None,
            400,
        ),
        case(
            "NUL in a term",
            "GET",
            "/api/v1/machines/M1/trends/term?term=E%00",
            None,
            400,
        ),
        case(
            "NUL in a result id",
            "GET",
            "/api/v1/results/r%00/verdict",
            None,
            400,
        ),
        case(
            "C1 control in a query",
            "GET",
            "/api/v1/fleet?site=%C2%85",
            None,
            400,
        ),
        // NUL in JSON strings, whatever the field.
        case(
            "NUL in a name",
            "POST",
            "/api/v1/machines",
            Some(json!({"id": "M9", "name": nul})),
            400,
        ),
        case(
            "NUL in an id",
            "POST",
            "/api/v1/machines",
            Some(json!({"id": nul, "name": "n"})),
            400,
        ),
        case(
            "NUL in a site",
            "POST",
            "/api/v1/machines",
            Some(json!({"id": "M9", "name": "n", "site": nul})),
            400,
        ),
        case(
            "NUL in a tag",
            "POST",
            "/api/v1/machines",
            Some(json!({"id": "M9", "name": "n", "tags": [nul]})),
            400,
        ),
        case(
            "NUL in a patch",
            "PATCH",
            "/api/v1/machines/M1",
            Some(json!({"name": nul})),
            400,
        ),
        case(
            "NUL in a baseline",
            "PATCH",
            "/api/v1/machines/M1",
            Some(json!({"baseline_result_id": nul})),
            400,
        ),
        case(
            "NUL in a tolerance target",
            "POST",
            "/api/v1/tolerances",
            Some(json!({"scope": "tag", "target": nul, "limits": {"drift_um": 1}})),
            400,
        ),
        case(
            "NUL in a job's dataset",
            "POST",
            "/api/v1/jobs",
            Some(json!({"kind": "identify", "dataset_id": nul})),
            400,
        ),
        case(
            "NUL in a reason",
            "POST",
            &format!("/api/v1/results/{result}/exclude"),
            Some(json!({"reason": nul})),
            400,
        ),
        case(
            "NUL in a key name",
            "POST",
            "/api/v1/machines",
            Some(json!({"id": "M9", "name": "n", "topology": {nul: ["X"]}})),
            400,
        ),
        Case {
            who: Who::Admin,
            ..case(
                "NUL in a key label",
                "POST",
                "/api/v1/keys",
                Some(json!({"scope": "read", "label": nul})),
                400,
            )
        },
        // Control characters other than NUL.
        case(
            "line feed in a name",
            "POST",
            "/api/v1/machines",
            Some(json!({"id": "M9", "name": "a\nb"})),
            400,
        ),
        case(
            "escape in a tag",
            "POST",
            "/api/v1/machines",
            Some(json!({"id": "M9", "name": "n", "tags": ["a\u{1b}[31m"]})),
            400,
        ),
        // Lengths, emptiness, counts.
        case(
            "site over 2.7 kB",
            "POST",
            "/api/v1/machines",
            Some(json!({"id": "M9", "name": "n", "site": long})),
            400,
        ),
        case(
            "tag over 2.7 kB",
            "POST",
            "/api/v1/machines",
            Some(json!({"id": "M9", "name": "n", "tags": [long]})),
            400,
        ),
        case(
            "10 000 tags",
            "POST",
            "/api/v1/machines",
            Some(json!({"id": "M9", "name": "n", "tags": many})),
            400,
        ),
        case(
            "long name",
            "POST",
            "/api/v1/machines",
            Some(json!({"id": "M9", "name": long})),
            400,
        ),
        case(
            "empty name",
            "POST",
            "/api/v1/machines",
            Some(json!({"id": "M9", "name": ""})),
            400,
        ),
        case(
            "blank name",
            "POST",
            "/api/v1/machines",
            Some(json!({"id": "M9", "name": "   "})),
            400,
        ),
        case(
            "empty tag",
            "POST",
            "/api/v1/machines",
            Some(json!({"id": "M9", "name": "n", "tags": [""]})),
            400,
        ),
        case(
            "repeated tag",
            "POST",
            "/api/v1/machines",
            Some(json!({"id": "M9", "name": "n", "tags": ["a", "a"]})),
            400,
        ),
        case(
            "long site in a patch",
            "PATCH",
            "/api/v1/machines/M1",
            Some(json!({"site": long})),
            400,
        ),
        case(
            "10 000 tags in a patch",
            "PATCH",
            "/api/v1/machines/M1",
            Some(json!({"tags": many})),
            400,
        ),
        case(
            "long tolerance target",
            "POST",
            "/api/v1/tolerances",
            Some(json!({"scope": "tag", "target": long, "limits": {"drift_um": 1}})),
            400,
        ),
        case(
            "long reason",
            "POST",
            &format!("/api/v1/results/{result}/exclude"),
            Some(json!({"reason": "r".repeat(2001)})),
            400,
        ),
        Case {
            who: Who::Admin,
            ..case(
                "empty key label",
                "POST",
                "/api/v1/keys",
                Some(json!({"scope": "read", "label": ""})),
                400,
            )
        },
        // Ids that no path can reach.
        case(
            "machine id .",
            "POST",
            "/api/v1/machines",
            Some(json!({"id": ".", "name": "n"})),
            400,
        ),
        case(
            "machine id ..",
            "POST",
            "/api/v1/machines",
            Some(json!({"id": "..", "name": "n"})),
            400,
        ),
        // What is inside the caps is accepted.
        case(
            "name of 200 characters",
            "POST",
            "/api/v1/machines",
            Some(
                json!({"id": "M8", "name": "é".repeat(200), "site": "s".repeat(100),
                         "tags": (0..32).map(|i| format!("{i:0>64}")).collect::<Vec<_>>()}),
            ),
            201,
        ),
        case(
            "a tag list over its bytes as stored is refused (one indexed value)",
            "POST",
            "/api/v1/machines",
            Some(json!({"id": "M9", "name": "n",
                         "tags": (0..14u32).map(|i| char::from_u32(0x4e00 + i).unwrap().to_string().repeat(64)).collect::<Vec<_>>()})),
            400,
        ),
        case(
            "a plain name is accepted",
            "PATCH",
            "/api/v1/machines/M1",
            Some(json!({"name": "ok name"})),
            200,
        ),
        case(
            "a reason may have lines",
            "POST",
            &format!("/api/v1/results/{result}/exclude"),
            Some(json!({"reason": "first line\nsecond line"})),
            200,
        ),
    ];
    // Limits out of range are refused on every list, never clamped.
    for route in [
        "/api/v1/machines",
        "/api/v1/jobs",
        "/api/v1/alerts",
        "/api/v1/fleet",
        "/api/v1/fleet/drift",
    ] {
        for (limit, status) in [
            ("0", 400),
            ("-1", 400),
            ("1e8", 400),
            ("100000001", 400),
            ("1", 200),
        ] {
            c.push(Case {
                who: Who::Read,
                ..case(
                    &format!("limit={limit} on {route}"),
                    "GET",
                    &format!("{route}?limit={limit}"),
                    None,
                    status,
                )
            });
        }
    }
    c
}

/// Sends every case to the service on `url`; returns each case's status, and checks that
/// no refused case stored anything.
async fn statuses(url: &str) -> Vec<(String, u16)> {
    let (app, keys, store): (_, Keys, Arc<dyn Store>) = app_on(url).await;
    machine(&app, &keys.write, "M1").await;
    let r = store
        .import_result(identification("M1", "2026-01-01T00:00:00Z", 0.001, 1e-8))
        .await
        .unwrap();
    let machines_before = store.list_machines(None, 1000).await.unwrap();
    let keys_before = store.list_keys().await.unwrap().len();
    let mut out = vec![];
    for c in cases(&r.id) {
        let key = match c.who {
            Who::Read => &keys.read,
            Who::Write => &keys.write,
            Who::Admin => &keys.admin,
        };
        let body = c
            .body
            .map(|b| b.to_string().into_bytes())
            .unwrap_or_default();
        let ct = if body.is_empty() {
            ""
        } else {
            "application/json"
        };
        let (s, b) = send(&app, request(c.method, &c.uri, ct, None, body, Some(key))).await;
        assert!(!s.is_server_error(), "{}: {s} {b} on {url}", c.what);
        if s.is_client_error() {
            assert!(
                b["error"]["message"]
                    .as_str()
                    .is_some_and(|m| !m.is_empty()),
                "{}: {s} without a JSON error: {b}",
                c.what
            );
        }
        out.push((c.what, s.as_u16()));
    }
    // Refused requests stored nothing: only M8 (accepted) is new, M1 has its own name.
    let after = store.list_machines(None, 1000).await.unwrap();
    let ids: Vec<&str> = after.iter().map(|m| m.id.as_str()).collect();
    assert_eq!(ids, ["M1", "M8"], "on {url}");
    assert_eq!(after[0].name, "ok name");
    assert_eq!(machines_before.len(), 1);
    assert_eq!(store.list_keys().await.unwrap().len(), keys_before);
    assert!(store.list_tolerances().await.unwrap().is_empty());
    out
}

fn expected() -> Vec<(String, u16)> {
    cases("res_x")
        .into_iter()
        .map(|c| (c.what, c.status))
        .collect()
}

fn compare(got: &[(String, u16)], want: &[(String, u16)], backend: &str) {
    let wrong: Vec<String> = got
        .iter()
        .zip(want)
        .filter(|(g, w)| g.1 != w.1)
        .map(|(g, w)| format!("{}: {} on {backend}, expected {}", g.0, g.1, w.1))
        .collect();
    assert!(wrong.is_empty(), "{}", wrong.join("\n"));
}

#[tokio::test]
async fn hostile_inputs_get_the_same_answers_on_both_backends() {
    let dir = tempfile::tempdir().unwrap();
    let sqlite = statuses(&format!(
        "sqlite://{}",
        dir.path().join("p.sqlite").display()
    ))
    .await;
    compare(&sqlite, &expected(), "SQLite");
    let name = "hostile_inputs_get_the_same_answers_on_both_backends";
    let Some(pg) = mtcal_store::testing::ScratchPg::create(name).await.unwrap() else {
        return;
    };
    let postgres = statuses(&pg.url).await;
    pg.drop_schema().await.unwrap();
    compare(&postgres, &sqlite, "PostgreSQL (against SQLite)");
}
