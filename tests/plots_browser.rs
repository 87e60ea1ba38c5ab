//! Every plot the dashboard shows, read as a person reads it, in a real headless
//! Chromium (1400 × 1000 window) on the demo fleet of `mtcal demo` plus a positioning
//! run of `data/ecmccfg_iso230` (diagnosed, and its ISO 230-2 figures): the fleet,
//! every machine's page (trends), every stored result of every kind (error functions,
//! circle tests, the diagnosis figures, positioning, the cradle's, sensitivity) and a
//! comparison. In every figure, at the size it is drawn on screen, the test fails on
//! text under [`MIN_TEXT_PX`], text cut by the figure's edge, texts over each other,
//! and text lying over the data (a legend over a trace, a ring label on a trace); the
//! checks run in the page (`tests/browser/plots.js`, with the browser's own text
//! boxes: `getBoundingClientRect`, `getScreenCTM`).

mod browser;

use browser::{api, wait_for};
use fantoccini::Client;
use mtcal_client::Client as Api;
use mtcal_server::api::jobs::SubmitJob;
use mtcal_server::jobs::JobKind;
use serde_json::{Value, json};
use std::path::Path;
use std::time::Duration;

/// The smallest text a plot may show on screen, px.
const MIN_TEXT_PX: f64 = 12.0;

/// The check of one page's figures (module docs).
const CHECK: &str = include_str!("browser/plots.js");

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn every_plot_is_readable_on_screen() {
    browser::on_demo(|c, d| async move {
        run(&c, &d.dashboard, &d.base, &d.key).await;
    })
    .await;
}

/// The pages with plots: the fleet, each machine, each result, a comparison.
async fn pages(base: &str, key: &str) -> Vec<String> {
    let api_ = Api::new(base, key);
    // A positioning run of a real stage: its diagnosis and its ISO 230-2 figures.
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("data/ecmccfg_iso230/psi_test_stage.csv");
    let ds = api_
        .upload_path("VMC-0001", &data)
        .await
        .expect("positioning upload");
    for kind in [JobKind::Diagnose, JobKind::Standards] {
        let job = api_
            .submit(&SubmitJob {
                kind,
                dataset_id: Some(ds.id.clone()),
                machine_id: None,
                params: json!({}),
            })
            .await
            .expect("submitted");
        let done = api_
            .wait_job(
                &job.id,
                Duration::from_secs(240),
                Duration::from_millis(300),
                |_| {},
            )
            .await
            .expect("job ends");
        assert_eq!(done.state.as_str(), "succeeded", "{done:?}");
    }
    let mut pages = vec!["/".to_string()];
    let fleet = api(base, key, "/api/v1/fleet").await;
    for m in fleet["machines"].as_array().unwrap() {
        let id = m["machine_id"].as_str().unwrap();
        pages.push(format!("/machines/{id}"));
        for kind in [
            "identification",
            "diagnosis",
            "cradle",
            "standards",
            "sensitivity",
        ] {
            let list = api(
                base,
                key,
                &format!("/api/v1/machines/{id}/results?kind={kind}"),
            )
            .await;
            let ids: Vec<&str> = list
                .as_array()
                .unwrap()
                .iter()
                .map(|r| r["id"].as_str().unwrap())
                .collect();
            pages.extend(ids.iter().map(|r| format!("/results/{r}")));
            if kind == "identification" && ids.len() >= 2 {
                pages.push(format!("/compare?a={}&b={}", ids[0], ids[ids.len() - 1]));
            }
        }
    }
    pages
}

async fn run(c: &Client, dashboard: &str, base: &str, key: &str) {
    browser::sign_in(c, dashboard).await;
    let pages = pages(base, key).await;
    assert!(pages.len() > 10, "{pages:?}");
    let mut problems = vec![];
    let mut figures = 0;
    for page in &pages {
        c.goto(&format!("{base}{page}")).await.unwrap();
        wait_for(c, "main", Duration::from_secs(10)).await;
        figures += c
            .execute("return document.querySelectorAll('main svg text').length > 0 ? document.querySelectorAll('main svg').length : 0;", vec![])
            .await
            .unwrap()
            .as_u64()
            .unwrap();
        let found = c.execute(CHECK, vec![json!(MIN_TEXT_PX)]).await.unwrap();
        let Value::Array(found) = found else {
            panic!("{page}: {found}")
        };
        problems.extend(
            found
                .iter()
                .map(|p| format!("{page}: {}", p.as_str().unwrap_or_default())),
        );
    }
    assert!(figures > 50, "only {figures} figures seen");
    assert!(
        problems.is_empty(),
        "{} problems in the plots of {} pages:\n{}",
        problems.len(),
        pages.len(),
        problems.join("\n")
    );
}
