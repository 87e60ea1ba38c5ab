//! The check report of a three-plane check printed by a real headless Chromium
//! (`--print-to-pdf`, A4): a simulated machine with 6 µm of X backlash, its session stating
//! the test's conditions (docs/datasets.md), identified, diagnosed and reported with the
//! command line against a tolerance file. Page 1 is the decision: the verdict with the
//! items that do not pass (named as a person says them), the findings of the diagnosis and
//! the actions, read from the PDF's first page (`pdftotext` of Debian's poppler-utils);
//! the summary (everything before the appendix) prints on at most 2 A4 pages and the
//! appendix starts on a page of its own (docs/report.md). A second check without the
//! backlash and a tight limit on EXX fails, and its failing item is on page 1. Pages are
//! counted as the PDF's `/Type /Page` objects.
//!
//! With `UPDATE_SCREENSHOTS=1` it saves the report's first page as
//! `docs/screenshots/report.png` (the README's). The tests skip, with a printed reason,
//! only when Chromium or pdftotext is absent (`CHROMIUM` names another path than
//! `/usr/bin/chromium`); under `MTCAL_CI` they must run.

mod support;

use std::path::{Path, PathBuf};
use std::process::Command;

fn chromium() -> Option<PathBuf> {
    let p = PathBuf::from(std::env::var("CHROMIUM").unwrap_or_else(|_| "/usr/bin/chromium".into()));
    p.exists().then_some(p)
}

/// Chromium and pdftotext, or None after saying why (never under `MTCAL_CI`).
fn tools() -> Option<PathBuf> {
    let pdftotext = Command::new("pdftotext").arg("-v").output().is_ok();
    match chromium() {
        Some(c) if pdftotext => Some(c),
        _ => {
            assert!(
                std::env::var_os("MTCAL_CI").is_none(),
                "chromium or pdftotext not found under MTCAL_CI"
            );
            eprintln!(
                "skipped: chromium (at /usr/bin/chromium, or CHROMIUM) or pdftotext (Debian's \
                 poppler-utils) not found"
            );
            None
        }
    }
}

/// Runs mtcal with `args`, its standard output written to `out` when given.
fn mtcal(args: &[&str], out: Option<&Path>) {
    let stdout = support::mtcal_ok(args);
    if let Some(p) = out {
        std::fs::write(p, stdout).unwrap();
    }
}

/// The number of pages of a PDF: its `/Type /Page` objects (not `/Pages`).
fn pages(pdf: &[u8]) -> usize {
    let pat = b"/Type";
    let mut n = 0;
    let mut i = 0;
    while let Some(at) = pdf[i..].windows(pat.len()).position(|w| w == pat) {
        let mut j = i + at + pat.len();
        while j < pdf.len() && pdf[j].is_ascii_whitespace() {
            j += 1;
        }
        let rest = &pdf[j..];
        if rest.starts_with(b"/Page") && !rest[5..].first().is_some_and(u8::is_ascii_alphanumeric) {
            n += 1;
        }
        i = j;
    }
    n
}

/// `html` printed to PDF on A4 by headless Chromium: the PDF's path and page count.
fn print(chromium: &Path, dir: &Path, name: &str, html: &str) -> (PathBuf, usize) {
    let page = dir.join(format!("{name}.html"));
    let pdf = dir.join(format!("{name}.pdf"));
    std::fs::write(&page, html).unwrap();
    let o = Command::new(chromium)
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--no-pdf-header-footer",
        ])
        .arg(format!("--user-data-dir={}", dir.join("profile").display()))
        .arg(format!("--print-to-pdf={}", pdf.display()))
        .arg(format!("file://{}", page.display()))
        .output()
        .unwrap();
    let bytes = std::fs::read(&pdf)
        .unwrap_or_else(|e| panic!("no PDF ({e}): {}", String::from_utf8_lossy(&o.stderr)));
    (pdf, pages(&bytes))
}

/// The text of page `n` of a PDF (pdftotext), its white space collapsed to single spaces.
fn page_text(pdf: &Path, n: usize) -> String {
    let o = Command::new("pdftotext")
        .args(["-f", &n.to_string(), "-l", &n.to_string()])
        .arg(pdf)
        .arg("-")
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    String::from_utf8(o.stdout)
        .unwrap()
        .split_whitespace()
        .collect::<Vec<_>>()
        .join(" ")
}

