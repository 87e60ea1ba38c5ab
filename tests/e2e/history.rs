//! History and trends return what was stored.

use crate::common::*;
use mtcal_solver::identification::IdentificationResult;
use mtcal_store::JobState;

#[tokio::test]
async fn history_and_trends_return_what_was_stored() {
    let app = spawn_app().await;
    for m in ["VMC-A", "VMC-B"] {
        app.machine(m).await;
    }
    // Upload out of time order: history must come back in measured_at order.
    let mut jobs = Vec::new();
    for (m, seed, q) in [
        ("VMC-A", 1, 2),
        ("VMC-A", 1, 0),
        ("VMC-A", 1, 1),
        ("VMC-B", 2, 0),
        ("VMC-B", 2, 1),
    ] {
        let dir = app.path(&format!("{m}-{q}"));
        write_session(&dir, m, seed, q);
        let ds = app.client.upload_path(m, &dir).await.unwrap();
        jobs.push(app.identify(&ds.id).await);
    }
    for j in &jobs {
        app.wait(j, JobState::Succeeded).await;
    }
    let hist = app.client.results("VMC-A", None).await.unwrap();
    let times: Vec<&str> = hist.iter().map(|r| r.measured_at.as_str()).collect();
    assert_eq!(
        times,
        [
            "2026-01-05T08:00:00Z",
            "2026-04-05T08:00:00Z",
            "2026-07-05T08:00:00Z"
        ]
    );
    // An unknown result kind is refused with the kinds, not answered with an empty list.
    let msg = refusal_message(app.client.results("VMC-A", Some("bogus")).await);
    assert!(msg.contains("one of identification"), "{msg}");
    let diagnoses = app
        .client
        .results("VMC-A", Some("diagnosis"))
        .await
        .unwrap();
    assert!(diagnoses.is_empty());
    let latest = app.client.latest("VMC-A", None).await.unwrap();
    assert_eq!(latest.meta.id, hist[2].id);

    // Stored documents, for the expected values.
    let mut docs: Vec<IdentificationResult> = Vec::new();
    for r in &hist {
        docs.push(typed(&app.client.result(&r.id).await.unwrap().document));
    }
    // A squareness name asked as a term points to where its trend is.
    let msg = refusal_message(app.client.term_trend("VMC-A", "EC0Y", &[0.0]).await);
    assert!(msg.contains("trends/summary"), "{msg}");
    let trend = app
        .client
        .term_trend("VMC-A", "EXX", &[50.0, -50.0])
        .await
        .unwrap();
    assert_eq!(trend.unit, "um");
    for (p, doc) in trend.points.iter().zip(&docs) {
        for (k, q) in [50.0, -50.0].iter().enumerate() {
            let want = doc.reported_value_at("EXX", *q).unwrap();
            let got = p.values[k].unwrap();
            assert!(
                (got - want).abs() <= 1e-12 * (1.0 + want.abs()),
                "{got} vs {want}"
            );
        }
    }
    // Each value carries its standard uncertainty: the one the result reports there.
    for (p, doc) in trend.points.iter().zip(&docs) {
        let exx = &doc.terms["EXX"];
        for (k, q) in [50.0, -50.0].iter().enumerate() {
            let i = exx.positions_mm.iter().position(|x| x == q).unwrap();
            let u = p.u[k].expect("u stored");
            assert!(
                (u - exx.std[i]).abs() <= 1e-3 + 1e-3 * exx.std[i],
                "{u} vs {}",
                exx.std[i]
            );
        }
    }
    // Nothing outside the travel the checks measured: a position beyond it is refused
    // with the measured travel in the message (the machine's registered ±100 mm does not
    // count).
    let [_, x_hi] = docs[2].model.measured_travel_mm["X"];
    let beyond = x_hi + 10.0;
    let (status, body) = refused(app.client.term_trend("VMC-A", "EXX", &[beyond]).await);
    assert_eq!(status.as_u16(), 422, "{body}");
    let msg = refusal_message(app.client.term_trend("VMC-A", "EXX", &[beyond]).await);
    assert!(
        msg.contains("measured over") && msg.contains(&format!("{x_hi}")),
        "{msg}"
    );
    let summary = app.client.summary_trend("VMC-A").await.unwrap();
    for (p, doc) in summary.points.iter().zip(&docs) {
        assert_eq!(p.summary.ec0y_urad, doc.squareness["EC0Y"].value_urad);
        // Each squareness point carries the check's standard uncertainty (the ±2σ bars of
        // the machine page's squareness plot).
        for (name, u) in [
            ("EC0Y", p.ec0y_u_urad),
            ("EB0Z", p.eb0z_u_urad),
            ("EA0Z", p.ea0z_u_urad),
        ] {
            let want = doc.squareness[name].std_urad.unwrap();
            let got = u.unwrap_or_else(|| panic!("{name}: no uncertainty"));
            assert!(
                (got - want).abs() <= 1e-9 * want.max(1.0),
                "{name}: {got} vs {want}"
            );
        }
        assert_eq!(p.summary.residual_rms_um, Some(doc.fit.residual_rms_um));
    }
    // The generator drifts EC0Y by 3·rate µrad per quarter (rate ≥ 0.5): the identified
    // squareness follows within its uncertainty.
    let ec: Vec<f64> = docs
        .iter()
        .map(|d| d.squareness["EC0Y"].value_urad.unwrap())
        .collect();
    assert!(ec[1] > ec[0] + 1.0 && ec[2] > ec[1] + 1.0, "EC0Y {ec:?}");

    // Difference from the baseline (default: the first result).
    // Read keys cannot make the service allocate without bound: a step too fine for the
    // travel is refused, and so is a travel of absurd size.
    let msg = refusal_message(app.client.diff("VMC-A", &[("step_mm", "0.001")]).await);
    assert!(msg.contains("positions per term"), "{msg}");
    let msg = refusal_message(app.client.diff("VMC-A", &[("step_mm", "5e-324")]).await);
    assert!(msg.contains("at least 0.001"), "{msg}");
    for huge in [1e9, 1e300] {
        let patch = mtcal_store::MachinePatch {
            travel_mm: Some([("X".to_string(), [-huge, huge])].into()),
            ..Default::default()
        };
        let msg = refusal_message(app.client.update_machine("VMC-A", &patch).await);
        assert!(msg.contains("travel_mm.X"), "{msg}");
    }
    // A result of another machine is the same conflict in a diff as in a baseline PATCH.
    let b_result = app.client.results("VMC-B", None).await.unwrap()[0]
        .id
        .clone();
    let (status, code) = refused(app.client.diff("VMC-A", &[("baseline", &b_result)]).await);
    assert_eq!((status.as_u16(), code.as_str()), (409, "conflict"));
    let patch = mtcal_store::MachinePatch {
        baseline_result_id: Some(b_result.clone()),
        ..Default::default()
    };
    let (status, code) = refused(app.client.update_machine("VMC-A", &patch).await);
    assert_eq!((status.as_u16(), code.as_str()), (409, "conflict"));
    let diff = app.client.diff("VMC-A", &[]).await.unwrap();
    assert_eq!(diff.baseline.id, hist[0].id);
    assert_eq!(diff.against.id, hist[2].id);
    let dsq = diff.squareness["EC0Y"].unwrap();
    assert!((dsq - (ec[2] - ec[0])).abs() < 1e-9);
    let exx = &diff.terms["EXX"];
    let i = exx.positions_mm.iter().position(|&q| q == 50.0).unwrap();
    let want = docs[2].reported_value_at("EXX", 50.0).unwrap()
        - docs[0].reported_value_at("EXX", 50.0).unwrap();
    assert!((exx.delta[i] - want).abs() < 1e-9);
    // The grid lies in the travel both checks measured, each difference with u² = u₀² + u₂².
    let [lo, hi] = exx.travel_mm.expect("the checks overlap");
    let (t0, t2) = (
        docs[0].model.measured_travel_mm["X"],
        docs[2].model.measured_travel_mm["X"],
    );
    assert_eq!([lo, hi], [t0[0].max(t2[0]), t0[1].min(t2[1])]);
    assert!(exx.positions_mm.iter().all(|&q| q >= lo && q <= hi));
    let std_at = |d: &IdentificationResult, q: f64| {
        let t = &d.terms["EXX"];
        t.std[t.positions_mm.iter().position(|&x| x == q).unwrap()]
    };
    let want_u = std_at(&docs[0], 50.0).hypot(std_at(&docs[2], 50.0));
    assert!(
        (exx.u[i] - want_u).abs() <= 2e-3 + 1e-3 * want_u,
        "{} vs {want_u}",
        exx.u[i]
    );
    assert!(diff.drift.drift_um_u.is_some() && diff.drift.drift_urad_u.is_some());

    // Fleet: both machines ranked, each with its own baseline and latest result.
    let fleet = app.client.fleet_drift(Some("urad"), None).await.unwrap();
    let ms = &fleet.machines;
    assert_eq!(ms.len(), 2);
    assert!(ms[0].drift.drift_urad >= ms[1].drift.drift_urad);
    let a = ms.iter().find(|m| m.machine_id == "VMC-A").unwrap();
    assert_eq!(a.results, 3);
    assert!(a.drift.drift_urad >= (ec[2] - ec[0]).abs() - 1e-9);
    assert_eq!(a.baseline_result_id, hist[0].id);
    // The ranking is maintained, not recomputed per request: a new baseline shows at once.
    let patch = mtcal_store::MachinePatch {
        baseline_result_id: Some(hist[1].id.clone()),
        ..Default::default()
    };
    app.client.update_machine("VMC-A", &patch).await.unwrap();
    let a = fleet_entry(&app, "VMC-A").await;
    assert_eq!(a.baseline_result_id, hist[1].id);
    let want = mtcal_domain::trends::drift(&hist[1].scalars, &hist[2].scalars);
    assert_eq!(a.drift, want);

    // Excluding a check (write key, with a reason): it stays readable by id with who,
    // when and why, and leaves the history, trends and fleet drift at once.
    let http = reqwest::Client::new();
    let exclude = |key: &str, reason: &str| {
        http.post(format!("{}/api/v1/results/{}/exclude", app.url, hist[2].id))
            .bearer_auth(key.to_string())
            .json(&serde_json::json!({ "reason": reason }))
            .send()
    };
    assert_eq!(
        exclude(&app.read_key, "bad setup").await.unwrap().status(),
        403
    );
    assert_eq!(exclude(&app.write_key, "  ").await.unwrap().status(), 400);
    let r = exclude(&app.write_key, "probe loose").await.unwrap();
    assert_eq!(r.status(), 200);
    let meta: serde_json::Value = r.json().await.unwrap();
    assert_eq!(meta["excluded"]["reason"], "probe loose");
    assert!(meta["excluded"]["by"].as_str().unwrap().starts_with("key "));
    let hist2 = app.client.results("VMC-A", None).await.unwrap();
    assert_eq!(hist2.len(), 2);
    assert_eq!(
        app.client.latest("VMC-A", None).await.unwrap().meta.id,
        hist[1].id
    );
    let trend = app
        .client
        .term_trend("VMC-A", "EXX", &[50.0])
        .await
        .unwrap();
    assert_eq!(trend.points.len(), 2);
    let a = fleet_entry(&app, "VMC-A").await;
    assert_eq!(
        (a.latest_result_id.as_str(), a.results),
        (hist[1].id.as_str(), 2)
    );
    let kept = app.client.result(&hist[2].id).await.unwrap();
    assert_eq!(kept.meta.excluded.unwrap().reason, "probe loose");
}

/// The fleet ranking's entry of machine `id`.
async fn fleet_entry(app: &App, id: &str) -> mtcal_server::api::trends::FleetEntry {
    let fleet = app.client.fleet_drift(Some("urad"), None).await.unwrap();
    fleet
        .machines
        .into_iter()
        .find(|m| m.machine_id == id)
        .unwrap()
}
