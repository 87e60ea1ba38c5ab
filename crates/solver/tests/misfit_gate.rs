//! The misfit gate (`mtcal_solver::misfit`) on identifications: clean sessions of both
//! plans and three noise levels are never gated; the effects of the catalogue that leave
//! a residual are, at their default sizes; so are effects made outside the simulator (a
//! lost motion and a triangular screw error written into the samples by hand); an effect
//! near the floor is not (the gate is a gate, not a detector: the diagnosis is).

use mtcal_solver::Axis;
use mtcal_solver::identification::{IdentificationResult, IdentifyOptions, identify};
use mtcal_solver::misfit::{AT_NOISE_LEVEL, FitState};
use mtcal_solver::session::{Session, TestKind};
use mtcal_solver::simulate::{Effect, Plan, SimOptions, random_truth, simulate};

fn session(plan: Plan, seed: u64, noise: f64, effects: Vec<Effect>) -> Session {
    let o = SimOptions {
        plan,
        seed,
        sample_rate_hz: 10.0,
        noise_um: noise,
        effects,
        ..SimOptions::default()
    };
    simulate(&random_truth(seed), &o).unwrap().session
}

fn identified(s: &Session) -> IdentificationResult {
    identify(s, &IdentifyOptions::default()).unwrap()
}

#[test]
fn clean_sessions_are_never_gated() {
    for plan in [Plan::Seed, Plan::Full] {
        for (k, noise) in [0.05, 0.15, 0.5].into_iter().enumerate() {
            for seed in 0..2 {
                let r = identified(&session(
                    plan.clone(),
                    300 + 10 * k as u64 + seed,
                    noise,
                    vec![],
                ));
                let c = r.model_check.clone().unwrap();
                assert_eq!(
                    c.state,
                    FitState::Explains,
                    "{plan:?} {noise} {seed}: {}",
                    c.statement
                );
                let ratio = c.ratio.unwrap();
                assert!(
                    (0.95..1.05).contains(&ratio),
                    "{plan:?} {noise} {seed}: {ratio}"
                );
                assert_eq!(r.model_check(), c, "the stored check is the one read");
            }
        }
    }
}

#[test]
fn catalogue_effects_that_leave_a_residual_are_gated() {
    for name in [
        "backlash",
        "servo_lag",
        "reversal_spike",
        "cyclic",
        "waviness",
        "vibration",
        "velocity_coupling",
        "temperature_growth",
    ] {
        let e = Effect::default_for(name).unwrap();
        let r = identified(&session(Plan::Seed, 7, 0.15, vec![e]));
        let c = r.model_check.unwrap();
        assert_eq!(c.state, FitState::Misfit, "{name}: {}", c.statement);
        assert!(
            c.statement
                .starts_with("the model does not explain this recording")
        );
    }
}

/// The commanded direction of travel of each sample along `axis` (+1, −1; a sample at
/// rest keeps the last direction).
fn directions(pos: &[[f64; 3]], axis: usize) -> Vec<f64> {
    let mut d = 1.0;
    let mut out = Vec::with_capacity(pos.len());
    for i in 0..pos.len() {
        if i > 0 {
            let step = pos[i][axis] - pos[i - 1][axis];
            if step.abs() > 1e-9 {
                d = step.signum();
            }
        }
        out.push(d);
    }
    out
}

/// Adds `f(x, direction of X travel)` µm to the reading along X of every sample whose
/// plane holds X.
fn edit_x(s: &mut Session, f: impl Fn(f64, f64) -> f64) {
    for p in &mut s.planes {
        let (u, v) = p.plane.axes();
        for run in &mut p.runs {
            let dirs = directions(&run.pos_mm, 0);
            for i in 0..run.len() {
                let e = f(run.pos_mm[i][0], dirs[i]);
                if u == Axis::X {
                    run.du_um[i] += e;
                } else if v == Axis::X {
                    run.dv_um[i] += e;
                }
            }
        }
    }
}

#[test]
fn effects_made_by_hand_are_gated_and_one_near_the_floor_is_not() {
    // A lost motion of 5 µm written into the readings: half of it against the direction
    // of X travel (not the simulator's backlash model: no memory through dwells).
    let mut s = session(Plan::Seed, 11, 0.15, vec![]);
    edit_x(&mut s, |_, d| -2.5 * d);
    let c = identified(&s).model_check.unwrap();
    assert_eq!(c.state, FitState::Misfit, "{}", c.statement);
    // A triangular screw error of 1 µm amplitude and 8 mm period (not a sine).
    let mut s = session(Plan::Full, 12, 0.15, vec![]);
    edit_x(&mut s, |x, _| {
        let p = (x / 8.0).rem_euclid(1.0);
        4.0 * (p - 0.5).abs() - 1.0
    });
    let c = identified(&s).model_check.unwrap();
    assert_eq!(c.state, FitState::Misfit, "{}", c.statement);
    // A lost motion of 0.1 µm at noise 0.15 µm: below what a residual test can see
    // (ratio under the gate), the model is said to explain the recording.
    let mut s = session(Plan::Seed, 13, 0.15, vec![]);
    edit_x(&mut s, |_, d| -0.05 * d);
    let c = identified(&s).model_check.unwrap();
    assert!(c.ratio.unwrap() <= AT_NOISE_LEVEL, "{}", c.statement);
    // Only lines and circles are written: the test kinds are kept.
    assert!(
        s.planes[0]
            .runs
            .iter()
            .all(|r| r.test_kind(s.planes[0].plane) != TestKind::Free)
    );
}
