//! The tests of `report.rs`.

use super::*;
use mtcal_solver::diagnosis::{Baseline, BeforeAfter, Finding, Verdict};
use mtcal_solver::identification::{IdentifyOptions, identify};
use mtcal_solver::simulate::{Plan, SimOptions, random_truth, simulate};

/// The seed plan (rank 34 of 51: some terms not identifiable) at 10 Hz.
fn simulated_check() -> IdentificationResult {
    let out = simulate(
        &random_truth(7),
        &SimOptions {
            plan: Plan::Seed,
            seed: 7,
            sample_rate_hz: 10.0,
            ..Default::default()
        },
    )
    .unwrap();
    identify(&out.session, &IdentifyOptions::default()).unwrap()
}

fn finding() -> DiagnosisResult {
    DiagnosisResult {
        kind: "diagnosis".into(),
        machine_id: "SIM-0007".into(),
        source: "session".into(),
        baseline: Baseline {
            residual_rms_um: 1.2,
            heldout_rms_um: 1.3,
            noise_estimate_um: 0.15,
        },
        mismatch: vec![],
        findings: vec![Finding {
            effect: "backlash".into(),
            axis: Some("X".into()),
            depends_on: None,
            parameters: [("backlash_um".to_string(), 4.0)].into(),
            physics: "lost motion at reversal".into(),
            signature: None,
            residual_rms_um: BeforeAfter {
                before: 1.2,
                after: 0.2,
            },
            heldout_rms_um: BeforeAfter {
                before: 1.3,
                after: 0.2,
            },
            evidence: "BIC".into(),
            undetermined: vec![],
            rivals: Vec::new(),
        }],
        possible: vec![],
        rejected: vec![],
        verdict: Verdict::Explained,
        unexplained: vec![],
        plots: vec![],
    }
}

/// The `<section …id="…"…>` of the page, or a panic naming it.
fn section<'a>(html: &'a str, id: &str) -> &'a str {
    let start = html
        .find(&format!("id=\"{id}\""))
        .unwrap_or_else(|| panic!("no section {id}"));
    let end = html[start..]
        .find("</section>")
        .map_or(html.len(), |e| start + e);
    &html[start..end]
}