/// The `<section … id="id" …>` of the page up to its end.
fn section<'a>(html: &'a str, id: &str) -> &'a str {
    let start = html
        .find(&format!("id=\"{id}\""))
        .unwrap_or_else(|| panic!("no section {id}"));
    &html[start..start + html[start..].find("</section>").unwrap()]
}

/// A simulated three-plane check (the seed plan at 10 Hz, seed 5) in `dir/name`, with
/// `effect` (e.g. 6 µm of X backlash) when given, identified into `dir/name.json`.
fn simulated_check(dir: &Path, name: &str, effect: Option<&str>) -> (String, PathBuf) {
    let session = dir.join(name).to_str().unwrap().to_string();
    let mut args = vec![
        "simulate",
        "--out",
        &session,
        "--plan",
        "seed",
        "--seed",
        "5",
        "--rate-hz",
        "10",
        "--machine-id",
        name,
    ];
    if let Some(e) = effect {
        args.extend(["--effect", e]);
    }
    mtcal(&args, None);
    let result = dir.join(format!("{name}.json"));
    (session, result)
}

/// The tolerance file of the checks: the X, Y and Z positioning ranges, the X–Y
/// squareness and one figure of ISO 230-2 (µm, µrad).
fn tolerances(dir: &Path, exx_um: f64) -> String {
    let p = dir.join(format!("limits-{exx_um}.json"));
    let limits = serde_json::json!({
        "terms": {"EXX": exx_um, "EYY": 40.0, "EZZ": 40.0},
        "squareness": {"EC0Y": 200.0},
        "standards": {"iso230_2.X.E_up_um": 40.0}
    });
    std::fs::write(&p, limits.to_string()).unwrap();
    p.to_str().unwrap().to_string()
}

#[test]
fn pages_of_the_sample_pdf_objects_are_counted() {
    let pdf = b"<< /Type /Pages /Kids [3 0 R 4 0 R] >> << /Type /Page /Parent 2 0 R >>\
                << /Type/Page >> << /Type /PageLabel >>";
    assert_eq!(pages(pdf), 2);
}

