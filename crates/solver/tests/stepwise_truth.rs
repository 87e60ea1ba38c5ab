//! The stepwise method (seed patent CN101982726) against truth when its assumption holds:
//! a machine whose angular errors are zero, so that nothing is absorbed by step 1. Then
//! both steps are unbiased and the reported uncertainties (with step-1 uncertainty
//! propagated into step 2) must be honest. Where the assumption fails, see
//! `stepwise_bias.rs`.

use crate::stepwise_common::{pairs, record, run, without_angles};
use mtcal_solver::identification::{IdentificationResult, Method};
use mtcal_solver::session::Session;
use mtcal_solver::simulate::{Plan, Truth};
use mtcal_solver::terms::Term;

fn machine(plan: Plan, seed: u64) -> (Session, Truth) {
    record(&without_angles(seed), plan, seed)
}

/// Largest |identified − truth| / max(floor, 3σ) over the reported values of every
/// identifiable term and squareness (floors 0.1 µm, 1 µrad as in identification_truth.rs).
fn worst_ratio(r: &IdentificationResult, truth: &Truth) -> (f64, String) {
    pairs(r, truth, None)
        .iter()
        .map(|p| (p.ratio(), format!("{} at {} mm", p.name, p.q_mm)))
        .fold((0.0, String::new()), |a, b| if b.0 > a.0 { b } else { a })
}

/// Seed plan, no angular errors: step 1 determines all 12 translational terms (rank 24
/// of 24), step 2 (circles) only part of the angular block (rank 20 of 27: EBX and EBZ
/// separately, the other seven angular functions not). Every reported value within
/// 0.1 µm / 1 µrad or 3σ of the truth, no number for an undetermined term, and the
/// per-step identifiability stated in the document.
#[test]
fn seed_plan_without_angular_errors_is_recovered() {
    for seed in [21, 22] {
        let (session, truth) = machine(Plan::Seed, seed);
        let r = run(&session, Method::Stepwise);
        let json = serde_json::to_value(&r).unwrap();
        assert_eq!(json["method"], "stepwise");
        assert_eq!(r.observability.parameters, 51);
        assert_eq!(r.observability.rank, 24 + 20);
        let mut not: Vec<String> = r.observability.not_identifiable.clone();
        not.sort();
        assert_eq!(
            not,
            ["EAX", "EAY", "EAZ", "EBY", "ECX", "ECY", "ECZ"].map(String::from)
        );
        for (name, t) in &r.terms {
            let angular = Term::parse(name).unwrap().is_angular();
            assert_eq!(t.identifiable, !angular || name == "EBX" || name == "EBZ");
            if !t.identifiable {
                assert!(
                    t.values.is_empty() && t.std.is_empty(),
                    "{name} has numbers"
                );
            }
        }
        assert!(r.reporting.iter().any(|s| s.starts_with(
            "stepwise step 1 (line runs, model of the 12 translational terms without angular terms; 60 runs): rank 24 of 24 parameters"
        ) && s.ends_with("every term of the step determined")));
        assert!(r.reporting.iter().any(|s| s.starts_with("stepwise step 2")
            && s.contains("6 runs): rank 20 of 27 parameters")
            && s.ends_with("not determined: EAX, ECX, EAY, EBY, ECY, EAZ, ECZ")));
        // The model fits: no misfit advice, only the pointer to the joint method.
        assert_eq!(
            r.observability.advice.len(),
            1,
            "{:?}",
            r.observability.advice
        );
        // The undetermined angles are step 2's groups, said so.
        assert!(!r.observability.confounded.is_empty());
        for g in &r.observability.confounded {
            assert!(g.seen_as.starts_with("stepwise step 2: "), "{}", g.seen_as);
        }
        let (ratio, at) = worst_ratio(&r, &truth);
        eprintln!("seed {seed}: worst {ratio:.2} at {at}");
        assert!(ratio <= 1.0, "seed {seed}: worst {ratio:.2} at {at}");
        assert!(
            (r.fit.residual_rms_um - 0.15).abs() < 0.03,
            "{}",
            r.fit.residual_rms_um
        );
    }
}

