//! The fleet rows the service maintains (drift, verdict's profile, sparkline, basis) equal
//! a computation from scratch after every change they follow: results landing, the
//! baseline chosen, a machine's tags, tolerance profiles created and replaced; and the
//! start-up refresh recomputes exactly the rows whose basis changed behind the service's
//! back. While results land and baselines change concurrently, every read of the fleet
//! (the drift route, the baseline pairs, the fleet page) is whole and consistent. On
//! SQLite, and on PostgreSQL when `MTCAL_TEST_PG` names a server
//! (`scripts/with-postgres`).

use crate::common::identification;
use mtcal_domain::fleet::{Refreshed, refresh_all};
use mtcal_domain::landing::result_landed;
use mtcal_server::api::trends::FleetDrift;
use mtcal_store::{FleetDriftRow, FleetPageQuery, FleetSort, Store};
use serde_json::{Value, json};
use std::time::Duration;

/// Sends `body` as JSON with `key`; the response's body (a success asserted).
async fn call(app: &axum::Router, method: &str, uri: &str, key: &str, body: Value) -> Value {
    let req = crate::common::request(
        method,
        uri,
        "application/json",
        None,
        body.to_string().into_bytes(),
        Some(key),
    );
    let (status, v) = crate::common::send(app, req).await;
    assert!(status.is_success(), "{method} {uri}: {status} {v}");
    v
}

/// The stored rows by machine, without their read times (when is not what).
async fn stored(store: &dyn Store) -> Vec<FleetDriftRow> {
    let mut rows: Vec<FleetDriftRow> = store
        .fleet_drift_ranked(true, usize::MAX)
        .await
        .unwrap()
        .into_iter()
        .map(|(r, _, _)| FleetDriftRow { read_at_ms: 0, ..r })
        .collect();
    rows.sort_by(|a, b| a.machine_id.cmp(&b.machine_id));
    rows
}

/// The maintained rows equal the rows computed from scratch (every row removed, then
/// the whole fleet refreshed, which recomputes them all).
async fn assert_maintained(store: &dyn Store, when: &str) -> Vec<FleetDriftRow> {
    let maintained = stored(store).await;
    for r in &maintained {
        assert!(
            store
                .delete_fleet_drift(&r.machine_id, i64::MAX)
                .await
                .unwrap()
        );
    }
    let n = refresh_all(store).await.unwrap();
    assert_eq!(n.recomputed, n.machines, "{when}: all recomputed");
    let scratch = stored(store).await;
    assert_eq!(maintained, scratch, "{when}");
    scratch
}

/// Waits for the refresh a profile change starts in the background: until machine
/// `id`'s row is computed against `profile` (its id and revision).
async fn until_against(store: &dyn Store, id: &str, profile: &Value) {
    let want = format!(
        "{}@{}",
        profile["id"].as_str().unwrap(),
        profile["updated_at"].as_str().unwrap()
    );
    for _ in 0..500 {
        let rows = stored(store).await;
        let row = rows.iter().find(|r| r.machine_id == id).unwrap();
        if row.basis.as_deref().unwrap().ends_with(&want) {
            return;
        }
        tokio::time::sleep(Duration::from_millis(10)).await;
    }
    panic!("the row of {id} was not refreshed against {want}");
}

