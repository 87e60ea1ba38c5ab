//! The dashboard in a real headless Chromium driven over WebDriver (chromedriver), on the
//! demo fleet of `mtcal demo`: sign in by typing a key, see the fleet as the API's fleet
//! route lists it (ranked as the drift ranking ranks it; the 5-axis machine with its
//! cradle check and why it has no drift), open a machine and read its trend plot (values
//! and ±2σ bars) back against the API's values and uncertainties, open results (an
//! identification's error functions and its circle tests' polar plots, a diagnosis's
//! polar plot, a cradle check's compliance against A with its ±2σ bands), give a machine a tolerance profile and a drift threshold through the
//! API, upload a drifted session through the form and see the new check appear with its
//! verdict and its drift alert on the fleet page, acknowledge the alert on the alerts
//! page, see the jobs page, compare two checks, sign out; then sign in again with one
//! click on the link `mtcal demo` prints (the key in the URL's fragment), and sign out.
//! One browser, a small fleet.
//!
//! A screenshot of each page is saved under `target/tmp/dashboard/`; with
//! `UPDATE_SCREENSHOTS=1` those of the README (fleet, machine, result scrolled to its
//! error functions and to its circle tests, a cradle result's compliance, compare, jobs,
//! alerts) are copied to
//! `docs/screenshots/` too. The test skips, with a printed reason, only when chromedriver
//! is absent (`CHROMEDRIVER` names another path than `/usr/bin/chromedriver`).

mod browser;

use browser::{api, log_tail, text, wait_for};
use fantoccini::{Client, Locator};
use mtcal_views::plots::{BAND, COLORS, inspect};
use serde_json::{Value, json};
use std::path::Path;
use std::process::Command;
use std::time::{Duration, Instant};

/// The pages whose screenshots the README shows (docs/screenshots/).
const DOCUMENTED: [&str; 9] = [
    "fleet",
    "result-misfit",
    "machine",
    "result",
    "result-circles",
    "result-cradle",
    "compare",
    "jobs",
    "alerts",
];

async fn shot(c: &Client, dir: &Path, name: &str) {
    browser::shot(c, dir, name, &DOCUMENTED).await;
}

/// A write to the API (the demo key has admin scope).
async fn api_send(base: &str, key: &str, method: &str, path: &str, body: Value) -> Value {
    let r = reqwest::Client::new()
        .request(method.parse().unwrap(), format!("{base}{path}"))
        .bearer_auth(key)
        .json(&body)
        .send()
        .await
        .expect("API answers");
    let status = r.status();
    let v: Value = r.json().await.unwrap_or(Value::Null);
    assert!(status.is_success(), "{method} {path}: {status} {v}");
    v
}

/// Attribute `name` of the element `css` matches (which must have it).
async fn attr(c: &Client, css: &str, name: &str) -> String {
    c.find(Locator::Css(css))
        .await
        .unwrap_or_else(|e| panic!("{css}: {e}"))
        .attr(name)
        .await
        .expect("attribute")
        .unwrap_or_else(|| panic!("{css} has no {name}"))
}