/// Full plan, no angular errors: both steps full rank (24 + 27), all 21 terms within
/// tolerance of the truth, plate rotations (from step 1) too.
#[test]
fn full_plan_without_angular_errors_is_recovered() {
    let (session, truth) = machine(Plan::Full, 31);
    let r = run(&session, Method::Stepwise);
    assert_eq!(r.observability.rank, 51);
    assert!(r.observability.not_identifiable.is_empty());
    let (ratio, at) = worst_ratio(&r, &truth);
    eprintln!("full: worst {ratio:.2} at {at}");
    assert!(ratio <= 1.0, "worst {ratio:.2} at {at}");
    for (m, rep) in &r.nuisance.mountings {
        let want = truth.mounting_rotation_urad[m];
        let got = rep.rotation_urad.expect("rotation determined by step 1");
        assert!(
            (got - want).abs() <= 1.0f64.max(3.0 * rep.std_urad.unwrap()),
            "{m}"
        );
    }
}

/// Honest uncertainty when the method's assumption holds: over 16 seeds about 95 % of
/// the reported values (σ > 0) lie within 2σ of the truth (band 0.90–0.99), and so do
/// step 2's angular values on their own, whose std must include the propagated step-1
/// uncertainty: without the propagation this count measured 545 of 640 = 0.85 for the
/// angular values (same seeds), below the band; with it, 0.96.
#[test]
fn stepwise_uncertainties_are_honest_when_angles_are_zero() {
    let (mut inside, mut total) = (0usize, 0usize);
    let (mut ang_in, mut ang_total) = (0usize, 0usize);
    for seed in 200..216 {
        let (session, truth) = machine(Plan::Seed, seed);
        let r = run(&session, Method::Stepwise);
        for p in pairs(&r, &truth, None).iter().filter(|p| p.std > 0.0) {
            let ok = (p.value - p.truth).abs() <= 2.0 * p.std;
            total += 1;
            inside += ok as usize;
            if Term::parse(&p.name).is_some_and(Term::is_angular) {
                ang_total += 1;
                ang_in += ok as usize;
            }
        }
    }
    let share = inside as f64 / total as f64;
    let ang = ang_in as f64 / ang_total as f64;
    eprintln!("honesty: {inside}/{total} = {share:.3}; angular {ang_in}/{ang_total} = {ang:.3}");
    assert!((0.90..=0.99).contains(&share), "{share:.3}");
    assert!((0.90..=0.99).contains(&ang), "angular {ang:.3}");
}

/// A session without line runs cannot run step 1: a clear error naming the fix.
#[test]
fn stepwise_without_lines_is_a_clear_error() {
    let (mut session, _) = machine(Plan::Seed, 5);
    for p in &mut session.planes {
        let plane = p.plane;
        p.runs.retain(|r| !r.test_kind(plane).is_line());
    }
    let opts = mtcal_solver::identification::IdentifyOptions {
        method: Method::Stepwise,
        ..Default::default()
    };
    let e = mtcal_solver::identification::identify(&session, &opts)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("needs line runs") && e.contains("--method joint"),
        "{e}"
    );
}

/// Without circle runs step 2 has no data: the angular terms are reported as not
/// identifiable (no numbers), the translational ones as usual.
#[test]
fn stepwise_without_circles_reports_no_angles() {
    let (mut session, truth) = machine(Plan::Seed, 6);
    for p in &mut session.planes {
        let plane = p.plane;
        p.runs.retain(|r| !r.test_kind(plane).is_circle());
    }
    let r = run(&session, Method::Stepwise);
    for (name, t) in &r.terms {
        let angular = Term::parse(name).unwrap().is_angular();
        assert_eq!(t.identifiable, !angular, "{name}");
        assert_eq!(t.values.is_empty(), angular, "{name}");
    }
    assert_eq!(r.observability.rank, 24);
    assert!(
        r.reporting
            .iter()
            .any(|s| s.contains("0 runs): rank 0 of 27 parameters"))
    );
    let (ratio, at) = worst_ratio(&r, &truth);
    assert!(ratio <= 1.0, "worst {ratio:.2} at {at}");
}