async fn story(url: &str) {
    let (app, keys, store) = crate::common::app_on(url).await;
    let write = keys.write;
    crate::common::machine(&app, &write, "M1").await;
    crate::common::machine(&app, &write, "M2").await;
    let tags = json!({"tags": ["vmc"]});
    call(&app, "PATCH", "/api/v1/machines/M1", &write, tags).await;
    let land = |m: &'static str, at: &'static str, c1: f64| {
        let store = store.clone();
        async move {
            let r = store
                .import_result(identification(m, at, c1, 1e-6))
                .await
                .unwrap();
            result_landed(&store, m, &r.id).await.unwrap();
            r.id
        }
    };

    // Results land.
    let first = land("M1", "2026-01-01T00:00:00Z", 0.02).await;
    let second = land("M1", "2026-02-01T00:00:00Z", 0.05).await;
    land("M1", "2026-03-01T00:00:00Z", 0.10).await;
    land("M2", "2026-01-15T00:00:00Z", 0.01).await;
    let rows = assert_maintained(store.as_ref(), "after results landed").await;
    // Hand-worked: EXX changed by (0.10 − 0.02)·50 = 4 µm at either end of the travel;
    // the sparkline is EXX at one end in each check: ±(1, 2.5, 5) µm.
    let m1 = &rows[0];
    let m1_entry: serde_json::Value = m1.entry.decode().unwrap();
    assert_eq!(m1_entry["baseline_result_id"], json!(first));
    assert!((m1.drift_um - 4.0).abs() < 1e-9, "{}", m1.drift_um);
    let spark: Vec<f64> = m1_entry["sparkline"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_f64().unwrap().abs())
        .collect();
    assert_eq!(spark.len(), 3);
    for (got, want) in spark.iter().zip([1.0, 2.5, 5.0]) {
        assert!((got - want).abs() < 1e-9, "{spark:?}");
    }

    // The baseline is chosen: drift (0.10 − 0.05)·50 = 2.5 µm.
    call(
        &app,
        "PATCH",
        "/api/v1/machines/M1",
        &write,
        json!({"baseline_result_id": second}),
    )
    .await;
    let rows = assert_maintained(store.as_ref(), "after the baseline changed").await;
    assert!(
        (rows[0].drift_um - 2.5).abs() < 1e-9,
        "{}",
        rows[0].drift_um
    );

    // A tag profile is created, then replaced: M1's row follows, M2's does not change.
    let before_m2 = rows[1].clone();
    let p = call(
        &app,
        "POST",
        "/api/v1/tolerances",
        &write,
        json!({"scope": "tag", "target": "vmc", "limits": {"drift_um": 5.0}}),
    )
    .await;
    until_against(store.as_ref(), "M1", &p).await;
    let rows = assert_maintained(store.as_ref(), "after a profile was created").await;
    assert_eq!(rows[1], before_m2);
    let uri = format!("/api/v1/tolerances/{}", p["id"].as_str().unwrap());
    let p = call(
        &app,
        "PUT",
        &uri,
        &write,
        json!({"limits": {"drift_um": 1.0}}),
    )
    .await;
    until_against(store.as_ref(), "M1", &p).await;
    assert_maintained(store.as_ref(), "after a profile was replaced").await;

    // M2 is given the tag: its row is computed against the tag's profile.
    call(
        &app,
        "PATCH",
        "/api/v1/machines/M2",
        &write,
        json!({"tags": ["vmc"]}),
    )
    .await;
    let rows = assert_maintained(store.as_ref(), "after a machine's tags changed").await;
    assert!(
        rows[1]
            .basis
            .as_deref()
            .unwrap()
            .contains(p["id"].as_str().unwrap())
    );

    // Behind the service's back (a bulk import; a profile written in the store alone),
    // the refresh at start recomputes exactly the rows whose basis changed.
    assert_eq!(
        refresh_all(store.as_ref()).await.unwrap(),
        Refreshed {
            machines: 2,
            recomputed: 0
        }
    );
    store
        .import_results_bulk(&[identification("M2", "2026-04-01T00:00:00Z", 0.03, 1e-6)])
        .await
        .unwrap();
    let before = stored(store.as_ref()).await;
    assert_eq!(
        refresh_all(store.as_ref()).await.unwrap(),
        Refreshed {
            machines: 2,
            recomputed: 1
        }
    );
    let after = stored(store.as_ref()).await;
    assert_eq!(after[0], before[0], "M1 kept");
    assert!(
        (after[1].drift_um - 1.0).abs() < 1e-9,
        "M2: (0.03 − 0.01)·50"
    );
    assert_maintained(store.as_ref(), "after a bulk import and a refresh").await;
    let mut profile = store
        .get_tolerance(p["id"].as_str().unwrap())
        .await
        .unwrap();
    profile.limits = json!({"drift_um": 2.0});
    profile.webhook_url = None;
    profile.webhook_secret = None;
    store.update_tolerance(&profile).await.unwrap();
    assert_eq!(
        refresh_all(store.as_ref()).await.unwrap().recomputed,
        2,
        "both machines of the tag"
    );
    assert_maintained(store.as_ref(), "after a profile changed in the store").await;
}

#[tokio::test]
async fn maintained_fleet_rows_equal_a_recomputation_on_sqlite() {
    let dir = tempfile::tempdir().unwrap();
    story(dir.path().join("t.sqlite").to_str().unwrap()).await;
}

#[tokio::test]
async fn maintained_fleet_rows_equal_a_recomputation_on_postgres() {
    crate::common::on_postgres("fleet_rows", |url| async move { story(&url).await }).await;
}

/// Machines of [`concurrent_story`], and the checks each lands while the fleet is read.
const CONCURRENT_MACHINES: usize = 3;
const CONCURRENT_ROUNDS: usize = 20;

/// What a reader of [`concurrent_story`] saw wrong in one answer (empty: whole and
/// consistent).
type Faults = Vec<String>;