/// Scrolls the page so that the element `css` matches starts at the top of the window.
async fn scroll_to(c: &Client, css: &str) {
    let e = c
        .find(Locator::Css(css))
        .await
        .unwrap_or_else(|e| panic!("{css}: {e}"));
    let arg = serde_json::to_value(&e).unwrap();
    c.execute("arguments[0].scrollIntoView({block: 'start'});", vec![arg])
        .await
        .expect("scrolled");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn dashboard_in_headless_chromium() {
    let shots = browser::shots_dir("dashboard");
    browser::on_demo(|c, d| async move {
        run(&c, &d.dashboard, &d.base, &d.key, &shots, &d.work).await;
    })
    .await;
}

async fn run(c: &Client, dashboard: &str, base: &str, key: &str, shots: &Path, work: &Path) {
    // Without a session, a page sends the browser to the sign-in form.
    c.goto(&format!("{base}/machines/VMC-0001")).await.unwrap();
    assert!(c.current_url().await.unwrap().path().starts_with("/signin"));
    shot(c, shots, "signin").await;
    // A wrong key is refused and changes nothing.
    c.find(Locator::Css("#key"))
        .await
        .unwrap()
        .send_keys("mtk_00000000000000000000000000000000")
        .await
        .unwrap();
    c.find(Locator::Css("form.stack button"))
        .await
        .unwrap()
        .click()
        .await
        .unwrap();
    assert!(
        text(c, "#signin-error")
            .await
            .contains("unknown or revoked API key")
    );
    // The key signs in and goes on to the page asked for.
    c.find(Locator::Css("#key"))
        .await
        .unwrap()
        .send_keys(key)
        .await
        .unwrap();
    c.find(Locator::Css("form.stack button"))
        .await
        .unwrap()
        .click()
        .await
        .unwrap();
    wait_for(c, "#term-trend", Duration::from_secs(10)).await;
    assert_eq!(c.current_url().await.unwrap().path(), "/machines/VMC-0001");

    // The fleet: the machines of the API's fleet route in its order, those with drift
    // ranked as the drift ranking ranks them (µm, largest first).
    c.goto(&format!("{base}/")).await.unwrap();
    let ids = |v: &Value| -> Vec<String> {
        v["machines"]
            .as_array()
            .unwrap()
            .iter()
            .map(|m| m["machine_id"].as_str().unwrap().to_string())
            .collect()
    };
    let fleet = api(base, key, "/api/v1/fleet").await;
    let ranked = ids(&api(base, key, "/api/v1/fleet/drift?by=um").await);
    let mut rows = vec![];
    for r in c.find_all(Locator::Css("#fleet tbody tr")).await.unwrap() {
        rows.push(r.attr("data-machine").await.unwrap().unwrap());
    }
    assert_eq!(
        rows,
        ids(&fleet),
        "the page lists the fleet route's machines"
    );
    // Machines with active alerts first (the demo's VMC-0003), then by drift as ranked.
    let alerted: Vec<String> = fleet["machines"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|m| m["active_alerts"].as_i64() > Some(0))
        .map(|m| m["machine_id"].as_str().unwrap().to_string())
        .collect();
    assert_eq!(alerted, ["VMC-0003"], "the demo's active alert");
    assert_eq!(&rows[..alerted.len()], &alerted[..], "alerted first");
    let quiet: Vec<&String> = rows.iter().filter(|r| !alerted.contains(r)).collect();
    let ranked_quiet: Vec<&String> = ranked.iter().filter(|r| !alerted.contains(r)).collect();
    assert_eq!(
        &quiet[..ranked_quiet.len()],
        &ranked_quiet[..],
        "fleet order"
    );
    // The 5-axis machine has only a cradle check: shown, with why it has no drift.
    let cradle = r#"#fleet tr[data-machine="5AX-0001"]"#;
    assert!(
        text(c, &format!("{cradle} .last-check"))
            .await
            .contains("(cradle)"),
        "its last check"
    );
    assert!(
        text(c, &format!("{cradle} .drift-note"))
            .await
            .contains("not applicable"),
        "why it has no drift"
    );
    // The demo's decisions: the machine beyond its own profile says why it fails; the
    // worn machine, whose backlash was compensated after its explained check, is decided
    // and shows what the diagnosis of its latest check found (the lost motion left); the
    // warm-nut machine's latest check is not decided; the failing machine's squareness
    // drift alert is active.
    let strict = r#"#fleet tr[data-machine="VMC-0003"]"#;
    assert_eq!(text(c, &format!("{strict} .badge.verdict")).await, "fail");
    let count = text(c, &format!("{strict} .verdict-count")).await;
    assert!(count.contains("of 6 limits fail"), "{count}");
    let reason = text(c, &format!("{strict} .reason")).await;
    assert!(reason.contains("(limit 1.200 µm)"), "{reason}");
    let worn = r#"#fleet tr[data-machine="VMC-0900"]"#;
    assert_ne!(
        text(c, &format!("{worn} .badge.verdict")).await,
        "not decided: model misfit"
    );
    let found = text(c, &format!("{worn} .findings")).await;
    // The backlash left after compensation is 0.4 µm.
    let lost_motion: f64 = found
        .split("backlash (X): lost_motion_um = ")
        .nth(1)
        .and_then(|v| v.split_whitespace().next())
        .and_then(|v| v.parse().ok())
        .unwrap_or_else(|| panic!("no X backlash found: {found}"));
    assert!((lost_motion - 0.4).abs() < 0.1, "{found}");
    let warm = r#"#fleet tr[data-machine="VMC-0901"]"#;
    assert_eq!(
        text(c, &format!("{warm} .badge.verdict")).await,
        "not decided: model misfit"
    );
    let demo_alerts = api(base, key, "/api/v1/alerts?machine=VMC-0003&active=true").await;
    assert_eq!(demo_alerts.as_array().unwrap().len(), 1, "{demo_alerts}");
    assert!(
        text(c, "#alerts").await.contains("VMC-0003"),
        "the fleet page lists the active alert"
    );
    shot(c, shots, "fleet-before").await;
    // The misfit's result page (the warm-nut machine's original check, kept beside its
    // explained model): the banner above everything, and the way to its findings.
    let warm_latest = api(base, key, "/api/v1/machines/VMC-0901/results/latest").await;
    let original = warm_latest["document"]["explained"]["original_result_id"]
        .as_str()
        .expect("the warm-nut machine's latest check is its explained model");
    c.goto(&format!("{base}/results/{original}")).await.unwrap();
    let banner = text(c, "#misfit").await;
    assert!(banner.contains("Not decided: model misfit"), "{banner}");
    assert!(
        banner.contains("diagnosis of this recording found: backlash (X)"),
        "the banner says what the service's diagnosis found: {banner}"
    );
    shot(c, shots, "result-misfit").await;
    c.goto(&format!("{base}/")).await.unwrap();

    // A machine: the trend plot's points are the API's values.
    c.find(Locator::Css(r#"#fleet tr[data-machine="VMC-0001"] a"#))
        .await
        .unwrap()
        .click()
        .await
        .unwrap();
    wait_for(c, "#term-trend", Duration::from_secs(10)).await;
    let (svg, trend) = browser::shown_trend(c, base, key, "VMC-0001").await;
    let plot = inspect::parse(&svg).unwrap();
    let axes = plot.axes().unwrap();
    let points = trend["points"].as_array().unwrap();
    assert_eq!(points.len(), 3, "three quarterly checks");
    let mut bars_checked = 0;
    for (series, colour) in COLORS
        .iter()
        .take(trend["positions_mm"].as_array().unwrap().len())
        .enumerate()
    {
        let marks: Vec<_> = plot
            .marks("circle", &inspect::hex(*colour))
            .into_iter()
            .filter(|m| m.r == 4.0 && m.fill.is_some())
            .collect();
        assert_eq!(marks.len(), points.len(), "one marker per check");
        // The ±2σ bars: vertical lines of the series colour through each marker.
        let bars = plot.marks("line", &inspect::hex(*colour));
        let px = 1.0 / axes.y.scale.abs();
        for (m, p) in marks.iter().zip(points) {
            let t = mtcal_views::plots::unix_seconds(p["measured_at"].as_str().unwrap()).unwrap();
            let v = p["values"][series].as_f64().unwrap();
            let (x, y) = axes.data(m.points[0]);
            assert!((x - t).abs() <= 1.5 / axes.x.scale.abs(), "time of {p}");
            assert!(
                (y - v).abs() <= 1.5 / axes.y.scale.abs(),
                "value {y} vs {v}"
            );
            let u = p["u"][series]
                .as_f64()
                .expect("every trend point has its uncertainty");
            assert!(u > 0.0, "{p}");
            let bar = bars.iter().find(|b| {
                b.points[0].0 == b.points[1].0 && (b.points[0].0 - m.points[0].0).abs() < 0.5
            });
            if 2.0 * u < 2.0 * px {
                continue; // a bar shorter than a pixel or two need not be drawn apart
            }
            let b = bar.unwrap_or_else(|| panic!("no ±2σ bar at {p}"));
            let lo = axes.y.value(b.points[0].1.max(b.points[1].1));
            let hi = axes.y.value(b.points[0].1.min(b.points[1].1));
            assert!(
                (lo - (v - 2.0 * u)).abs() <= 1.5 * px,
                "{lo} vs {v} - 2·{u}"
            );
            assert!(
                (hi - (v + 2.0 * u)).abs() <= 1.5 * px,
                "{hi} vs {v} + 2·{u}"
            );
            bars_checked += 1;
        }
    }
    assert!(bars_checked > 0, "no ±2σ bar long enough to check");
    shot(c, shots, "machine-trend").await;

    // A result: the identification's 18 error functions; a diagnosis's polar plot.
    let latest = api(base, key, "/api/v1/machines/VMC-0001/results/latest").await;
    let rid = latest["meta"]["id"].as_str().unwrap();
    c.goto(&format!("{base}/results/{rid}")).await.unwrap();
    assert_eq!(
        c.find_all(Locator::Css("#terms figure"))
            .await
            .unwrap()
            .len(),
        18
    );
    // Its own circle tests: one polar plot per file, plane and radius of the stored
    // document's circles, each with the measured and the model's traces.
    let stored = api(base, key, &format!("/api/v1/results/{rid}")).await;
    let mut groups: Vec<String> = stored["document"]["circles"]
        .as_array()
        .expect("the identification stores its circle tests")
        .iter()
        .map(|c| format!("{} {} {}", c["file"], c["plane"], c["radius_mm"]))
        .collect();
    groups.sort();
    groups.dedup();
    assert!(!groups.is_empty());
    let polar = c
        .find_all(Locator::Css("#circles figure.polar svg"))
        .await
        .unwrap();
    assert_eq!(polar.len(), groups.len(), "one polar plot per circle test");
    let plot = inspect::parse(&polar[0].html(false).await.unwrap()).unwrap();
    assert_eq!(
        ["+X", "+Y", "+Z"]
            .iter()
            .filter(|a| plot.has_text(a))
            .count(),
        2,
        "the plane's axis labels"
    );
    assert!(
        plot.texts
            .iter()
            .any(|t| t.content.starts_with("R ") && t.content.ends_with(" mm")),
        "the nominal radius labels the reference circle"
    );
    assert!(
        plot.marks
            .iter()
            .filter(|m| m.tag == "polyline" && m.points.len() > 20)
            .count()
            >= 2,
        "measured and model traces"
    );
    assert!(
        c.find(Locator::Css(".circles-error")).await.is_err(),
        "the stored circles read"
    );
    shot(c, shots, "result-without-tolerance").await;
    let diag = api(
        base,
        key,
        "/api/v1/machines/VMC-0001/results/latest?kind=diagnosis",
    )
    .await;
    c.goto(&format!(
        "{base}/results/{}",
        diag["meta"]["id"].as_str().unwrap()
    ))
    .await
    .unwrap();
    let polar = c
        .find(Locator::Css(r#"figure[data-plot="circle_polar"] svg"#))
        .await
        .unwrap()
        .html(false)
        .await
        .unwrap();
    let plot = inspect::parse(&polar).unwrap();
    assert!(
        plot.has_text("90°") && plot.has_text("0 µm"),
        "a polar plot with rings"
    );
    assert!(
        plot.marks
            .iter()
            .filter(|m| m.tag == "polyline" && m.points.len() > 100)
            .count()
            >= 3
    );
    assert!(
        !c.find_all(Locator::Css("section.finding"))
            .await
            .unwrap()
            .is_empty()
    );
    shot(c, shots, "diagnosis").await;

    // The cradle check of the 5-axis machine: the chosen model's compliance against A,
    // one plot per term of the stored document, each curve and its ±2σ band where the
    // document's values put them, and what the ball data can separate.
    let cradle = api(
        base,
        key,
        "/api/v1/machines/5AX-0001/results/latest?kind=cradle",
    )
    .await;
    c.goto(&format!(
        "{base}/results/{}",
        cradle["meta"]["id"].as_str().unwrap()
    ))
    .await
    .unwrap();
    let curves = cradle["document"]["kinematics"]["curves"]
        .as_array()
        .expect("the cradle check stores its compliance curves");
    assert!(!curves.is_empty(), "the demo cradle's table tilts with A");
    let plots = c
        .find_all(Locator::Css("#compliance figure svg"))
        .await
        .unwrap();
    assert_eq!(plots.len(), curves.len(), "one plot per compliance term");
    for (svg, curve) in plots.iter().zip(curves) {
        let plot = inspect::parse(&svg.html(false).await.unwrap()).unwrap();
        assert!(plot.has_text("A (°)"));
        let axes = plot.axes().unwrap();
        let line = &plot.marks("polyline", &inspect::hex(COLORS[0]))[0];
        let value = curve["value"].as_array().unwrap();
        let std = curve["std"].as_array().unwrap();
        let a = curve["a_deg"].as_array().unwrap();
        assert_eq!(line.points.len(), value.len());
        let band = &plot.marks("polygon", &inspect::hex(BAND))[0].points;
        let n = value.len();
        for i in [0, n / 4, n - 1] {
            let (a, v, u) = (
                a[i].as_f64().unwrap(),
                value[i].as_f64().unwrap(),
                std[i].as_f64().unwrap(),
            );
            assert!((axes.x.px(a) - line.points[i].0).abs() <= 1.0, "A {a}");
            assert!(
                (axes.y.px(v) - line.points[i].1).abs() <= 1.0,
                "value at A {a}"
            );
            assert!(
                (axes.y.px(v + 2.0 * u) - band[i].1).abs() <= 1.0,
                "band at A {a}"
            );
        }
    }
    let sep = text(c, "#separability").await;
    assert!(sep.contains("tilt of the C table about its mount"), "{sep}");
    scroll_to(c, "#compliance").await;
    shot(c, shots, "result-cradle").await;

    // A tolerance profile of VMC-0002 (its own, so it wins over any tag's): a term
    // limit far above the demo's errors, and a drift threshold of 0.1 µm that the demo's
    // drift of EXX (5 nm/mm per quarter and unit rate, rate ≥ 0.5) exceeds by far after
    // three quarters.
    api_send(
        base,
        key,
        "POST",
        "/api/v1/tolerances",
        json!({
            "scope": "machine", "target": "VMC-0002",
            "limits": {"terms": {"EXX": 1000.0, "EYY": 1000.0}, "drift_um": 0.1}
        }),
    )
    .await;
    assert!(
        api(base, key, "/api/v1/alerts?machine=VMC-0002")
            .await
            .as_array()
            .unwrap()
            .is_empty(),
        "no alert before the drifted check lands"
    );

    // Upload a drifted check through the form and watch it appear with its verdict.
    let session = work.join("VMC-0002-q3");
    let st = Command::new(env!("CARGO_BIN_EXE_mtcal"))
        .args(["demo", "--write-session"])
        .arg(&session)
        .args(["--machine", "VMC-0002", "--seed", "2", "--quarter", "3"])
        .status()
        .unwrap();
    assert!(st.success());
    let mut files: Vec<String> = std::fs::read_dir(&session)
        .unwrap()
        .map(|e| e.unwrap().path().display().to_string())
        .collect();
    files.sort();
    c.goto(&format!("{base}/machines/VMC-0002")).await.unwrap();
    let before = c
        .find_all(Locator::Css("#checks tbody tr"))
        .await
        .unwrap()
        .len();
    c.find(Locator::Css(r#"form.upload input[type="file"]"#))
        .await
        .unwrap()
        .send_keys(&files.join("\n"))
        .await
        .unwrap();
    c.find(Locator::Css("form.upload button[type=submit]"))
        .await
        .unwrap()
        .click()
        .await
        .unwrap();
    wait_for(c, "#jobs .job", Duration::from_secs(20)).await;
    shot(c, shots, "upload").await;
    // The page reloads when the job ends; the new check is the newest row. The job is
    // watched through the API as well, so that a failure says what happened to it.
    let job_id = attr(c, "#jobs .job", "data-job").await;
    let t0 = Instant::now();
    let mut ended: Option<Instant> = None;
    loop {
        let n = c
            .find_all(Locator::Css("#checks tbody tr"))
            .await
            .map(|rows| rows.len())
            .unwrap_or(0);
        if n == before + 1 {
            break;
        }
        let job = api(base, key, &format!("/api/v1/jobs/{job_id}")).await;
        match job["state"].as_str() {
            Some("succeeded") => {
                // The page script reloads within its next poll (a second).
                let at = *ended.get_or_insert_with(Instant::now);
                assert!(
                    at.elapsed() < Duration::from_secs(20),
                    "job {job_id} succeeded but the page did not show its check ({n} rows, {before} before)\n{}",
                    log_tail(work)
                );
            }
            Some("failed" | "cancelled") => {
                panic!("the uploaded check's job ended {job}\n{}", log_tail(work))
            }
            _ => assert!(
                t0.elapsed() < Duration::from_secs(240),
                "the uploaded check's job did not end: {job}\n{}",
                log_tail(work)
            ),
        }
        tokio::time::sleep(Duration::from_millis(500)).await;
    }
    let newest = text(c, "#checks tbody tr:first-child").await;
    assert!(newest.contains("2026-10-05"), "{newest}");
    let new_id = attr(c, "#checks tbody tr:first-child", "data-result").await;
    let verdict = api(base, key, &format!("/api/v1/results/{new_id}/verdict")).await;
    assert_eq!(verdict["verdict"]["decision"], "pass", "{verdict}");
    assert_eq!(
        text(c, "#checks tbody tr:first-child .badge.verdict").await,
        "pass",
        "the verdict shown is the API's"
    );
    // The drift alert it raised: on the machine page, and first on the fleet page.
    // (The worker checks drift right after it records the job's success: allow it a
    // moment.)
    let t0 = Instant::now();
    let alerts = loop {
        let a = api(base, key, "/api/v1/alerts?machine=VMC-0002&active=true").await;
        if !a.as_array().unwrap().is_empty() || t0.elapsed() > Duration::from_secs(10) {
            break a;
        }
        tokio::time::sleep(Duration::from_millis(200)).await;
    };
    assert_eq!(alerts.as_array().unwrap().len(), 1, "{alerts}");
    c.refresh().await.unwrap();
    wait_for(c, "#checks", Duration::from_secs(10)).await;
    let alert_id = alerts[0]["id"].as_str().unwrap().to_string();
    assert_eq!(alerts[0]["result_id"], new_id.as_str());
    assert!(
        c.find(Locator::Css(&format!(
            r#"#alerts tr[data-alert="{alert_id}"]"#
        )))
        .await
        .is_ok(),
        "the machine page lists the alert"
    );
    shot(c, shots, "machine").await;
    c.goto(&format!("{base}/")).await.unwrap();
    wait_for(c, "#fleet", Duration::from_secs(10)).await;
    // Machines with active alerts first: the demo's VMC-0003 and now VMC-0002.
    let mut alerted = vec![];
    for r in c.find_all(Locator::Css("#fleet tbody tr")).await.unwrap() {
        if r.attr("class").await.unwrap().as_deref() != Some("alerted") {
            break;
        }
        alerted.push(r.attr("data-machine").await.unwrap().unwrap());
    }
    alerted.sort();
    assert_eq!(
        alerted,
        ["VMC-0002", "VMC-0003"],
        "machines with active alerts first"
    );
    assert!(
        text(c, &format!(r#"#alerts tr[data-alert="{alert_id}"]"#))
            .await
            .contains("EXX")
    );
    assert_eq!(
        text(c, r#"#fleet tr[data-machine="VMC-0002"] .badge.verdict"#).await,
        "pass"
    );
    shot(c, shots, "fleet").await;

    // The jobs page lists the upload's job, succeeded.
    c.goto(&format!("{base}/jobs")).await.unwrap();
    wait_for(c, "#jobs tbody tr", Duration::from_secs(10)).await;
    assert!(
        text(c, "#jobs tbody tr:first-child")
            .await
            .contains("succeeded"),
        "the newest job is the upload's"
    );
    shot(c, shots, "jobs").await;

    // The alerts page: acknowledge it (a write key), then it is no longer active.
    c.goto(&format!("{base}/alerts")).await.unwrap();
    wait_for(
        c,
        &format!(r#"tr[data-alert="{alert_id}"]"#),
        Duration::from_secs(10),
    )
    .await;
    shot(c, shots, "alerts").await;
    c.find(Locator::Css(&format!(
        r#"tr[data-alert="{alert_id}"] button"#
    )))
    .await
    .unwrap()
    .click()
    .await
    .unwrap();
    // Acknowledged: the page lists the active alerts left (the demo's VMC-0003 one).
    let t0 = Instant::now();
    while c
        .find(Locator::Css(&format!(
            r#"tr[data-alert="{alert_id}"] button"#
        )))
        .await
        .is_ok()
    {
        assert!(
            t0.elapsed() < Duration::from_secs(10),
            "the alert is still active"
        );
        tokio::time::sleep(Duration::from_millis(200)).await;
    }
    let acked = api(base, key, "/api/v1/alerts?machine=VMC-0002").await;
    assert_eq!(acked[0]["active"], false, "{acked}");
    assert!(
        acked[0]["acknowledged_by"]
            .as_str()
            .unwrap()
            .contains("demo")
    );
    // The new check's result page: its verdict table, item by item as the API decides.
    c.goto(&format!("{base}/results/{new_id}")).await.unwrap();
    wait_for(c, "#verdict", Duration::from_secs(10)).await;
    let items = verdict["verdict"]["items"].as_array().unwrap();
    assert_eq!(
        c.find_all(Locator::Css("#verdict tbody tr"))
            .await
            .unwrap()
            .len(),
        items.len()
    );
    shot(c, shots, "result-top").await;
    // The README's views of it: its error functions, and its circle tests' polar plots
    // (further down the page, past the residuals).
    scroll_to(c, "#terms").await;
    shot(c, shots, "result").await;
    scroll_to(c, "#circles").await;
    shot(c, shots, "result-circles").await;
    c.goto(&format!("{base}/machines/VMC-0002")).await.unwrap();
    wait_for(c, "#checks", Duration::from_secs(10)).await;

    // Compare the new check with the baseline.
    c.find(Locator::Css(
        "#checks tbody tr:first-child a[href^='/compare']",
    ))
    .await
    .unwrap()
    .click()
    .await
    .unwrap();
    assert_eq!(
        c.find_all(Locator::Css("#term-diffs figure"))
            .await
            .unwrap()
            .len(),
        18
    );
    // Every difference drawn with its ±2σ band.
    let mut banded = 0;
    for f in c
        .find_all(Locator::Css("#term-diffs figure svg"))
        .await
        .unwrap()
    {
        let plot = inspect::parse(&f.html(false).await.unwrap()).unwrap();
        banded += usize::from(!plot.marks("polygon", &inspect::hex(BAND)).is_empty());
    }
    assert_eq!(banded, 18, "a ±2σ band in every difference panel");
    shot(c, shots, "compare").await;

    // Sign out: the session is gone.
    sign_out(c, base).await;

    // The link `mtcal demo` prints signs in with one click: the page script reads the
    // key from the fragment (never sent to the server), removes it from the address bar
    // and posts the sign-in form; the fleet follows.
    c.goto(dashboard).await.unwrap();
    wait_for(c, "#fleet", Duration::from_secs(10)).await;
    let at = c.current_url().await.unwrap();
    assert_eq!(at.path(), "/", "{at}");
    assert!(
        at.fragment().is_none() && !at.as_str().contains(key),
        "{at}"
    );
    sign_out(c, base).await;
}

/// Signs out with the page header's button; then a page asks to sign in again.
async fn sign_out(c: &Client, base: &str) {
    c.find(Locator::Css("header form button"))
        .await
        .unwrap()
        .click()
        .await
        .unwrap();
    wait_for(c, "#key", Duration::from_secs(10)).await;
    c.goto(&format!("{base}/")).await.unwrap();
    assert!(c.current_url().await.unwrap().path().starts_with("/signin"));
}
