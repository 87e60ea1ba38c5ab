//! The check report of a three-plane check printed by a real headless Chromium
//! (`--print-to-pdf`, A4): a simulated machine with 6 µm of X backlash, its session stating
//! the test's conditions (docs/datasets.md), identified, diagnosed and reported with the
//! command line. The report opens with the misfit banner, holds the findings of the
//! diagnosis and the uncertainty budget with the certificate's contribution, names the
//! instrument's serial and calibration date, and its summary (everything before the
//! appendix) prints on at most 6 A4 pages; the appendix starts on a page of its own
//! (docs/report.md). Pages are counted as the PDF's `/Type /Page` objects.
//!
//! With `UPDATE_SCREENSHOTS=1` it saves the report's first page as
//! `docs/screenshots/report.png` (the README's). The test skips, with a printed reason, only when Chromium is absent (`CHROMIUM` names
//! another path than `/usr/bin/chromium`); under `MTCAL_CI` it must run.

use std::path::{Path, PathBuf};
use std::process::Command;

fn chromium() -> Option<PathBuf> {
    let p = PathBuf::from(std::env::var("CHROMIUM").unwrap_or_else(|_| "/usr/bin/chromium".into()));
    p.exists().then_some(p)
}

/// Runs mtcal with `args`, its standard output written to `out` when given.
fn mtcal(args: &[&str], out: Option<&Path>) {
    let o = Command::new(env!("CARGO_BIN_EXE_mtcal"))
        .args(args)
        .output()
        .unwrap();
    assert!(
        o.status.success(),
        "mtcal {args:?}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    if let Some(p) = out {
        std::fs::write(p, &o.stdout).unwrap();
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

/// `html` printed to PDF on A4 by headless Chromium; its page count.
fn print(chromium: &Path, dir: &Path, name: &str, html: &str) -> usize {
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
    pages(&bytes)
}

/// The `<section … id="id" …>` of the page up to its end.
fn section<'a>(html: &'a str, id: &str) -> &'a str {
    let start = html
        .find(&format!("id=\"{id}\""))
        .unwrap_or_else(|| panic!("no section {id}"));
    &html[start..start + html[start..].find("</section>").unwrap()]
}

#[test]
fn pages_of_the_sample_pdf_objects_are_counted() {
    let pdf = b"<< /Type /Pages /Kids [3 0 R 4 0 R] >> << /Type /Page /Parent 2 0 R >>\
                << /Type/Page >> << /Type /PageLabel >>";
    assert_eq!(pages(pdf), 2);
}

#[test]
fn a_three_plane_checks_report_prints_its_summary_on_six_a4_pages() {
    let Some(chromium) = chromium() else {
        assert!(
            std::env::var_os("MTCAL_CI").is_none(),
            "chromium not found under MTCAL_CI"
        );
        eprintln!(
            "skipped: chromium not found at /usr/bin/chromium (install Debian's chromium, or set CHROMIUM)"
        );
        return;
    };
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    let s = |p: PathBuf| p.to_str().unwrap().to_string();
    let session = s(dir.join("bk"));
    mtcal(
        &[
            "simulate",
            "--out",
            &session,
            "--plan",
            "seed",
            "--seed",
            "5",
            "--rate-hz",
            "10",
            "--effect",
            "backlash:lost_motion_um=6",
            "--machine-id",
            "BACKLASH",
        ],
        None,
    );
    // The test's conditions as a plant states them (docs/datasets.md, session.json).
    let meta = dir.join("bk").join("session.json");
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
    let result = dir.join("bk.json");
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
    let summary_pages = print(&chromium, dir, "summary", &summary);
    let all_pages = print(&chromium, dir, "report", &html);
    assert!(
        (1..=6).contains(&summary_pages),
        "the summary prints on {summary_pages} A4 pages"
    );
    assert!(
        all_pages > summary_pages,
        "the appendix starts on a page of its own: {all_pages} pages in all"
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