/// `GET /api/v1/fleet/drift`: 200, ranked, one entry per machine, each naming a
/// baseline and a latest result of its own machine.
async fn read_route(app: &axum::Router, store: &dyn Store, key: &str) -> Faults {
    let req = crate::common::request(
        "GET",
        "/api/v1/fleet/drift?limit=100",
        "",
        None,
        vec![],
        Some(key),
    );
    let (status, v) = crate::common::send(app, req).await;
    if status != axum::http::StatusCode::OK {
        return vec![format!("GET /api/v1/fleet/drift: {status} {v}")];
    }
    let fleet: FleetDrift = serde_json::from_value(v).unwrap();
    let mut faults = Vec::new();
    if fleet.machines.len() != CONCURRENT_MACHINES || !fleet.warnings.is_empty() {
        faults.push(format!(
            "{} entries, warnings {:?}",
            fleet.machines.len(),
            fleet.warnings
        ));
    }
    if fleet
        .machines
        .windows(2)
        .any(|w| w[0].drift.drift_um < w[1].drift.drift_um)
    {
        faults.push("not ranked by drift".into());
    }
    for e in &fleet.machines {
        let base = store.get_result(&e.baseline_result_id).await.unwrap();
        let latest = store.get_result(&e.latest_result_id).await.unwrap();
        if base.meta.machine_id != e.machine_id
            || latest.meta.machine_id != e.machine_id
            || latest.meta.measured_at != e.latest_measured_at
            || (e.results == 1) != (e.baseline_result_id == e.latest_result_id)
            || (!e.sparkline.is_empty() && e.sparkline.len() != usize::try_from(e.results).unwrap())
        {
            faults.push(format!(
                "entry of {} does not hold together: {e:?}",
                e.machine_id
            ));
        }
    }
    faults
}

/// The store's baseline pairs (what the start-up refresh reads): every machine once,
/// each pair's results its machine's and current.
async fn read_pairs(store: &dyn Store) -> Faults {
    let pairs = match store.baseline_pairs("identification").await {
        Ok(p) => p,
        Err(e) => return vec![format!("baseline_pairs: {e}")],
    };
    let mut faults = Vec::new();
    if pairs.len() != CONCURRENT_MACHINES {
        faults.push(format!("{} pairs", pairs.len()));
    }
    for p in &pairs {
        let m = &p.machine.id;
        if &p.baseline.machine_id != m
            || &p.latest.machine_id != m
            || p.baseline.excluded.is_some()
            || p.latest.excluded.is_some()
            || p.results < 1
            || (p.results == 1) != (p.baseline.id == p.latest.id)
        {
            faults.push(format!("pair of {m} does not hold together: {p:?}"));
        }
    }
    faults
}

/// The fleet page's store read: every machine, each with its drift row, counted once.
async fn read_page(store: &dyn Store) -> Faults {
    let q = FleetPageQuery {
        site: None,
        tag: None,
        sort: FleetSort::DriftUm,
        offset: 0,
        limit: 100,
        within_sites: vec![],
        within_tags: vec![],
    };
    let page = match store.fleet_page(&q).await {
        Ok(p) => p,
        Err(e) => return vec![format!("fleet_page: {e}")],
    };
    let ids: std::collections::BTreeSet<_> = page.rows.iter().map(|r| &r.machine.id).collect();
    if page.total != CONCURRENT_MACHINES as i64
        || ids.len() != CONCURRENT_MACHINES
        || page.rows.iter().any(|r| r.drift.is_none())
    {
        vec![format!("fleet page: total {}, rows {ids:?}", page.total)]
    } else {
        vec![]
    }
}

