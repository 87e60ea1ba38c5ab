//! `mtcal identify --explain` end to end: a simulated session with 6 µm of X backlash
//! misfits the 21-term model, is diagnosed, and is decided on the explained model, whose
//! backlash is the simulated one and whose action says what to set; its document exports
//! a LinuxCNC table with the reversal and reports a decided verdict; a clean session
//! gives exactly what plain identify gives.

mod support;

use mtcal_formats::compensation::Format;
use mtcal_solver::diagnosis::Verdict;
use mtcal_solver::identification::IdentificationResult;
use mtcal_solver::misfit::FitState;
use support::mtcal_ok;

/// Simulated lost motion of X, µm.
const LOST_X: f64 = 6.0;

/// `mtcal simulate` of a full-plan session (5 Hz) of seed `seed` with `effects` into
/// `dir/name`; its path.
fn simulated(dir: &std::path::Path, name: &str, seed: u64, effects: &[&str]) -> String {
    let out = dir.join(name);
    let out = out.to_str().unwrap().to_string();
    let seed = seed.to_string();
    let mut args = vec![
        "simulate",
        "--out",
        &out,
        "--plan",
        "full",
        "--seed",
        &seed,
        "--rate-hz",
        "5",
    ];
    for e in effects {
        args.extend(["--effect", e]);
    }
    mtcal_ok(&args);
    out
}

