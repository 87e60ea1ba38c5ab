//! The published contract against the running service: schemathesis (4.x) generates
//! requests for every operation of `/api-docs/openapi.json` (examples, coverage, fuzzing
//! and stateful phases) and checks every answer with all its checks (no server error, a
//! declared status, the declared content type and headers, a body matching its schema,
//! invalid data refused, valid data accepted, authentication not ignored, …) against a
//! service on 127.0.0.1, seeded with a machine, a session dataset and its
//! identification, authenticated with a write key: on a fresh SQLite file, and on
//! PostgreSQL (a schema of its own on the server `MTCAL_TEST_PG` names; without it that
//! half says it skipped, and fails under `MTCAL_CI=1`). Zero failures.
//!
//! `positive_data_acceptance` (a request valid for the document is accepted) runs with
//! the statuses of `tests/e2e/schemathesis.toml`: beside the default refusals of
//! schema-valid data (404 for an id that names nothing, 403, 409), a few operations may
//! refuse such data with 400 or 422 for a rule JSON Schema cannot state there (a travel's
//! min < max, an upload's file formats, a job on a dataset of another kind, a webhook
//! URL refused by where it leads); the file says which and why. Every other rule the
//! server enforces is in the document.
//!
//! Bounded: at most [`MAX_EXAMPLES`] cases per operation and phase, and the run is
//! killed (failing the test) after [`WALL_CLOCK`]. Without schemathesis on the PATH the
//! test says it skipped, unless `MTCAL_CI=1` (`.ci/run` installs it), where it fails.

use crate::common::*;
use mtcal_server::jobs::JobKind;
use mtcal_store::JobState;
use std::process::Stdio;
use std::time::Duration;

/// Cases per operation and phase.
const MAX_EXAMPLES: &str = "25";
/// The whole run's limit: a guard against a hang, not a timing. Both backends' runs go at
/// once beside the rest of the suite; under a load of 10 on 2 cores a run passed 150 s.
const WALL_CLOCK: Duration = Duration::from_secs(480);

/// Seeds the service: machine M1 with a session dataset and a result of every kind but
/// cradle on it (identification, diagnosis, standards; sensitivity from parameters),
/// machine C1 with a rotary point set and its cradle check. Returns the result ids.
async fn seed(app: &App) -> Vec<String> {
    app.machine("M1").await;
    let dir = app.path("session");
    write_session(&dir, "M1", 1, 0);
    let ds = app.client.upload_path("M1", &dir).await.unwrap();
    let mut jobs = vec![];
    for kind in [JobKind::Identify, JobKind::Standards, JobKind::Diagnose] {
        jobs.push(submit(&app.client, kind, Some(&ds.id), None).await.id);
    }
    let mut j = job(JobKind::Sensitivity, None, Some("M1"));
    j.params = serde_json::json!({"machine": {"template": "vmc3"}});
    jobs.push(app.client.submit(&j).await.unwrap().id);
    app.machine("C1").await;
    let dir = app.path("cradle");
    write_cradle_set(&dir, "C1");
    let ds = app.client.upload_path("C1", &dir).await.unwrap();
    jobs.push(
        submit(&app.client, JobKind::Cradle, Some(&ds.id), None)
            .await
            .id,
    );
    let mut results = vec![];
    for id in jobs {
        let done = app.wait(&id, JobState::Succeeded).await;
        results.push(done.result_id.unwrap());
    }
    results
}

/// Each seeded result, as `GET /api/v1/results/{id}` returns it, is valid for the
/// document's `StoredResult` schema and its document for the schema of its kind
/// (Python's jsonschema, Draft 2020-12, which schemathesis brings).
fn check_documents(app: &App, results: &[String]) {
    const SCRIPT: &str = r##"
import json, sys, urllib.request, jsonschema
base, key, ids = sys.argv[1], sys.argv[2], sys.argv[3:]
def get(p):
    r = urllib.request.Request(base + p, headers={"Authorization": "Bearer " + key})
    return json.load(urllib.request.urlopen(r))
doc = get("/api-docs/openapi.json")
names = {"identification": "IdentificationResult", "diagnosis": "DiagnosisResult",
         "cradle": "CradleResult", "standards": "StandardsResult",
         "sensitivity": "SensitivityResult"}
def validator(name):
    return jsonschema.Draft202012Validator(
        {"$ref": "#/components/schemas/" + name, "components": doc["components"]})
bad = []
kinds = set()
for rid in ids:
    r = get("/api/v1/results/" + rid)
    kind = r["meta"]["kind"]
    kinds.add(kind)
    for v, inst in ((validator("StoredResult"), r), (validator(names[kind]), r["document"])):
        for e in v.iter_errors(inst):
            bad.append(f"{kind} {rid}: {'/'.join(map(str, e.absolute_path))}: {e.message[:300]}")
assert kinds == set(names), kinds
print(chr(10).join(bad[:40]))
sys.exit(1 if bad else 0)
"##;
    let out = std::process::Command::new("python3")
        .args(["-c", SCRIPT, &app.url, &app.read_key])
        .args(results)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "stored results do not match their schemas:\n{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
}

