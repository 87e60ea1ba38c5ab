//! Numbers as a person reads them (`mtcal_solver::text`, docs/report.md "Numbers"): the
//! check report of a three-plane check with a diagnosis and a tolerance file, the result
//! page of the same identification and the diagnosis's, and the text of `mtcal identify`
//! (with and without `--explain`) and `mtcal diagnose` hold no raw float (more than 6 significant digits, e.g.
//! `28.541666666666664` or `16000005`) and no negative zero (`-0.000`). Plots are
//! checked by their own tests: the `<svg>` elements are left out here, as are tags,
//! styles and code names.

mod support;

use std::path::Path;
use support::mtcal_ok as mtcal;

/// The text a person reads of an HTML page: without tags, `<style>` and `<svg>` elements
/// and `<code>` names.
fn visible_text(html: &str) -> String {
    let mut out = String::new();
    let mut rest = html;
    while let Some(lt) = rest.find('<') {
        out.push_str(&rest[..lt]);
        out.push(' ');
        let tag = &rest[lt + 1..];
        let skip_to = ["style", "svg", "code", "title"]
            .into_iter()
            .find(|t| tag.starts_with(t) && !tag[t.len()..].starts_with(char::is_alphanumeric))
            .map(|t| format!("</{t}>"));
        rest = match skip_to {
            Some(end) => &tag[tag.find(&end).map_or(tag.len(), |e| e + end.len())..],
            None => &tag[tag.find('>').map_or(tag.len(), |e| e + 1)..],
        };
    }
    out.push_str(rest);
    out
}

/// The numbers of `text` that break the rule: more than 6 significant digits, or a
/// negative zero. A number is a run of digits and at most one decimal point (with an
/// exponent `e±n`), not joined to a letter, `_` or another number by `.`, `-` or `:`
/// (names like `xy_t1.csv`, dates, times and versions are not numbers).
fn offending(text: &str) -> Vec<String> {
    let b: Vec<char> = text.chars().collect();
    let word = |c: char| c.is_alphanumeric() || c == '_';
    let mut bad = vec![];
    let mut i = 0;
    while i < b.len() {
        if !b[i].is_ascii_digit() || (i > 0 && (word(b[i - 1]) || b[i - 1] == '.')) {
            i += 1;
            continue;
        }
        let start = i;
        while i < b.len() && (b[i].is_ascii_digit() || b[i] == '.') {
            i += 1;
        }
        let mut end = i;
        if i + 1 < b.len() && b[i] == 'e' && (b[i + 1].is_ascii_digit() || b[i + 1] == '-') {
            i += 2;
            while i < b.len() && b[i].is_ascii_digit() {
                i += 1;
            }
            end = i;
        }
        let token: String = b[start..end].iter().collect();
        let joined = |c: Option<&char>| c.is_some_and(|c| word(*c) || ['-', ':'].contains(c));
        let before = if start > 0 { b.get(start - 1) } else { None };
        let dated = joined(b.get(end));
        if token.matches('.').count() > 1
            || token.ends_with('.')
            || dated
            || (before == Some(&'-') && start > 1 && b[start - 2].is_ascii_digit())
        {
            continue;
        }
        let mantissa = token.split('e').next().unwrap();
        let digits: String = mantissa.chars().filter(char::is_ascii_digit).collect();
        let significant = digits.trim_start_matches('0');
        let significant = if mantissa.contains('.') {
            significant
        } else {
            significant.trim_end_matches('0')
        };
        let negative = before.is_some_and(|c| *c == '-' || *c == '−');
        if significant.len() > 6 {
            bad.push(token);
        } else if negative && significant.is_empty() {
            bad.push(format!("-{token}"));
        }
    }
    bad
}

fn assert_clean(what: &str, text: &str) {
    let bad = offending(text);
    assert!(
        bad.is_empty(),
        "{what}: numbers past their resolution: {bad:?}"
    );
}

