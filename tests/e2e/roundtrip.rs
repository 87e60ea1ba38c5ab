//! Every diagnosis document mtcal writes is read back by everything that takes one
//! (docs/results.md, "Every document round-trips"): over the whole effect catalogue, at
//! two seeds and two sizes each, with combinations, the `mtcal diagnose --json` output and
//! the service's stored diagnosis of the same session both hold no `null`, decode into
//! the typed document and encode back to the same JSON; the service's API returns it, the
//! result page shows its findings (and its possible, undetermined effects), the check
//! report of the identification of the same dataset holds them, and `mtcal report
//! --diagnosis` takes both documents.

use crate::common::*;
use mtcal_server::jobs::JobKind;
use mtcal_solver::diagnosis::DiagnosisResult;
use mtcal_store::JobState;
use reqwest::StatusCode;
use serde_json::Value;
use std::path::Path;

/// The effect catalogue of `mtcal simulate --effect` (its `--help` lists the same names),
/// each at two sizes (the second near the noise floor, where parameters are least often
/// determined), and combinations.
const CASES: &[&[&str]] = &[
    &["backlash:lost_motion_um=6"],
    &["backlash:axis=Y,lost_motion_um=0.3"],
    &["servo_lag:lag_s=0.003"],
    &["servo_lag:axis=Z,lag_s=0.0002"],
    &["reversal_spike"],
    &["reversal_spike:height_um=0.3"],
    &["cyclic"],
    &["cyclic:amplitude_um=0.1"],
    &["thermal_drift"],
    &["thermal_drift:scale_ppm=1/1/0"],
    &["setup_offset"],
    &["waviness"],
    &["vibration"],
    &["vibration:amplitude_um=0.08"],
    &["velocity_coupling"],
    &["temperature_growth"],
    &["backlash:lost_motion_um=6", "thermal_drift"],
    &["backlash", "temperature_growth"],
];

/// Paths of every `null` (and so of every number that was not finite) in `v`.
fn nulls(v: &Value, at: &str, out: &mut Vec<String>) {
    match v {
        Value::Null => out.push(at.to_string()),
        Value::Array(a) => a
            .iter()
            .enumerate()
            .for_each(|(i, x)| nulls(x, &format!("{at}[{i}]"), out)),
        Value::Object(o) => o
            .iter()
            .for_each(|(k, x)| nulls(x, &format!("{at}.{k}"), out)),
        _ => {}
    }
}

/// `doc` has no null, decodes into the typed diagnosis and encodes back to itself.
#[track_caller]
fn reads_back(doc: &Value, case: &str) -> DiagnosisResult {
    let mut bad = vec![];
    nulls(doc, "", &mut bad);
    assert!(bad.is_empty(), "{case}: null at {bad:?}");
    let typed: DiagnosisResult = serde_json::from_value(doc.clone())
        .unwrap_or_else(|e| panic!("{case}: the diagnosis does not decode: {e}"));
    assert_eq!(&serde_json::to_value(&typed).unwrap(), doc, "{case}");
    typed
}

/// What a person must find of `d` on a page or in a report: every finding's and every
/// possible effect's name as the pages write it.
fn effect_names(d: &DiagnosisResult) -> Vec<String> {
    d.findings
        .iter()
        .chain(&d.possible)
        .map(|f| f.effect.replace('_', " "))
        .collect()
}

fn simulate(dir: &Path, machine: &str, seed: u64, effects: &[&str]) {
    let mut args = vec![
        "simulate".to_string(),
        "--out".into(),
        dir.to_str().unwrap().into(),
        "--plan".into(),
        "seed".into(),
        "--seed".into(),
        seed.to_string(),
        "--rate-hz".into(),
        "10".into(),
        "--machine-id".into(),
        machine.into(),
    ];
    for e in effects {
        args.extend(["--effect".to_string(), e.to_string()]);
    }
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    mtcal(&args);
}

