//! Compensation exports and check reports of a stored identification result, over HTTP.

use crate::common::*;
use mtcal_formats::compensation::{Compensation, DEFAULT_STEP_MM, Format};
use mtcal_solver::identification::IdentificationResult;
use mtcal_store::{JobState, NewResult, ResultScalars};
use reqwest::StatusCode;

#[tokio::test]
async fn exports_and_report_of_a_stored_result() {
    let app = spawn_app().await;
    app.machine("VMC-E").await;
    let dir = app.path("check");
    write_session(&dir, "VMC-E", 4, 0);
    let ds = app.client.upload_path("VMC-E", &dir).await.unwrap();
    let job = app.identify(&ds.id).await;
    app.wait(&job, JobState::Succeeded).await;
    let stored = app.client.latest("VMC-E", None).await.unwrap();
    let doc: IdentificationResult = typed(&stored.document);
    let id = stored.meta.id.clone();
    let reader = app.with_key(&app.read_key);

    // Every format with a read key: the file the formats crate writes for the stored
    // document (the route adds nothing), its media type and an attachment name.
    for f in Format::ALL {
        let d = reader.export(&id, &[("format", f.name())]).await.unwrap();
        let want = f.write(&Compensation::from_result(&doc, DEFAULT_STEP_MM, false).unwrap());
        assert_eq!(d.text, want, "{}", f.name());
        assert_eq!(d.content_type, f.content_type());
        let disp = d.disposition.unwrap();
        assert!(
            disp.starts_with("attachment; filename=\"VMC-E-")
                && disp.ends_with(&format!(".{}.{}\"", f.name(), f.extension())),
            "{disp}"
        );
        assert!(d.text.contains("compensation = -error"));
    }
    // A step: a coarser grid, same travel.
    let coarse = reader
        .export(&id, &[("format", "csv"), ("step_mm", "50")])
        .await
        .unwrap();
    let back = Format::Csv.read("t.csv", &coarse.text).unwrap();
    let travel = doc.model.measured_travel_mm["X"];
    assert_eq!(back.axes[0].positions_mm.first(), Some(&travel[0]));
    assert_eq!(back.axes[0].positions_mm.last(), Some(&travel[1]));

    // Refusals: unknown or missing format (400 naming the formats), bad step, unknown id.
    for q in [vec![("format", "fanuc")], vec![]] {
        let r = reader.export(&id, &q).await;
        let msg = refusal_message(reader.export(&id, &q).await);
        assert_eq!(
            refused(r),
            (StatusCode::BAD_REQUEST, "invalid_request".into())
        );
        assert!(msg.contains("isg, etalon, heidenhain, csv"), "{msg}");
    }
    let r = reader
        .export(&id, &[("format", "isg"), ("step_mm", "0")])
        .await;
    assert_eq!(refused(r).0, StatusCode::BAD_REQUEST);
    let r = reader.export("nope", &[("format", "isg")]).await;
    assert_eq!(refused(r).0, StatusCode::NOT_FOUND);

    // A result whose terms are all undetermined: 422 not_identifiable.
    let mut blind = stored.document.clone();
    for t in blind["terms"].as_object_mut().unwrap().values_mut() {
        t["identifiable"] = false.into();
    }
    for s in blind["squareness"].as_object_mut().unwrap().values_mut() {
        s["identifiable"] = false.into();
    }
    let meta = app
        .store
        .import_result(NewResult {
            check_model: None,
            machine_id: "VMC-E".into(),
            dataset_id: None,
            kind: "identification".into(),
            measured_at: "2026-02-01T08:00:00Z".into(),
            document: blind,
            scalars: ResultScalars::default(),
            figures: vec![],
        })
        .await
        .unwrap();
    let r = reader.export(&meta.id, &[("format", "isg")]).await;
    assert_eq!(
        refused(r),
        (StatusCode::UNPROCESSABLE_ENTITY, "not_identifiable".into())
    );

    // The report: one self-contained HTML page with every section.
    let page = reader.report(&id).await.unwrap();
    assert_eq!(page.content_type, "text/html; charset=utf-8");
    for section in [
        "id=\"check\"",
        "id=\"standards\"",
        "id=\"terms\"",
        "id=\"circles\"",
        "id=\"findings\"",
        "id=\"compensation\"",
        "id=\"undetermined\"",
    ] {
        assert!(page.text.contains(section), "{section}");
    }
    assert!(page.text.contains(&id) && page.text.contains("no tolerance"));
    assert!(!page.text.contains("<link") && !page.text.contains("<script"));
    // With a tolerance profile for the machine the report decides its figures against
    // it: a limit of 1000 µm on EXX far above this check's errors passes, as the
    // verdict route says.
    let created = reqwest::Client::new()
        .post(format!("{}/api/v1/tolerances", app.url))
        .bearer_auth(&app.write_key)
        .json(&serde_json::json!({
            "scope": "machine", "target": "VMC-E", "limits": {"terms": {"EXX": 1000.0}}
        }))
        .send()
        .await
        .unwrap();
    assert_eq!(created.status(), StatusCode::CREATED);
    let verdict: serde_json::Value = reqwest::Client::new()
        .get(format!("{}/api/v1/results/{id}/verdict", app.url))
        .bearer_auth(&app.read_key)
        .send()
        .await
        .unwrap()
        .json()
        .await
        .unwrap();
    assert_eq!(verdict["verdict"]["decision"], "pass", "{verdict}");
    // Before the profile the report had no verdict section; now it has one, with EXX.
    assert!(!page.text.contains("id=\"verdict\""));
    let decided = reader.report(&id).await.unwrap();
    let section = &decided.text[decided
        .text
        .find("id=\"verdict\"")
        .expect("a verdict section once a profile applies")..];
    assert!(
        section.contains("EXX") && section.contains("pass"),
        "{}",
        &section[..section.len().min(2000)]
    );
    // Without a key: 401.
    let anon = app.with_key("nope");
    assert_eq!(refused(anon.report(&id).await).0, StatusCode::UNAUTHORIZED);
}
