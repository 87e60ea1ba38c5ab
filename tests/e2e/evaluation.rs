//! One evaluation of a term, whatever reads it: the identification's reported values
//! (what the result page draws), the solver's evaluation from the stored coefficients
//! (`mtcal_solver::comparison::term_value`), the domain's over the stored scalars, the
//! term trend route, the difference route, the fleet's drift, a drift alert's items and
//! the compensation table all give the same number for the same term at the same
//! position.

use crate::common::*;
use mtcal_solver::identification::IdentificationResult;
use mtcal_store::JobState;

/// Agreement of two values that went through JSON (shortest round-trip decimal) or not.
fn same(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-9 * (1.0 + a.abs().max(b.abs()))
}

#[tokio::test]
async fn a_term_has_one_value_in_every_consumer() {
    let app = spawn_app().await;
    let m = "VMC-EVAL";
    app.machine(m).await;
    // A drift threshold far below the demo's drift: the second check raises an alert.
    let created = reqwest::Client::new()
        .post(format!("{}/api/v1/tolerances", app.url))
        .bearer_auth(&app.write_key)
        .json(&serde_json::json!({
            "scope": "machine", "target": m,
            "limits": {"drift_um": 0.001, "drift_urad": 0.001}
        }))
        .send()
        .await
        .unwrap();
    assert_eq!(created.status().as_u16(), 201);
    for q in [0, 1] {
        let dir = app.path(&format!("eval-{q}"));
        write_session(&dir, m, 3, q);
        let ds = app.client.upload_path(m, &dir).await.unwrap();
        let job = app.identify(&ds.id).await;
        app.wait(&job, JobState::Succeeded).await;
    }
    let hist = app.client.results(m, None).await.unwrap();
    assert_eq!(hist.len(), 2);
    let mut docs: Vec<IdentificationResult> = Vec::new();
    for r in &hist {
        docs.push(typed(&app.client.result(&r.id).await.unwrap().document));
    }
    // A positioning, a straightness (reported about its least-squares line) and an
    // angular term, each identifiable in both checks.
    let mut checked = 0;
    for name in ["EXX", "EYX", "EZX", "ECX", "EXY", "EYZ"] {
        if !docs.iter().all(|d| d.terms[name].identifiable) {
            continue;
        }
        checked += 1;
        let rep = &docs[0].terms[name];
        // The reporting grid of the baseline, inside the later check's travel too.
        let axis = &name[2..3];
        let [lo, hi] = docs[1].model.measured_travel_mm[axis];
        let positions: Vec<f64> = rep
            .positions_mm
            .iter()
            .copied()
            .filter(|q| (lo..=hi).contains(q))
            .collect();
        assert!(positions.len() >= 3, "{name}: {positions:?}");
        let trend = app.client.term_trend(m, name, &positions).await.unwrap();
        let diff = app.client.diff(m, &[("step_mm", "5")]).await.unwrap();
        let tdiff = &diff.terms[name];
        for (k, &q) in positions.iter().enumerate() {
            let mut v = [0.0; 2];
            for (c, (doc, meta)) in docs.iter().zip(&hist).enumerate() {
                // The solver, from the stored coefficients.
                let solver = doc.reported_value_at(name, q).unwrap();
                // The identification's own values (the result page's band), rounded to
                // 1e-6 in the document.
                let t = &doc.terms[name];
                if let Some(i) = t.positions_mm.iter().position(|&p| p == q) {
                    assert!(
                        (t.values[i] - solver).abs() <= 2e-6,
                        "{name} at {q}: reported {} vs evaluated {solver}",
                        t.values[i]
                    );
                }
                // The domain, from the stored scalars.
                let domain = mtcal_domain::trends::value(&meta.scalars, name, q)
                    .unwrap()
                    .value;
                assert!(same(domain, solver), "{name} at {q}: {domain} vs {solver}");
                // The term trend route.
                let api = trend.points[c].values[k].unwrap();
                assert!(same(api, solver), "{name} at {q}: {api} vs {solver}");
                v[c] = solver;
            }
            // The difference route, where its grid has q.
            if let Some(i) = tdiff.positions_mm.iter().position(|&p| same(p, q)) {
                assert!(
                    same(tdiff.delta[i], v[1] - v[0]),
                    "{name} at {q}: diff {} vs {}",
                    tdiff.delta[i],
                    v[1] - v[0]
                );
            }
        }
        // The compensation table (plain CSV: µm or µrad, 6 decimals) of each check.
        for (doc, meta) in docs.iter().zip(&hist) {
            let d = app
                .client
                .export(&meta.id, &[("format", "csv"), ("step_mm", "5")])
                .await
                .unwrap();
            let mut rows = 0;
            for line in d
                .text
                .lines()
                .filter(|l| l.starts_with(&format!("{name},")))
            {
                let f: Vec<&str> = line.split(',').collect();
                let q: f64 = f[2].parse().unwrap();
                let value: f64 = f[3].parse().unwrap();
                let want = doc.reported_value_at(name, q).unwrap();
                assert!(
                    (value - want).abs() <= 1e-6,
                    "{name} at {q}: table {value} vs {want}"
                );
                rows += 1;
            }
            assert!(rows >= 3, "{name}: {rows} rows in the table");
        }
    }
    assert!(
        checked >= 3,
        "only {checked} terms identifiable in both checks"
    );

    // The fleet's drift: the largest change over 41 points of the travel both checks
    // measured, recomputed here from the solver's evaluation.
    let entry = app
        .client
        .fleet_drift(None, None)
        .await
        .unwrap()
        .machines
        .into_iter()
        .find(|e| e.machine_id == m)
        .unwrap();
    let (mut worst, mut worst_term) = (0.0f64, String::new());
    for t in mtcal_solver::terms::Term::all() {
        let name = t.name();
        if t.is_angular() || !docs.iter().all(|d| d.terms[&name].identifiable) {
            continue;
        }
        let axis = t.axis.letter().to_string();
        let ([l0, h0], [l1, h1]) = (
            docs[0].model.measured_travel_mm[&axis],
            docs[1].model.measured_travel_mm[&axis],
        );
        let (lo, hi) = (l0.max(l1), h0.min(h1));
        for i in 0..41 {
            let q = lo + (hi - lo) * i as f64 / 40.0;
            let (Some(a), Some(b)) = (
                docs[0].reported_value_at(&name, q),
                docs[1].reported_value_at(&name, q),
            ) else {
                continue;
            };
            if (b - a).abs() > worst {
                (worst, worst_term) = ((b - a).abs(), name.clone());
            }
        }
    }
    assert!(
        same(entry.drift.drift_um, worst),
        "fleet drift {} vs {worst}",
        entry.drift.drift_um
    );
    assert_eq!(
        entry.drift.worst_term_um.as_deref(),
        Some(worst_term.as_str())
    );

    // The drift alert of the second check: each item's change at its position is the
    // difference of the two checks' values there (a squareness: of the two angles).
    let alerts: Vec<mtcal_domain::alerts::AlertView> = reqwest::Client::new()
        .get(format!("{}/api/v1/alerts?machine={m}", app.url))
        .bearer_auth(&app.read_key)
        .send()
        .await
        .unwrap()
        .json()
        .await
        .unwrap();
    assert_eq!(alerts.len(), 1, "{alerts:?}");
    assert_eq!(alerts[0].raised.result_id, hist[1].id);
    assert!(!alerts[0].items.is_empty());
    for item in &alerts[0].items {
        let value = item.value.unwrap();
        let want = match item.position_mm {
            Some(q) => {
                docs[1].reported_value_at(&item.item, q).unwrap()
                    - docs[0].reported_value_at(&item.item, q).unwrap()
            }
            None => {
                docs[1].squareness[&item.item].value_urad.unwrap()
                    - docs[0].squareness[&item.item].value_urad.unwrap()
            }
        };
        assert!(same(value, want), "{}: {value} vs {want}", item.item);
    }
}
