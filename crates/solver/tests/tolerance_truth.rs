//! Verdicts of real identifications against limits set from the simulated truth. An error
//! function is judged by its range (max − min) over the measured travel (ISO 230-1): a
//! limit well above the true range passes, one well below fails, one at the true range is
//! neither proven (undecided); the range's standard uncertainty covers the truth over
//! seeds; a limit on a term the plan cannot identify is undecided, never a pass.

use mtcal_solver::comparison::RANGE_GRID_POINTS;
use mtcal_solver::identification::{IdentificationResult, IdentifyOptions, identify};
use mtcal_solver::simulate::{SimOptions, Truth, random_truth, simulate};
use mtcal_solver::terms::Term;
use mtcal_solver::tolerance::{
    Assessment, Decision, Limits, TermLimit, evaluate, identification_figures,
};

fn check(seed: u64) -> (Truth, IdentificationResult) {
    let out = simulate(
        &random_truth(seed),
        &SimOptions {
            seed,
            sample_rate_hz: 10.0,
            ..Default::default()
        },
    )
    .unwrap();
    let r = identify(&out.session, &IdentifyOptions::default()).unwrap();
    (out.truth, r)
}

/// The true range of a positioning term over [lo, hi] on the same grid.
fn true_range(truth: &Truth, term: &str, [lo, hi]: [f64; 2]) -> f64 {
    let t = Term::parse(term).unwrap();
    let n = RANGE_GRID_POINTS;
    let v: Vec<f64> = (0..n)
        .map(|i| {
            truth
                .errors
                .value(t, lo + (hi - lo) * i as f64 / (n - 1) as f64)
        })
        .collect();
    v.iter().copied().fold(f64::NEG_INFINITY, f64::max)
        - v.iter().copied().fold(f64::INFINITY, f64::min)
}

#[test]
fn verdicts_follow_the_true_range_over_the_measured_travel() {
    let (truth, r) = check(7);
    let figures = identification_figures(&r);
    let fig = &figures.figures["EXX"];
    assert_eq!(fig.travel_mm, Some([-50.0, 50.0]));
    let range = true_range(&truth, "EXX", [-50.0, 50.0]);
    let u = fig.u.unwrap();
    assert!(
        range > 50.0 * u,
        "the case must be resolved: {range} vs {u}"
    );
    let verdict = |limit: f64| {
        let limits = Limits {
            terms: [("EXX".to_string(), TermLimit::range(limit))].into(),
            ..Limits::default()
        };
        evaluate(&limits, &figures, &Assessment::default())
    };
    assert_eq!(verdict(range * 1.2).decision, Some(Decision::Pass));
    assert_eq!(verdict(range * 0.8).decision, Some(Decision::Fail));
    // At the true range the estimate's interval must straddle the limit.
    assert_eq!(verdict(range).decision, Some(Decision::Undecided));

    // The seed plan with one head offset cannot separate EYX: undecided whatever the limit.
    assert!(!r.terms["EYX"].identifiable);
    let limits = Limits {
        terms: [
            ("EYX".to_string(), TermLimit::range(1e6)),
            ("EXX".to_string(), TermLimit::range(range * 1.2)),
        ]
        .into(),
        ..Limits::default()
    };
    let v = evaluate(&limits, &figures, &Assessment::default());
    assert_eq!(v.decision, Some(Decision::Undecided));
    let eyx = v.items.iter().find(|i| i.item == "EYX").unwrap();
    assert_eq!(eyx.value, None);
    assert!(eyx.reason.contains("not identifiable"), "{}", eyx.reason);
}

/// The range's standard uncertainty is honest: over 12 machines the estimated ranges of
/// the three positioning functions lie within 2u of the true ranges in about 95 % of
/// cases (at least 30 of 36).
#[test]
fn the_range_uncertainty_covers_the_truth() {
    let (mut within, mut all) = (0, 0);
    for seed in 0..12 {
        let (truth, r) = check(100 + seed);
        let figures = identification_figures(&r);
        for term in ["EXX", "EYY", "EZZ"] {
            let Some(q) = figures.figures.get(term) else {
                continue;
            };
            let t = true_range(&truth, term, q.travel_mm.unwrap());
            all += 1;
            if (q.value - t).abs() <= 2.0 * q.u.unwrap() {
                within += 1;
            } else {
                eprintln!(
                    "seed {seed} {term}: range {} vs true {t}, u {:?}",
                    q.value, q.u
                );
            }
        }
    }
    assert!(all >= 30, "{all}");
    assert!(within as f64 >= 0.83 * all as f64, "{within} of {all}");
}
