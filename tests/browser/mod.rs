//! What the browser tests share: `mtcal demo` on a free port, headless Chromium driven
//! by chromedriver over WebDriver, the documented API as a client, and waiting for an
//! element. A test skips, with a printed reason, only when chromedriver is absent
//! (`CHROMEDRIVER` names another path than `/usr/bin/chromedriver`) and `MTCAL_CI` is
//! not set.

#![allow(dead_code)] // each test binary uses its own part of it

use fantoccini::{Client, ClientBuilder, Locator};
use serde_json::{Value, json};
use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

/// Kills a child process when dropped (by its own handle).
pub struct Guard(pub Child);

impl Drop for Guard {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

fn chromedriver() -> Option<PathBuf> {
    let p = PathBuf::from(
        std::env::var("CHROMEDRIVER").unwrap_or_else(|_| "/usr/bin/chromedriver".into()),
    );
    p.exists().then_some(p)
}

fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0")
        .and_then(|l| l.local_addr())
        .map(|a| a.port())
        .expect("a free port")
}

/// `mtcal demo` serving a small fleet on a free port: (guard, the dashboard URL it
/// prints first, base URL, API key).
pub fn start_demo(dir: &Path) -> (Guard, String, String, String) {
    let mut child = Command::new(env!("CARGO_BIN_EXE_mtcal"))
        .args(["demo", "--no-browser", "--machines", "3", "--checks", "3"])
        .args(["--listen", "127.0.0.1:0", "--db"])
        .arg(dir.join("demo.sqlite"))
        .stdout(Stdio::piped())
        // The service's log, printed when the test fails (see `log_tail`).
        .stderr(std::fs::File::create(dir.join("demo.log")).expect("demo log"))
        .spawn()
        .expect("mtcal demo starts");
    let out = BufReader::new(child.stdout.take().expect("stdout"));
    let guard = Guard(child);
    let (mut dashboard, mut key) = (String::new(), String::new());
    for line in out.lines() {
        let line = line.expect("demo output");
        if let Some(rest) = line.strip_prefix("dashboard:") {
            dashboard = rest.trim().to_string();
        }
        if let Some(rest) = line.strip_prefix("API key:") {
            key = rest.split_whitespace().next().unwrap_or("").to_string();
        }
        assert!(!line.contains("failed "), "demo job failed: {line}");
        if line.starts_with("serving") {
            break;
        }
    }
    let base = dashboard
        .split("/signin")
        .next()
        .expect("the dashboard URL is printed first")
        .to_string();
    assert!(base.starts_with("http://127.0.0.1:"), "{dashboard}");
    assert!(key.starts_with("mtk_"));
    assert_eq!(
        dashboard,
        format!("{base}/signin#key={key}"),
        "the one-click sign-in"
    );
    (guard, dashboard, base, key)
}

/// The last lines of the demo service's log (for a failure message).
pub fn log_tail(dir: &Path) -> String {
    let log = std::fs::read_to_string(dir.join("demo.log")).unwrap_or_default();
    let lines: Vec<&str> = log.lines().collect();
    format!(
        "--- service log (last 40 lines) ---\n{}",
        lines[lines.len().saturating_sub(40)..].join("\n")
    )
}

/// The API, as a client of the documented routes.
pub async fn api(base: &str, key: &str, path: &str) -> Value {
    let r = reqwest::Client::new()
        .get(format!("{base}{path}"))
        .bearer_auth(key)
        .send()
        .await
        .expect("API answers");
    assert!(r.status().is_success(), "GET {path}: {}", r.status());
    r.json().await.expect("JSON")
}

