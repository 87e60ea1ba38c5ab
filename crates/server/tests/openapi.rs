//! The committed `openapi/openapi.json` must be what the code generates. After changing
//! the API, regenerate it with `UPDATE_OPENAPI=1 cargo test -p mtcal-server --test server openapi::`.

#[test]
fn committed_openapi_matches_the_code() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../openapi/openapi.json");
    let generated = mtcal_server::openapi_json();
    if std::env::var_os("UPDATE_OPENAPI").is_some() {
        std::fs::write(path, &generated).unwrap();
    }
    let committed = std::fs::read_to_string(path).unwrap_or_default();
    assert!(
        committed == generated,
        "openapi/openapi.json differs from the code; run \
         UPDATE_OPENAPI=1 cargo test -p mtcal-server --test server openapi:: and commit it"
    );
}

#[test]
fn document_is_openapi_3_1_with_every_route_secured_but_health_and_ready() {
    let doc: serde_json::Value = serde_json::from_str(&mtcal_server::openapi_json()).unwrap();
    assert!(doc["openapi"].as_str().unwrap().starts_with("3.1"));
    let paths = doc["paths"].as_object().unwrap();
    assert!(paths.len() >= 15, "{} paths", paths.len());
    let mut ids = std::collections::BTreeSet::new();
    for (p, ops) in paths {
        for (method, op) in ops.as_object().unwrap() {
            let id = op["operationId"].as_str().unwrap();
            assert!(ids.insert(id.to_string()), "operationId {id} used twice");
            assert!(
                op["summary"].as_str().is_some_and(|t| !t.is_empty()),
                "{method} {p}: no summary"
            );
            let secured = op.get("security").is_some();
            let open = ["/health", "/ready"].contains(&p.as_str());
            assert_eq!(secured, !open, "{method} {p}");
        }
    }
}

/// A parameter declared `in: path` is one of the path's `{…}` segments, and every other
/// parameter is in the query (the document once declared query parameters as path
/// parameters, which validators refuse and Swagger UI shows wrongly).
#[test]
fn parameters_are_in_the_path_only_when_the_path_has_them() {
    let doc: serde_json::Value = serde_json::from_str(&mtcal_server::openapi_json()).unwrap();
    let mut query = 0;
    for (p, ops) in doc["paths"].as_object().unwrap() {
        for (method, op) in ops.as_object().unwrap() {
            for param in op["parameters"].as_array().into_iter().flatten() {
                let name = param["name"].as_str().unwrap();
                let in_path = p.contains(&format!("{{{name}}}"));
                let declared = param["in"].as_str().unwrap();
                assert_eq!(
                    declared,
                    if in_path { "path" } else { "query" },
                    "{method} {p}: parameter {name}"
                );
                query += usize::from(!in_path);
            }
        }
    }
    assert!(query >= 5, "{query} query parameters");
}

/// The committed document is valid OpenAPI for `openapi-spec-validator` (PyPI; `.ci/run`
/// installs it next to schemathesis). Without the tool the test says it skipped, unless
/// `MTCAL_CI=1`, where it fails.
#[test]
fn committed_document_passes_openapi_spec_validator() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../openapi/openapi.json");
    const INSTALL: &str = "pip install openapi-spec-validator";
    let out = std::process::Command::new("openapi-spec-validator")
        .arg(path)
        .output();
    // Not found, or a version manager's shim without it (exit 127).
    let missing = match &out {
        Err(e) => e.kind() == std::io::ErrorKind::NotFound,
        Ok(o) => o.status.code() == Some(127),
    };
    if missing {
        assert!(
            std::env::var("MTCAL_CI").as_deref() != Ok("1"),
            "openapi-spec-validator is not installed ({INSTALL}); MTCAL_CI=1 needs it"
        );
        eprintln!("skipped: openapi-spec-validator is not installed ({INSTALL})");
        return;
    }
    let out = out.unwrap();
    assert!(
        out.status.success(),
        "openapi/openapi.json is not valid OpenAPI:\n{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
}

