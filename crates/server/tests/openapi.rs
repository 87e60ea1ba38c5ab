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

/// A value at its place in the document, and the server's request carrying it; the
/// status the server answers. A request the server refuses with 400 must be invalid for
/// the document; any other answer (success, or 404 for an id that names nothing) valid.
struct Case<'a> {
    at: At,
    value: serde_json::Value,
    method: &'a str,
    uri: String,
    key: &'a str,
    status: u16,
}

fn case<'a>(
    at: At,
    value: serde_json::Value,
    method: &'a str,
    uri: &str,
    key: &'a str,
    status: u16,
) -> Case<'a> {
    Case {
        at,
        value,
        method,
        uri: uri.into(),
        key,
        status,
    }
}

/// `c` answered with `status`.
fn with(c: Case, status: u16) -> Case {
    Case { status, ..c }
}

/// A multipart body of form fields (`csv_dialect`, …) and files, as an upload sends it.
fn multipart(value: &serde_json::Value) -> (String, Vec<u8>) {
    let boundary = "b0undary";
    let mut body = Vec::new();
    for (name, v) in value.as_object().unwrap() {
        let parts: Vec<&serde_json::Value> = match v {
            serde_json::Value::Array(a) => a.iter().collect(),
            v => vec![v],
        };
        for p in parts {
            let file = if name == "files" {
                "; filename=\"positions.csv\""
            } else {
                ""
            };
            body.extend_from_slice(
                format!(
                    "--{boundary}\r\nContent-Disposition: form-data; name=\"{name}\"{file}\r\n\r\n{}\r\n",
                    p.as_str().unwrap()
                )
                .as_bytes(),
            );
        }
    }
    body.extend_from_slice(format!("--{boundary}--\r\n").as_bytes());
    (format!("multipart/form-data; boundary={boundary}"), body)
}

