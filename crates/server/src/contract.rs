//! The parts of the OpenAPI document that no single handler states: the typed result
//! documents, binary downloads, and the statuses every operation can answer because of
//! what stands in front of its handler.
//!
//! Statuses added to each operation ([`Statuses`]), each with the JSON error body
//! ([`crate::error::ErrorBody`]) unless the operation declares it already:
//! * secured (`security` present): 401 `unauthorized` (no, unknown or revoked key) and
//!   408 `timeout` (the route's time limit), 503 `unavailable` (the database cannot be
//!   reached: crate::outage); 403 `forbidden` when the requirement names
//!   a scope above `read` (`security(("api_key" = ["write"]))`): the scope is declared
//!   once, in the requirement, and a key of a lower scope gets 403;
//! * a request body: 400 `invalid_request` (not valid for its schema), 413
//!   `payload_too_large`, 415 `unsupported_media_type`;
//! * a query parameter: 400 `invalid_request`;
//! * a path parameter: 400 `invalid_request` (a control character, refused by
//!   crate::edge before any route) and 404 `not_found` (no such resource).
//!
//! `crates/server/tests/contract.rs` sends each operation the requests that provoke
//! these and checks that every status answered is declared.
//!
//! Every text parameter in a path or a query is stated without control characters
//! (`state_edge_rules`), as crate::edge refuses them before any route.

use serde_json::{Value, json};
use utoipa::openapi::schema::{AnyOfBuilder, ObjectBuilder, Schema, Type};
use utoipa::openapi::{Ref, RefOr};
use utoipa::{PartialSchema, ToSchema};

/// The result document of any job kind: what `GET /api/v1/results/{id}` (in
/// `document`) and `GET /api/v1/jobs/{id}/result` return. Its `kind` (identification,
/// diagnosis, cradle, standards, sensitivity) says which.
pub struct ResultDocument;

use mtcal_solver::cradle::CradleResult;
use mtcal_solver::diagnosis::DiagnosisResult;
use mtcal_solver::identification::IdentificationResult;
use mtcal_solver::sensitivity::SensitivityResult;
use mtcal_solver::standards::StandardsResult;

impl PartialSchema for ResultDocument {
    fn schema() -> RefOr<Schema> {
        AnyOfBuilder::new()
            .item(Ref::from_schema_name(IdentificationResult::name()))
            .item(Ref::from_schema_name(DiagnosisResult::name()))
            .item(Ref::from_schema_name(CradleResult::name()))
            .item(Ref::from_schema_name(StandardsResult::name()))
            .item(Ref::from_schema_name(SensitivityResult::name()))
            .description(Some(
                "A result document; its kind (identification, diagnosis, cradle, standards, \
                 sensitivity) says which schema it follows (docs/results.md).",
            ))
            .into()
    }
}

impl ToSchema for ResultDocument {
    fn schemas(schemas: &mut Vec<(String, RefOr<Schema>)>) {
        fn add<T: ToSchema>(schemas: &mut Vec<(String, RefOr<Schema>)>) {
            schemas.push((T::name().into_owned(), T::schema()));
            T::schemas(schemas);
        }
        add::<IdentificationResult>(schemas);
        add::<DiagnosisResult>(schemas);
        add::<CradleResult>(schemas);
        add::<StandardsResult>(schemas);
        add::<SensitivityResult>(schemas);
    }
}

/// A stored result with its document, as the API returns it (the schema of
/// [`mtcal_store::StoredResult`], whose document is typed here).
#[derive(ToSchema)]
#[schema(as = StoredResult)]
#[allow(dead_code)]
pub struct StoredResultSchema {
    meta: mtcal_store::ResultMeta,
    document: ResultDocument,
}

/// A file's bytes, unchanged (`application/octet-stream`).
pub struct FileBytes;

impl PartialSchema for FileBytes {
    fn schema() -> RefOr<Schema> {
        ObjectBuilder::new()
            .schema_type(Type::String)
            .content_media_type("application/octet-stream")
            .into()
    }
}

impl ToSchema for FileBytes {}

/// Adds to every operation the statuses its layers and extractors can answer (see the
/// module documentation).
pub struct Statuses;

impl utoipa::Modify for Statuses {
    fn modify(&self, openapi: &mut utoipa::openapi::OpenApi) {
        let mut doc = serde_json::to_value(&*openapi).expect("the OpenAPI document serialises");
        complete_statuses(&mut doc);
        state_edge_rules(&mut doc);
        optional_bodies(&mut doc);
        *openapi = serde_json::from_value(doc).expect("the completed document reads back");
    }
}