/// Every section is there, the page is self-contained and printable on A4, and what
/// is not determined is said.
#[test]
fn report_of_a_simulated_check_holds_every_section() {
    let doc = simulated_check();
    let html = check_report(&CheckReport {
        doc: &doc,
        result_id: Some("r-42"),
        generated_at: "2026-11-25T09:00:00Z",
        verdict: None,
        diagnosis: None,
    })
    .into_string();
    // Self-contained: no external stylesheet, script, image or font.
    for bad in [
        "<link",
        "<script",
        "src=\"http",
        "href=\"http",
        "url(http",
        "@import",
    ] {
        assert!(!html.contains(bad), "external asset: {bad}");
    }
    assert!(html.contains("@page { size: A4"), "A4 print rule");
    let facts = section(&html, "check");
    for want in [
        doc.machine_id.as_str(),
        "r-42",
        INSTRUMENT,
        "plan",
        "measured travel",
    ] {
        assert!(facts.contains(want), "facts lack {want}");
    }
    assert!(facts.contains(&when(&doc.measured_at)));
    // Standards: every scalar figure has a row in the appendix, named in words and by
    // its code, with "no tolerance"; the summary counts them per group.
    let all = section(&html, "figures");
    let figures = doc.standards.scalar_figures();
    assert!(!figures.is_empty());
    for f in &figures {
        assert!(
            all.contains(&format!("data-figure=\"{}\"", f.name))
                && all.contains(&format!("<code>{}</code>", f.name)),
            "{}",
            f.name
        );
    }
    assert_eq!(all.matches("no tolerance</span>").count(), figures.len());
    assert!(all.contains("ISO 230-4, XY, clockwise: mean radial deviation"));
    let st = section(&html, "standards");
    assert!(
        !st.contains("data-figure="),
        "no unjudged row in the summary"
    );
    let counted: usize = st
        .split("<span class=\"count\"")
        .skip(1)
        .map(|c| {
            let text = &c[c.find('>').unwrap() + 1..c.find("</span>").unwrap()];
            text.rsplit(": ").next().unwrap().parse::<usize>().unwrap()
        })
        .sum();
    assert_eq!(counted, figures.len(), "{st}");
    assert!(st.contains("ISO 230-4, XY: "), "{st}");
    assert!(section(&html, "decision").contains("No tolerance profile applies"));
    let appendix = html.find("id=\"appendix\"").unwrap();
    assert!(
        html.find("id=\"budget\"").unwrap() > appendix,
        "unjudged budget rows in the appendix"
    );
    // The 18 functions drawn or labelled, squareness, identifiability, circles.
    let terms = section(&html, "terms");
    assert_eq!(terms.matches("<svg").count(), 18);
    assert!(terms.contains("data-identifiable=\"false\""));
    assert!(terms.contains("2σ"));
    for id in ["fit", "squareness", "identifiability"] {
        section(&html, id);
    }
    let circles = section(&html, "circles");
    assert!(
        circles.matches("<svg").count() >= 1,
        "polar plots of the circles"
    );
    assert!(section(&html, "findings").contains("No diagnosis was run"));
    // Compensation: a row per exported term, and the terms left out named.
    let comp = section(&html, "compensation");
    let c = Compensation::from_result(&doc, DEFAULT_STEP_MM, false).unwrap();
    for a in &c.axes {
        for col in &a.columns {
            assert!(
                comp.contains(&format!("data-term=\"{}\"", col.term)),
                "{}",
                col.term
            );
        }
    }
    assert!(!c.not_identifiable.is_empty());
    for n in &doc.observability.not_identifiable {
        assert!(comp.contains(n.as_str()), "{n} not said to be left out");
        assert!(section(&html, "undetermined").contains(n.as_str()), "{n}");
    }
    // No verdict table without a tolerance profile.
    assert!(!html.contains("id=\"verdict\""));
}

/// With a tolerance profile's decisions the figures carry their verdicts and the
/// verdict table appears; a diagnosis's findings are shown.
#[test]
fn verdicts_and_findings_are_shown_when_given() {
    let doc = simulated_check();
    let figures = mtcal_solver::tolerance::identification_figures(&doc);
    // A figure of the standards that line passes give (not one depending on the
    // passes' zeros, which is undetermined).
    let figure = doc
        .standards
        .scalar_figures()
        .into_iter()
        .find(|f| figures.figures.contains_key(&f.name))
        .unwrap();
    let limits = mtcal_solver::tolerance::Limits {
        standards: [(figure.name.clone(), figure.value.abs() + 100.0)].into(),
        ..Default::default()
    };
    let how = mtcal_solver::tolerance::Assessment::of_identification(&doc, Default::default());
    let verdict = mtcal_solver::tolerance::evaluate(&limits, &figures, &how);
    let diag = ReportDiagnosis {
        id: "diagnosis.json".into(),
        stored: false,
        doc: Ok(finding()),
    };
    let html = check_report(&CheckReport {
        doc: &doc,
        result_id: None,
        generated_at: "2026-11-25T09:00:00Z",
        verdict: Some(&verdict),
        diagnosis: Some(&diag),
    })
    .into_string();
    let st = section(&html, "standards");
    let row_start = st
        .find(&format!("data-figure=\"{}\"", figure.name))
        .unwrap();
    let row = &st[row_start..row_start + st[row_start..].find("</tr>").unwrap()];
    assert!(row.contains("badge verdict pass"), "{row}");
    assert!(!st.contains("No tolerance profile applies"));
    section(&html, "verdict");
    assert!(html.contains("Finding: backlash (X)"));
    assert!(section(&html, "check").contains("badge verdict pass"));
    // Page 1: the decision, then the findings and the actions, before the figures.
    let d = section(&html, "decision");
    assert!(
        d.contains("badge verdict pass") && d.contains("1 of 1 limits pass"),
        "{d}"
    );
    assert!(
        row.contains(&mtcal_solver::names::in_words(&figure.name)),
        "{row}"
    );
    let at = |id: &str| html.find(&format!("id=\"{id}\"")).unwrap();
    assert!(at("check") < at("decision") && at("decision") < at("findings"));
    assert!(at("findings") < at("actions") && at("actions") < at("standards"));
    let actions = section(&html, "actions");
    assert!(
        actions.contains("backlash (X)") && actions.contains("backlash compensation"),
        "{actions}"
    );
    // A failing item is listed on the decision, in words, with its action.
    let tight = mtcal_solver::tolerance::Limits {
        terms: [(
            "EXX".to_string(),
            mtcal_solver::tolerance::TermLimit::range(1e-6),
        )]
        .into(),
        ..Default::default()
    };
    let verdict = mtcal_solver::tolerance::evaluate(&tight, &figures, &how);
    assert_eq!(
        verdict.items[0].decision,
        mtcal_solver::tolerance::Decision::Fail
    );
    let html = check_report(&CheckReport {
        doc: &doc,
        result_id: None,
        generated_at: "2026-11-25T09:00:00Z",
        verdict: Some(&verdict),
        diagnosis: None,
    })
    .into_string();
    let d = section(&html, "decision");
    assert!(
        d.contains("data-item=\"EXX\"")
            && d.contains("X axis: positioning")
            && d.contains("0 of 1 limits pass"),
        "{d}"
    );
    assert!(section(&html, "actions").contains("X axis: positioning"));
}