/// Where a case's value sits in the document: a request body of a component schema, or
/// one query parameter of an operation.
#[derive(Clone, Copy)]
enum At {
    Body(&'static str),
    Query(&'static str, &'static str),
}

/// Whether each value is valid for its schema in the committed document, by Python's
/// `jsonschema` (Draft 2020-12, the validator schemathesis uses); `None` without it.
fn valid_for_document(cases: &[(At, serde_json::Value)]) -> Option<Vec<bool>> {
    let doc: serde_json::Value = serde_json::from_str(&mtcal_server::openapi_json()).unwrap();
    let schemas: Vec<serde_json::Value> = cases
        .iter()
        .map(|(at, _)| match at {
            At::Body(name) => serde_json::json!({
                "components": doc["components"],
                "$ref": format!("#/components/schemas/{name}"),
            }),
            At::Query(path, name) => doc["paths"][path]["get"]["parameters"]
                .as_array()
                .unwrap()
                .iter()
                .find(|p| p["name"] == *name)
                .unwrap_or_else(|| panic!("{path} has no parameter {name}"))["schema"]
                .clone(),
        })
        .collect();
    let values: Vec<&serde_json::Value> = cases.iter().map(|(_, v)| v).collect();
    let input = serde_json::json!({"schemas": schemas, "values": values}).to_string();
    let script = "import json, sys\n\
        from jsonschema import Draft202012Validator as V\n\
        d = json.load(sys.stdin)\n\
        print(json.dumps([V(s).is_valid(v) for s, v in zip(d['schemas'], d['values'])]))\n";
    let mut child = std::process::Command::new("python3")
        .args(["-c", script])
        .stdin(std::process::Stdio::piped())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .ok()?;
    use std::io::Write;
    child
        .stdin
        .take()
        .unwrap()
        .write_all(input.as_bytes())
        .unwrap();
    let out = child.wait_with_output().unwrap();
    if !out.status.success() {
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains("No module named"), "{err}");
        return None;
    }
    Some(serde_json::from_slice(&out.stdout).unwrap())
}

/// A value at its place in the document, and the server's request carrying it: method,
/// URI, key; whether the server accepts it.
type Case<'a> = (At, serde_json::Value, &'a str, String, &'a str, bool);

