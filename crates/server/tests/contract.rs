//! The OpenAPI document declares every status an operation answers: each operation of
//! the document is sent the requests that provoke the rejections of the layers and
//! extractors in front of its handler (no key, too low a scope, a body that is not JSON,
//! of the wrong type or too large, bad query values, unknown ids) and each answer's
//! status must be one the operation declares, with the JSON error body of a stable code.

use crate::common::{Keys, app, request, send};
use axum::http::StatusCode;
use mtcal_server::contract::required_scope;
use serde_json::Value;

/// One provocation: what was sent, and the status it must get when the rule is known.
struct Case {
    what: String,
    method: String,
    uri: String,
    ct: String,
    body: Vec<u8>,
    key: Option<String>,
    want: Option<StatusCode>,
}

fn cases(path: &str, method: &str, op: &Value, keys: &Keys, subject: &str) -> Vec<Case> {
    let uri = path
        .split('/')
        .map(|seg| if seg.starts_with('{') { subject } else { seg })
        .collect::<Vec<_>>()
        .join("/");
    let m = method.to_uppercase();
    let scope = required_scope(op);
    let own = match scope {
        Some("admin") => Some(keys.admin.clone()),
        Some("write") => Some(keys.write.clone()),
        Some(_) => Some(keys.read.clone()),
        None => None,
    };
    let body_ct = op["requestBody"]["content"]
        .as_object()
        .and_then(|c| c.keys().next().cloned());
    let plain_ct = body_ct.clone().unwrap_or_default();
    let plain_body = if plain_ct == "application/json" {
        b"{}".to_vec()
    } else {
        vec![]
    };
    let case = |what: &str, uri: &str, ct: &str, body: Vec<u8>, key: Option<String>, want| Case {
        what: what.into(),
        method: m.clone(),
        uri: uri.into(),
        ct: ct.into(),
        body,
        key,
        want,
    };
    let mut out = vec![case(
        "plain",
        &uri,
        &plain_ct,
        plain_body.clone(),
        own.clone(),
        None,
    )];
    if scope.is_some() {
        out.push(case(
            "no key",
            &uri,
            &plain_ct,
            plain_body.clone(),
            None,
            Some(StatusCode::UNAUTHORIZED),
        ));
        out.push(case(
            "unknown key",
            &uri,
            &plain_ct,
            plain_body.clone(),
            Some("mtk_00000000000000000000000000000000".into()),
            Some(StatusCode::UNAUTHORIZED),
        ));
        out.push(case(
            "read key",
            &uri,
            &plain_ct,
            plain_body.clone(),
            Some(keys.read.clone()),
            (scope != Some("read")).then_some(StatusCode::FORBIDDEN),
        ));
    }
    if let Some(ct) = &body_ct {
        out.push(case(
            "body of the wrong type",
            &uri,
            "text/plain",
            b"{}".to_vec(),
            own.clone(),
            Some(StatusCode::UNSUPPORTED_MEDIA_TYPE),
        ));
        let sized_ct = if ct == "multipart/form-data" {
            "multipart/form-data; boundary=x"
        } else {
            ct
        };
        out.push(case(
            "body too large",
            &uri,
            sized_ct,
            vec![b' '; 2 << 20],
            own.clone(),
            Some(StatusCode::PAYLOAD_TOO_LARGE),
        ));
        if ct == "application/json" {
            out.push(case(
                "body not JSON",
                &uri,
                ct,
                b"{not json".to_vec(),
                own.clone(),
                Some(StatusCode::BAD_REQUEST),
            ));
            out.push(case(
                "body of the wrong shape",
                &uri,
                ct,
                b"[1, 2]".to_vec(),
                own.clone(),
                Some(StatusCode::BAD_REQUEST),
            ));
        }
    }
    for p in op["parameters"].as_array().into_iter().flatten() {
        if p["in"] == "query" {
            let name = p["name"].as_str().unwrap();
            for bad in ["%ZZ", "-1", "1e999", "", "x%00y"] {
                out.push(case(
                    &format!("query {name}={bad}"),
                    &format!("{uri}?{name}={bad}"),
                    &plain_ct,
                    plain_body.clone(),
                    own.clone(),
                    None,
                ));
            }
        }
    }
    out
}

