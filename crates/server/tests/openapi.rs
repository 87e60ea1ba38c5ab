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