/// The `<tr data-item="…">` row of the budget table.
fn budget_row<'a>(html: &'a str, item: &str) -> &'a str {
    let b = section(html, "budget");
    let start = b
        .find(&format!("data-item=\"{item}\""))
        .unwrap_or_else(|| panic!("no budget row {item}"));
    &b[start..start + b[start..].find("</tr>").unwrap()]
}

/// The backlash machine's figures (a residual of 0.976 µm against a noise floor of
/// 0.149 µm): the report opens with the misfit banner, which states the residual,
/// the floor and the gate's factor and sends the reader to the findings of the
/// diagnosis, named by its id; the findings are in the summary, the whole diagnosis
/// in the appendix.
#[test]
fn a_misfit_report_opens_with_the_banner_and_its_diagnosis() {
    let mut doc = simulated_check();
    doc.fit.residual_rms_um = 0.976;
    doc.fit.noise_estimate_um = Some(0.149);
    doc.model_check = None;
    let diag = ReportDiagnosis {
        id: "res_diag7".into(),
        stored: true,
        doc: Ok(finding()),
    };
    let html = check_report(&CheckReport {
        doc: &doc,
        result_id: Some("r-42"),
        generated_at: "2026-11-25T09:00:00Z",
        verdict: None,
        diagnosis: Some(&diag),
    })
    .into_string();
    let article = &html[html.find("<article").unwrap()..];
    let first = &article[article.find("<section").unwrap()..];
    assert!(
        first[..first.find('>').unwrap()].contains("id=\"misfit\""),
        "the first section is the banner: {}",
        &first[..200]
    );
    let banner = section(&html, "misfit");
    for want in [
        "the model does not explain this recording",
        "0.976 µm",
        "6.6 ×",
        "0.149 µm",
        "1.2 ×",
        "res_diag7",
        "href=\"#findings\"",
    ] {
        assert!(banner.contains(want), "the banner lacks {want}: {banner}");
    }
    let f = section(&html, "findings");
    assert!(
        f.contains("data-effect=\"backlash\"") && f.contains("backlash_um = 4.000"),
        "{f}"
    );
    assert!(f.contains("href=\"/results/res_diag7\""), "{f}");
    let appendix = html.find("id=\"appendix\"").unwrap();
    assert!(html.find("id=\"findings\"").unwrap() < appendix);
    assert!(html.find("Finding: backlash (X)").unwrap() > appendix);
    // The same check at noise level has no banner.
    let clean = simulated_check();
    let html = check_report(&CheckReport {
        doc: &clean,
        result_id: None,
        generated_at: "2026-11-25T09:00:00Z",
        verdict: None,
        diagnosis: None,
    })
    .into_string();
    assert!(!clean.model_check().is_misfit());
    assert!(!html.contains("id=\"misfit\""));
}

