//! The dashboard's pages read as a person reads them, in a real headless Chromium on the
//! demo fleet of `mtcal demo` (src/cli/demo/physics.rs: its worn machine's misfit, a 6 µm
//! backlash of X the rigid model lacks, is diagnosed by the service on its own and
//! decided on the explained model, then checked again after compensation; its warm-nut
//! machine's latest check is explained only partly and stays not decided):
//!
//! * a check decided on its explained model says so, lists the backlash to set and links
//!   its LinuxCNC table (whose reversal column is the backlash put in); the check after
//!   compensation is verified against the prediction on the machine page ("backlash
//!   (X): 6.00 → 0.40 µm after compensation (predicted 0)"), beside the table set;
//! * a misfit check is marked wherever it shows: its drift on the fleet page is not a
//!   figure but "not decided: misfit"; in the machine's trends it is a ring without a
//!   ±2σ bar, named in the legend; it is not offered as a baseline, and the API and the
//!   dashboard's form refuse it as one (409, saying why); its result page offers no
//!   compensation table (the export would refuse it);
//! * the diagnosis page speaks words: each parameter as value ± u in one cell, the BIC
//!   as what it means (its number on hover), the places of the misfit with the share
//!   they sum to, no "no tolerance" badge on a machine with a profile, plot titles not
//!   doubled, the 180° label whole, the RMS-against-time plot full width; the
//!   squareness table in words;
//! * job rows name their check (machine, dataset, when measured); a verdict row says
//!   where, with the per-length limit scaled to the measured travel; the "also
//!   diagnose" checkbox sits with its label;
//! * error pages (404, a refused form, a refused baseline) keep the layout and its
//!   navigation and say what to do, never a bare status line.
//!
//! Screenshots go to `target/tmp/pages/`; with `UPDATE_SCREENSHOTS=1` those the README
//! shows are copied to `docs/screenshots/` too.

mod browser;

use browser::{api, text, wait_for};
use fantoccini::{Client, Locator};
use mtcal_views::plots::{COLORS, MISFIT_KEY, inspect};
use serde_json::{Value, json};
use std::path::Path;
use std::time::Duration;

/// The demo's machine decided on its explained model (6 µm of X backlash), then checked
/// again after compensation.
const WORN: &str = "VMC-0900";

/// The demo's machine whose latest check stays not decided (partly explained).
const MISFIT: &str = "VMC-0901";

/// The screenshots the README shows (docs/screenshots/).
const DOCUMENTED: [&str; 4] = [
    "machine-misfit",
    "diagnosis",
    "result-explained",
    "machine-verified",
];

async fn shot(c: &Client, dir: &Path, name: &str) {
    browser::shot(c, dir, name, &DOCUMENTED).await;
}

/// The visible texts of every element `css` matches.
async fn texts(c: &Client, css: &str) -> Vec<String> {
    let mut out = vec![];
    for e in c.find_all(Locator::Css(css)).await.unwrap() {
        out.push(e.text().await.unwrap());
    }
    out
}

