//! `mtcal export` and `mtcal report` end to end: an identification result written to
//! disk, exported in every format (the file the formats crate writes) and reported as a
//! self-contained HTML page; bad input is refused with exit code 2 and a message.

mod support;

use mtcal_formats::compensation::{Compensation, Format};
use mtcal_solver::identification::{IdentificationResult, IdentifyOptions, identify};
use mtcal_solver::simulate::{Plan, SimOptions, random_truth, simulate};
use std::path::Path;
use support::mtcal;

/// The seed plan's result (some terms not identifiable), written to `dir/result.json`.
fn result_file(dir: &Path) -> (IdentificationResult, String) {
    let out = simulate(
        &random_truth(11),
        &SimOptions {
            plan: Plan::Seed,
            seed: 11,
            sample_rate_hz: 10.0,
            ..Default::default()
        },
    )
    .unwrap();
    let r = identify(&out.session, &IdentifyOptions::default()).unwrap();
    let path = dir.join("result.json");
    std::fs::write(&path, serde_json::to_string_pretty(&r).unwrap()).unwrap();
    (r, path.to_str().unwrap().to_string())
}

#[test]
fn export_writes_each_format_and_refuses_bad_input() {
    let dir = tempfile::tempdir().unwrap();
    let (r, path) = result_file(dir.path());
    for f in Format::ALL {
        let out = mtcal(&["export", &path, "--format", f.name(), "--step-mm", "10"]);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let want = f.write(&Compensation::from_result(&r, 10.0, false).unwrap());
        assert_eq!(String::from_utf8(out.stdout).unwrap(), want, "{}", f.name());
    }
    let file = dir.path().join("x.com");
    let out = mtcal(&[
        "export",
        &path,
        "--format",
        "heidenhain",
        "--out",
        file.to_str().unwrap(),
    ]);
    assert!(out.status.success());
    assert!(
        std::fs::read_to_string(&file)
            .unwrap()
            .contains("BEGIN X.COM MM")
    );
    for (args, says) in [
        (vec!["--format", "fanuc"], "isg, etalon, heidenhain, csv"),
        (vec!["--format", "isg", "--step-mm", "0"], "--step-mm"),
    ] {
        let mut a = vec!["export", path.as_str()];
        a.extend(args);
        let out = mtcal(&a);
        assert_eq!(out.status.code(), Some(2));
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains(says), "{err}");
    }
    // Not an identification result.
    let other = dir.path().join("other.json");
    std::fs::write(&other, r#"{"kind": "diagnosis"}"#).unwrap();
    let out = mtcal(&["export", other.to_str().unwrap(), "--format", "isg"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("kind `diagnosis`"));
}

#[test]
fn report_writes_a_self_contained_page_with_verdicts_from_tolerances() {
    let dir = tempfile::tempdir().unwrap();
    let (r, path) = result_file(dir.path());
    let html = dir.path().join("check.html");
    let out = mtcal(&["report", &path, "--out", html.to_str().unwrap()]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let page = std::fs::read_to_string(&html).unwrap();
    // It says on stderr what it wrote, where (stdout stays empty).
    let note = String::from_utf8_lossy(&out.stderr);
    assert!(
        note.contains(&format!("wrote the report ({} bytes) to ", page.len()))
            && note.contains("check.html"),
        "{note}"
    );
    assert!(out.stdout.is_empty());
    for id in [
        "check",
        "standards",
        "terms",
        "circles",
        "findings",
        "compensation",
        "undetermined",
    ] {
        assert!(page.contains(&format!("id=\"{id}\"")), "{id}");
    }
    assert!(page.contains("no tolerance"));
    // A tolerance profile's limits: the figure gets its verdict.
    let figure = r.standards.scalar_figures()[0].clone();
    let limits = dir.path().join("limits.json");
    std::fs::write(
        &limits,
        format!(
            r#"{{"standards": {{"{}": {}}}}}"#,
            figure.name,
            figure.value.abs() + 50.0
        ),
    )
    .unwrap();
    let out = mtcal(&["report", &path, "--tolerances", limits.to_str().unwrap()]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let page = String::from_utf8(out.stdout).unwrap();
    assert!(page.contains("id=\"verdict\"") && page.contains("badge verdict pass"));
    // A limit that is not positive is refused, naming the file.
    std::fs::write(&limits, r#"{"terms": {"EXX": -1}}"#).unwrap();
    let out = mtcal(&["report", &path, "--tolerances", limits.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("limits.json"));
}

/// `mtcal report` on a cradle result (`mtcal cradle --json`): the cradle check's page,
/// with one compliance plot per A-dependent term of the chosen model; the options that
/// only an identification takes are refused with exit code 2.
#[test]
fn report_of_a_cradle_result_draws_its_compliance() {
    let dir = tempfile::tempdir().unwrap();
    let points = dir.path().join("mount.csv");
    let p = points.to_str().unwrap();
    let out = mtcal(&["cradle", "--simulate", p, "--deflection", "mount"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let out = mtcal(&["cradle", p, "--json"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let doc: mtcal_solver::cradle::CradleResult = serde_json::from_slice(&out.stdout).unwrap();
    let result = dir.path().join("cradle-result.json");
    std::fs::write(&result, &out.stdout).unwrap();
    let r = result.to_str().unwrap();
    let out = mtcal(&["report", r]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let page = String::from_utf8(out.stdout).unwrap();
    assert!(page.contains("Cradle check report: SIM-CRADLE"));
    assert!(doc.kinematics.curves.len() >= 2);
    assert_eq!(
        page.matches("data-term=").count(),
        doc.kinematics.curves.len()
    );
    let limits = dir.path().join("limits.json");
    std::fs::write(&limits, r#"{"terms": {"EXX": 5}}"#).unwrap();
    let out = mtcal(&["report", r, "--tolerances", limits.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("a cradle result"));
}

/// A backlash machine's result (the model does not explain its recording): `export`
/// refuses it with exit code 2 and the reason; `--force` writes the table with the
/// reason in its first header line.
#[test]
fn export_of_a_misfit_needs_force() {
    use mtcal_solver::Axis;
    use mtcal_solver::simulate::Effect;
    let out = simulate(
        &random_truth(5),
        &SimOptions {
            plan: Plan::Seed,
            seed: 5,
            sample_rate_hz: 10.0,
            effects: vec![Effect::Backlash {
                axis: Axis::X,
                lost_motion_um: 6.0,
            }],
            ..Default::default()
        },
    )
    .unwrap();
    let r = identify(&out.session, &IdentifyOptions::default()).unwrap();
    assert!(r.model_check().is_misfit(), "{}", r.model_check().statement);
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("result.json");
    std::fs::write(&path, serde_json::to_string(&r).unwrap()).unwrap();
    let path = path.to_str().unwrap();
    let out = mtcal(&["export", path, "--format", "csv"]);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("the model does not explain this recording"),
        "{err}"
    );
    assert!(err.contains("--force"), "{err}");
    let out = mtcal(&["export", path, "--format", "csv", "--force"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(
        text.lines()
            .next()
            .unwrap()
            .starts_with("# FORCED, NOT FOR USE WITHOUT REVIEW: the model does not explain"),
        "{text}"
    );
}
