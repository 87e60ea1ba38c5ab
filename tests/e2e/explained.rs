//! From explanation to action in the service: a check whose 21-term model misfits is
//! diagnosed on its own, its explained model is stored beside it and decides its
//! verdicts, its LinuxCNC table carries the reversal the simulation put in, and the next
//! check is verified against the prediction; a check the diagnosis explains only partly
//! stays not decided.

use crate::common::*;
use mtcal_formats::compensation::Format;
use mtcal_solver::identification::IdentificationResult;
use mtcal_store::{JobState, StoredResult};
use reqwest::StatusCode;
use serde_json::{Value, json};
use std::time::Duration;

/// Simulated lost motion of X and Y, µm.
const LOST_X: f64 = 6.0;
const LOST_Y: f64 = 3.5;

/// Simulates a full-plan session of `machine` (seed `seed`, 5 Hz) with `effects` and
/// uploads it; its folder and the dataset.
pub(crate) async fn simulated(
    app: &App,
    machine: &str,
    seed: u64,
    effects: &[String],
) -> (std::path::PathBuf, mtcal_store::Dataset) {
    let dir = app.path(&format!("{machine}-{seed}"));
    let mut args: Vec<String> = [
        "simulate",
        "--out",
        dir.to_str().unwrap(),
        "--plan",
        "full",
        "--seed",
        &seed.to_string(),
        "--rate-hz",
        "5",
        "--machine-id",
        machine,
    ]
    .map(String::from)
    .to_vec();
    for e in effects {
        args.extend(["--effect".to_string(), e.clone()]);
    }
    mtcal(&args.iter().map(String::as_str).collect::<Vec<_>>());
    let ds = app.client.upload_path(machine, &dir).await.unwrap();
    (dir, ds)
}

/// Simulates a session ([`simulated`]), uploads it and identifies it; the dataset id
/// and the stored identification.
pub(crate) async fn checked(
    app: &App,
    machine: &str,
    seed: u64,
    effects: &[String],
) -> (String, StoredResult) {
    let (_, ds) = simulated(app, machine, seed, effects).await;
    let job = app.identify(&ds.id).await;
    let job = app.wait(&job, JobState::Succeeded).await;
    let stored = app
        .client
        .result(job.result_id.as_deref().unwrap())
        .await
        .unwrap();
    (ds.id, stored)
}

/// The machine's row of the fleet route.
async fn fleet_row(app: &App, machine: &str) -> mtcal_server::api::fleet::FleetMachine {
    let f = app.client.fleet(&Default::default()).await.unwrap();
    let mut rows = f.machines.into_iter();
    rows.find(|e| e.machine_id == machine).unwrap()
}

/// The machine's latest identification.
pub(crate) async fn latest(app: &App, machine: &str) -> StoredResult {
    let r = app.client.latest(machine, Some("identification")).await;
    r.unwrap()
}

/// Waits until the machine's latest identification is the explained model of dataset
/// `ds` (the worker stores it once the diagnosis it queued on its own has landed).
pub(crate) async fn explained_of(app: &App, machine: &str, ds: &str) -> StoredResult {
    for _ in 0..1200 {
        let r = latest(app, machine).await;
        if r.meta.dataset_id.as_deref() == Some(ds) && r.document.get("explained").is_some() {
            return r;
        }
        tokio::time::sleep(Duration::from_millis(100)).await;
    }
    panic!("no explained model of {ds} was stored");
}

fn doc(r: &StoredResult) -> IdentificationResult {
    typed(&r.document)
}

pub(crate) async fn get_json(app: &App, path: &str) -> Value {
    let r = reqwest::Client::new()
        .get(format!("{}{path}", app.url))
        .bearer_auth(&app.read_key)
        .send()
        .await
        .unwrap();
    assert_eq!(r.status(), StatusCode::OK, "{path}");
    r.json().await.unwrap()
}

/// A service with machine `machine` registered and a tolerance profile of `limits`.
async fn with_profile(machine: &str, limits: Value) -> App {
    let app = spawn_app().await;
    app.machine(machine).await;
    profile(&app, machine, limits).await;
    app
}

