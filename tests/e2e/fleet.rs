//! The fleet as the dashboard's fleet page shows it, from the documented route
//! `GET /api/v1/fleet`: filtered by site and tag, machines with active alerts first,
//! then sorted, a page at a time, each machine with its tags, last check, drift ± u,
//! sparkline and active alerts (a machine whose only check is a cradle check shows that
//! check, and why it has no drift); and the fleet page, a client of that route, lists
//! the same machines in the same order.

use crate::common::*;
use mtcal_server::api::fleet::{FleetList, FleetParams};
use mtcal_store::NewResult;
use reqwest::StatusCode;

/// Machines A…E: A (north, vmc) drifts 4 µm, B (north, 5-axis) 1 µm with an active
/// alert, C (south, vmc) 2.5 µm, D (south, 5-axis) has only a cradle check, E (south)
/// no check.
async fn fleet() -> App {
    let app = spawn_app_with(AppOptions {
        run_worker: false,
        ..AppOptions::default()
    })
    .await;
    // Moving a machine to a site takes an admin key (docs/sites.md).
    let c = &app.with_key(&app.admin_key);
    for (id, site, tags) in [
        ("A", "north", vec!["vmc"]),
        ("B", "north", vec!["5-axis"]),
        ("C", "south", vec!["vmc"]),
        ("D", "south", vec!["5-axis"]),
        ("E", "south", vec![]),
    ] {
        app.machine(id).await;
        c.update_machine(
            id,
            &mtcal_store::MachinePatch {
                site: Some(site.into()),
                tags: Some(tags.into_iter().map(String::from).collect()),
                ..Default::default()
            },
        )
        .await
        .unwrap();
    }
    let land = |r: NewResult| {
        let store = app.store.clone();
        async move {
            let kind = r.kind.clone();
            let m = r.machine_id.clone();
            let stored = store.import_result(r).await.unwrap();
            if kind == "identification" {
                mtcal_domain::landing::result_landed(&store, &m, &stored.id)
                    .await
                    .unwrap();
            }
            stored.id
        }
    };
    let id = "identification";
    land(check("A", id, "2026-01-05T08:00:00Z", 0.02)).await;
    land(check("A", id, "2026-04-06T08:00:00Z", 0.10)).await;
    land(check("B", id, "2026-01-06T08:00:00Z", 0.01)).await;
    let b = land(check("B", id, "2026-03-06T08:00:00Z", 0.03)).await;
    land(check("C", id, "2026-01-07T08:00:00Z", 0.0)).await;
    land(check("C", id, "2026-02-07T08:00:00Z", 0.05)).await;
    land(check("D", "cradle", "2026-02-08T08:00:00Z", 0.0)).await;
    app.store
        .raise_alert(&alert("al_b", "B", &b), &[])
        .await
        .unwrap();
    app
}

fn ids(f: &FleetList) -> Vec<&str> {
    f.machines.iter().map(|m| m.machine_id.as_str()).collect()
}

fn params(sort: Option<&str>, site: Option<&str>, tag: Option<&str>) -> FleetParams {
    FleetParams {
        sort: sort.map(Into::into),
        site: site.map(Into::into),
        tag: tag.map(Into::into),
        ..FleetParams::default()
    }
}