#[test]
fn a_three_plane_checks_report_has_its_decision_on_page_one_and_prints_its_summary_on_two_a4_pages()
{
    let Some(chromium) = tools() else { return };
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    let s = |p: PathBuf| p.to_str().unwrap().to_string();
    let (session, result) = simulated_check(dir, "BACKLASH", Some("backlash:lost_motion_um=6"));
    // The test's conditions as a plant states them (docs/datasets.md, session.json).
    let meta = dir.join("BACKLASH").join("session.json");
    let mut v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&meta).unwrap()).unwrap();
    let conditions = serde_json::json!({
        "operator": "A. Keller",
        "instrument": {"model": "KGM 282", "serial": "SN-7731", "calibration_date": "2026-03-01",
                       "certificate": "DKD 2026-117", "calibration_u_um": 0.5,
                       "calibration_u_um_per_m": 1.0, "calibration_k": 2,
                       "expansion_ppm_per_k": 8.0, "expansion_u_ppm_per_k": 0.5},
        "temperature_c": 21.3,
        "temperature_u_k": 0.2,
        "alignment_urad": 500
    });
    for (k, x) in conditions.as_object().unwrap() {
        v[k] = x.clone();
    }
    std::fs::write(&meta, v.to_string()).unwrap();
    let diagnosis = dir.join("bkd.json");
    let report = dir.join("report.html");
    mtcal(&["identify", &session, "--json"], Some(&result));
    mtcal(&["diagnose", &session, "--json"], Some(&diagnosis));
    mtcal(
        &[
            "report",
            &s(result),
            "--diagnosis",
            &s(diagnosis),
            "--tolerances",
            &tolerances(dir, 40.0),
            "--out",
            &s(report.clone()),
        ],
        None,
    );
    let html = std::fs::read_to_string(&report).unwrap();

    let article = &html[html.find("<article").unwrap()..];
    let first = &article[article.find("<section").unwrap()..];
    assert!(
        first[..first.find('>').unwrap()].contains("id=\"misfit\""),
        "the report opens with the misfit banner"
    );
    let banner = section(&html, "misfit");
    assert!(
        banner.contains("(bkd.json)") && !banner.contains(dir.to_str().unwrap()),
        "the banner names the diagnosis by its file's name: {banner}"
    );
    let facts = section(&html, "check");
    for want in [
        "KGM 282 s/n SN-7731, calibrated 2026-03-01",
        "DKD 2026-117",
        "21.3 °C",
        "A. Keller",
    ] {
        assert!(facts.contains(want), "the facts lack {want}");
    }
    let findings = section(&html, "findings");
    assert!(
        findings.contains("data-effect=\"backlash\"") && findings.contains("lost_motion_um = "),
        "{findings}"
    );
    let budget = section(&html, "budget");
    let exx = &budget[budget.find("data-item=\"EXX\"").expect("EXX's budget")..];
    let exx = &exx[..exx.find("</tr>").unwrap()];
    // The certificate over the measured X travel of 100 mm: (0.5 + 1.0 × 0.1)/2 µm.
    assert!(exx.contains(">0.300<"), "{exx}");
    assert!(!exx.contains("not included"), "{exx}");
    section(&html, "signature");

    let appendix = html
        .find("<div class=\"appendix\" id=\"appendix\">")
        .expect("the appendix");
    let end = html.rfind("</article>").unwrap();
    let summary = format!("{}{}", &html[..appendix], &html[end..]);
    let (_, summary_pages) = print(&chromium, dir, "summary", &summary);
    let (pdf, all_pages) = print(&chromium, dir, "report", &html);
    eprintln!(
        "the three-plane check's report: summary {summary_pages} A4 pages, {all_pages} in all"
    );
    assert!(
        (1..=2).contains(&summary_pages),
        "the summary prints on {summary_pages} A4 pages"
    );
    assert!(
        all_pages > summary_pages,
        "the appendix starts on a page of its own: {all_pages} pages in all"
    );
    // Page 1 is the decision: the verdict with the items not decided (the model does
    // not explain its recording), named in words, the findings and the actions.
    let one = page_text(&pdf, 1);
    for want in [
        "Verdict",
        "not decided: model misfit",
        "X axis: positioning",
        "Z axis: positioning",
        "squareness X–Y",
        "Findings of the diagnosis",
        "backlash (X)",
        "Actions",
        "backlash compensation",
    ] {
        assert!(one.contains(want), "page 1 lacks {want:?}: {one}");
    }
    // The judged figure of the standards passes: it is in the summary, named in words,
    // page 1 or 2 (page 1 lists only what does not pass).
    let summary = format!("{one}{}", page_text(&pdf, 2));
    assert!(
        summary.contains("ISO 230-2, X: E↑"),
        "the summary lacks the judged figure: {summary}"
    );
    assert!(
        !one.contains("EXX"),
        "code names belong to the appendix: {one}"
    );
    // The README's picture of a report: its first A4 page (794 × 1123 px at 96 dpi).
    if std::env::var_os("UPDATE_SCREENSHOTS").is_some() {
        let png = Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/screenshots/report.png");
        let o = Command::new(&chromium)
            .args([
                "--headless",
                "--no-sandbox",
                "--disable-gpu",
                "--hide-scrollbars",
            ])
            .arg(format!("--user-data-dir={}", dir.join("profile").display()))
            .arg("--window-size=794,1123")
            .arg(format!("--screenshot={}", png.display()))
            .arg(format!("file://{}", report.display()))
            .output()
            .unwrap();
        assert!(
            o.status.success() && png.exists(),
            "{}",
            String::from_utf8_lossy(&o.stderr)
        );
    }
}

/// A check the model explains, against a limit on EXX far below its range: it fails,
/// and the failing item is on page 1 in words, with its action.
#[test]
fn a_failing_item_is_printed_on_page_one() {
    let Some(chromium) = tools() else { return };
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    let (session, result) = simulated_check(dir, "CLEAN", None);
    mtcal(&["identify", &session, "--json"], Some(&result));
    let report = dir.join("clean.html");
    mtcal(
        &[
            "report",
            result.to_str().unwrap(),
            "--tolerances",
            &tolerances(dir, 0.01),
            "--out",
            report.to_str().unwrap(),
        ],
        None,
    );
    let html = std::fs::read_to_string(&report).unwrap();
    let (pdf, _) = print(&chromium, dir, "clean", &html);
    let one = page_text(&pdf, 1);
    let verdict = &one[one.find("Verdict").expect("the verdict on page 1")..];
    assert!(verdict.starts_with("Verdict fail"), "{verdict}");
    let items = &verdict[..verdict.find("limits pass").expect("the count of passes")];
    assert!(items.contains("X axis: positioning"), "{items}");
    assert!(
        one.contains("X axis: positioning: exceeds its limit of 0.010 µm"),
        "the action: {one}"
    );
}