/// Gives machine `machine` a tolerance profile of `limits`.
pub(crate) async fn profile(app: &App, machine: &str, limits: Value) {
    let created = reqwest::Client::new()
        .post(format!("{}/api/v1/tolerances", app.url))
        .bearer_auth(&app.write_key)
        .json(&json!({"scope": "machine", "target": machine, "limits": limits}))
        .send()
        .await
        .unwrap();
    assert_eq!(created.status(), StatusCode::CREATED);
}

/// A result of `kind` of dataset `ds` with `document`, as the worker stores it (no
/// scalars, no figures: nothing reads them here).
pub(crate) fn as_worker_stores(
    ds: &mtcal_store::Dataset,
    kind: &str,
    document: Value,
) -> mtcal_store::NewResult {
    mtcal_store::NewResult {
        check_model: None,
        machine_id: ds.machine_id.clone(),
        dataset_id: Some(ds.id.clone()),
        kind: kind.into(),
        measured_at: ds.measured_at.clone(),
        document,
        scalars: Default::default(),
        figures: vec![],
    }
}

pub(crate) fn backlash(axis: &str, um: f64) -> String {
    format!("backlash:axis={axis},lost_motion_um={um}")
}

/// identify → misfit → diagnosis → explained result → decided verdicts → LinuxCNC table
/// with the reversal; then a check after compensation verified against the prediction.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_misfit_is_decided_on_its_explained_model_compensated_and_verified() {
    let machine = "EXPL-1";
    let app = with_profile(
        machine,
        json!({"terms": {"EXX": 1000.0, "EYY": 1000.0}, "standards": {"iso230_2.X.B_um": 10.0}}),
    )
    .await;
    let (ds, original) = checked(
        &app,
        machine,
        31,
        &[backlash("X", LOST_X), backlash("Y", LOST_Y)],
    )
    .await;
    assert!(
        doc(&original).model_check().is_misfit(),
        "the 21-term model misfits"
    );
    let v = get_json(
        &app,
        &format!("/api/v1/results/{}/verdict", original.meta.id),
    )
    .await;
    assert_eq!(v["verdict"]["decision"], "misfit", "{v}");

    // The explained model, stored beside the original, which is kept but excluded.
    let r = explained_of(&app, machine, &ds).await;
    let d = doc(&r);
    let check = d.model_check();
    assert!(check.decided_on_explained_model(), "{}", check.statement);
    assert!(check.statement.contains("backlash (X)") && check.statement.contains("backlash (Y)"));
    let m = d.explained.as_ref().unwrap();
    assert_eq!(
        m.original_result_id.as_deref(),
        Some(original.meta.id.as_str())
    );
    let lost = |axis: &str| {
        let p = m
            .physics
            .iter()
            .find(|p| p.effect == "backlash" && p.axis.as_deref() == Some(axis));
        p.and_then(|p| p.get("lost_motion_um"))
            .expect("a backlash")
            .0
    };
    assert!((lost("X") - LOST_X).abs() < 0.3 && (lost("Y") - LOST_Y).abs() < 0.3);
    let was = app.client.result(&original.meta.id).await.unwrap();
    let excluded = was.meta.excluded.expect("the original is set aside");
    assert_eq!(excluded.by, mtcal_server::explain::BY);
    assert!(excluded.reason.contains(&r.meta.id), "{}", excluded.reason);
    let checks = app
        .client
        .results(machine, Some("identification"))
        .await
        .unwrap();
    assert_eq!(checks.len(), 1, "one check in the history, not two");

    // Decided verdicts, saying so; the lost motion judged as ISO 230-2's B.
    let v = get_json(&app, &format!("/api/v1/results/{}/verdict", r.meta.id)).await;
    assert_eq!(v["verdict"]["decision"], "pass", "{v}");
    let note = v["verdict"]["notes"][0].as_str().unwrap();
    assert!(
        note.starts_with("decided on the explained model") && note.contains("backlash (X)"),
        "{note}"
    );
    let items = v["verdict"]["items"].as_array().unwrap();
    let b = items
        .iter()
        .find(|i| i["item"] == "iso230_2.X.B_um")
        .expect("B of X judged");
    assert!(
        (b["value"].as_f64().unwrap().abs() - LOST_X).abs() < 0.3,
        "{b}"
    );

    // The fleet row is the explained check's, and says so.
    let mut row = None;
    for _ in 0..200 {
        let e = fleet_row(&app, machine).await;
        if e.explained_model.is_some() && e.diagnosis.is_some() {
            row = Some(e);
            break;
        }
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
    let row = row.expect("the fleet row never said it is decided on the explained model");
    assert!(row.misfit.is_none());
    assert_eq!(row.verdict.map(|d| d.as_str()), Some("pass"));
    assert!(row.explained_model.unwrap().contains("backlash (X)"));
    assert_eq!(row.last_check.unwrap().result_id, r.meta.id);

    // The LinuxCNC table, read back: reverse − forward is the simulated backlash.
    let table = app
        .client
        .export(&r.meta.id, &[("format", "linuxcnc")])
        .await
        .unwrap()
        .text;
    assert!(
        table.contains("# model: decided on the explained model"),
        "{table}"
    );
    let read = Format::Linuxcnc.read("t.txt", &table).unwrap();
    for (axis, want) in [("X", LOST_X), ("Y", LOST_Y)] {
        let a = read
            .axes
            .iter()
            .find(|a| a.axis.to_string() == axis)
            .unwrap();
        let rev = a.reversal_mm.as_ref().expect("a reversal column");
        for b in rev {
            assert!((b * 1e3 - want).abs() < 0.3, "{axis}: {b} mm vs {want} µm");
        }
    }
    // The report and the machine page say it too.
    let report = app.client.report(&r.meta.id).await.unwrap().text;
    let decided = &report[report.find(r#"id="decided-on""#).expect("page 1 says so")..];
    assert!(decided[..decided.find("</p>").unwrap()].contains("backlash (X)"));
    let actions = &report[report.find(r#"id="actions""#).expect("the actions")..];
    let actions = &actions[..actions.find("</section>").unwrap()];
    let set: Vec<f64> = actions
        .split("backlash compensation to +")
        .skip(1)
        .map(|rest| rest.split(' ').next().unwrap().parse().unwrap())
        .collect();
    for want in [LOST_X, LOST_Y] {
        assert!(
            set.iter().any(|b| (b - want).abs() < 0.3),
            "{set:?} vs {want}"
        );
    }
    assert!(actions.contains("predicted after it"), "{actions}");
    // Its findings: decided on the explained model, its physics, and the diagnosis it
    // names (not the latest of the dataset by chance), linked.
    let findings = &report[report.find(r#"id="findings""#).expect("the findings")..];
    let findings = &findings[..findings.find("</section>").unwrap()];
    let diagnosis = m
        .diagnosis_result_id
        .as_deref()
        .expect("the diagnosis named");
    assert!(
        findings.contains("decided on the explained model")
            && findings.contains("backlash (X)")
            && findings.contains(&format!("href=\"/results/{diagnosis}\"")),
        "{findings}"
    );
    assert!(!report.contains("No diagnosis was run"));
    let browser = app.sign_in(&app.read_key).await;
    let page = browser
        .get(&format!("/machines/{machine}"))
        .await
        .text()
        .await
        .unwrap();
    assert!(
        page.contains("decided on the explained model"),
        "machine page"
    );

    // The next check, after compensation: 0.3 µm of X backlash left, none of Y.
    let (_, later) = checked(&app, machine, 32, &[backlash("X", 0.3)]).await;
    let mut v = None;
    for _ in 0..1200 {
        let w = latest(&app, machine).await;
        let w = app.client.verification(&w.meta.id).await.unwrap();
        if !w.findings.is_empty() && w.findings.iter().all(|f| f.state != "pending") {
            v = Some(w);
            break;
        }
        tokio::time::sleep(Duration::from_millis(100)).await;
    }
    let v = v.expect("the later check was never verified");
    assert_eq!(v.previous_result_id.as_deref(), Some(r.meta.id.as_str()));
    assert_eq!(v.findings.len(), 2, "{v:?}");
    for f in &v.findings {
        assert_eq!(f.as_predicted, Some(true), "{}", f.statement);
        assert!(f.statement.contains("(predicted 0)"), "{}", f.statement);
    }
    let x = v
        .findings
        .iter()
        .find(|f| f.axis.as_deref() == Some("X"))
        .unwrap();
    assert!((x.before - LOST_X).abs() < 0.3, "{}", x.statement);
    assert!(x.measured.is_none_or(|b| b < 0.5), "{}", x.statement);
    let _ = later;
}

/// A check whose diagnosis explains its misfit only partly: its explained model is stored
/// the same way, stays not decided (verdict `misfit`, table refused) and says what
/// remains. The diagnosis is the solver's own with its Y finding taken out and its
/// verdict `partly_explained` (what the diagnosis gives when a finding is left over), so
/// the model it adds leaves the Y backlash in the residual.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_partly_explained_check_stays_not_decided_and_says_what_remains() {
    let machine = "EXPL-2";
    let app = with_profile(machine, json!({"terms": {"EXX": 1000.0}})).await;
    let effects = [backlash("X", LOST_X), backlash("Y", LOST_Y)];
    let (dir, ds) = simulated(&app, machine, 33, &effects).await;
    let d = dir.to_str().unwrap();
    // Stored as the worker stores them, without the worker (which would diagnose it
    // fully on its own).
    let store = |kind: &str, document: Value| as_worker_stores(&ds, kind, document);
    let ident: Value = serde_json::from_str(&mtcal(&["identify", d, "--json"])).unwrap();
    assert_eq!(ident["model_check"]["state"], "misfit");
    let original = app
        .store
        .import_result(store("identification", ident))
        .await
        .unwrap();
    let mut diag: Value = serde_json::from_str(&mtcal(&["diagnose", d, "--json"])).unwrap();
    let findings = diag["findings"].as_array_mut().unwrap();
    findings.retain(|f| !(f["effect"] == "backlash" && f["axis"] == "Y"));
    assert!(
        findings
            .iter()
            .any(|f| f["effect"] == "backlash" && f["axis"] == "X")
    );
    diag["verdict"] = json!("partly_explained");
    let left = "a reversal of Y, about 3.5 µm, in the line passes along Y";
    diag["unexplained"] = json!([left]);
    let diag = app
        .store
        .import_result(store("diagnosis", diag))
        .await
        .unwrap();
    let limits = mtcal_server::UploadLimits::default();
    let stored = mtcal_server::explain::diagnosis_landed(&app.store, limits, &diag.id)
        .await
        .unwrap()
        .expect("the partly explained model is stored");

    let r = app.client.result(&stored.id).await.unwrap();
    let check = doc(&r).model_check();
    assert!(
        check.is_misfit() && !check.decided_on_explained_model(),
        "{}",
        check.statement
    );
    assert!(
        check.statement.contains("only partly") && check.statement.contains(left),
        "{}",
        check.statement
    );
    let was = app.client.result(&original.id).await.unwrap();
    assert!(was.meta.excluded.unwrap().reason.contains("only partly"));
    // Not decided, and saying what remains, in the verdict, the fleet row and the export.
    let v = get_json(&app, &format!("/api/v1/results/{}/verdict", r.meta.id)).await;
    assert_eq!(v["verdict"]["decision"], "misfit", "{v}");
    assert!(
        v["verdict"]["notes"][0].as_str().unwrap().contains(left),
        "{v}"
    );
    let e = fleet_row(&app, machine).await;
    assert_eq!(e.last_check.unwrap().result_id, r.meta.id);
    assert!(e.explained_model.is_none());
    assert!(e.misfit.unwrap().statement.contains(left));
    let export = || app.client.export(&r.meta.id, &[("format", "linuxcnc")]);
    let (status, code) = refused(export().await);
    assert_eq!(
        (status, code.as_str()),
        (StatusCode::CONFLICT, "model_misfit")
    );
    let message = refusal_message(export().await);
    assert!(message.contains(left), "{message}");
    // A second landing of the same diagnosis makes nothing more.
    let again = mtcal_server::explain::diagnosis_landed(&app.store, limits, &diag.id)
        .await
        .unwrap();
    assert!(again.is_none());
}