#[test]
fn the_rule_finds_raw_floats_and_negative_zeros() {
    assert_eq!(
        offending("at 28.541666666666664 mm; run 16000005; -0.000 µm; −0.0"),
        ["28.541666666666664", "16000005", "-0.000", "-0.0"]
    );
    assert!(
        offending(
            "0.300 µm, 1.712e7, 2026-03-01 08:30 UTC, xy_t1.csv, mtcal 0.1.0, 12345.6, \
             0.0002600 ± 0.0000042, 1000000 runs, res_9f31, -1.250, [-50.00, 50.00] mm"
        )
        .is_empty()
    );
    assert_eq!(
        visible_text("<p>a <svg><text>1.23456789</text></svg> b <code>x_1.123456789</code> 2</p>"),
        " a   b   2 "
    );
}

/// The three-plane check of 6 µm X backlash (the report's print test's), its report,
/// result and diagnosis pages and the command line's summaries.
#[test]
fn a_three_plane_check_reads_at_the_resolution_of_its_numbers() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    let p = |name: &str| dir.join(name).to_str().unwrap().to_string();
    mtcal(&[
        "simulate",
        "--out",
        &p("bk"),
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
    ]);
    let identified = mtcal(&["identify", &p("bk")]);
    assert_clean("mtcal identify", &identified);
    let explained = mtcal(&["identify", &p("bk"), "--explain"]);
    assert!(explained.contains("what to do"), "{explained}");
    assert_clean("mtcal identify --explain", &explained);
    let diagnosed = mtcal(&["diagnose", &p("bk")]);
    assert_clean("mtcal diagnose", &diagnosed);
    assert_clean("mtcal standards", &mtcal(&["standards", &p("bk")]));
    std::fs::write(p("bk.json"), mtcal(&["identify", &p("bk"), "--json"])).unwrap();
    std::fs::write(p("bkd.json"), mtcal(&["diagnose", &p("bk"), "--json"])).unwrap();
    std::fs::write(
        p("limits.json"),
        r#"{"terms": {"EXX": 40, "EYY": 40, "EZZ": 40}, "squareness": {"EC0Y": 200},
            "standards": {"iso230_2.X.E_up_um": 40}}"#,
    )
    .unwrap();
    mtcal(&[
        "report",
        &p("bk.json"),
        "--diagnosis",
        &p("bkd.json"),
        "--tolerances",
        &p("limits.json"),
        "--out",
        &p("report.html"),
    ]);
    let report = std::fs::read_to_string(p("report.html")).unwrap();
    assert_clean("the check report", &visible_text(&report));

    let read = |f: &str| -> serde_json::Value {
        serde_json::from_str(&std::fs::read_to_string(Path::new(&p(f))).unwrap()).unwrap()
    };
    use mtcal_views::pages::result::{ResultBody, ResultHeader, StoredIdentification, result_page};
    let viewer = mtcal_views::pages::Viewer {
        label: "reader".into(),
        scope: "read".into(),
        csrf: "t".into(),
    };
    let header = |kind: &str| ResultHeader {
        id: "res_1".into(),
        machine_id: "BACKLASH".into(),
        kind: kind.into(),
        measured_at: "2026-11-02T08:30:00Z".into(),
        created_at: "2026-11-02T09:00:00Z".into(),
        dataset_id: None,
        is_baseline: false,
        verdict: None,
        profile: None,
        diagnosis: None,
    };
    let stored = StoredIdentification::read(read("bk.json")).unwrap();
    let page = result_page(
        &viewer,
        &header("identification"),
        &[],
        &ResultBody::Identification(stored.view()),
    );
    assert_clean("the result page", &visible_text(&page.into_string()));
    let diagnosis: mtcal_solver::positioning_check::DiagnosisDocument =
        serde_json::from_value(read("bkd.json")).unwrap();
    let page = result_page(
        &viewer,
        &header("diagnosis"),
        &[],
        &ResultBody::Diagnosis(&diagnosis),
    );
    assert_clean("the diagnosis page", &visible_text(&page.into_string()));
}
