//! The tests of `result.rs`.

use super::*;
use crate::pages::tests::viewer;
use crate::plots::inspect;
use mtcal_solver::identification::{IdentifyOptions, identify};
use mtcal_solver::simulate::{Plan, SimOptions, random_truth, simulate};

fn header(kind: &str) -> ResultHeader {
    ResultHeader {
        id: "r1".into(),
        machine_id: "SIM-0001".into(),
        kind: kind.into(),
        measured_at: "2026-01-05T08:00:00Z".into(),
        created_at: "2026-01-05T09:00:00Z".into(),
        dataset_id: Some("d1".into()),
        is_baseline: false,
        verdict: Some("undecided".into()),
        profile: Some("machine SIM-0001".into()),
        diagnosis: None,
    }
}

/// An identification of a simulated machine (seed `seed`) measured with the seed
/// plan (one head offset: most terms confounded; circle tests in every plane).
fn seed_plan_check(seed: u64) -> IdentificationResult {
    let out = simulate(
        &random_truth(seed),
        &SimOptions {
            plan: Plan::Seed,
            seed,
            sample_rate_hz: 10.0,
            ..Default::default()
        },
    )
    .unwrap();
    identify(&out.session, &IdentifyOptions::default()).unwrap()
}

/// The `<figure …>…</figure>` of a term.
fn figure<'a>(html: &'a str, term: &str) -> &'a str {
    let start = html
        .find(&format!(r#"<figure class="plot" data-term="{term}""#))
        .unwrap_or_else(|| panic!("figure of {term}"));
    let end = html[start..].find("</figure>").unwrap() + start;
    &html[start..end]
}

/// A possible effect and a finding's undetermined parameter are both shown with
/// their value, uncertainty and what would decide them (one shape for every kind of
/// recording); the undetermined parameter is not among the finding's parameters.
#[test]
fn undetermined_parameters_and_possible_effects_are_shown() {
    use mtcal_solver::diagnosis::{Baseline, BeforeAfter, Finding, Undetermined, Verdict};
    let ba = BeforeAfter {
        before: 2.0,
        after: 0.5,
    };
    let finding = |effect: &str, undetermined: Vec<Undetermined>| Finding {
        effect: effect.into(),
        axis: Some("ch1".into()),
        depends_on: None,
        parameters: [("share_predicted".to_string(), 0.8)].into(),
        physics: "thermal growth".into(),
        signature: None,
        residual_rms_um: ba,
        heldout_rms_um: ba,
        evidence: "CV".into(),
        undetermined,
        rivals: Vec::new(),
    };
    let d = DiagnosisResult {
        kind: "diagnosis".into(),
        machine_id: "M".into(),
        source: "drift_log".into(),
        baseline: Baseline {
            residual_rms_um: 2.0,
            heldout_rms_um: 2.0,
            noise_estimate_um: 0.1,
        },
        mismatch: vec![],
        findings: vec![finding(
            "thermal_drift",
            vec![Undetermined::new(
                "t14_um_per_k",
                0.37,
                0.9,
                "a log with t14 alone",
            )],
        )],
        possible: vec![finding(
            "backlash",
            vec![Undetermined::new(
                "lost_motion_um",
                0.3,
                0.2,
                "more reversals",
            )],
        )],
        rejected: vec![],
        verdict: Verdict::PartlyExplained,
        unexplained: vec![],
        plots: vec![],
    };
    let html = diagnosis(&d).into_string();
    let card = |class: &str| {
        let start = html.find(&format!("class=\"card {class}\"")).unwrap();
        let end = html[start..].find("</section>").unwrap() + start;
        &html[start..end]
    };
    let f = card("finding");
    assert!(
        f.contains("t14_um_per_k") && f.contains("0.37") && f.contains("0.9"),
        "{f}"
    );
    assert!(f.contains("a log with t14 alone would decide it"), "{f}");
    let p = card("possible");
    assert!(p.contains("Possible, undetermined: backlash"), "{p}");
    assert!(
        p.contains("lost_motion_um") && p.contains("more reversals would decide it"),
        "{p}"
    );
}

#[test]
fn a_misfit_result_says_so_above_everything_else() {
    let mut doc = seed_plan_check(3);
    let body = ResultBody::Identification(IdentificationView::of(&doc));
    let html = result_page(&viewer("write"), &header("identification"), &[], &body).into_string();
    assert!(
        !html.contains("id=\"misfit\""),
        "a model at noise level has no banner"
    );
    // A check whose model fits offers its tables and to be the baseline.
    assert!(html.contains("/export?format=") && html.contains("Set as baseline"));
    // The issue's backlash machine: 0.976 µm against a floor of 0.149 µm.
    doc.fit.residual_rms_um = 0.976;
    doc.fit.noise_estimate_um = Some(0.149);
    doc.model_check = None;
    let body = ResultBody::Identification(IdentificationView::of(&doc));
    let mut h = header("identification");
    h.verdict = Some("misfit".into());
    let verdict = [VerdictRow {
        quantity: "EXX".into(),
        at: String::new(),
        value: 3.747,
        std: Some(0.01),
        unit: "um".into(),
        limit: 4.0,
        outcome: "misfit".into(),
    }];
    let html = result_page(&viewer("read"), &h, &verdict, &body).into_string();
    let at = html.find("id=\"misfit\"").expect("the misfit banner");
    assert!(
        at < html.find("id=\"verdict\"").unwrap() && at < html.find("id=\"fit\"").unwrap(),
        "the banner comes first, above the verdict"
    );
    assert!(html.contains("the model does not explain this recording"));
    assert!(html.contains("6.6 × the noise floor"));
    // With the diagnosis of its recording stored, the banner says what it found.
    h.diagnosis = Some(crate::pages::DiagnosisFindings {
        result_id: "res_d".into(),
        verdict: Some("explained".into()),
        findings: vec!["backlash (X): lost_motion_um = 6.00 (u = 0.01)".into()],
        more: 0,
    });
    let html = result_page(&viewer("read"), &h, &verdict, &body).into_string();
    let banner = &html[html.find("id=\"misfit\"").unwrap()..html.find("id=\"verdict\"").unwrap()];
    assert!(
        banner.contains("href=\"/results/res_d\"")
            && banner.contains("found: backlash (X): lost_motion_um = 6.00"),
        "{banner}"
    );
    assert!(
        html.contains(">not decided: model misfit<"),
        "the badge's words"
    );
    // No table it would refuse (a 409 from the export), no baseline the API refuses.
    let html = result_page(&viewer("write"), &h, &verdict, &body).into_string();
    assert!(
        !html.contains("/export?format="),
        "no compensation table link"
    );
    assert!(html.contains("no compensation table: its model does not explain"));
    assert!(!html.contains("Set as baseline") && !html.contains("/baseline\""));
    assert!(html.contains("/report\""), "the check report stays");
}

#[test]
fn identification_page_draws_identified_terms_and_only_labels_the_others() {
    let doc = seed_plan_check(3);
    let verdict = [VerdictRow {
        quantity: "EXX".into(),
        at: "max over the travel".into(),
        value: 2.0,
        std: Some(0.1),
        limit: 2.1,
        unit: "um".into(),
        outcome: "undecided".into(),
    }];
    let body = ResultBody::Identification(IdentificationView::of(&doc));
    let html =
        result_page(&viewer("write"), &header("identification"), &verdict, &body).into_string();
    assert!(html.contains("Set as baseline"));
    assert!(html.contains("2.000 ± 0.200 µm") && html.contains("2.100 µm"));
    // The result links to its check report and its compensation tables.
    let id = crate::pages::encode(&header("identification").id);
    assert!(
        html.contains(&format!(r#"href="/api/v1/results/{id}/report""#)),
        "{html}"
    );
    for f in ["isg", "etalon", "heidenhain", "csv", "linuxcnc"] {
        assert!(
            html.contains(&format!(r#"href="/api/v1/results/{id}/export?format={f}""#)),
            "{f}"
        );
    }
    for name in TERM_ORDER {
        let t = &doc.terms[name];
        let fig = figure(&html, name);
        assert!(fig.contains(&format!(r#"data-identifiable="{}""#, t.identifiable)));
        if t.identifiable {
            // The curve passes through the reported values (read back via the axes).
            let plot = inspect::parse(fig).unwrap();
            let axes = plot.axes().unwrap();
            let line = &plot.marks("polyline", &inspect::hex(plots::COLORS[0]))[0];
            assert_eq!(line.points.len(), t.values.len(), "{name}");
            for (p, v) in line.points.iter().zip(&t.values) {
                let tol = 1.5 / axes.y.scale.abs();
                assert!((axes.y.value(p.1) - v).abs() <= tol, "{name}");
            }
        } else {
            assert!(fig.contains("not identifiable"), "{name}");
            assert!(
                !fig.contains("<polyline") && !fig.contains("<polygon"),
                "{name}"
            );
        }
    }
    assert!(doc.terms.values().any(|t| t.identifiable));
    assert!(doc.terms.values().any(|t| !t.identifiable));
    assert!(html.contains("Advice"), "the seed plan gets advice");
}

/// The `<section …>…</section>` whose id is `id`.
fn section<'a>(html: &'a str, id: &str) -> &'a str {
    let start = html
        .find(&format!(r#"id="{id}""#))
        .unwrap_or_else(|| panic!("section {id}"));
    let end = html[start..].find("</section>").unwrap() + start;
    &html[start..end]
}

/// An identification document as the service stores it (its JSON, read back as the
/// result page reads it) draws its circle tests: one polar plot per file, plane and
/// radius, with the measured and the model's traces. A stored shape this version
/// does not read leaves a note where they would be, and the rest of the page.
#[test]
fn a_stored_identification_draws_its_circle_tests() {
    let doc = seed_plan_check(5);
    assert!(!doc.circles.is_empty(), "the plan has circle tests");
    let stored = serde_json::to_value(&doc).unwrap();
    let read = StoredIdentification::read(stored.clone()).unwrap();
    assert_eq!(read.circles_error, None);
    assert_eq!(read.doc.circles.len(), doc.circles.len());
    let page = |read: &StoredIdentification| {
        let body = ResultBody::Identification(read.view());
        result_page(&viewer("read"), &header("identification"), &[], &body).into_string()
    };
    let html = page(&read);
    let circles = section(&html, "circles");
    let mut groups: Vec<(&str, String, u64)> = doc
        .circles
        .iter()
        .map(|c| (c.file.as_str(), c.plane.to_string(), c.radius_mm.to_bits()))
        .collect();
    groups.sort();
    groups.dedup();
    assert_eq!(circles.matches("<svg").count(), groups.len(), "{circles}");
    for c in &doc.circles {
        assert!(circles.contains(&format!("measured {}", c.direction)));
        assert!(circles.contains(&format!("model {}", c.direction)));
    }
    // Each plot with its plane's ISO 230-4 figures, all on one radial scale.
    assert!(!doc.standards.iso230_4.is_empty());
    for f in &doc.standards.iso230_4 {
        let at = circles
            .find(&format!("data-file=\"{}\"", f.file))
            .unwrap_or_else(|| panic!("no plot of {}", f.file));
        let fig = &circles[at..at + circles[at..].find("</figure>").unwrap()];
        let caption = &fig[fig.find("<figcaption>").unwrap()..];
        for d in &f.directions {
            let g = format!("G({}) {} µm", d.direction, num(d.g_um));
            assert!(caption.contains(&g), "{g}: {caption}");
        }
        if let Some(b) = &f.bidirectional {
            assert!(
                caption.contains(&format!("H {} µm", num(b.h_um))),
                "{caption}"
            );
        }
    }
    let step = plots::circle_step(&read.view().circles.unwrap());
    let rings = format!("+{} µm", plots::tick_label(2.0 * step));
    assert_eq!(circles.matches(&rings).count(), groups.len(), "{rings}");
    // A shape this version does not read: a note, and the rest of the page.
    let mut changed = stored;
    changed["circles"][0]["angle_deg"] = serde_json::json!("every degree");
    let read = StoredIdentification::read(changed).unwrap();
    assert!(read.circles_error.is_some());
    let html = page(&read);
    let circles = section(&html, "circles");
    assert!(
        circles.contains("circles-error") && circles.contains("could not be read"),
        "{circles}"
    );
    assert!(!circles.contains("<svg"));
    assert_eq!(section(&html, "terms").matches("<svg").count(), 18);
    // A document without circle tests (an older one) has no such section.
    let mut older = serde_json::to_value(&doc).unwrap();
    older.as_object_mut().unwrap().remove("circles");
    let html = page(&StoredIdentification::read(older).unwrap());
    assert!(!html.contains(r#"id="circles""#));
}

#[test]
fn circle_tests_are_grouped_by_file_with_both_directions() {
    let c = |dir: &str| CirclePlot {
        file: "xy.csv".into(),
        run: 1,
        plane: mtcal_solver::Plane::XY,
        direction: dir.into(),
        radius_mm: 50.0,
        centre_mm: [0.0, 0.0],
        feed_mm_min: 500.0,
        start_angle_deg: 0.0,
        angle_deg: vec![0.0, 90.0, 180.0, 270.0],
        measured_um: vec![1.0, -1.0, 1.0, -1.0],
        model_um: vec![0.9, -0.9, 0.9, -0.9],
    };
    let html = circles(&[c("ccw"), c("cw")], &[]).into_string();
    assert_eq!(
        html.matches("<svg").count(),
        1,
        "one polar plot for both directions"
    );
    assert!(html.contains("measured ccw") && html.contains("model cw"));
}

#[test]
fn cradle_and_sensitivity_sections_render() {
    use mtcal_solver::cradle::{CradleOptions, check_cradle, simulate::CradleSimulation};
    let points =
        mtcal_solver::cradle::simulate::simulate_cradle(&CradleSimulation::example(true, 1));
    let c = check_cradle(&points, &CradleOptions::default()).unwrap();
    let html = cradle(&c).into_string();
    assert!(html.contains("Rotation vector per A pose"));
    let plot = inspect::parse(&html).unwrap();
    let bars = plot
        .marks("line", &inspect::hex(plots::COLORS[0]))
        .into_iter()
        .filter(|m| m.points[0].0 == m.points[1].0 && m.points[0].1 != m.points[1].1)
        .count();
    assert_eq!(bars, c.poses.len(), "one ±2σ bar per A pose");
    // The chosen model's compliance against A (one plot per curve) and what the ball
    // data can separate.
    assert_eq!(
        c.kinematics.curves.len(),
        html.matches("data-term=").count()
    );
    assert!(!c.kinematics.curves.is_empty());
    assert!(
        html.contains("Compliance against A") && html.contains("What the ball data can separate")
    );
    for p in &c.kinematics.parameters {
        assert!(html.contains(&format!("<td>{}</td>", p.name)), "{}", p.name);
    }

    let req: mtcal_solver::sensitivity::SensitivityRequest =
        serde_json::from_str(r#"{"machine": {"template": "vmc3"}}"#).unwrap();
    let s = mtcal_solver::sensitivity::analyse(&req).unwrap();
    let html = sensitivity(&s).into_string();
    assert_eq!(html.matches("<svg").count(), s.components.len());
    assert!(html.contains("key errors:"));
}

/// The verdict table's "where": the travel a range was taken over, where its max and
/// min lie, and how a per-length limit was scaled to the measured length; empty only
/// where nothing is positional.
#[test]
fn the_where_of_a_scaled_per_length_limit() {
    let item = |extra: serde_json::Value| -> VerdictItem {
        let mut v = serde_json::json!({
            "item": "EXX", "group": "term", "limit": 10.0 / 3.0, "unit": "um",
            "decision": "pass", "measure": "range", "value": 3.0, "u": 0.1,
            "expanded_u": 0.2, "reason": "range + U = 3 + 0.2 <= 3.333 um",
        });
        v.as_object_mut()
            .unwrap()
            .extend(extra.as_object().unwrap().clone());
        serde_json::from_value(v).unwrap()
    };
    let scaled = item(serde_json::json!({
        "at_mm": [80.0, 12.5], "travel_mm": [0.0, 100.0],
        "limit_basis": "10 per 300 mm over L = 100 mm: 10 × 100/300 = 3.333",
    }));
    let at = item_at(&scaled);
    assert!(
        at.contains("max at 80") && at.contains("min at 12.5"),
        "{at}"
    );
    assert!(at.contains("[0") && at.contains("100"), "{at}");
    assert!(
        at.contains("limit 10 per 300 mm over L = 100 mm: 10 × 100/300 = 3.333"),
        "{at}"
    );
    let plain = item(serde_json::json!({"group": "squareness", "measure": "magnitude"}));
    assert_eq!(item_at(&plain), "");
    let v: Verdict = serde_json::from_value(serde_json::json!({
        "decision": "pass", "k": 2.0, "rule": "", "items": [scaled], "not_evaluated": [],
    }))
    .unwrap();
    let html = verdict_table(&verdict_rows(&v)).into_string();
    assert!(html.contains("10 × 100/300 = 3.333"), "{html}");
}

/// A diagnosis finding in words: each parameter as value ± u in one cell (no `std_*`
/// row), named in words with its unit; the BIC said as what it means, the number on
/// hover only.
#[test]
fn a_finding_reads_in_words() {
    use mtcal_solver::diagnosis::{BeforeAfter, Finding, Verdict};
    let ba = BeforeAfter {
        before: 0.98,
        after: 0.15,
    };
    let f = Finding {
        effect: "backlash".into(),
        axis: Some("X".into()),
        depends_on: None,
        parameters: [
            ("lost_motion_um".to_string(), 6.0043),
            ("std_lost_motion_um".to_string(), 0.0041),
        ]
        .into(),
        physics: "lost motion at reversal".into(),
        signature: None,
        residual_rms_um: ba,
        heldout_rms_um: ba,
        evidence: "backlash X: BIC -129095.9 with 1 extra parameter(s); held-out RMS 0.980 -> \
                   0.150 um over 5 folds of whole runs; noise floor 0.149 um"
            .into(),
        undetermined: vec![],
        rivals: Vec::new(),
    };
    let d = session_diagnosis(vec![], vec![f], Verdict::Explained);
    let html = diagnosis(&d).into_string();
    let table = &html[html.find("class=\"parameters\"").unwrap()..];
    let table = &table[..table.find("</table>").unwrap()];
    assert!(
        table.contains(r#"<td title="lost_motion_um">lost motion</td>"#),
        "{table}"
    );
    assert!(table.contains(">6.0043 ± 0.0041 µm<"), "{table}");
    assert!(!table.contains("std_"), "no row of its own for u: {table}");
    assert!(!html.contains(">BIC"), "no bare BIC: {html}");
    let ev = &html[html.find("class=\"muted evidence\"").unwrap()..];
    let ev = &ev[..ev.find("</p>").unwrap()];
    assert!(
        ev.contains("the data prefer this model by odds of more than a million to one (very strong evidence)"),
        "{ev}"
    );
    assert!(ev.contains(r#"title="ΔBIC = -129095.9"#), "{ev}");
    assert!(ev.contains("0.980 → 0.150 µm"), "{ev}");
    // The scale, by hand: ΔBIC −4 is odds e² ≈ 7 to one, positive evidence.
    assert_eq!(
        preference_in_words(-4.0),
        "the data prefer this model by odds of about 7 to one (positive evidence)"
    );
    assert_eq!(
        preference_in_words(3.0),
        "the data do not prefer this model"
    );
}

/// A result without a verdict on a machine with a profile says that none of the
/// profile's limits applies, not "no tolerance"; without a profile it says that.
#[test]
fn no_tolerance_badge_where_a_profile_applies() {
    let doc = seed_plan_check(3);
    let d = session_diagnosis(vec![], vec![], mtcal_solver::diagnosis::Verdict::Consistent);
    let dd = DiagnosisDocument::from(d);
    let mut h = header("diagnosis");
    h.verdict = None;
    let html = result_page(&viewer("read"), &h, &[], &ResultBody::Diagnosis(&dd)).into_string();
    let h1 = &html[html.find("<h1>").unwrap()..html.find("</h1>").unwrap()];
    assert!(
        h1.contains("no limit applies") && !h1.contains("no tolerance"),
        "{h1}"
    );
    h.profile = None;
    let body = ResultBody::Identification(IdentificationView::of(&doc));
    let html = result_page(&viewer("read"), &h, &[], &body).into_string();
    let h1 = &html[html.find("<h1>").unwrap()..html.find("</h1>").unwrap()];
    assert!(h1.contains("no tolerance"), "{h1}");
}

/// "Where they differ" says what share of the misfit the places listed carry together.
#[test]
fn the_places_of_the_misfit_say_what_they_sum_to() {
    use mtcal_solver::diagnosis::{Mismatch, Verdict};
    let place = |w: &str, share: f64| Mismatch {
        where_: w.into(),
        tests: vec!["xy.csv#run 1".into()],
        share_of_misfit: share,
    };
    let d = session_diagnosis(
        vec![
            place("xy.csv: clockwise circle runs", 0.32),
            place("xy.csv: circle runs, angle 165..195 deg (X reverses)", 0.2),
            place("xz.csv: X line runs", 0.31),
            place("yz.csv: Y line runs", 0.28),
        ],
        vec![],
        Verdict::PartlyExplained,
    );
    let html = diagnosis(&d).into_string();
    assert_eq!(html.matches("<tr class=\"part\">").count(), 3, "{html}");
    assert!(
        html.contains("listed (they do not overlap) carry 91 % of the misfit together"),
        "{html}"
    );
}

/// The squareness table says how each value was measured in words, not by its code.
#[test]
fn squareness_reads_in_words() {
    // The full plan (line passes of every axis): squareness is identified.
    let out = simulate(
        &random_truth(5),
        &SimOptions {
            plan: Plan::Full,
            seed: 5,
            sample_rate_hz: 5.0,
            ..Default::default()
        },
    )
    .unwrap();
    let doc = identify(&out.session, &IdentifyOptions::default()).unwrap();
    let body = ResultBody::Identification(IdentificationView::of(&doc));
    let html = result_page(&viewer("read"), &header("identification"), &[], &body).into_string();
    let sq = section(&html, "squareness");
    assert!(
        !sq.contains(">ls_axis_lines<") && !sq.contains(">model_constant<"),
        "{sq}"
    );
    assert!(doc.squareness.values().any(|s| s.reported_as.is_some()));
    assert!(
        sq.contains("least-squares lines of the two axes") || sq.contains("the model's constant"),
        "{sq}"
    );
}

/// A session's diagnosis of a misfit (0.98 µm against a floor of 0.149 µm) with these
/// places, findings and verdict.
fn session_diagnosis(
    mismatch: Vec<mtcal_solver::diagnosis::Mismatch>,
    findings: Vec<mtcal_solver::diagnosis::Finding>,
    verdict: mtcal_solver::diagnosis::Verdict,
) -> DiagnosisResult {
    DiagnosisResult {
        kind: "diagnosis".into(),
        machine_id: "M".into(),
        source: "session".into(),
        baseline: mtcal_solver::diagnosis::Baseline {
            residual_rms_um: 0.98,
            heldout_rms_um: 0.98,
            noise_estimate_um: 0.149,
        },
        mismatch,
        findings,
        possible: vec![],
        rejected: vec![],
        verdict,
        unexplained: vec![],
        plots: vec![],
    }
}