/// The document states the constraints the server enforces: each request the server
/// refuses (400) for a text rule, a scope, an empty query value or a format is invalid
/// for the document too, and each one it accepts is valid for it.
#[tokio::test]
async fn the_document_refuses_what_the_server_refuses() {
    use crate::common::{app, machine, request, send};
    use serde_json::json;
    let (app, keys, _) = app().await;
    machine(&app, &keys.write, "M1").await;
    let long = "x".repeat(201);
    let tags: Vec<String> = (0..33).map(|i| format!("t{i}")).collect();
    let profile = |scope: &str, target: &str| json!({"scope": scope, "target": target, "limits": {"drift_um": 1.0}});
    let cases: Vec<Case> = vec![
        (
            At::Body("NewMachine"),
            json!({"id": "M2", "name": "Mill 2"}),
            "POST",
            "/api/v1/machines".into(),
            &keys.write,
            true,
        ),
        (
            At::Body("NewMachine"),
            json!({"id": ".", "name": "dot"}),
            "POST",
            "/api/v1/machines".into(),
            &keys.write,
            false,
        ),
        (
            At::Body("NewMachine"),
            json!({"id": "..", "name": "dots"}),
            "POST",
            "/api/v1/machines".into(),
            &keys.write,
            false,
        ),
        (
            At::Body("NewMachine"),
            json!({"id": "M3", "name": ""}),
            "POST",
            "/api/v1/machines".into(),
            &keys.write,
            false,
        ),
        (
            At::Body("NewMachine"),
            json!({"id": "M3", "name": "  "}),
            "POST",
            "/api/v1/machines".into(),
            &keys.write,
            false,
        ),
        (
            At::Body("NewMachine"),
            json!({"id": "M3", "name": "a\u{0}b"}),
            "POST",
            "/api/v1/machines".into(),
            &keys.write,
            false,
        ),
        (
            At::Body("NewMachine"),
            json!({"id": "M3", "name": long}),
            "POST",
            "/api/v1/machines".into(),
            &keys.write,
            false,
        ),
        (
            At::Body("NewMachine"),
            json!({"id": "M3", "name": "n", "site": ""}),
            "POST",
            "/api/v1/machines".into(),
            &keys.write,
            false,
        ),
        (
            At::Body("NewMachine"),
            json!({"id": "M3", "name": "n", "tags": tags}),
            "POST",
            "/api/v1/machines".into(),
            &keys.write,
            false,
        ),
        (
            At::Body("MachinePatch"),
            json!({"name": "\t"}),
            "PATCH",
            "/api/v1/machines/M1".into(),
            &keys.write,
            false,
        ),
        (
            At::Body("NewProfile"),
            profile("machine", "M1"),
            "POST",
            "/api/v1/tolerances".into(),
            &keys.write,
            true,
        ),
        (
            At::Body("NewProfile"),
            profile("", "M1"),
            "POST",
            "/api/v1/tolerances".into(),
            &keys.write,
            false,
        ),
        (
            At::Body("NewProfile"),
            profile("tag", ""),
            "POST",
            "/api/v1/tolerances".into(),
            &keys.write,
            false,
        ),
        (
            At::Body("NewKey"),
            json!({"scope": "read", "label": ""}),
            "POST",
            "/api/v1/keys".into(),
            &keys.admin,
            false,
        ),
        (
            At::Body("NewKey"),
            json!({"scope": "read", "label": "viewer"}),
            "POST",
            "/api/v1/keys".into(),
            &keys.admin,
            true,
        ),
        (
            At::Query("/api/v1/machines/{id}/trends/term", "at"),
            json!(""),
            "GET",
            "/api/v1/machines/M1/trends/term?term=EXX&at=".into(),
            &keys.read,
            false,
        ),
        (
            At::Query("/api/v1/jobs", "state"),
            json!("lost"),
            "GET",
            "/api/v1/jobs?state=lost".into(),
            &keys.read,
            false,
        ),
        (
            At::Query("/api/v1/jobs", "state"),
            json!("queued"),
            "GET",
            "/api/v1/jobs?state=queued".into(),
            &keys.read,
            true,
        ),
        (
            At::Query("/api/v1/jobs", "limit"),
            json!(0),
            "GET",
            "/api/v1/jobs?limit=0".into(),
            &keys.read,
            false,
        ),
    ];
    let mut wrong = vec![];
    for (i, (_, value, method, uri, key, accepted)) in cases.iter().enumerate() {
        let body = if method == &"GET" {
            vec![]
        } else {
            value.to_string().into_bytes()
        };
        let ct = if body.is_empty() {
            ""
        } else {
            "application/json"
        };
        let (s, b) = send(&app, request(method, uri, ct, None, body, Some(key))).await;
        if s.is_success() != *accepted || (!accepted && s != axum::http::StatusCode::BAD_REQUEST) {
            wrong.push(format!(
                "case {i}: the server answered {method} {uri} {value}: {s} {b}"
            ));
        }
    }
    let checked: Vec<(At, serde_json::Value)> = cases.iter().map(|c| (c.0, c.1.clone())).collect();
    let Some(valid) = valid_for_document(&checked) else {
        assert!(
            std::env::var("MTCAL_CI").as_deref() != Ok("1"),
            "python3 with jsonschema is needed (schemathesis brings it)"
        );
        eprintln!("skipped the document's half: no python3 with jsonschema");
        assert!(wrong.is_empty(), "{}", wrong.join("\n"));
        return;
    };
    for (i, (c, v)) in cases.iter().zip(valid).enumerate() {
        let (value, ok) = (&c.1, c.5);
        if v != ok {
            wrong.push(format!(
                "case {i}: the document finds {value} valid: {v}, the server: {ok}"
            ));
        }
    }
    assert!(wrong.is_empty(), "{}", wrong.join("\n"));
}