/// A stored diagnosis whose document does not read is said to be unreadable, with its
/// id, in the findings and in the misfit banner: never "No diagnosis was run".
#[test]
fn an_unreadable_diagnosis_is_said_with_its_id() {
    let mut doc = simulated_check();
    doc.fit.residual_rms_um = 0.976;
    doc.fit.noise_estimate_um = Some(0.149);
    doc.model_check = None;
    let diag = ReportDiagnosis {
        id: "res_bad3".into(),
        stored: true,
        doc: Err("its document does not read: missing field `baseline`".into()),
    };
    let html = check_report(&CheckReport {
        doc: &doc,
        result_id: None,
        generated_at: "2026-11-25T09:00:00Z",
        verdict: None,
        diagnosis: Some(&diag),
    })
    .into_string();
    assert!(!html.contains("No diagnosis was run"));
    let f = section(&html, "findings");
    assert!(
        f.contains("could not be read") && f.contains("res_bad3") && f.contains("`baseline`"),
        "{f}"
    );
    let banner = section(&html, "misfit");
    assert!(
        banner.contains("res_bad3") && banner.contains("could not be read"),
        "{banner}"
    );
    assert!(!html.contains("id=\"diagnosis-detail\""));
}

/// An explained model of the backlash found (4 µm on X, fitted jointly with the 21
/// terms), as the service stores it.
fn explained_model(
    verdict: Verdict,
    remains: Vec<String>,
) -> mtcal_solver::explained::ExplainedModel {
    use mtcal_solver::explained::{ExplainedModel, Physics, RigidFigures};
    ExplainedModel {
        verdict,
        physics: vec![Physics {
            effect: "backlash".into(),
            axis: Some("X".into()),
            depends_on: None,
            parameters: [
                ("backlash_um".to_string(), 4.02),
                ("std_backlash_um".to_string(), 0.03),
            ]
            .into(),
            held: Default::default(),
            predicted_rms_um: BeforeAfter {
                before: 0.976,
                after: 0.15,
            },
        }],
        residual_rms_um: 0.15,
        heldout_rms_um: 0.16,
        noise_floor_um: 0.149,
        rigid: RigidFigures {
            residual_rms_um: 0.976,
            heldout_rms_um: 1.0,
        },
        adds: "backlash (X)".into(),
        remains,
        predicted_residual_rms_um: 0.15,
        actions: vec![],
        original_result_id: Some("res_orig1".into()),
        diagnosis_result_id: Some("res_diag7".into()),
    }
}

/// A document that carries its explained model reports its findings without a
/// diagnosis given: decided on the explained model with the physics and its u, or
/// partly explained with what remains (and the banner sends to the findings); never
/// "No diagnosis was run".
#[test]
fn an_explained_model_reports_its_physics_without_a_diagnosis() {
    let mut doc = simulated_check();
    doc.explained = Some(explained_model(Verdict::Explained, vec![]));
    doc.model_check = Some(mtcal_solver::misfit::ModelCheck::explained(
        0.15,
        Some(0.149),
        "backlash (X)",
        true,
        &[],
    ));
    let report = |doc: &IdentificationResult| {
        check_report(&CheckReport {
            doc,
            result_id: None,
            generated_at: "2026-11-25T09:00:00Z",
            verdict: None,
            diagnosis: None,
        })
        .into_string()
    };
    let html = report(&doc);
    assert!(!html.contains("No diagnosis was run"), "{html}");
    assert!(!html.contains("id=\"misfit\""));
    let f = section(&html, "findings");
    for want in [
        "data-decided=\"true\"",
        "decided on the explained model",
        "backlash (X)",
        "data-effect=\"backlash\"",
        "backlash_um = 4.020 (u = 0.030)",
        "res_diag7",
    ] {
        assert!(f.contains(want), "the findings lack {want}: {f}");
    }
    // Partly explained: not decided, what remains said, the banner to the findings.
    let remains = vec!["a cyclic error on Y, period 5 mm".to_string()];
    doc.explained = Some(explained_model(Verdict::PartlyExplained, remains.clone()));
    doc.model_check = Some(mtcal_solver::misfit::ModelCheck::explained(
        0.4,
        Some(0.149),
        "backlash (X)",
        false,
        &remains,
    ));
    let html = report(&doc);
    assert!(!html.contains("No diagnosis was run"), "{html}");
    let f = section(&html, "findings");
    for want in [
        "data-decided=\"false\"",
        "partly explained by the explained model",
        "backlash_um = 4.020 (u = 0.030)",
        "What remains unexplained: a cyclic error on Y, period 5 mm",
    ] {
        assert!(f.contains(want), "the findings lack {want}: {f}");
    }
    let banner = section(&html, "misfit");
    assert!(
        banner.contains("href=\"#findings\"") && !banner.contains("No diagnosis"),
        "{banner}"
    );
}