/// `doc`, the diagnosis stored as result `diag_id` of the same dataset as identification
/// `ident`, is read by the result page, the service's check report and `mtcal report
/// --diagnosis`, each showing every finding and possible effect.
async fn shown_everywhere(
    app: &App,
    browser: &Browser,
    ident: &Value,
    diag_id: &str,
    doc: &Value,
    case: &str,
) {
    let d: DiagnosisResult = typed(doc);
    let page = browser.get(&format!("/results/{diag_id}")).await;
    assert_eq!(page.status(), StatusCode::OK, "{case}: result page");
    let html = page.text().await.unwrap();
    for name in effect_names(&d) {
        assert!(html.contains(&name), "{case}: the result page lacks {name}");
    }

    let ident_id = ident["meta"]["id"].as_str().unwrap();
    let reader = app.with_key(&app.read_key);
    let report = reader.report(ident_id).await.unwrap().text;
    assert!(
        !report.contains("No diagnosis was run"),
        "{case}: the report lost the diagnosis"
    );
    for name in effect_names(&d) {
        assert!(report.contains(&name), "{case}: the report lacks {name}");
    }

    let stem = diag_id.replace(|c: char| !c.is_ascii_alphanumeric(), "_");
    let ident_file = app.path(&format!("{stem}-ident.json"));
    std::fs::write(&ident_file, ident["document"].to_string()).unwrap();
    let diag_file = app.path(&format!("{stem}-diag.json"));
    std::fs::write(&diag_file, doc.to_string()).unwrap();
    let html = mtcal(&[
        "report",
        ident_file.to_str().unwrap(),
        "--diagnosis",
        diag_file.to_str().unwrap(),
    ]);
    for name in effect_names(&d) {
        assert!(html.contains(&name), "{case}: mtcal report lacks {name}");
    }
}