/// While identifications land, baselines are chosen and results excluded on every
/// machine at once, the fleet is read again and again through the route and the store
/// functions behind the fleet's drift: every answer is whole (200, every machine) and
/// holds together (each entry's results are its machine's). A read made of several
/// statements outside one snapshot fails here (a baseline chosen or excluded between
/// them leaves a pair without its result: the fleet drift's old 404). The rows then
/// equal a computation from scratch.
async fn concurrent_story(url: &str) {
    let (app, keys, store) = crate::common::app_on(url).await;
    let stop = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
    let mut writers = tokio::task::JoinSet::new();
    for m in 0..CONCURRENT_MACHINES {
        let id = format!("M{m}");
        crate::common::machine(&app, &keys.write, &id).await;
        let first = store
            .import_result(identification(&id, "2026-01-01T00:00:00Z", 0.01, 1e-6))
            .await
            .unwrap();
        result_landed(&store, &id, &first.id).await.unwrap();
        let (app, store, key) = (app.clone(), store.clone(), keys.write.clone());
        writers.spawn(async move {
            let mut ids = vec![first.id];
            for r in 1..=CONCURRENT_ROUNDS {
                let at = format!("2026-01-01T{:02}:{:02}:00Z", r / 60, r % 60);
                let c1 = 0.01 * (1 + (r * (m + 2)) % 7) as f64;
                let landed = store
                    .import_result(identification(&id, &at, c1, 1e-6))
                    .await
                    .unwrap();
                result_landed(&store, &id, &landed.id).await.unwrap();
                ids.push(landed.id);
                // Any result but the latest.
                let chosen = &ids[(r * 7 + m) % (ids.len() - 1)];
                let patch = json!({ "baseline_result_id": chosen });
                call(
                    &app,
                    "PATCH",
                    &format!("/api/v1/machines/{id}"),
                    &key,
                    patch,
                )
                .await;
                if r % 3 == 0 {
                    // The chosen baseline itself at times (the first result takes over).
                    let gone = ids.remove(ids.len() - 2);
                    let uri = format!("/api/v1/results/{gone}/exclude");
                    call(&app, "POST", &uri, &key, json!({"reason": "test"})).await;
                }
            }
        });
    }
    let mut readers = tokio::task::JoinSet::new();
    for reader in 0..2 {
        let (app, store, key, stop) = (app.clone(), store.clone(), keys.read.clone(), stop.clone());
        readers.spawn(async move {
            let (mut reads, mut faults) = (0, Faults::new());
            while !stop.load(std::sync::atomic::Ordering::Relaxed) || reads == 0 {
                let s = store.as_ref();
                faults.extend(match (reader + reads) % 3 {
                    0 => read_route(&app, s, &key).await,
                    1 => read_pairs(s).await,
                    _ => read_page(s).await,
                });
                reads += 1;
            }
            (reads, faults)
        });
    }
    while let Some(w) = writers.join_next().await {
        w.unwrap();
    }
    stop.store(true, std::sync::atomic::Ordering::Relaxed);
    let mut reads = 0;
    let mut faults = Faults::new();
    while let Some(r) = readers.join_next().await {
        let (n, f) = r.unwrap();
        reads += n;
        faults.extend(f);
    }
    assert!(
        faults.is_empty(),
        "{} of {reads} reads went wrong, e.g.:\n{}",
        faults.len(),
        faults[..faults.len().min(5)].join("\n")
    );
    assert!(reads >= 30, "only {reads} reads while the results landed");
    eprintln!("{reads} reads, all whole");
    assert_maintained(store.as_ref(), "after the concurrent changes").await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn fleet_reads_are_whole_while_results_land_and_baselines_change_on_sqlite() {
    let dir = tempfile::tempdir().unwrap();
    concurrent_story(dir.path().join("t.sqlite").to_str().unwrap()).await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn fleet_reads_are_whole_while_results_land_and_baselines_change_on_postgres() {
    let Some(pg) = mtcal_store::testing::ScratchPg::create("fleet_rows_concurrent")
        .await
        .unwrap()
    else {
        return;
    };
    concurrent_story(&pg.url).await;
    pg.drop_schema().await.unwrap();
}

/// A machine of a tag with a profile and no check yet shows the tag's profile (not "no
/// tolerance"), without a verdict.
#[tokio::test]
async fn the_fleet_says_why_a_machine_fails_and_which_profile_an_unchecked_one_has() {
    let dir = tempfile::tempdir().unwrap();
    let (app, keys, store) =
        crate::common::app_on(dir.path().join("t.sqlite").to_str().unwrap()).await;
    let write = keys.write;
    for m in ["M1", "M3"] {
        crate::common::machine(&app, &write, m).await;
        let tags = json!({"tags": ["vmc"]});
        call(
            &app,
            "PATCH",
            &format!("/api/v1/machines/{m}"),
            &write,
            tags,
        )
        .await;
    }
    // EXX = 0.1·q over X ∈ [−50, 50]: 5 µm at the ends, u = 0.05 µm there (var 1e-6);
    // against 3 µm: |5| − 0.1 > 3 fails. EC0Y is not limited.
    let p = call(
        &app,
        "POST",
        "/api/v1/tolerances",
        &write,
        json!({"scope": "tag", "target": "vmc", "limits": {"terms": {"EXX": 3.0}}}),
    )
    .await;
    let r = store
        .import_result(identification("M1", "2026-01-01T00:00:00Z", 0.10, 1e-6))
        .await
        .unwrap();
    result_landed(&store, "M1", &r.id).await.unwrap();
    let fleet = call(
        &app,
        "GET",
        "/api/v1/fleet?sort=name",
        &keys.read,
        Value::Null,
    )
    .await;
    let of = |id: &str| {
        fleet["machines"]
            .as_array()
            .unwrap()
            .iter()
            .find(|m| m["machine_id"] == id)
            .unwrap()
            .clone()
    };
    let m3 = of("M3");
    assert_eq!(m3["last_check"], Value::Null, "{m3}");
    assert_eq!(m3["verdict"], Value::Null);
    assert_eq!(m3["tolerance_profile_id"], p["id"]);
    assert_eq!(m3["tolerance_profile"]["scope"], "tag");
    assert_eq!(m3["tolerance_profile"]["target"], "vmc");
}