/// Whether schemathesis is on the PATH (else the test says it skipped, and fails under
/// `MTCAL_CI=1`).
fn schemathesis_available() -> bool {
    let found = std::process::Command::new("schemathesis")
        .arg("--version")
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success());
    if !found {
        assert!(
            std::env::var("MTCAL_CI").as_deref() != Ok("1"),
            "schemathesis is not installed (pip install 'schemathesis>=4,<5'); MTCAL_CI=1 \
             needs it"
        );
        eprintln!("skipped: schemathesis is not installed (pip install 'schemathesis>=4,<5')");
    }
    found
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn schemathesis_finds_nothing_on_sqlite() {
    if !schemathesis_available() {
        return;
    }
    run(spawn_app().await).await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn schemathesis_finds_nothing_on_postgres() {
    if !schemathesis_available() {
        return;
    }
    let Some(pg) = mtcal_store::testing::ScratchPg::create("e2e::schemathesis")
        .await
        .unwrap()
    else {
        return;
    };
    run(spawn_app_with(AppOptions {
        db_url: Some(pg.url.clone()),
        ..AppOptions::default()
    })
    .await)
    .await;
    pg.drop_schema().await.unwrap();
}

/// Seeds `app`, checks its stored results against their schemas and runs schemathesis
/// against it.
async fn run(app: App) {
    assert!(app.url.starts_with("http://127.0.0.1:"), "{}", app.url);
    let results = seed(&app).await;
    check_documents(&app, &results);

    let report = app.path("schemathesis.xml");
    let mut cmd = tokio::process::Command::new("schemathesis");
    cmd.arg("--config-file")
        .arg(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/tests/e2e/schemathesis.toml"
        ))
        .arg("run")
        .arg(format!("{}/api-docs/openapi.json", app.url))
        .args([
            "--header",
            &format!("Authorization: Bearer {}", app.write_key),
        ])
        .args(["--checks", "all"])
        .args(["--phases", "examples,coverage,fuzzing,stateful"])
        .args(["--max-examples", MAX_EXAMPLES])
        .args(["--seed", "1"])
        // One worker: Python 3.11's compile() is not thread-safe in schemathesis'
        // coverage phase ("AST constructor recursion depth mismatch").
        .args(["--workers", "1"])
        .args(["--request-timeout", "20"])
        .args(["--suppress-health-check", "all"])
        .args(["--report", "junit", "--report-junit-path"])
        .arg(&report)
        .env("NO_COLOR", "1")
        .env("SCHEMATHESIS_TELEMETRY", "false")
        .current_dir(app.dir.path())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .kill_on_drop(true);
    let child = cmd.spawn().unwrap();
    let out = tokio::time::timeout(WALL_CLOCK, child.wait_with_output())
        .await
        .unwrap_or_else(|_| panic!("schemathesis ran longer than {WALL_CLOCK:?}"))
        .unwrap();
    let text = format!(
        "{}\n{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(out.status.success(), "schemathesis found failures:\n{text}");
    let summary = text.find("SUMMARY").map_or(&text[..0], |i| &text[i..]);
    eprintln!("{summary}");
    // It did test every operation of the document.
    let doc: serde_json::Value = serde_json::from_str(&mtcal_server::openapi_json()).unwrap();
    let operations: usize = doc["paths"]
        .as_object()
        .unwrap()
        .values()
        .map(|p| p.as_object().unwrap().len())
        .sum();
    assert!(
        summary.contains(&format!("Tested: {operations}\n")),
        "not every one of the {operations} operations was tested:\n{summary}"
    );
}