#[test]
fn a_backlash_misfit_is_decided_on_the_explained_model_with_its_action() {
    let dir = tempfile::tempdir().unwrap();
    let s = simulated(
        dir.path(),
        "bl",
        31,
        &[&format!("backlash:axis=X,lost_motion_um={LOST_X}")],
    );
    let truth: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(format!("{s}/truth.json")).unwrap()).unwrap();
    assert_eq!(truth["effects"][0]["lost_motion_um"], LOST_X);

    // Plain identify: a misfit, not decided, pointing to --explain.
    let plain: IdentificationResult =
        serde_json::from_str(&mtcal_ok(&["identify", &s, "--json"])).unwrap();
    assert!(plain.model_check().is_misfit());
    let text = mtcal_ok(&["identify", &s]);
    assert!(text.contains("`mtcal identify --explain`"), "{text}");

    // --explain --json: the explained model, decided on it.
    let json = mtcal_ok(&["identify", &s, "--explain", "--json"]);
    let r: IdentificationResult = serde_json::from_str(&json).unwrap();
    let check = r.model_check();
    assert_eq!(check.state, FitState::Explains, "{}", check.statement);
    assert!(check.decided_on_explained_model(), "{}", check.statement);
    assert!(
        check
            .statement
            .starts_with("decided on the explained model")
            && check.statement.contains("backlash (X)"),
        "{}",
        check.statement
    );
    let m = r.explained.as_ref().expect("the explained model");
    assert_eq!(m.verdict, Verdict::Explained);
    assert!(m.remains.is_empty(), "{:?}", m.remains);
    assert!(m.residual_rms_um <= 1.2 * m.noise_floor_um, "{m:?}");
    assert!(m.rigid.residual_rms_um > 1.2 * m.noise_floor_um, "{m:?}");
    let p = m
        .physics
        .iter()
        .find(|p| p.effect == "backlash" && p.axis.as_deref() == Some("X"))
        .expect("X backlash in the model");
    let (b, sd) = p.get("lost_motion_um").unwrap();
    let sd = sd.expect("a σ");
    assert!(sd > 0.0 && sd < 0.3, "σ {sd}");
    // Within 3σ of the truth, or 0.3 µm (the service's tolerance) where σ is smaller
    // than what the terms it is confounded with leave.
    assert!((b - LOST_X).abs() <= (3.0 * sd).max(0.3), "{b} ± {sd}");
    let action = m
        .actions
        .iter()
        .find(|a| a.finding == "backlash (X)")
        .expect("an action for the X backlash");
    let set = action.set.as_ref().expect("a value to set");
    assert_eq!(set.value, b);
    assert!(action.predicted_rms_um.after < action.predicted_rms_um.before);
    assert!(
        m.predicted_residual_rms_um <= 1.2 * m.noise_floor_um,
        "{m:?}"
    );

    // The text: the decision, the physics with its σ, the action with its number.
    let text = mtcal_ok(&["identify", &s, "--explain"]);
    assert!(
        text.contains("model check: decided on the explained model"),
        "{text}"
    );
    assert!(
        text.contains(&format!("backlash (X): lost_motion_um = {}", {
            mtcal_solver::text::with_std(b, sd, 2, false)
        })),
        "{text}"
    );
    assert!(
        text.contains(&format!("set X's backlash compensation to {b:+.2} µm")),
        "{text}"
    );
    assert!(text.contains("set: X backlash compensation = +"), "{text}");
    assert!(
        text.contains(&format!(
            "{} µm predicted after it",
            mtcal_solver::text::num(action.predicted_rms_um.after)
        )),
        "{text}"
    );

    // The session as a .tar.gz is read where the folder is: the same document.
    let archive = dir.path().join("bl.tar.gz");
    let tar = std::process::Command::new("tar")
        .args(["czf", archive.to_str().unwrap(), "-C", &s, "."])
        .status()
        .unwrap();
    assert!(tar.success());
    let from_archive = mtcal_ok(&["identify", archive.to_str().unwrap(), "--explain", "--json"]);
    assert_eq!(from_archive, json, "the archive as the folder");

    // The document exports (not refused as a misfit): the LinuxCNC table read back
    // carries the reversal, reverse − forward the simulated backlash.
    let result = dir.path().join("explained.json");
    std::fs::write(&result, &json).unwrap();
    let table = mtcal_ok(&["export", result.to_str().unwrap(), "--format", "linuxcnc"]);
    assert!(
        table.contains("# model: decided on the explained model"),
        "{table}"
    );
    let read = Format::Linuxcnc.read("t.txt", &table).unwrap();
    let x = read
        .axes
        .iter()
        .find(|a| a.axis.to_string() == "X")
        .unwrap();
    for rev in x.reversal_mm.as_ref().expect("a reversal column") {
        assert!((rev * 1e3 - LOST_X).abs() < 0.3, "{rev} mm vs {LOST_X} µm");
    }

    // Its verdicts are decided: the report against a tolerance profile passes, on the
    // explained model, and judges the lost motion as ISO 230-2's B of X.
    let limits = dir.path().join("limits.json");
    let profile = r#"{"terms": {"EXX": 1000.0}, "standards": {"iso230_2.X.B_um": 10.0}}"#;
    std::fs::write(&limits, profile).unwrap();
    let page = dir.path().join("check.html");
    let (result, limits) = (result.to_str().unwrap(), limits.to_str().unwrap());
    let args = ["report", result, "--tolerances", limits, "--out"];
    mtcal_ok(&[&args[..], &[page.to_str().unwrap()]].concat());
    let page = std::fs::read_to_string(page).unwrap();
    let decision = &page[page.find(r#"id="decision""#).expect("the verdict")..];
    let decision = &decision[..decision.find("</section>").unwrap()];
    assert!(decision.contains("badge verdict pass"), "{decision}");
    assert!(
        decision.contains("Decided on the explained model: backlash (X)"),
        "{decision}"
    );
    assert!(!decision.contains("misfit"), "{decision}");
    // Without `--diagnosis` the findings are the explained model's, never "none run".
    assert!(!page.contains("No diagnosis was run"));
    let findings = &page[page.find(r#"id="findings""#).expect("the findings")..];
    let findings = &findings[..findings.find("</section>").unwrap()];
    assert!(
        findings.contains("decided on the explained model")
            && findings.contains("data-effect=\"backlash\""),
        "{findings}"
    );
}

/// On a session the 21-term model explains, `--explain` changes nothing: the same
/// document byte for byte, the same summary.
#[test]
fn a_clean_session_gives_exactly_the_plain_result() {
    let dir = tempfile::tempdir().unwrap();
    let s = simulated(dir.path(), "clean", 21, &[]);
    let plain = mtcal_ok(&["identify", &s, "--json"]);
    let r: IdentificationResult = serde_json::from_str(&plain).unwrap();
    assert_eq!(r.model_check().state, FitState::Explains);
    assert_eq!(mtcal_ok(&["identify", &s, "--explain", "--json"]), plain);
    assert!(!plain.contains("\"explained\""));
    assert_eq!(
        mtcal_ok(&["identify", &s, "--explain"]),
        mtcal_ok(&["identify", &s])
    );
}