/// The budget table against docs/conventions.md's worked example, computed here from
/// its formulas: EXX's positioning range over L = the measured X travel takes the
/// certificate's (a + b·L)/k, the differential expansion's u_th and the cosine error's
/// L·ϑ²/(4√3) beside its fit u; an angular term takes no instrument contribution
/// ("not included", with the reason); with a verdict every row carries the very u_c
/// the decision used. The header names the operator, the instrument with its serial
/// and calibration date and the temperature; the signature block follows.
#[test]
fn the_budget_table_and_the_conditions_are_the_verdicts() {
    let mut doc = simulated_check();
    doc.conditions = mtcal_solver::uncertainty::Conditions::worked_example();
    let html = check_report(&CheckReport {
        doc: &doc,
        result_id: None,
        generated_at: "2026-11-25T09:00:00Z",
        verdict: None,
        diagnosis: None,
    })
    .into_string();
    let [lo, hi] = doc.model.measured_travel_mm["X"];
    let l = (hi - lo) / 1000.0; // m
    let instrument = (0.5 + 1.0 * l) / 2.0;
    let e_nde = (11.5 - 8.0) * (22.0 - 20.0) * l;
    let thermal = ((e_nde / 3f64.sqrt()).powi(2)
        + (2.0 * l * (1.0f64 + 0.25).sqrt()).powi(2)
        + (3.5 * 0.2 * l).powi(2))
    .sqrt();
    let setup = (hi - lo) * 1000.0 * 500e-6f64.powi(2) / (4.0 * 3f64.sqrt());
    let figures = identification_figures(&doc);
    let fit = figures.figures["EXX"].u.unwrap();
    let u_c = (instrument.powi(2) + thermal.powi(2) + setup.powi(2) + fit.powi(2)).sqrt();
    let row = budget_row(&html, "EXX");
    for (what, v) in [
        ("instrument", instrument),
        ("thermal", thermal),
        ("setup", setup),
        ("fit", fit),
        ("u_c", u_c),
        ("U", 2.0 * u_c),
    ] {
        assert!(
            row.contains(&format!(">{}<", num(v))),
            "EXX {what} {}: {row}",
            num(v)
        );
    }
    if l == 0.1 {
        // The worked example's own numbers.
        assert!(row.contains(">0.300<") && row.contains(">0.467<"), "{row}");
    }
    let angular = ["EAX", "EBX", "ECX", "EAY", "EBY", "ECY"]
        .into_iter()
        .find(|t| figures.figures.contains_key(*t))
        .expect("an identifiable angular term");
    assert!(budget_row(&html, angular).contains("not included"));
    assert!(section(&html, "budget").contains("the certificate states no angular uncertainty"));
    let facts = section(&html, "check");
    for want in [
        "A. Keller",
        "grid encoder s/n 1234, calibrated 2026-03-01",
        "C-77",
        "22.0 °C",
        "0.200 K",
    ] {
        assert!(facts.contains(want), "the facts lack {want}: {facts}");
    }
    let sign = section(&html, "signature");
    for want in ["Checked by", "Date", "Signature"] {
        assert!(sign.contains(want), "{sign}");
    }
    // Without conditions the instrument is not included anywhere, and said so.
    let plain = simulated_check();
    let html = check_report(&CheckReport {
        doc: &plain,
        result_id: None,
        generated_at: "2026-11-25T09:00:00Z",
        verdict: None,
        diagnosis: None,
    })
    .into_string();
    let b = section(&html, "budget");
    assert_eq!(
        b.matches("<tr data-item=").count(),
        identification_figures(&plain).figures.len()
    );
    assert!(budget_row(&html, "EXX").contains("not included"));
    assert!(b.contains("no calibration certificate stated"), "{b}");
    assert!(section(&html, "check").contains("operator</dt><dd>not stated"));
    // With a verdict: its items' budgets, u_c as the decisions used them.
    let limits = mtcal_solver::tolerance::Limits {
        terms: [(
            "EXX".to_string(),
            mtcal_solver::tolerance::TermLimit::range(4.0),
        )]
        .into(),
        ..Default::default()
    };
    let how = Assessment::of_identification(&doc, Default::default());
    let verdict = mtcal_solver::tolerance::evaluate(&limits, &figures, &how);
    let html = check_report(&CheckReport {
        doc: &doc,
        result_id: None,
        generated_at: "2026-11-25T09:00:00Z",
        verdict: Some(&verdict),
        diagnosis: None,
    })
    .into_string();
    let item = &verdict.items[0];
    assert_eq!(item.item, "EXX");
    let row = budget_row(&html, "EXX");
    assert!(
        row.contains(&format!(">{}<", num(item.u.unwrap()))),
        "{row}"
    );
    assert!(
        row.contains(&format!(">{}<", num(item.expanded_u.unwrap()))),
        "{row}"
    );
    assert_eq!(
        section(&html, "budget").matches("<tr data-item=").count(),
        1
    );
}