/// Runs `script` in the page and returns its value.
async fn js(c: &Client, script: &str) -> Value {
    c.execute(script, vec![]).await.expect("script runs")
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn pages_in_words_in_headless_chromium() {
    let shots = browser::shots_dir("pages");
    browser::on_demo(|c, d| async move {
        let (base, key) = (&d.base, &d.key);
        browser::sign_in(&c, &d.dashboard).await;
        let diagnosis_id = worn_check(&c, base, key, &shots).await;
        let misfit_id = misfit_marks(&c, base, key, &shots).await;
        diagnosis_in_words(&c, base, key, &diagnosis_id, &shots).await;
        rows_say_which_and_where(&c, base, key).await;
        error_pages(&c, base, &misfit_id, &shots).await;
    })
    .await;
}

/// The worn machine, decided on its explained model and verified at its next check: the
/// check after compensation is verified as predicted (its lost motion left, against the
/// prediction 0) on the machine page, which links the LinuxCNC table that was set; the
/// explained check's page is decided on the explained model, lists the backlash to set
/// and links its LinuxCNC table, whose reversal column is the 6 µm put in; the fleet
/// shows the latest check's drift as a figure. Returns the id of the diagnosis that
/// explained the misfit.
async fn worn_check(c: &Client, base: &str, key: &str, shots: &Path) -> String {
    let trend = api(
        base,
        key,
        &format!("/api/v1/machines/{WORN}/trends/verification"),
    )
    .await;
    let v = trend
        .as_array()
        .unwrap()
        .last()
        .expect("the check after compensation is verified")
        .clone();
    let explained_id = v["previous_result_id"].as_str().unwrap().to_string();
    let f = &v["findings"][0];
    assert_eq!(v["findings"].as_array().unwrap().len(), 1, "{v}");
    assert_eq!(
        (f["effect"].as_str(), f["axis"].as_str()),
        (Some("backlash"), Some("X"))
    );
    assert_eq!(
        (f["state"].as_str(), f["as_predicted"].as_bool()),
        (Some("still_present"), Some(true)),
        "{v}"
    );
    let before = f["before"].as_f64().unwrap();
    let left = f["measured"].as_f64().unwrap();
    assert!(
        (before - 6.0).abs() < 0.1 && (left - 0.4).abs() < 0.1,
        "{v}"
    );
    // The fleet: the latest check is decided, its drift a figure.
    c.goto(&format!("{base}/")).await.unwrap();
    let worn = format!(r#"#fleet tr[data-machine="{WORN}"]"#);
    let cells = texts(c, &format!("{worn} td.num")).await;
    assert!(
        cells[0].contains(" ± ") && !cells[0].contains("misfit"),
        "the latest check's drift is a figure: {cells:?}"
    );
    // The explained check: decided on it, the actions, the LinuxCNC table.
    c.goto(&format!("{base}/results/{explained_id}"))
        .await
        .unwrap();
    wait_for(c, "#explained", Duration::from_secs(10)).await;
    assert_eq!(
        text(c, "#explained h2").await,
        "Decided on the explained model"
    );
    assert!(
        c.find(Locator::Css("#misfit")).await.is_err(),
        "no misfit banner"
    );
    let actions = texts(c, "#actions li").await;
    let set = actions
        .iter()
        .find_map(|a| a.split("set X's backlash compensation to +").nth(1))
        .and_then(|rest| rest.split_whitespace().next()?.parse::<f64>().ok())
        .unwrap_or_else(|| panic!("the backlash to set: {actions:?}"));
    assert!((set - 6.0).abs() < 0.1, "{actions:?}");
    let export = format!("/api/v1/results/{explained_id}/export?format=linuxcnc");
    let link = c
        .find(Locator::Css("#reversal-table a.linuxcnc"))
        .await
        .expect("the LinuxCNC table link");
    assert!(link.is_displayed().await.unwrap(), "visible");
    assert_eq!(link.text().await.unwrap(), "LinuxCNC compensation table");
    assert_eq!(
        link.attr("href").await.unwrap().as_deref(),
        Some(export.as_str())
    );
    assert!(text(c, "#reversal-table").await.contains("backlash (X)"));
    let r = reqwest::Client::new()
        .get(format!("{base}{export}"))
        .bearer_auth(key)
        .send()
        .await
        .unwrap();
    assert_eq!(r.status().as_u16(), 200);
    let table = mtcal_formats::compensation::Format::Linuxcnc
        .read("t.txt", &r.text().await.unwrap())
        .unwrap();
    let x = table
        .axes
        .iter()
        .find(|a| a.axis.to_string() == "X")
        .unwrap();
    for b in x.reversal_mm.as_ref().expect("X's reversal column") {
        assert!((b * 1e3 - 6.0).abs() < 0.3, "X reversal {b} mm vs 6 µm");
    }
    js(
        c,
        "document.querySelector('#explained').scrollIntoView({block: 'start'});",
    )
    .await;
    shot(c, shots, "result-explained").await;
    // The machine page: the check after compensation verified, the table set linked.
    c.goto(&format!("{base}/machines/{WORN}")).await.unwrap();
    wait_for(c, "#verification", Duration::from_secs(10)).await;
    assert!(
        text(c, "#verification p")
            .await
            .contains("1 of 1 as predicted")
    );
    let lines = texts(c, "#verification li").await;
    assert_eq!(
        lines,
        [format!(
            "backlash (X): {before:.2} → {left:.2} µm after compensation (predicted 0)"
        )]
    );
    let set_from = c
        .find(Locator::Css("#verified-table a.linuxcnc"))
        .await
        .expect("the table set");
    assert_eq!(
        set_from.attr("href").await.unwrap().as_deref(),
        Some(export.as_str())
    );
    js(
        c,
        "document.querySelector('#verification').scrollIntoView({block: 'start'});",
    )
    .await;
    shot(c, shots, "machine-verified").await;
    let doc = api(base, key, &format!("/api/v1/results/{explained_id}")).await;
    doc["document"]["explained"]["diagnosis_result_id"]
        .as_str()
        .expect("the diagnosis it was explained by")
        .to_string()
}

/// Item by item, the misfit machine's latest check (partly explained: not decided) is
/// marked and never offered as a decided value; returns its result id.
async fn misfit_marks(c: &Client, base: &str, key: &str, shots: &Path) -> String {
    let latest = api(
        base,
        key,
        &format!("/api/v1/machines/{MISFIT}/results/latest"),
    )
    .await;
    assert_eq!(
        latest["document"]["explained"]["verdict"], "partly_explained",
        "the latest check's diagnosis explains it only partly"
    );
    let misfit_id = latest["meta"]["id"].as_str().unwrap().to_string();
    // The fleet: the misfit machine's drift is not a figure; the others' are.
    c.goto(&format!("{base}/")).await.unwrap();
    let row = format!(r#"#fleet tr[data-machine="{MISFIT}"]"#);
    let cells = texts(c, &format!("{row} td.num")).await;
    assert_eq!(cells.len(), 2, "{cells:?}");
    for cell in &cells {
        assert_eq!(cell, "not decided: misfit", "{cells:?}");
    }
    assert_eq!(
        text(c, &format!("{row} .badge.verdict")).await,
        "not decided: model misfit"
    );
    let decided = texts(c, r#"#fleet tr[data-machine="VMC-0001"] td.num"#).await;
    assert!(
        decided[0].contains(" ± ") && decided[0].contains("µm"),
        "{decided:?}"
    );
    // The machine page: the misfit check is marked, not offered as a baseline, and a
    // ring in the trend.
    c.goto(&format!("{base}/machines/{MISFIT}")).await.unwrap();
    wait_for(c, "#term-trend", Duration::from_secs(10)).await;
    let row = format!(r#"#checks tr[data-result="{misfit_id}"]"#);
    let row_text = text(c, &row).await;
    assert!(row_text.contains("model misfit"), "{row_text}");
    assert!(
        row_text.contains("not a baseline (model misfit)"),
        "{row_text}"
    );
    assert!(!row_text.contains("Set as baseline"), "{row_text}");
    assert!(
        c.find(Locator::Css(&format!("{row} input[name=result_id]")))
            .await
            .is_err(),
        "no baseline form on the misfit check"
    );
    let (svg, trend) = browser::shown_trend(c, base, key, MISFIT).await;
    let plot = inspect::parse(&svg).unwrap();
    assert!(plot.has_text(MISFIT_KEY), "the legend names the ring");
    let axes = plot.axes().unwrap();
    let point = trend["points"]
        .as_array()
        .unwrap()
        .iter()
        .find(|p| p["result_id"] == misfit_id.as_str())
        .expect("the misfit check in the trend");
    let colour = inspect::hex(COLORS[0]);
    let rings: Vec<_> = plot
        .marks("circle", &colour)
        .into_iter()
        .filter(|m| m.r == 5.0 && m.fill.as_deref() != Some(colour.as_str()))
        .collect();
    assert_eq!(rings.len(), 1, "one ring in the first series: {rings:?}");
    let (_, y) = axes.data(rings[0].points[0]);
    let want = point["values"][0].as_f64().unwrap();
    assert!(
        (y - want).abs() < 1.5 * axes.y.scale.recip().abs(),
        "the ring sits at the API's value: {y} vs {want}"
    );
    let bars_at_ring = plot
        .marks("line", &colour)
        .into_iter()
        .filter(|m| m.points[0].0 == m.points[1].0 && m.points[0].1 != m.points[1].1)
        .filter(|m| (m.points[0].0 - rings[0].points[0].0).abs() < 2.0)
        .count();
    assert_eq!(bars_at_ring, 0, "no ±2σ bar on the misfit check");
    assert!(text(c, "#trend .misfit-note").await.contains("not decided"));
    js(
        c,
        "document.querySelector('#trend').scrollIntoView({block: 'start'});",
    )
    .await;
    shot(c, shots, "machine-misfit").await;
    // The API refuses it as a baseline, saying why.
    let r = reqwest::Client::new()
        .patch(format!("{base}/api/v1/machines/{MISFIT}"))
        .bearer_auth(key)
        .json(&json!({"baseline_result_id": misfit_id}))
        .send()
        .await
        .unwrap();
    assert_eq!(r.status().as_u16(), 409);
    let body: Value = r.json().await.unwrap();
    let message = body["error"]["message"].as_str().unwrap();
    assert!(
        message.contains("cannot be the baseline") && message.contains("misfit"),
        "{body}"
    );
    let machine = api(base, key, &format!("/api/v1/machines/{MISFIT}")).await;
    assert_ne!(machine["baseline_result_id"], misfit_id.as_str());
    // Its result page: no compensation table it would refuse, no baseline button.
    c.goto(&format!("{base}/results/{misfit_id}"))
        .await
        .unwrap();
    wait_for(c, "#misfit", Duration::from_secs(10)).await;
    assert!(c.find(Locator::Css("a.export")).await.is_err());
    assert!(
        text(c, "#result-links")
            .await
            .contains("no compensation table")
    );
    let page = text(c, "main").await;
    assert!(!page.contains("Set as baseline"), "{page}");
    let export = reqwest::Client::new()
        .get(format!(
            "{base}/api/v1/results/{misfit_id}/export?format=csv"
        ))
        .bearer_auth(key)
        .send()
        .await
        .unwrap();
    assert_eq!(
        export.status().as_u16(),
        409,
        "the table it no longer links"
    );
    misfit_id
}

/// The worn machine's diagnosis page (diagnosis `id`, of its misfit check) and an
/// identification's squareness in words.
async fn diagnosis_in_words(c: &Client, base: &str, key: &str, id: &str, shots: &Path) {
    c.goto(&format!("{base}/results/{id}")).await.unwrap();
    wait_for(c, "#diagnosis", Duration::from_secs(10)).await;
    // The machine has a profile (tag vmc): no "no tolerance" badge.
    let h1 = text(c, "h1").await;
    assert!(!h1.contains("no tolerance"), "{h1}");
    let page = text(c, "main").await;
    // Each parameter as value ± u in one cell; no std_ row; no bare BIC.
    let cells = texts(c, ".finding table.parameters td.num").await;
    assert!(!cells.is_empty(), "{page}");
    assert!(cells.iter().all(|c| c.contains(" ± ")), "{cells:?}");
    assert!(!page.contains("std_"), "no std_ row: {page}");
    let names = texts(c, ".finding table.parameters td:first-child").await;
    assert!(names.iter().any(|n| n == "lost motion"), "{names:?}");
    assert!(!page.contains("BIC"), "BIC in words only: {page}");
    let bic = c.find(Locator::Css(".finding .bic")).await.unwrap();
    assert!(
        bic.text()
            .await
            .unwrap()
            .starts_with("the data prefer this model by odds of")
    );
    assert!(
        bic.attr("title")
            .await
            .unwrap()
            .unwrap()
            .starts_with("ΔBIC = -")
    );
    // The places of the misfit with the share they sum to, most of it.
    let share = text(c, ".mismatch-share").await;
    let sum: f64 = share
        .split("carry ")
        .nth(1)
        .and_then(|s| s.split(" %").next())
        .and_then(|s| s.parse().ok())
        .unwrap_or_else(|| panic!("{share}"));
    assert!(sum >= 80.0, "the places listed carry {sum} % of the misfit");
    // Plot titles not doubled, the 180° label whole, the time series full width.
    let titles: Vec<String> = js(
        c,
        "return [...document.querySelectorAll('main svg text')].map(t => t.textContent);",
    )
    .await
    .as_array()
    .unwrap()
    .iter()
    .map(|t| t.as_str().unwrap().trim().to_string())
    .collect();
    assert!(
        titles.iter().all(|t| !t.contains("((")),
        "{:?}",
        titles
            .iter()
            .filter(|t| t.contains("(("))
            .collect::<Vec<_>>()
    );
    // Every angle label of the polar figures, with its box and its figure's.
    let labels = js(
        c,
        "return [...document.querySelectorAll('main svg text')].filter(t => /^[0-9]+°$/.test(t.textContent.trim())).map(t => {
           const b = t.getBoundingClientRect(), s = t.ownerSVGElement.getBoundingClientRect();
           return {text: t.textContent.trim(), inside: b.width > 0 && b.left >= s.left - 0.5 && b.right <= s.right + 0.5 && b.top >= s.top - 0.5 && b.bottom <= s.bottom + 0.5}; });",
    )
    .await;
    let labels = labels.as_array().unwrap();
    assert!(
        labels.iter().any(|l| l["text"] == "180°"),
        "the 180° label is drawn: {labels:?} among {:?}",
        titles
            .iter()
            .filter(|t| t.contains('°') || t.contains("80"))
            .collect::<Vec<_>>()
    );
    assert!(
        labels.iter().all(|l| l["inside"] == true),
        "every angle label whole: {labels:?}"
    );
    let widest = js(
        c,
        "return Math.max(0, ...[...document.querySelectorAll('#diagnosis-plots figure.wide svg')].map(s => s.getBoundingClientRect().width));",
    )
    .await
    .as_f64()
    .unwrap();
    assert!(
        widest >= 800.0,
        "the time series is drawn full size: {widest} px"
    );
    shot(c, shots, "diagnosis").await;
    // An identification's squareness table in words.
    let ident = api(
        base,
        key,
        "/api/v1/machines/VMC-0001/results?kind=identification",
    )
    .await;
    let first = ident.as_array().unwrap()[0]["id"]
        .as_str()
        .unwrap()
        .to_string();
    c.goto(&format!("{base}/results/{first}")).await.unwrap();
    let sq = text(c, "#squareness").await;
    assert!(
        !sq.contains("ls_axis_lines") && !sq.contains("model_constant"),
        "{sq}"
    );
    assert!(sq.contains("measured as"), "{sq}");
}

/// Jobs name their check; a verdict row says where, with its per-length limit scaled;
/// the "also diagnose" checkbox sits with its label.
async fn rows_say_which_and_where(c: &Client, base: &str, key: &str) {
    c.goto(&format!("{base}/jobs")).await.unwrap();
    wait_for(c, "#jobs", Duration::from_secs(10)).await;
    let jobs = api(base, key, "/api/v1/jobs?limit=200").await;
    let mut checked = 0;
    for j in jobs.as_array().unwrap() {
        let (Some(id), Some(ds)) = (j["id"].as_str(), j["dataset_id"].as_str()) else {
            continue;
        };
        let dataset = api(base, key, &format!("/api/v1/datasets/{ds}")).await;
        let cell = text(c, &format!(r#"#jobs tr[data-job="{id}"] td.check"#)).await;
        let machine = j["machine_id"].as_str().unwrap();
        assert!(cell.starts_with(machine), "{cell}");
        let day = &dataset["measured_at"].as_str().unwrap()[..10];
        assert!(
            cell.contains(&format!("measured {day}"))
                && cell.contains(dataset["kind"].as_str().unwrap().replace('_', " ").as_str()),
            "{cell} vs {dataset}"
        );
        checked += 1;
    }
    assert!(checked >= 5, "{checked} jobs with a dataset");
    // The vmc profile's ranges are per 300 mm: each verdict row says over which travel
    // and how the limit was scaled to it.
    let ident = api(
        base,
        key,
        "/api/v1/machines/VMC-0001/results?kind=identification",
    )
    .await;
    let last = ident.as_array().unwrap().last().unwrap()["id"]
        .as_str()
        .unwrap()
        .to_string();
    c.goto(&format!("{base}/results/{last}")).await.unwrap();
    wait_for(c, "#verdict", Duration::from_secs(10)).await;
    let rows = texts(c, "#verdict tbody tr").await;
    let exx = rows
        .iter()
        .find(|r| r.starts_with("EXX"))
        .unwrap_or_else(|| panic!("{rows:?}"));
    assert!(exx.contains("limit 25 per 300 mm over L = "), "{exx}");
    let where_cells = texts(c, "#verdict tbody tr td:nth-child(2)").await;
    // The profile's nine per-length ranges, each scaled to the travel it was taken over.
    assert_eq!(
        where_cells
            .iter()
            .filter(|w| w.contains(" per 300 mm over L = 100 mm: ")
                && w.contains(" of [-50.00, 50.00] mm"))
            .count(),
        9,
        "{where_cells:?}"
    );
    // The checkbox and its words: on one line, side by side.
    c.goto(&format!("{base}/machines/VMC-0001")).await.unwrap();
    wait_for(c, "form.upload", Duration::from_secs(10)).await;
    let gap = js(
        c,
        "const box = document.querySelector('form.upload input[name=diagnose]');
         const label = box.closest('label');
         const r = document.createRange(); r.selectNodeContents(label);
         const words = [...r.getClientRects()].filter(q => q.left >= box.getBoundingClientRect().right - 1);
         const b = box.getBoundingClientRect(), w = words[0];
         return w ? {gap: w.left - b.right, dy: Math.abs((w.top + w.bottom) / 2 - (b.top + b.bottom) / 2)} : null;",
    )
    .await;
    let gap_px = gap["gap"].as_f64().unwrap_or(f64::NAN);
    let dy = gap["dy"].as_f64().unwrap_or(f64::NAN);
    assert!((0.0..=16.0).contains(&gap_px), "checkbox to label {gap}");
    assert!(dy <= 6.0, "checkbox and label on one line: {gap}");
}

/// Error pages keep the layout and its navigation and say what to do.
async fn error_pages(c: &Client, base: &str, misfit_id: &str, shots: &Path) {
    // A machine that does not exist.
    c.goto(&format!("{base}/machines/NO-SUCH-MACHINE"))
        .await
        .unwrap();
    wait_for(c, "#error", Duration::from_secs(10)).await;
    let nav = texts(c, "header.top nav a").await;
    assert!(
        nav.contains(&"Fleet".to_string()) && nav.contains(&"Jobs".to_string()),
        "{nav:?}"
    );
    assert!(
        c.find(Locator::Css("header.top form[action='/signout']"))
            .await
            .is_ok()
    );
    assert_eq!(text(c, "#error h1").await, "Not found");
    assert!(
        text(c, "#error")
            .await
            .contains("start again from the fleet")
    );
    // A query the page refuses (no second check to compare with): words, not a bare
    // status line.
    c.goto(&format!("{base}/compare?a=x")).await.unwrap();
    wait_for(c, "#error", Duration::from_secs(10)).await;
    let page = text(c, "main").await;
    assert_eq!(
        text(c, "#error h1").await,
        "The request was not accepted",
        "{page}"
    );
    assert!(page.contains("send the form again"), "{page}");
    assert!(c.find(Locator::Css("header.top nav")).await.is_ok());
    // The dashboard's baseline form refusing the misfit check (as the API does).
    c.goto(&format!("{base}/machines/{MISFIT}")).await.unwrap();
    wait_for(c, "#checks", Duration::from_secs(10)).await;
    js(
        c,
        &format!(
            "const f = document.createElement('form'); f.method = 'post'; f.action = '/machines/{MISFIT}/baseline';
             for (const [k, v] of [['csrf', document.querySelector('input[name=csrf]').value], ['result_id', '{misfit_id}']]) {{
               const i = document.createElement('input'); i.type = 'hidden'; i.name = k; i.value = v; f.appendChild(i); }}
             document.body.appendChild(f); f.submit(); return true;"
        ),
    )
    .await;
    wait_for(c, "#error", Duration::from_secs(10)).await;
    assert_eq!(text(c, "#error h1").await, "Not possible now");
    let page = text(c, "main").await;
    assert!(
        page.contains("cannot be the baseline") && page.contains("misfit"),
        "{page}"
    );
    assert!(c.find(Locator::Css("header.top nav")).await.is_ok());
    shot(c, shots, "error-page").await;
}