#[tokio::test]
async fn every_status_answered_is_declared() {
    let (app, keys, _) = app().await;
    // A machine to name, so that handlers get past the lookup.
    crate::common::machine(&app, &keys.write, "M").await;
    let doc: Value = serde_json::from_str(&mtcal_server::openapi_json()).unwrap();
    let mut sent = 0;
    for (path, ops) in doc["paths"].as_object().unwrap() {
        for (method, op) in ops.as_object().unwrap() {
            let declared: Vec<&String> = op["responses"].as_object().unwrap().keys().collect();
            for subject in ["nope", "M"] {
                for c in cases(path, method, op, &keys, subject) {
                    let (status, body) = send(
                        &app,
                        request(&c.method, &c.uri, &c.ct, None, c.body, c.key.as_deref()),
                    )
                    .await;
                    sent += 1;
                    let at = format!("{method} {path} ({} as {}): {status}", c.what, c.uri);
                    // An unknown subject may be refused (404) before its body is read.
                    let decided = c.key.is_none() || c.what.contains("key") || subject == "M";
                    if let Some(want) = c.want.filter(|_| decided) {
                        assert_eq!(status, want, "{at} {body:?}");
                    }
                    assert!(
                        declared.contains(&&status.as_u16().to_string()),
                        "{at} is not declared ({declared:?}): {body:?}"
                    );
                    if status.is_client_error() || status.is_server_error() {
                        let code = body["error"]["code"].as_str();
                        assert!(code.is_some(), "{at}: no JSON error body: {body:?}");
                    }
                }
            }
        }
    }
    assert!(sent > 200, "{sent} requests");
}

/// The document declares no status a rule above forbids: a read route never 403s.
#[test]
fn forbidden_is_declared_only_above_read_scope() {
    let doc: Value = serde_json::from_str(&mtcal_server::openapi_json()).unwrap();
    for (path, ops) in doc["paths"].as_object().unwrap() {
        for (method, op) in ops.as_object().unwrap() {
            let has_403 = op["responses"].get("403").is_some();
            let above_read = matches!(required_scope(op), Some("write" | "admin"));
            assert_eq!(has_403, above_read, "{method} {path}");
        }
    }
}

/// Result documents and downloads are typed: no operation answers a bare `object` or an
/// array of integers.
#[test]
fn result_documents_are_typed_and_files_are_binary() {
    let doc: Value = serde_json::from_str(&mtcal_server::openapi_json()).unwrap();
    let schemas = &doc["components"]["schemas"];
    for name in [
        "IdentificationResult",
        "DiagnosisResult",
        "CradleResult",
        "StandardsResult",
        "SensitivityResult",
    ] {
        assert!(
            schemas[name]["properties"].as_object().is_some()
                || schemas[name]["allOf"].as_array().is_some(),
            "{name} is not a typed schema"
        );
    }
    let resolve = |v: &Value| -> Value {
        match v["$ref"].as_str() {
            Some(r) => schemas[r.trim_start_matches("#/components/schemas/")].clone(),
            None => v.clone(),
        }
    };
    let document = resolve(&schemas["StoredResult"]["properties"]["document"]);
    assert_eq!(
        document["anyOf"].as_array().map(Vec::len),
        Some(5),
        "{document}"
    );
    let job_result = &doc["paths"]["/api/v1/jobs/{id}/result"]["get"]["responses"]["200"];
    let job_result = resolve(&job_result["content"]["application/json"]["schema"]);
    assert_eq!(job_result, document);
    let file = resolve(
        &doc["paths"]["/api/v1/datasets/{id}/files/{name}"]["get"]["responses"]["200"]["content"]["application/octet-stream"]
            ["schema"],
    );
    assert_eq!(file["type"], "string", "{file}");
    assert!(file.get("items").is_none(), "{file}");
}