/// The EXX trend a machine page shows: its SVG, and the API's term trend of `machine` at
/// the positions the page's form names.
pub async fn shown_trend(c: &Client, base: &str, key: &str, machine: &str) -> (String, Value) {
    let at = c
        .find(Locator::Css(r#"input[name="at"]"#))
        .await
        .expect("the trend form")
        .prop("value")
        .await
        .expect("its positions")
        .unwrap_or_default();
    let trend = api(
        base,
        key,
        &format!("/api/v1/machines/{machine}/trends/term?term=EXX&at={at}"),
    )
    .await;
    let svg = c
        .find(Locator::Css("#term-trend svg"))
        .await
        .expect("the trend plot")
        .html(false)
        .await
        .expect("its SVG");
    (svg, trend)
}

/// Waits until `css` matches an element (the page script reloads pages).
pub async fn wait_for(c: &Client, css: &str, timeout: Duration) {
    let t0 = Instant::now();
    loop {
        if c.find(Locator::Css(css)).await.is_ok() {
            return;
        }
        assert!(t0.elapsed() < timeout, "{css} did not appear");
        tokio::time::sleep(Duration::from_millis(250)).await;
    }
}

/// Headless Chromium (a 1400 × 1000 window) under chromedriver, or None (the test then
/// skips) when chromedriver is absent outside CI. Keep the guard while the client runs.
pub async fn browser(profile: &Path) -> Option<(Guard, Client)> {
    let Some(driver) = chromedriver() else {
        // In CI (.ci/run installs chromium and chromium-driver, sets MTCAL_CI) it must run.
        assert!(
            std::env::var_os("MTCAL_CI").is_none(),
            "chromedriver not found under MTCAL_CI"
        );
        println!(
            "skipped: chromedriver not found at /usr/bin/chromedriver (install Debian's \
             chromium and chromium-driver, or set CHROMEDRIVER)"
        );
        return None;
    };
    let port = free_port();
    let guard = Guard(
        Command::new(driver)
            .arg(format!("--port={port}"))
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .expect("chromedriver starts"),
    );
    let caps = json!({"goog:chromeOptions": {"args": [
        "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
        "--disable-background-networking", "--disable-component-update", "--disable-sync",
        "--window-size=1400,1000", format!("--user-data-dir={}", profile.display()),
    ]}});
    let Value::Object(caps) = caps else {
        unreachable!()
    };
    let t0 = Instant::now();
    loop {
        match ClientBuilder::new(hyper_util::client::legacy::connect::HttpConnector::new())
            .capabilities(caps.clone())
            .connect(&format!("http://127.0.0.1:{port}"))
            .await
        {
            Ok(c) => return Some((guard, c)),
            Err(e) => {
                assert!(t0.elapsed() < Duration::from_secs(30), "chromedriver: {e}");
                tokio::time::sleep(Duration::from_millis(200)).await;
            }
        }
    }
}

/// Runs `test` in a task and closes the browser `c` afterwards, also when an assertion
/// in it fails (whose panic is then passed on).
pub async fn closing(c: Client, test: impl Future<Output = ()> + Send + 'static) {
    let outcome = tokio::spawn(test).await;
    let _ = c.close().await;
    if let Err(e) = outcome {
        std::panic::resume_unwind(e.into_panic());
    }
}

/// The demo a browser test runs on: the dashboard's sign-in link (the key in its
/// fragment), the service's address, the demo's admin key and the test's folder.
pub struct Demo {
    pub dashboard: String,
    pub base: String,
    pub key: String,
    pub work: PathBuf,
}

/// The start-up every browser test shares: a temporary folder, headless Chromium under
/// chromedriver, `mtcal demo`; then `test` on them, the browser closed afterwards (also
/// when it fails). Returns without running `test` when the browser test skips.
pub async fn on_demo<F, T>(test: F)
where
    F: FnOnce(Client, Demo) -> T,
    T: Future<Output = ()> + Send + 'static,
{
    let work = tempfile::tempdir().unwrap();
    let Some((_driver, c)) = browser(&work.path().join("chromium-profile")).await else {
        return;
    };
    let (_demo, dashboard, base, key) = start_demo(work.path());
    let demo = Demo {
        dashboard,
        base,
        key,
        work: work.path().to_path_buf(),
    };
    closing(c.clone(), test(c, demo)).await;
}

/// Signs in with one click on the demo's link and waits for the fleet.
pub async fn sign_in(c: &Client, dashboard: &str) {
    c.goto(dashboard).await.unwrap();
    wait_for(c, "#fleet", Duration::from_secs(10)).await;
}

/// The folder of a test's screenshots (under the target's temporary folder), made.
pub fn shots_dir(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(name);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// A screenshot `name`.png in `dir`; with `UPDATE_SCREENSHOTS` set, one whose name is in
/// `documented` (those the README shows) is written to docs/screenshots/ too.
pub async fn shot(c: &Client, dir: &Path, name: &str, documented: &[&str]) {
    let png = c.screenshot().await.expect("screenshot");
    std::fs::write(dir.join(format!("{name}.png")), &png).expect("write screenshot");
    if documented.contains(&name) && std::env::var_os("UPDATE_SCREENSHOTS").is_some() {
        let docs = Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/screenshots");
        std::fs::write(docs.join(format!("{name}.png")), &png).expect("write docs screenshot");
    }
}

/// The text of the element `css` matches, once it appears (a click that submits a form
/// returns before the next page is loaded).
pub async fn text(c: &Client, css: &str) -> String {
    wait_for(c, css, Duration::from_secs(10)).await;
    c.find(Locator::Css(css))
        .await
        .unwrap_or_else(|e| panic!("{css}: {e}"))
        .text()
        .await
        .expect("text")
}
