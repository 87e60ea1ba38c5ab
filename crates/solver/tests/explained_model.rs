//! The explained model against truth: a simulated machine with known 21 terms and
//! 6 µm X / 3.5 µm Y backlash. The 21-term model misfits; the diagnosis names the
//! backlash; the 21 terms fitted jointly with it cover the true terms and the true lost
//! motion within 2σ, and the geometry is decided where it was not.

use mtcal_solver::axis::Axis;
use mtcal_solver::diagnosis::{DiagnoseOptions, Verdict, diagnose_session};
use mtcal_solver::explained::explain;
use mtcal_solver::identification::{IdentificationResult, IdentifyOptions, identify};
use mtcal_solver::misfit::FitState;
use mtcal_solver::simulate::{Effect, Plan, SimOptions, Truth, random_truth, simulate};
use mtcal_solver::tolerance::{
    Assessment, Decision, Limits, TermLimit, evaluate, identification_figures,
};

const LOST_X: f64 = 6.0;
const LOST_Y: f64 = 3.5;

fn backlash_session(seed: u64) -> (mtcal_solver::session::Session, Truth) {
    let out = simulate(
        &random_truth(seed),
        &SimOptions {
            plan: Plan::Full,
            seed,
            sample_rate_hz: 10.0,
            effects: vec![
                Effect::Backlash {
                    axis: Axis::X,
                    lost_motion_um: LOST_X,
                },
                Effect::Backlash {
                    axis: Axis::Y,
                    lost_motion_um: LOST_Y,
                },
            ],
            ..Default::default()
        },
    )
    .unwrap();
    (out.session, out.truth)
}

/// (inside 2σ, total) over every grid value of every term and every squareness.
fn covered(r: &IdentificationResult, truth: &Truth) -> (usize, usize) {
    let (mut inside, mut total) = (0, 0);
    for (name, t) in &r.terms {
        let tt = &truth.terms[name];
        for (k, q) in t.positions_mm.iter().enumerate() {
            if t.std[k] == 0.0 {
                continue;
            }
            let j = tt.positions_mm.iter().position(|p| p == q).unwrap();
            total += 1;
            inside += usize::from((t.values[k] - tt.values[j]).abs() <= 2.0 * t.std[k]);
        }
    }
    for (name, q) in &r.squareness {
        total += 1;
        let d = (q.value_urad.unwrap() - truth.squareness_urad[name]).abs();
        inside += usize::from(d <= 2.0 * q.std_urad.unwrap());
    }
    (inside, total)
}

/// Limits well above every true range: a model that explains the recording passes them,
/// a misfit leaves them not decided.
fn generous(truth: &Truth) -> Limits {
    let terms = truth
        .terms
        .iter()
        .map(|(name, t)| {
            let lo = t.values.iter().copied().fold(f64::INFINITY, f64::min);
            let hi = t.values.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            (name.clone(), TermLimit::range(2.0 * (hi - lo) + 5.0))
        })
        .collect();
    Limits {
        terms,
        standards: [("iso230_2.X.B_um".to_string(), 10.0)].into(),
        ..Limits::default()
    }
}

#[test]
fn explained_model_covers_the_truth_and_decides_the_geometry() {
    let (mut inside, mut total) = (0, 0);
    let mut lost = Vec::new();
    for seed in [31, 32, 33, 34] {
        let (session, truth) = backlash_session(seed);
        let plain = identify(&session, &IdentifyOptions::default()).unwrap();
        assert_eq!(plain.model_check().state, FitState::Misfit, "seed {seed}");
        let d = diagnose_session(&session, &DiagnoseOptions::default()).unwrap();
        assert_eq!(d.verdict, Verdict::Explained, "seed {seed}: {d:#?}");
        let r = explain(&session, &IdentifyOptions::default(), &d).unwrap();
        let check = r.model_check();
        assert_eq!(check.state, FitState::Explains, "{}", check.statement);
        assert!(check.decided_on_explained_model(), "{}", check.statement);
        assert!(
            check.statement.contains("explained model"),
            "{}",
            check.statement
        );
        let m = r.explained.as_ref().expect("the explained model");
        assert!(m.heldout_rms_um <= 1.2 * m.noise_floor_um, "{m:#?}");
        assert!(m.residual_rms_um < m.rigid.residual_rms_um);
        let (i, t) = covered(&r, &truth);
        inside += i;
        total += t;
        for (axis, want) in [("X", LOST_X), ("Y", LOST_Y)] {
            let p = m
                .physics
                .iter()
                .find(|p| p.effect == "backlash" && p.axis.as_deref() == Some(axis))
                .unwrap_or_else(|| panic!("seed {seed}: no backlash {axis}: {m:#?}"));
            let (b, s) = p.get("lost_motion_um").unwrap();
            lost.push((seed, axis, b, s.unwrap(), want));
        }
        // Compensating every finding leaves the 21-term model at the floor.
        assert!(
            m.predicted_residual_rms_um <= 1.2 * m.noise_floor_um,
            "{m:#?}"
        );
        // The geometry that misfit is decided on the explained model; the plain one is not.
        let limits = generous(&truth);
        let decide = |r: &IdentificationResult| {
            evaluate(
                &limits,
                &identification_figures(r),
                &Assessment::of_identification(r, Default::default()),
            )
        };
        let before = decide(&plain);
        assert_eq!(before.decision, Some(Decision::Misfit));
        let after = decide(&r);
        let terms: Vec<_> = after.items.iter().filter(|i| i.group == "term").collect();
        assert!(!terms.is_empty());
        for item in &terms {
            assert_eq!(item.decision, Decision::Pass, "seed {seed}: {item:#?}");
        }
        // The lost motion is judged as ISO 230-2's reversal value B, which line passes
        // alone cannot give.
        let b = after
            .items
            .iter()
            .find(|i| i.item == "iso230_2.X.B_um")
            .expect("B judged");
        assert_eq!(b.decision, Decision::Pass, "{b:#?}");
        assert!((b.value.unwrap().abs() - LOST_X).abs() < 0.5, "{b:#?}");
    }
    let share = inside as f64 / total as f64;
    eprintln!("explained model: {inside}/{total} within 2σ ({share:.3}); lost motion {lost:?}");
    assert!(share >= 0.9, "{inside} of {total} within 2σ");
    for (seed, axis, b, s, want) in lost {
        assert!(
            (b - want).abs() <= 2.0 * s,
            "seed {seed} {axis}: {b} ± {s} vs {want}"
        );
    }
}

/// On a session the 21-term model explains, the explained path gives the values of plain
/// identification.
#[test]
fn a_clean_session_explains_to_the_plain_identification() {
    let out = simulate(
        &random_truth(5),
        &SimOptions {
            seed: 5,
            sample_rate_hz: 10.0,
            ..Default::default()
        },
    )
    .unwrap();
    let opts = IdentifyOptions::default();
    let d = diagnose_session(&out.session, &DiagnoseOptions::default()).unwrap();
    assert_eq!(d.verdict, Verdict::Consistent);
    let plain = identify(&out.session, &opts).unwrap();
    let r = explain(&out.session, &opts, &d).unwrap();
    assert!(r.explained.is_none());
    assert_eq!(r.terms, plain.terms);
    assert_eq!(r.squareness, plain.squareness);
}
