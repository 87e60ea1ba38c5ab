//! Verdicts of a real identification against limits set from the simulated truth: a limit
//! well above the true max |f| over the measured travel passes, one well below fails, one
//! at the true max is neither proven (undecided), and a limit on a term the plan cannot
//! identify is undecided, never a pass.

use mtcal_solver::identification::{IdentifyOptions, identify};
use mtcal_solver::simulate::{SimOptions, random_truth, simulate};
use mtcal_solver::tolerance::{Decision, Limits, evaluate, identification_figures};

#[test]
fn verdicts_follow_the_truth_over_the_measured_travel() {
    let truth = random_truth(7);
    let out = simulate(
        &truth,
        &SimOptions {
            seed: 7,
            sample_rate_hz: 10.0,
            ..Default::default()
        },
    )
    .unwrap();
    let r = identify(&out.session, &IdentifyOptions::default()).unwrap();
    let figures = identification_figures(&r);

    // The truth's max |EXX| over the reporting grid of the measured travel (±50 mm here).
    let t = &out.truth.terms["EXX"];
    assert_eq!(t.positions_mm, r.terms["EXX"].positions_mm);
    let true_max = t.values.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let max_std = r.terms["EXX"].std.iter().fold(0.0f64, |m, &v| m.max(v));
    assert!(
        true_max > 50.0 * max_std,
        "the case must be resolved: {true_max} vs {max_std}"
    );
    let fig = &figures.figures["EXX"];
    assert_eq!(fig.travel_mm, Some([-50.0, 50.0]));

    let verdict = |limit: f64| {
        let limits = Limits {
            terms: [("EXX".to_string(), limit)].into(),
            ..Limits::default()
        };
        evaluate(&limits, &figures)
    };
    assert_eq!(verdict(true_max * 1.2).decision, Some(Decision::Pass));
    assert_eq!(verdict(true_max * 0.8).decision, Some(Decision::Fail));
    // At the true maximum the estimate's interval must straddle the limit (the
    // uncertainty is an honest 1σ: |estimate − truth| ≪ 2u would be needed to decide).
    assert_eq!(verdict(true_max).decision, Some(Decision::Undecided));
    let v = verdict(true_max * 0.8);
    let item = &v.items[0];
    // The failing point is where the truth is largest.
    let at = t.positions_mm[t
        .values
        .iter()
        .enumerate()
        .max_by(|a, b| a.1.abs().total_cmp(&b.1.abs()))
        .unwrap()
        .0];
    assert_eq!(item.position_mm, Some(at));

    // The seed plan with one head offset cannot separate EYX: undecided whatever the limit.
    assert!(!r.terms["EYX"].identifiable);
    let limits = Limits {
        terms: [
            ("EYX".to_string(), 1e6),
            ("EXX".to_string(), true_max * 1.2),
        ]
        .into(),
        ..Limits::default()
    };
    let v = evaluate(&limits, &figures);
    assert_eq!(v.decision, Some(Decision::Undecided));
    let eyx = v.items.iter().find(|i| i.item == "EYX").unwrap();
    assert_eq!(eyx.value, None);
    assert!(eyx.reason.contains("not identifiable"), "{}", eyx.reason);
}