/// The document states the constraints the server enforces: each request the server
/// refuses (400) for a text rule, a scope, an empty query value, a format, a job kind's
/// dataset or machine, a topology or a travel is invalid for the document too, and each
/// one it accepts is valid for it.
#[tokio::test]
async fn the_document_refuses_what_the_server_refuses() {
    use crate::common::{app, machine, request, send};
    use serde_json::json;
    let (app, keys, _) = app().await;
    machine(&app, &keys.write, "M1").await;
    let long = "x".repeat(201);
    let tags: Vec<String> = (0..33).map(|i| format!("t{i}")).collect();
    let profile = |scope: &str, target: &str| json!({"scope": scope, "target": target, "limits": {"drift_um": 1.0}});
    let (w, r, a) = (keys.write.as_str(), keys.read.as_str(), keys.admin.as_str());
    let new_machine = |id: &str, extra: serde_json::Value| {
        let mut m = json!({"id": id, "name": "n"});
        m.as_object_mut()
            .unwrap()
            .extend(extra.as_object().unwrap().clone());
        case(At::Body("NewMachine"), m, "POST", "/api/v1/machines", w, 0)
    };
    let job = |value: serde_json::Value, status: u16| {
        case(
            At::Body("SubmitJob"),
            value,
            "POST",
            "/api/v1/jobs",
            w,
            status,
        )
    };
    let upload = |value: serde_json::Value, status: u16| {
        case(
            At::Body("SessionUpload"),
            value,
            "POST",
            "/api/v1/machines/M1/datasets",
            w,
            status,
        )
    };
    let positioning = "axis,run,direction,target_mm,deviation_um\nX,1,+,0,0.5\nX,1,+,10,0.7\n\
                       X,1,-,10,0.6\nX,1,-,0,0.4\n";
    let sensitivity = json!({"machine": {"template": "vmc3"}});
    let cases: Vec<Case> = vec![
        case(
            At::Body("NewMachine"),
            json!({"id": "M2", "name": "Mill 2"}),
            "POST",
            "/api/v1/machines",
            w,
            201,
        ),
        case(
            At::Body("NewMachine"),
            json!({"id": ".", "name": "dot"}),
            "POST",
            "/api/v1/machines",
            w,
            400,
        ),
        case(
            At::Body("NewMachine"),
            json!({"id": "..", "name": "dots"}),
            "POST",
            "/api/v1/machines",
            w,
            400,
        ),
        case(
            At::Body("NewMachine"),
            json!({"id": "M3", "name": ""}),
            "POST",
            "/api/v1/machines",
            w,
            400,
        ),
        case(
            At::Body("NewMachine"),
            json!({"id": "M3", "name": "  "}),
            "POST",
            "/api/v1/machines",
            w,
            400,
        ),
        case(
            At::Body("NewMachine"),
            json!({"id": "M3", "name": "a\u{0}b"}),
            "POST",
            "/api/v1/machines",
            w,
            400,
        ),
        case(
            At::Body("NewMachine"),
            json!({"id": "M3", "name": long}),
            "POST",
            "/api/v1/machines",
            w,
            400,
        ),
        case(
            At::Body("NewMachine"),
            json!({"id": "M3", "name": "n", "site": ""}),
            "POST",
            "/api/v1/machines",
            w,
            400,
        ),
        case(
            At::Body("NewMachine"),
            json!({"id": "M3", "name": "n", "tags": tags}),
            "POST",
            "/api/v1/machines",
            w,
            400,
        ),
        with(new_machine("M3", json!({"tags": [""]})), 400),
        with(new_machine("M3", json!({"tags": ["a", "a"]})), 400),
        with(new_machine("M3", json!({"topology": {}})), 400),
        with(
            new_machine(
                "M3",
                json!({"topology": {"workpiece": ["X", "X"], "tool": ["Z"]}}),
            ),
            400,
        ),
        with(
            new_machine(
                "M3",
                json!({"topology": {"workpiece": ["X"], "tool": ["Y", "Z"], "spindle": []}}),
            ),
            400,
        ),
        with(
            new_machine(
                "M3",
                json!({"topology": {"workpiece": ["Y"], "tool": ["Z", "X"]}}),
            ),
            201,
        ),
        with(
            new_machine("M4", json!({"travel_mm": {"X": [-10.0, 10.0, 20.0]}})),
            400,
        ),
        with(
            new_machine("M4", json!({"travel_mm": {"A": [-10.0, 10.0]}})),
            400,
        ),
        with(
            new_machine("M4", json!({"travel_mm": {"X": [-2e5, 10.0]}})),
            400,
        ),
        with(
            new_machine(
                "M4",
                json!({"travel_mm": {"X": [-300.0, 300.0], "Z": [-1e5, 0.0]}}),
            ),
            201,
        ),
        case(
            At::Body("MachinePatch"),
            json!({"name": "\t"}),
            "PATCH",
            "/api/v1/machines/M1",
            w,
            400,
        ),
        case(
            At::Body("MachinePatch"),
            json!({"topology": {}}),
            "PATCH",
            "/api/v1/machines/M1",
            w,
            400,
        ),
        case(
            At::Body("MachinePatch"),
            json!({"tags": ["line-a", " "]}),
            "PATCH",
            "/api/v1/machines/M1",
            w,
            400,
        ),
        case(
            At::Body("MachinePatch"),
            json!({"tags": ["line-a"], "topology": null}),
            "PATCH",
            "/api/v1/machines/M1",
            w,
            200,
        ),
        case(
            At::Body("NewProfile"),
            profile("machine", "M1"),
            "POST",
            "/api/v1/tolerances",
            w,
            201,
        ),
        case(
            At::Body("NewProfile"),
            profile("", "M1"),
            "POST",
            "/api/v1/tolerances",
            w,
            400,
        ),
        case(
            At::Body("NewProfile"),
            profile("tag", ""),
            "POST",
            "/api/v1/tolerances",
            w,
            400,
        ),
        case(
            At::Body("NewKey"),
            json!({"scope": "read", "label": ""}),
            "POST",
            "/api/v1/keys",
            a,
            400,
        ),
        case(
            At::Body("NewKey"),
            json!({"scope": "read", "label": "viewer"}),
            "POST",
            "/api/v1/keys",
            a,
            201,
        ),
        // A job kind that runs on a dataset needs one; sensitivity needs a machine and
        // takes no dataset; cradle and standards take no parameters.
        job(json!({"kind": "cradle"}), 400),
        job(json!({"kind": "identify", "machine_id": "M1"}), 400),
        job(json!({"kind": "diagnose", "params": {}}), 400),
        job(json!({"kind": "standards", "dataset_id": null}), 400),
        job(
            json!({"kind": "cradle", "dataset_id": "ds_none", "params": {"order": 3}}),
            400,
        ),
        job(
            json!({"kind": "identify", "dataset_id": "ds_none", "params": {"method": "best"}}),
            400,
        ),
        job(
            json!({"kind": "diagnose", "dataset_id": "ds_none", "params": {"fit_fraction": 0.1}}),
            400,
        ),
        job(json!({"kind": "sensitivity", "params": sensitivity}), 400),
        job(json!({"kind": "sensitivity", "machine_id": "M1"}), 400),
        job(
            json!({"kind": "sensitivity", "machine_id": "M1", "dataset_id": "ds_none", "params": sensitivity}),
            400,
        ),
        job(json!({"kind": "import", "dataset_id": "ds_none"}), 400),
        job(
            json!({"kind": "sensitivity", "machine_id": "M1", "params": sensitivity}),
            202,
        ),
        job(
            json!({"kind": "cradle", "dataset_id": "ds_none", "params": {}}),
            404,
        ),
        job(
            json!({"kind": "identify", "dataset_id": "ds_none", "params": {"method": "stepwise", "basis": "legendre"}}),
            404,
        ),
        job(
            json!({"kind": "diagnose", "dataset_id": "ds_none", "params": {"fit_fraction": 0.5}}),
            404,
        ),
        // The CSV dialect of an upload is `plain` or `excel`.
        upload(json!({"csv_dialect": "", "files": [positioning]}), 400),
        upload(json!({"csv_dialect": "comma", "files": [positioning]}), 400),
        upload(json!({"csv_dialect": "plain", "files": [positioning]}), 201),
        case(
            At::Query("/api/v1/machines/{id}/trends/term", "at"),
            json!(""),
            "GET",
            "/api/v1/machines/M1/trends/term?term=EXX&at=",
            r,
            400,
        ),
        case(
            At::Query("/api/v1/machines/{id}/trends/term", "at"),
            json!("50,x"),
            "GET",
            "/api/v1/machines/M1/trends/term?term=EXX&at=50,x",
            r,
            400,
        ),
        case(
            At::Query("/api/v1/machines/{id}/trends/term", "at"),
            json!("1e400"),
            "GET",
            "/api/v1/machines/M1/trends/term?term=EXX&at=1e400",
            r,
            400,
        ),
        case(
            At::Query("/api/v1/machines/{id}/trends/term", "at"),
            json!("50, -50,.5,1e2"),
            "GET",
            "/api/v1/machines/M1/trends/term?term=EXX&at=50,%20-50,.5,1e2",
            r,
            200,
        ),
        case(
            At::Query("/api/v1/alerts", "machine"),
            json!("M\u{1}"),
            "GET",
            "/api/v1/alerts?machine=M%01",
            r,
            400,
        ),
        case(
            At::Query("/api/v1/alerts", "machine"),
            json!("M1"),
            "GET",
            "/api/v1/alerts?machine=M1",
            r,
            200,
        ),
        case(
            At::Query("/api/v1/jobs", "state"),
            json!("lost"),
            "GET",
            "/api/v1/jobs?state=lost",
            r,
            400,
        ),
        case(
            At::Query("/api/v1/jobs", "state"),
            json!("queued"),
            "GET",
            "/api/v1/jobs?state=queued",
            r,
            200,
        ),
        case(
            At::Query("/api/v1/jobs", "limit"),
            json!(0),
            "GET",
            "/api/v1/jobs?limit=0",
            r,
            400,
        ),
    ];
    let mut wrong = vec![];
    for (i, c) in cases.iter().enumerate() {
        let (ct, body) = match c.at {
            At::Body("SessionUpload") => multipart(&c.value),
            _ if c.method == "GET" => (String::new(), vec![]),
            _ => ("application/json".into(), c.value.to_string().into_bytes()),
        };
        let (s, b) = send(
            &app,
            request(c.method, &c.uri, &ct, None, body, Some(c.key)),
        )
        .await;
        if s.as_u16() != c.status {
            wrong.push(format!(
                "case {i}: the server answered {} {} {}: {s} {b} (expected {})",
                c.method, c.uri, c.value, c.status
            ));
        }
    }
    let checked: Vec<(At, serde_json::Value)> =
        cases.iter().map(|c| (c.at, c.value.clone())).collect();
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
        let ok = c.status != 400;
        if v != ok {
            wrong.push(format!(
                "case {i}: the document finds {} valid: {v}, the server answered {}",
                c.value, c.status
            ));
        }
    }
    assert!(wrong.is_empty(), "{}", wrong.join("\n"));
}