/// The operations whose body may be left out (utoipa marks every declared body
/// required): an acknowledgement without a comment is an empty body.
const OPTIONAL_BODIES: [&str; 1] = ["alerts_ack"];

/// Every operation of the document (each method of each path).
fn operations_mut(doc: &mut Value) -> impl Iterator<Item = &mut Value> {
    doc.get_mut("paths")
        .and_then(Value::as_object_mut)
        .into_iter()
        .flat_map(|paths| paths.values_mut())
        .filter_map(Value::as_object_mut)
        .flat_map(|o| o.values_mut())
}

fn optional_bodies(doc: &mut Value) {
    for op in operations_mut(doc) {
        let id = op.get("operationId").and_then(Value::as_str).unwrap_or("");
        if OPTIONAL_BODIES.contains(&id)
            && let Some(body) = op.get_mut("requestBody").and_then(Value::as_object_mut)
        {
            body.insert("required".into(), Value::Bool(false));
        }
    }
}

/// The scope an operation's security requirement names (`None`: open route).
pub fn required_scope(op: &Value) -> Option<&str> {
    let reqs = op.get("security")?.as_array()?;
    let scopes = reqs.first()?.as_object()?.values().next()?.as_array()?;
    Some(scopes.first().and_then(Value::as_str).unwrap_or("read"))
}

/// States the edge's rule (crate::edge: no control character in a path or query) on
/// every text parameter in a path or a query whose schema has no pattern or
/// enumeration of its own (those admit no control character anyway).
fn state_edge_rules(doc: &mut Value) {
    for op in operations_mut(doc) {
        let Some(params) = op.get_mut("parameters").and_then(Value::as_array_mut) else {
            continue;
        };
        for p in params {
            if !matches!(p["in"].as_str(), Some("path" | "query")) {
                continue;
            }
            let Some(schema) = p.get_mut("schema").and_then(Value::as_object_mut) else {
                continue;
            };
            let text = match schema.get("type") {
                Some(Value::String(t)) => t == "string",
                Some(Value::Array(ts)) => ts.iter().any(|t| t == "string"),
                _ => false,
            };
            if text && !schema.contains_key("pattern") && !schema.contains_key("enum") {
                schema.insert(
                    "pattern".into(),
                    mtcal_store::schemas::NO_CONTROL_PATTERN.into(),
                );
            }
        }
    }
}

fn complete_statuses(doc: &mut Value) {
    let Some(paths) = doc.get_mut("paths").and_then(Value::as_object_mut) else {
        return;
    };
    for item in paths.values_mut() {
        let Some(ops) = item.as_object_mut() else {
            continue;
        };
        for op in ops.values_mut() {
            let mut add: Vec<(&str, &str)> = Vec::new();
            if let Some(scope) = required_scope(op) {
                add.push(("401", "unauthorized: no key, or an unknown or revoked one"));
                if scope != "read" {
                    add.push(("403", "forbidden: the key's scope is too low"));
                }
                add.push((
                    "408",
                    "timeout: the request took longer than the route's limit",
                ));
                add.push((
                    "503",
                    "unavailable: the database cannot be reached now (with Retry-After)",
                ));
            }
            if op.get("requestBody").is_some() {
                add.push(("400", "invalid_request: the body does not match its schema"));
                add.push((
                    "413",
                    "payload_too_large: the body is over the route's limit",
                ));
                add.push((
                    "415",
                    "unsupported_media_type: a content type or encoding the route does not read",
                ));
            }
            let params = op["parameters"].as_array().cloned().unwrap_or_default();
            if params.iter().any(|p| p["in"] == "query") {
                add.push(("400", "invalid_request: a query parameter is not valid"));
            }
            if params.iter().any(|p| p["in"] == "path") {
                add.push((
                    "400",
                    "invalid_request: a path parameter holds a control character",
                ));
                add.push(("404", "not_found: no such resource"));
            }
            let responses = op
                .as_object_mut()
                .expect("an operation is an object")
                .entry("responses")
                .or_insert_with(|| json!({}))
                .as_object_mut()
                .expect("responses is an object");
            for (status, description) in add {
                responses.entry(status).or_insert_with(|| {
                    json!({
                        "description": description,
                        "content": {"application/json": {"schema": {
                            "$ref": "#/components/schemas/ErrorBody"}}}
                    })
                });
            }
        }
    }
}