/// The report of a cradle check whose C table tilts about its mount: facts, the
/// compliance against A (one plot per term of the chosen model, each with its band),
/// what the ball data can separate, and the undetermined: the location errors with
/// no value and the terms the data cannot tell apart, named.
#[test]
fn cradle_report_draws_the_compliance_and_names_what_is_undetermined() {
    use mtcal_solver::cradle::{
        CradleOptions, CradleSimulation, Deflection, check_cradle, simulate_cradle,
    };
    let points = simulate_cradle(&CradleSimulation::example_with(Deflection::Mount, 1));
    let doc = check_cradle(&points, &CradleOptions::default()).unwrap();
    let html = cradle_report(&CradleCheckReport {
        doc: &doc,
        result_id: Some("r-7"),
        generated_at: "2026-11-25T09:00:00Z",
    })
    .into_string();
    for bad in ["<link", "<script", "src=\"http", "href=\"http"] {
        assert!(!html.contains(bad), "external asset: {bad}");
    }
    let facts = section(&html, "check");
    for want in [
        "SIM-CRADLE",
        "r-7",
        CRADLE_INSTRUMENT,
        "234 points at 13 A poses",
    ] {
        assert!(facts.contains(want), "facts lack {want}");
    }
    let compliance = section(&html, "compliance");
    let curves = &doc.kinematics.curves;
    assert!(curves.len() >= 2, "{:?}", doc.kinematics.description);
    assert_eq!(compliance.matches("<svg").count(), curves.len());
    assert!(compliance.contains("tilt about the mount, X") && compliance.contains("A (°)"));
    assert!(
        compliance.matches("<polygon").count() >= curves.len(),
        "a band per curve"
    );
    let sep = section(&html, "separability");
    assert!(sep.contains("sideways shift"));
    let und = section(&html, "undetermined");
    for e in doc.location_errors.iter().filter(|e| e.value.is_none()) {
        assert!(und.contains(e.name.as_str()), "{}", e.name);
    }
    assert!(und.contains("-90°, 90°"), "the measured A range");
    assert!(und.contains("tilt of the C table about its mount, about X"));
}
