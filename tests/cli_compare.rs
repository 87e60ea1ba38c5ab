//! `mtcal compare` end to end against truth: two checks of one simulated machine whose
//! errors changed by known amounts between them (a positioning error grew linearly, a
//! straightness bowed, a squareness moved). The differences it prints must match the
//! change of the simulator's truth in the reporting convention (straightness about its
//! least-squares line) within max(0.1 µm / 1 µrad, 3u) at every compared position, and
//! the drift must name the term that changed most. Bad input is refused with exit code 2.

mod support;

use mtcal_solver::identification::{IdentifyOptions, identify};
use mtcal_solver::simulate::{Plan, SimOptions, SimOutput, random_truth, simulate};
use mtcal_solver::terms::Term;
use support::mtcal;

fn check(errors: &mtcal_solver::basis::PolyErrors, seed: u64) -> SimOutput {
    simulate(
        errors,
        &SimOptions {
            plan: Plan::Full,
            seed,
            sample_rate_hz: 20.0,
            ..Default::default()
        },
    )
    .unwrap()
}

#[test]
fn compare_reports_the_change_of_the_truth_with_its_uncertainty() {
    let before = random_truth(31);
    let mut after = before.clone();
    // EXX grows by 0.012 µm/mm (0.6 µm at 50 mm); EYX bows by 1.2 µm at ±50 mm
    // (c₂ q², reported about its least-squares line: 0.8 µm at the ends, −0.4 µm in the
    // middle); EC0Y moves by the model constant's 4 µrad.
    let mut c = before.coefficients["EXX"].clone();
    c[0] += 0.012;
    after.set(Term::parse("EXX").unwrap(), c);
    let mut c = before.coefficients["EYX"].clone();
    c[1] += 1.2 / 2500.0;
    after.set(Term::parse("EYX").unwrap(), c);
    after.squareness.ec0y_urad += 4.0;
    let (a, b) = (check(&before, 1), check(&after, 2));
    let dir = tempfile::tempdir().unwrap();
    let mut paths = Vec::new();
    for (name, out) in [("a.json", &a), ("b.json", &b)] {
        let r = identify(&out.session, &IdentifyOptions::default()).unwrap();
        let p = dir.path().join(name);
        std::fs::write(&p, serde_json::to_string(&r).unwrap()).unwrap();
        paths.push(p.to_str().unwrap().to_string());
    }
    let out = mtcal(&["compare", &paths[0], &paths[1], "--json", "--step-mm", "10"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let doc: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let mut compared = 0;
    for (name, d) in doc["terms"].as_object().unwrap() {
        if !d["identifiable"].as_bool().unwrap() {
            continue;
        }
        let (ta, tb) = (&a.truth.terms[name], &b.truth.terms[name]);
        let floor: f64 =
            if name.starts_with("EA") || name.starts_with("EB") || name.starts_with("EC") {
                1.0
            } else {
                0.1
            };
        let positions = d["positions_mm"].as_array().unwrap();
        for (i, q) in positions.iter().enumerate() {
            let q = q.as_f64().unwrap();
            let k = ta
                .positions_mm
                .iter()
                .position(|&p| (p - q).abs() < 1e-9)
                .unwrap();
            let truth = tb.values[k] - ta.values[k];
            let got = d["delta"][i].as_f64().unwrap();
            let u = d["u"][i].as_f64().unwrap();
            assert!(
                (got - truth).abs() <= floor.max(3.0 * u),
                "{name} at {q}: {got} vs truth {truth} (u {u})"
            );
            compared += 1;
        }
    }
    assert!(compared > 150, "{compared}");
    // The bow is compared about its least-squares line: 0.8 µm at the ends, not 1.2.
    let eyx = &doc["terms"]["EYX"];
    let end = eyx["delta"]
        .as_array()
        .unwrap()
        .last()
        .unwrap()
        .as_f64()
        .unwrap();
    assert!((end - 0.8).abs() < 0.15, "EYX change at +50: {end}");
    let sq = doc["squareness"]["EC0Y"].as_f64().unwrap();
    let truth_sq = b.truth.squareness_urad["EC0Y"] - a.truth.squareness_urad["EC0Y"];
    // The squareness difference has its uncertainty too (u² = u_a² + u_b²).
    let sq_u = doc["squareness_u"]["EC0Y"].as_f64().unwrap();
    assert!(sq_u > 0.0, "{sq_u}");
    assert!(
        (sq - truth_sq).abs() <= 1.0f64.max(3.0 * sq_u),
        "{sq} vs {truth_sq} (u {sq_u})"
    );
    assert_eq!(doc["drift"]["worst_term_um"], "EYX", "{}", doc["drift"]);
    // The plain summary names the same worst term.
    let out = mtcal(&["compare", &paths[0], &paths[1]]);
    assert!(out.status.success());
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("in EYX"));
    // Its squareness row ends with the u of the difference.
    let row = text.lines().find(|l| l.starts_with("EC0Y")).unwrap();
    assert!(row.ends_with(&format!("{sq_u:.3}")), "{row}");
    // Bad input: a step giving too many positions, a file that is not a result.
    let out = mtcal(&["compare", &paths[0], &paths[1], "--step-mm", "0.00001"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("--step-mm"));
    let junk = dir.path().join("junk.json");
    std::fs::write(&junk, "{\"kind\": \"cradle\"}").unwrap();
    let out = mtcal(&["compare", &paths[0], junk.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("junk.json"));
}

/// One seed-plan and one full-plan identification of a machine: a term the seed plan
/// cannot identify is said to be not identifiable "in the baseline" or "in the other
/// check", whichever lacks it, and "in either" when both lack it; the JSON names it too.
#[test]
fn compare_says_which_check_lacks_a_term() {
    let truth = random_truth(17);
    let dir = tempfile::tempdir().unwrap();
    let mut results = Vec::new();
    for (name, plan) in [("seed.json", Plan::Seed), ("full.json", Plan::Full)] {
        let out = simulate(
            &truth,
            &SimOptions {
                plan,
                seed: 3,
                sample_rate_hz: 10.0,
                ..Default::default()
            },
        )
        .unwrap();
        let r = identify(&out.session, &IdentifyOptions::default()).unwrap();
        let p = dir.path().join(name);
        std::fs::write(&p, serde_json::to_string(&r).unwrap()).unwrap();
        results.push((r, p.to_str().unwrap().to_string()));
    }
    let (seed, full) = (&results[0], &results[1]);
    // The terms (and squareness) the seed plan leaves unidentified and the full plan finds.
    let lacking: Vec<&String> = seed
        .0
        .terms
        .iter()
        .filter(|(n, t)| !t.identifiable && full.0.terms[*n].identifiable)
        .map(|(n, _)| n)
        .chain(
            seed.0
                .squareness
                .iter()
                .filter(|(n, s)| !s.identifiable && full.0.squareness[*n].identifiable)
                .map(|(n, _)| n),
        )
        .collect();
    assert!(!lacking.is_empty(), "the seed plan identifies every term");
    let row = |text: &str, name: &str| -> String {
        text.lines()
            .find(|l| l.split_whitespace().next() == Some(name))
            .unwrap_or_else(|| panic!("no row {name}: {text}"))
            .to_string()
    };
    for (args, says, key) in [
        (
            [&seed.1, &full.1],
            "not identifiable in the baseline",
            "baseline",
        ),
        (
            [&full.1, &seed.1],
            "not identifiable in the other check",
            "other",
        ),
        ([&seed.1, &seed.1], "not identifiable in either", "both"),
    ] {
        let out = mtcal(&["compare", args[0].as_str(), args[1].as_str()]);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let text = String::from_utf8_lossy(&out.stdout);
        assert!(!text.contains("in both"), "{text}");
        for name in &lacking {
            let r = row(&text, name);
            assert!(r.ends_with(says), "{args:?}: {r}");
        }
        let out = mtcal(&["compare", args[0].as_str(), args[1].as_str(), "--json"]);
        let doc: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        for name in &lacking {
            assert_eq!(doc["not_identifiable_in"][name.as_str()], key, "{name}");
        }
    }
}