#[tokio::test]
async fn the_fleet_route_filters_sorts_pages_and_puts_alerted_machines_first() {
    let app = fleet().await;
    let read = app.with_key(&app.read_key);
    let f = read.fleet(&FleetParams::default()).await.unwrap();
    assert_eq!(
        ids(&f),
        ["B", "A", "C", "D", "E"],
        "alerted first, then drift"
    );
    assert_eq!(
        (f.total, f.sort.as_str(), f.offset, f.limit),
        (5, "drift", 0, 100)
    );
    assert_eq!(f.sites, ["north", "south"]);
    assert_eq!(f.tags, ["5-axis", "vmc"]);
    assert!(f.definition.contains("both checks measured"));
    // What each machine carries.
    let by = |id: &str| f.machines.iter().find(|m| m.machine_id == id).unwrap();
    let a = by("A");
    assert_eq!(
        (a.site.as_deref(), &a.tags[..]),
        (Some("north"), &["vmc".to_string()][..])
    );
    assert_eq!(a.active_alerts, 0);
    assert_eq!(by("B").active_alerts, 1);
    let d = a.drift.as_ref().unwrap();
    assert!((d.drift_um - 4.0).abs() < 1e-9, "{d:?}");
    assert!(d.drift_um_u.is_some_and(|u| u > 0.0), "drift ± u");
    assert_eq!(d.worst_term_um.as_deref(), Some("EXX"));
    let last = a.last_check.as_ref().unwrap();
    assert_eq!(
        (last.kind.as_str(), last.measured_at.as_str()),
        ("identification", "2026-04-06T08:00:00Z")
    );
    assert_eq!((a.results, a.sparkline.len()), (2, 2));
    assert!(a.baseline_result_id.is_some() && a.drift_note.is_none());
    // A machine whose only check is a cradle check: that check, and why no drift.
    let d = by("D");
    assert_eq!(d.last_check.as_ref().unwrap().kind, "cradle");
    assert!(d.drift.is_none());
    let note = d.drift_note.as_deref().unwrap();
    assert!(
        note.contains("not applicable") && note.contains("cradle"),
        "{note}"
    );
    let e = by("E");
    assert!(e.last_check.is_none() && e.drift.is_none() && e.drift_note.is_none());

    // Orders, filters, pages.
    let order = |p: FleetParams| {
        let read = read.clone();
        async move {
            let f = read.fleet(&p).await.unwrap();
            (
                ids(&f).iter().map(|s| s.to_string()).collect::<Vec<_>>(),
                f.total,
            )
        }
    };
    assert_eq!(
        order(params(Some("name"), None, None)).await.0,
        ["B", "A", "C", "D", "E"]
    );
    assert_eq!(
        order(params(Some("last_check"), None, None)).await.0,
        ["B", "A", "C", "D", "E"]
    );
    assert_eq!(
        order(params(Some("drift"), Some("south"), None)).await,
        (vec!["C".to_string(), "D".into(), "E".into()], 3)
    );
    assert_eq!(
        order(params(None, None, Some("5-axis"))).await.0,
        ["B", "D"]
    );
    assert_eq!(
        order(params(None, Some(""), Some(""))).await.1,
        5,
        "empty: all"
    );
    let mut pages = vec![];
    for offset in [0, 2, 4] {
        let p = FleetParams {
            offset: Some(offset),
            limit: Some(2),
            ..FleetParams::default()
        };
        let (page, total) = order(p).await;
        assert_eq!(total, 5);
        pages.extend(page);
    }
    assert_eq!(
        pages,
        ["B", "A", "C", "D", "E"],
        "pages in order, each once"
    );
    for bad in [
        params(Some("size"), None, None),
        FleetParams {
            limit: Some(0),
            ..FleetParams::default()
        },
    ] {
        assert_eq!(
            refused(read.fleet(&bad).await),
            (StatusCode::BAD_REQUEST, "invalid_request".into())
        );
    }
}

/// The `data-machine` of each row of the page's fleet table, in order.
fn page_rows(html: &str) -> Vec<String> {
    let table = &html[html.find(r#"id="fleet""#).expect("the fleet table")..];
    let table = &table[..table.find("</table>").unwrap()];
    table
        .split(r#"data-machine=""#)
        .skip(1)
        .map(|s| s[..s.find('"').unwrap()].to_string())
        .collect()
}

#[tokio::test]
async fn the_fleet_page_lists_what_the_fleet_route_answers() {
    let app = fleet().await;
    let read = app.with_key(&app.read_key);
    let b = app.sign_in(&app.read_key).await;
    for (query, p) in [
        ("", FleetParams::default()),
        ("?sort=name", params(Some("name"), None, None)),
        (
            "?sort=last_check&site=south",
            params(Some("last_check"), Some("south"), None),
        ),
        (
            "?sort=drift_urad&tag=vmc",
            params(Some("drift_urad"), None, Some("vmc")),
        ),
    ] {
        let r = b.get(&format!("/{query}")).await;
        assert_eq!(r.status(), StatusCode::OK, "{query}");
        let html = r.text().await.unwrap();
        let f = read.fleet(&p).await.unwrap();
        assert_eq!(page_rows(&html), ids(&f), "{query}");
        assert!(html.contains(&format!("{} machine(s)", f.total)), "{query}");
    }
    let html = b.get("/").await.text().await.unwrap();
    let row = &html[html.find(r#"data-machine="D""#).unwrap()..];
    let row = &row[..row.find("</tr>").unwrap()];
    assert!(
        row.contains("(cradle)") && row.contains("not applicable"),
        "{row}"
    );
    assert!(!row.contains("no check yet"), "{row}");
    assert_eq!(b.get("/?sort=size").await.status(), StatusCode::BAD_REQUEST);
}