/// Uploads a simulated session of `machine` and identifies it; the dataset id and the
/// stored identification (as the API returns it).
async fn identified(app: &App, machine: &str, seed: u64, effects: &[&str]) -> (String, Value) {
    app.machine(machine).await;
    let dir = app.path(machine);
    simulate(&dir, machine, seed, effects);
    let ds = app.client.upload_path(machine, &dir).await.unwrap();
    let job = app.identify(&ds.id).await;
    app.wait(&job, JobState::Succeeded).await;
    let stored = app
        .client
        .latest(machine, Some("identification"))
        .await
        .unwrap();
    (ds.id, serde_json::to_value(&stored).unwrap())
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn every_diagnosis_of_the_catalogue_reads_back_everywhere() {
    let app = spawn_app().await;
    let browser = app.sign_in(&app.read_key).await;
    let reader = app.with_key(&app.read_key);
    let mut undetermined_seen = 0;
    for (i, effects) in CASES.iter().enumerate() {
        let seed = 11 + i as u64 % 2;
        let case = format!("{} (seed {seed})", effects.join(" + "));
        let machine = format!("RT-{i:02}");
        let (ds, ident) = identified(&app, &machine, seed, effects).await;
        let diag = submit(&app.client, JobKind::Diagnose, Some(&ds), None)
            .await
            .id;
        app.wait(&diag, JobState::Succeeded).await;
        let stored = reader.latest(&machine, Some("diagnosis")).await.unwrap();
        let d = reads_back(&stored.document, &case);
        assert_eq!(reader.job_result(&diag).await.unwrap(), stored.document);
        undetermined_seen += d
            .findings
            .iter()
            .chain(&d.possible)
            .map(|f| f.undetermined.len())
            .sum::<usize>();
        shown_everywhere(
            &app,
            &browser,
            &ident,
            &stored.meta.id,
            &stored.document,
            &case,
        )
        .await;

        // The CLI's own document of the same session reads back, and `mtcal report` takes it.
        let dir = app.path(&machine);
        let cli: Value =
            serde_json::from_str(&mtcal(&["diagnose", dir.to_str().unwrap(), "--json"])).unwrap();
        reads_back(&cli, &format!("{case}, mtcal diagnose --json"));
        let file = app.path(&format!("{machine}-cli.json"));
        std::fs::write(&file, cli.to_string()).unwrap();
        let ident_file = app.path(&format!("{machine}-ident.json"));
        std::fs::write(&ident_file, ident["document"].to_string()).unwrap();
        mtcal(&[
            "report",
            ident_file.to_str().unwrap(),
            "--diagnosis",
            file.to_str().unwrap(),
        ]);
    }
    // The catalogue reaches parameters the data leave undetermined (the cases near the
    // floor), so the undetermined shape is among what was read back.
    assert!(
        undetermined_seen > 0,
        "no undetermined parameter in the catalogue"
    );
}

/// A σ the data do not bound is written `"bounded": false` with no `std`, and a stored
/// document of an earlier version that wrote it as `null` still reads: both are shown by
/// the page, the report and `mtcal report` (before, the page answered 500, the report
/// said "No diagnosis was run" and the CLI refused the document).
#[tokio::test]
async fn unbounded_and_legacy_null_uncertainties_are_read_everywhere() {
    let app = spawn_app().await;
    let browser = app.sign_in(&app.read_key).await;
    let effects = ["backlash:lost_motion_um=6"];
    for (machine, legacy) in [("RT-UNB", false), ("RT-NULL", true)] {
        let (ds, ident) = identified(&app, machine, 5, &effects).await;
        let dir = app.path(machine);
        let mut doc: Value =
            serde_json::from_str(&mtcal(&["diagnose", dir.to_str().unwrap(), "--json"])).unwrap();
        let finding = &mut doc["findings"][0];
        assert_eq!(finding["effect"], "backlash");
        if legacy {
            // What an earlier version wrote for an unbounded σ.
            finding["parameters"]["std_lost_motion_um"] = Value::Null;
        } else {
            finding["undetermined"] = serde_json::json!([{"name": "lag_s", "value": 0.002,
                "bounded": false, "decide": "runs at several feeds would decide it"}]);
            reads_back(&doc, machine);
        }
        let meta = app
            .store
            .import_result(mtcal_store::NewResult {
                check_model: None,
                machine_id: machine.into(),
                dataset_id: Some(ds),
                kind: "diagnosis".into(),
                measured_at: ident["meta"]["measured_at"].as_str().unwrap().into(),
                document: doc.clone(),
                scalars: mtcal_store::ResultScalars::default(),
                figures: vec![],
            })
            .await
            .unwrap();
        shown_everywhere(&app, &browser, &ident, &meta.id, &doc, machine).await;
        let html = browser
            .get(&format!("/results/{}", meta.id))
            .await
            .text()
            .await
            .unwrap();
        let want = if legacy { "lost_motion_um" } else { "lag_s" };
        assert!(
            html.contains(want) && html.contains("no finite bound"),
            "{machine}"
        );
    }
}

/// The id of the stored diagnosis of dataset `ds`.
async fn diagnosis_id_of(app: &App, ds: &str) -> String {
    let jobs = app.store.list_jobs(None, 1000).await.unwrap();
    jobs.into_iter()
        .find(|j| j.kind == JobKind::Diagnose && j.dataset_id.as_deref() == Some(ds))
        .and_then(|j| j.result_id)
        .expect("the diagnosis job's result")
}

/// An identification whose model does not explain its recording (a 6 µm X backlash) gets
/// a diagnosis of its dataset queued by the service on its own, once; its findings reach
/// the check report, the fleet row and the machine page with nobody asking. A clean
/// session's identification gets none.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_misfit_identification_is_diagnosed_on_its_own() {
    let app = spawn_app().await;
    let reader = app.with_key(&app.read_key);
    let diagnoses = |ds: String| {
        let store = app.store.clone();
        async move {
            store
                .list_jobs(None, 1000)
                .await
                .unwrap()
                .into_iter()
                .filter(|j| j.kind == JobKind::Diagnose && j.dataset_id.as_deref() == Some(&ds))
                .collect::<Vec<_>>()
        }
    };
    let (ds, ident) = identified(&app, "AUTO-MISFIT", 5, &["backlash:lost_motion_um=6"]).await;
    assert_eq!(
        ident["document"]["model_check"]["state"], "misfit",
        "{ident}"
    );
    // The worker queues it just after it records the identification's success: allow
    // it a moment.
    let mut queued = diagnoses(ds.clone()).await;
    for _ in 0..200 {
        if !queued.is_empty() {
            break;
        }
        tokio::time::sleep(std::time::Duration::from_millis(50)).await;
        queued = diagnoses(ds.clone()).await;
    }
    assert_eq!(queued.len(), 1, "one diagnosis queued: {queued:?}");
    app.wait(&queued[0].id, JobState::Succeeded).await;
    let report = reader
        .report(ident["meta"]["id"].as_str().unwrap())
        .await
        .unwrap()
        .text;
    assert!(
        !report.contains("No diagnosis was run"),
        "the report lacks the diagnosis"
    );
    let findings = &report[report
        .find(r#"id="findings""#)
        .expect("no findings section")..];
    assert!(
        findings[..findings.find("</section>").unwrap()].contains(r#"data-effect="backlash""#),
        "the report's findings lack the backlash finding"
    );
    let budget = &report[report.find(r#"id="budget""#).expect("no budget table")..];
    assert!(
        budget.contains(r#"data-item="EXX""#),
        "no budget row of EXX"
    );
    assert!(
        report.find(r#"id="misfit""#).unwrap() < report.find(r#"id="check""#).unwrap(),
        "the report opens with the misfit banner"
    );
    // The fleet row says the check is a misfit and, once the diagnosis has landed (its
    // row is refreshed just after the job is recorded), what the diagnosis found.
    let params = mtcal_server::api::fleet::FleetParams::default();
    let mut row = None;
    for _ in 0..200 {
        let f = reader.fleet(&params).await.unwrap();
        let m = f
            .machines
            .into_iter()
            .find(|m| m.machine_id == "AUTO-MISFIT")
            .expect("the machine's fleet row");
        if m.diagnosis.is_some() {
            row = Some(m);
            break;
        }
        tokio::time::sleep(std::time::Duration::from_millis(50)).await;
    }
    let row = row.expect("the fleet row never showed the diagnosis");
    // The diagnosis explains the misfit: the row is the explained model's check, which
    // is decided and says so (tests/e2e/explained.rs); a misfit row says it is one.
    assert!(
        row.misfit.as_ref().is_some_and(|c| c.is_misfit()) != row.explained_model.is_some(),
        "{:?} {:?}",
        row.misfit,
        row.explained_model
    );
    let found = row.diagnosis.unwrap();
    assert_eq!(found.result_id, diagnosis_id_of(&app, &ds).await);
    assert!(
        found.findings.iter().any(|f| f.starts_with("backlash (")),
        "{:?}",
        found.findings
    );
    let browser = app.sign_in(&app.read_key).await;
    let fleet_page = browser.get("/").await.text().await.unwrap();
    let at = fleet_page
        .find(r#"data-machine="AUTO-MISFIT""#)
        .expect("the fleet page's row");
    let fleet_row = &fleet_page[at..at + fleet_page[at..].find("</tr>").unwrap()];
    assert!(
        (fleet_row.contains("model misfit") || fleet_row.contains("explained model"))
            && fleet_row.contains("backlash ("),
        "{fleet_row}"
    );
    // The machine page shows the latest diagnosis' findings.
    let page = browser
        .get("/machines/AUTO-MISFIT")
        .await
        .text()
        .await
        .unwrap();
    let card = &page[page.find(r#"id="findings""#).expect("no findings card")..];
    assert!(
        card.contains(r#"data-effect="backlash""#) && card.contains("lost_motion_um = "),
        "{card}"
    );
    // Identifying the same recording again queues no second diagnosis.
    let again = app.identify(&ds).await;
    app.wait(&again, JobState::Succeeded).await;
    // (A diagnosis would be queued within moments of the success, as above.)
    tokio::time::sleep(std::time::Duration::from_millis(500)).await;
    assert_eq!(diagnoses(ds).await.len(), 1);

    let (clean, ident) = identified(&app, "AUTO-CLEAN", 5, &[]).await;
    assert_ne!(
        ident["document"]["model_check"]["state"], "misfit",
        "{ident}"
    );
    tokio::time::sleep(std::time::Duration::from_millis(500)).await;
    assert!(diagnoses(clean).await.is_empty());
}
