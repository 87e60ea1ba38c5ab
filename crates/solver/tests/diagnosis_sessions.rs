//! Concealed effects: sessions simulated with an effect of random parameters are diagnosed
//! with no hint; the right effect must be named, its parameters recovered within the
//! stated tolerances, and the held-out residual brought within 1.5× the noise floor.
//!
//! Sample rate 10 Hz (seed plan, ~9 900 samples) keeps each diagnosis under a second;
//! every effect runs over four seeds and the clean sweep over 40, in CI.

use mtcal_solver::axis::Axis;
use mtcal_solver::diagnosis::{
    DiagnoseOptions, DiagnosisResult, Finding, Verdict, diagnose_session, effects,
};
use mtcal_solver::session::{PlaneRecord, Run, Session};
use mtcal_solver::simulate::{Effect, Plan, SimOptions, random_truth, simulate};
use rand::SeedableRng;
use rand::rngs::StdRng;

pub(crate) const RATE: f64 = 10.0;

fn plan_for(name: &str) -> (Plan, f64) {
    if name == "setup_offset" {
        // Three Z offsets: a wrong riser height on the middle one breaks the arms'
        // proportionality (with two Z offsets it is a re-parameterisation, see docs).
        (
            Plan::custom(
                &[
                    [0.0, 0.0, -100.0],
                    [0.0, 0.0, -200.0],
                    [0.0, 0.0, -300.0],
                    [40.0, 0.0, -100.0],
                ],
                true,
            ),
            5.0,
        )
    } else {
        (Plan::Seed, RATE)
    }
}

fn run(effects: &[&str], seed: u64) -> (Vec<Effect>, DiagnosisResult) {
    let mut rng = StdRng::seed_from_u64(seed ^ 0xeffec7);
    let (plan, rate) = plan_for(effects[0]);
    let effects: Vec<Effect> = effects
        .iter()
        .map(|n| Effect::random(n, &mut rng, rate / 2.0).unwrap())
        .collect();
    let o = SimOptions {
        plan,
        seed,
        sample_rate_hz: rate,
        effects: effects.clone(),
        ..SimOptions::default()
    };
    let out = simulate(&random_truth(seed), &o).unwrap();
    let r = diagnose_session(&out.session, &DiagnoseOptions::default()).unwrap();
    (effects, r)
}

fn close(got: f64, want: f64, rel: f64, abs: f64) -> bool {
    (got - want).abs() <= rel * want.abs() + abs
}

fn param(f: &Finding, k: &str) -> f64 {
    *f.parameters
        .get(k)
        .unwrap_or_else(|| panic!("{} has no {k}: {:?}", f.effect, f.parameters))
}

/// The finding for `e`, checked against its truth with the tolerances of the docs.
fn check(e: &Effect, r: &DiagnosisResult) {
    let ctx = format!("{e:?}\n{r:#?}");
    // Waviness is found by its signature as a periodic straightness error, or, when a
    // polynomial of higher order fits as well, as the model order.
    let name = match e {
        Effect::Waviness { .. } if !r.findings.iter().any(|f| f.effect == "waviness") => {
            "model_order"
        }
        Effect::TemperatureGrowth { .. } => "thermal_drift",
        _ => e.name(),
    };
    let f = r
        .findings
        .iter()
        .find(|f| f.effect == name)
        .unwrap_or_else(|| panic!("{name} not found: {ctx}"));
    for g in r.findings.iter().chain(&r.possible) {
        effects::conforms(g).unwrap();
    }
    let axis = |a: Axis| assert_eq!(f.axis.as_deref(), Some(a.to_string().as_str()), "{ctx}");
    match *e {
        // Lost motion: 3 % + 0.1 µm (reported σ ≈ 0.01-0.02 µm; the rest is the velocity
        // sign at the sample of a reversal).
        Effect::Backlash {
            axis: a,
            lost_motion_um,
        } => {
            axis(a);
            assert!(
                close(param(f, "lost_motion_um"), lost_motion_um, 0.03, 0.1),
                "{ctx}"
            );
        }
        // Lag: 3 % (velocity from set-points at 10 Hz).
        Effect::ServoLag { axis: a, lag_s } => {
            axis(a);
            assert!(close(param(f, "lag_s"), lag_s, 0.03, 0.0), "{ctx}");
        }
        // Spike: height 10 %, decay 20 % (two or three samples per transient at 10 Hz).
        Effect::ReversalSpike {
            axis: a,
            height_um,
            decay_mm,
        } => {
            axis(a);
            assert!(close(param(f, "height_um"), height_um, 0.1, 0.0), "{ctx}");
            assert!(close(param(f, "decay_mm"), decay_mm, 0.2, 0.0), "{ctx}");
        }
        // Cyclic: period 1 %, amplitude 5 % + 0.02 µm.
        Effect::Cyclic {
            axis: a,
            period_mm,
            amplitude_um,
            ..
        } => {
            axis(a);
            assert!(close(param(f, "period_mm"), period_mm, 0.01, 0.0), "{ctx}");
            assert!(
                close(param(f, "amplitude_um"), amplitude_um, 0.05, 0.02),
                "{ctx}"
            );
        }
        // Thermal: a session lasts about one time constant, so T and the scale trade off:
        // T within a factor 2, each axis scale within 40 % + 3 ppm.
        Effect::ThermalDrift {
            time_constant_s,
            scale_ppm,
            ..
        } => {
            let t = param(f, "time_constant_s");
            assert!(
                t > 0.5 * time_constant_s && t < 2.0 * time_constant_s,
                "{ctx}"
            );
            for a in Axis::ALL {
                let k = param(f, &format!("scale_ppm_{a}"));
                assert!(close(k, scale_ppm[a.index()], 0.4, 3.0), "{a}: {ctx}");
            }
        }
        // Setup: Δz within 1.5 mm (≈ 4 reported σ).
        Effect::SetupOffset { delta_mm, .. } => {
            assert!(
                close(param(f, "delta_mm_Z"), delta_mm[2], 0.0, 1.5),
                "{ctx}"
            );
        }
        // Waviness: on the right axis; as a periodic error, with its period within 3 %
        // and its amplitude within 10 % + 0.05 µm.
        Effect::Waviness {
            axis: a,
            period_mm,
            amplitude_um,
            ..
        } => {
            axis(a);
            if f.effect == "waviness" {
                assert!(close(param(f, "period_mm"), period_mm, 0.03, 0.0), "{ctx}");
                assert!(
                    close(param(f, "amplitude_um"), amplitude_um, 0.1, 0.05),
                    "{ctx}"
                );
            }
        }
        // Growth following a logged temperature that rises and falls: the scale per
        // kelvin of every axis within 15 % + 1 ppm/K (offsets per kelvin are mostly taken
        // by the run offsets: only their change within a run is seen).
        Effect::TemperatureGrowth {
            scale_ppm_per_k, ..
        } => {
            for a in Axis::ALL {
                let k = param(f, &format!("scale_ppm_per_k_{a}"));
                assert!(
                    close(k, scale_ppm_per_k[a.index()], 0.15, 1.0),
                    "{a}: {ctx}"
                );
            }
        }
        // Velocity coupling (outside the named catalogue): the moving axis named, the
        // coefficient within 5 %, the signature in words.
        Effect::VelocityCoupling {
            axis: a,
            direction,
            coefficient_um_per_mm_s,
        } => {
            // The error's own axis, and the axis whose velocity it follows.
            axis(direction);
            assert_eq!(
                f.depends_on.as_deref(),
                Some(a.to_string().as_str()),
                "{ctx}"
            );
            assert!(
                close(
                    param(f, "coefficient_um_per_mm_s"),
                    coefficient_um_per_mm_s,
                    0.05,
                    0.0
                ),
                "{ctx}"
            );
            assert_eq!(
                f.signature.as_deref(),
                Some(format!("a {direction} error that follows the {a} velocity").as_str())
            );
        }
        // Vibration: direction, frequency 0.2 %, amplitude 5 % + 0.02 µm.
        Effect::Vibration {
            direction,
            amplitude_um,
            frequency_hz,
            ..
        } => {
            axis(direction);
            assert!(
                close(param(f, "frequency_hz"), frequency_hz, 0.002, 0.0),
                "{ctx}"
            );
            assert!(
                close(param(f, "amplitude_um"), amplitude_um, 0.05, 0.02),
                "{ctx}"
            );
        }
    }
}

fn concealed(name: &str, seeds: &[u64]) {
    for &seed in seeds {
        let (effects, r) = run(&[name], seed);
        check(&effects[0], &r);
        assert_ne!(r.verdict, Verdict::Consistent);
        let last = r.findings.last().unwrap();
        let floor = r.baseline.noise_estimate_um;
        assert!(
            last.heldout_rms_um.after <= 1.5 * floor,
            "{name} seed {seed}: held-out {} floor {floor}",
            last.heldout_rms_um.after
        );
        assert!(last.heldout_rms_um.after < r.baseline.heldout_rms_um);
    }
}

#[test]
fn concealed_backlash() {
    concealed("backlash", &[1]);
}

#[test]
fn concealed_servo_lag() {
    concealed("servo_lag", &[2]);
}

#[test]
fn concealed_reversal_spike() {
    concealed("reversal_spike", &[3]);
}

#[test]
fn concealed_cyclic() {
    concealed("cyclic", &[4]);
}

#[test]
fn concealed_thermal_drift() {
    concealed("thermal_drift", &[5]);
}

#[test]
fn concealed_setup_offset() {
    concealed("setup_offset", &[6]);
}

#[test]
fn concealed_waviness() {
    concealed("waviness", &[7]);
}

#[test]
fn concealed_vibration() {
    concealed("vibration", &[8]);
}

/// Thermal growth that rises and then falls with a logged temperature (a monotonic
/// first-order drift in time cannot follow it).
#[test]
fn concealed_temperature_growth() {
    concealed("temperature_growth", &[10]);
}

#[test]
fn concealed_velocity_coupling() {
    concealed("velocity_coupling", &[9]);
}

/// A session with one known effect, no hint given.
fn diagnose_with(effect: Effect, seed: u64) -> DiagnosisResult {
    diagnose_session(
        &session_with(seed, RATE, vec![effect]),
        &DiagnoseOptions::default(),
    )
    .unwrap()
}

/// Outside the named catalogue: a Y error periodic in X with period 16 mm (a guideway
/// waviness six times finer than the travel, which no polynomial of the model follows) is
/// found by its signature, modelled, and proven on held-out runs.
#[test]
fn periodic_straightness_found_by_signature() {
    let r = diagnose_with(
        Effect::Waviness {
            axis: Axis::X,
            direction: Axis::Y,
            amplitude_um: 0.7,
            period_mm: 16.0,
            phase_rad: 1.0,
        },
        41,
    );
    let f = r
        .findings
        .iter()
        .find(|f| f.effect == "waviness")
        .unwrap_or_else(|| panic!("{r:#?}"));
    assert_eq!(
        f.signature.as_deref(),
        Some("a Y error periodic in the X position (period 16.0 mm)"),
        "{r:#?}"
    );
    assert!(close(param(f, "period_mm"), 16.0, 0.01, 0.0), "{r:#?}");
    assert!(close(param(f, "amplitude_um"), 0.7, 0.1, 0.03), "{r:#?}");
    assert!(f.heldout_rms_um.after < 0.8 * f.heldout_rms_um.before);
    assert_eq!(r.verdict, Verdict::Explained, "{r:#?}");
    effects::conforms(f).unwrap();
}

/// The wavy straightness of the issue (EYX, 0.8 µm at a 35 mm period): identification's
/// residual is above its floor, and the diagnosis, on the same floor, finds and names it
/// instead of answering "consistent".
#[test]
fn wavy_straightness_found_and_named() {
    let r = diagnose_with(
        Effect::Waviness {
            axis: Axis::X,
            direction: Axis::Y,
            amplitude_um: 0.8,
            period_mm: 35.0,
            phase_rad: 0.3,
        },
        42,
    );
    assert_ne!(r.verdict, Verdict::Consistent, "{r:#?}");
    assert_eq!(r.findings.len(), 1, "{r:#?}");
    let f = &r.findings[0];
    assert_eq!(f.effect, "waviness", "{r:#?}");
    assert_eq!(f.axis.as_deref(), Some("X"));
    assert_eq!(
        f.signature.as_deref(),
        Some("a Y error periodic in the X position (period 35.0 mm)"),
        "{r:#?}"
    );
    assert!(close(param(f, "period_mm"), 35.0, 0.01, 0.0), "{r:#?}");
    assert!(close(param(f, "amplitude_um"), 0.8, 0.05, 0.02), "{r:#?}");
    assert!(
        f.heldout_rms_um.after <= 1.2 * r.baseline.noise_estimate_um,
        "{r:#?}"
    );
}

/// Thermal growth with a time constant thirty times the session: the drift is a straight
/// line in time, so its time constant and scale trade off and the data cannot tell them.
/// The effect is listed as possible, undetermined, with what would decide it, and does
/// not count as a finding.
#[test]
fn undetermined_thermal_is_reported_as_possible() {
    let r = diagnose_with(
        Effect::ThermalDrift {
            time_constant_s: 60_000.0,
            offset_um: [20.0, -20.0, 10.0],
            scale_ppm: [250.0, -250.0, 200.0],
        },
        43,
    );
    let p = r
        .possible
        .iter()
        .find(|f| f.effect == "thermal_drift")
        .unwrap_or_else(|| panic!("{r:#?}"));
    let open = p
        .undetermined
        .iter()
        .find(|u| u.name == "time_constant_s")
        .unwrap_or_else(|| panic!("{p:#?}"));
    assert!(
        open.decide.contains("several time constants long"),
        "{open:?}"
    );
    // Undetermined: σ above half the value (the data cannot tell it), and not reported
    // among the determined parameters.
    assert!(open.std.is_none_or(|sd| sd > 0.5 * open.value), "{open:?}");
    assert!(!p.parameters.contains_key("time_constant_s"), "{p:#?}");
    assert!(
        r.findings.iter().all(|f| f.effect != "thermal_drift"),
        "{r:#?}"
    );
}

/// Every effect over three more seeds, on all cores.
#[test]
fn concealed_effects_more_seeds() {
    let jobs: Vec<u64> = (0..mtcal_solver::simulate::effects::EFFECT_NAMES.len() as u64).collect();
    par_map(&jobs, |i| {
        concealed(
            mtcal_solver::simulate::effects::EFFECT_NAMES[i as usize],
            &[11, 12, 13],
        )
    });
}

/// Two effects at once are separated: both named with their parameters.
#[test]
fn two_effects_are_separated() {
    for (pair, seed) in [
        (["backlash", "cyclic"], 21),
        (["vibration", "servo_lag"], 22),
        // Backlash and thermal growth together: the growth is not left unreported once
        // the backlash is found (one noise floor, independent of the model).
        (["backlash", "thermal_drift"], 23),
    ] {
        let (effects, r) = run(&pair, seed);
        for e in &effects {
            check(e, &r);
        }
        assert_eq!(r.verdict, Verdict::Explained, "{r:#?}");
    }
}

/// A clean session: consistent, no finding, no mismatch.
fn clean(seed: u64) -> DiagnosisResult {
    let o = SimOptions {
        seed,
        sample_rate_hz: RATE,
        ..SimOptions::default()
    };
    let out = simulate(&random_truth(seed), &o).unwrap();
    diagnose_session(&out.session, &DiagnoseOptions::default()).unwrap()
}

#[test]
fn clean_sessions_are_consistent() {
    for seed in 100..104 {
        let r = clean(seed);
        assert_eq!(r.verdict, Verdict::Consistent, "{r:#?}");
        assert!(r.findings.is_empty() && r.mismatch.is_empty());
        // The noise floor from repeated passes recovers σ = 0.15 within 5 %
        // (≈ 6 000 differences: 1σ of a MAD estimate ≈ 1.1 %).
        assert!((r.baseline.noise_estimate_um / 0.15 - 1.0).abs() < 0.05);
    }
}

/// `f(seed)` for every seed, on all cores (each diagnosis is single-threaded).
pub(crate) fn par_map<T: Send>(seeds: &[u64], f: impl Fn(u64) -> T + Sync) -> Vec<T> {
    let threads = std::thread::available_parallelism().map_or(2, |n| n.get());
    let chunk = seeds.len().div_ceil(threads).max(1);
    std::thread::scope(|s| {
        let handles: Vec<_> = seeds
            .chunks(chunk)
            .map(|c| s.spawn(|| c.iter().map(|&x| f(x)).collect::<Vec<T>>()))
            .collect();
        handles
            .into_iter()
            .flat_map(|h| h.join().expect("worker"))
            .collect()
    })
}

/// ≥ 95 % of 40 clean seeds with twice the default noise (σ = 0.3 µm) give `consistent`
/// with no finding: neither the global ratio nor the local scan (its family-wise
/// false-alarm rate 0.1 %) raises a false alarm.
#[test]
fn clean_sessions_at_twice_the_noise_are_consistent_in_95_percent_of_40_seeds() {
    let seeds: Vec<u64> = (200..240).collect();
    let results = par_map(&seeds, |seed| {
        let o = SimOptions {
            seed,
            sample_rate_hz: RATE,
            noise_um: 0.3,
            ..SimOptions::default()
        };
        let out = simulate(&random_truth(seed), &o).unwrap();
        let r = diagnose_session(&out.session, &DiagnoseOptions::default()).unwrap();
        let ok = r.verdict == Verdict::Consistent && r.findings.is_empty();
        (seed, ok, r)
    });
    let bad: Vec<String> = results
        .iter()
        .filter(|(_, ok, _)| !ok)
        .map(|(s, _, r)| {
            format!(
                "seed {s}: {:?} {:?} {:?}",
                r.verdict, r.findings, r.unexplained
            )
        })
        .collect();
    assert!(
        bad.len() <= 2,
        "{} of 40 not consistent: {bad:#?}",
        bad.len()
    );
}

/// Progress: the callback sees the phases in order with fractions that start at 0, never
/// decrease and end at 1, and the result is the one without a callback.
#[test]
fn progress_is_reported_through_the_phases() {
    let o = SimOptions {
        seed: 5,
        sample_rate_hz: RATE,
        effects: vec![Effect::Backlash {
            axis: Axis::Y,
            lost_motion_um: 2.0,
        }],
        ..SimOptions::default()
    };
    let out = simulate(&random_truth(5), &o).unwrap();
    let mut seen: Vec<(String, f64)> = Vec::new();
    let r = mtcal_solver::diagnosis::diagnose_session_with_progress(
        &out.session,
        &DiagnoseOptions::default(),
        &mut |phase: &str, f: f64| seen.push((phase.to_string(), f)),
    )
    .unwrap();
    assert_eq!(
        r,
        diagnose_session(&out.session, &DiagnoseOptions::default()).unwrap()
    );
    assert_eq!(seen.first().unwrap().1, 0.0);
    assert_eq!(seen.last().unwrap(), &("done".to_string(), 1.0));
    assert!(seen.windows(2).all(|w| w[1].1 >= w[0].1), "{seen:?}");
    let phase = |p: &str| seen.iter().position(|(s, _)| s.starts_with(p));
    let order: Vec<usize> = [
        "reducing the rigid model",
        "noise floor",
        "round 1 of candidates",
        "refitting with backlash Y",
        "round 2 of candidates",
        "report",
    ]
    .iter()
    .map(|p| phase(p).unwrap_or_else(|| panic!("no phase {p}: {seen:?}")))
    .collect();
    assert!(order.windows(2).all(|w| w[0] < w[1]), "{order:?}");
    // Intermediate fractions, not only the ends.
    assert!(seen.iter().filter(|(_, f)| *f > 0.1 && *f < 0.95).count() > 20);
}

/// A clean simulated session at `rate` Hz with the seed plan.
pub(crate) fn clean_session(seed: u64, rate: f64) -> Session {
    session_with(seed, rate, Vec::new())
}

/// The seed plan's session of `seed`'s random machine at `rate` Hz with `effects` made by
/// the simulator.
pub(crate) fn session_with(seed: u64, rate: f64, effects: Vec<Effect>) -> Session {
    let o = SimOptions {
        plan: Plan::Seed,
        seed,
        sample_rate_hz: rate,
        effects,
        ..SimOptions::default()
    };
    simulate(&random_truth(seed), &o).unwrap().session
}

/// Adds `e(run, i)` µm to the reading along `dir` of every sample: an effect made in the
/// test, outside the simulator and its catalogue of effects.
pub(crate) fn add_error(session: &mut Session, dir: Axis, e: impl Fn(&Run, usize) -> f64) {
    for p in &mut session.planes {
        let (u, v) = p.plane.axes();
        for run in &mut p.runs {
            let add: Vec<f64> = (0..run.t_s.len()).map(|i| e(run, i)).collect();
            let reading = if u == dir {
                &mut run.du_um
            } else if v == dir {
                &mut run.dv_um
            } else {
                continue;
            };
            reading.iter_mut().zip(&add).for_each(|(r, x)| *r += x);
        }
    }
}

/// Per sample of `run`: the sign of axis `a`'s last travel and the travel since it last
/// reversed (mm), from the set-points alone (before the first move: the first move's
/// sign, travel counted from the start).
fn direction_and_travel(run: &Run, a: usize) -> Vec<(f64, f64)> {
    let q: Vec<f64> = run.pos_mm.iter().map(|p| p[a]).collect();
    let first = q
        .windows(2)
        .map(|w| w[1] - w[0])
        .find(|d| d.abs() > 1e-9)
        .map_or(1.0, f64::signum);
    let (mut d, mut s) = (first, 0.0);
    let mut out = vec![(d, s)];
    for w in q.windows(2) {
        let step = w[1] - w[0];
        if step.abs() > 1e-9 {
            if step.signum() != d {
                (d, s) = (step.signum(), 0.0);
            }
            s += step.abs();
        }
        out.push((d, s));
    }
    out
}

/// A sideways shift at each X reversal (a carriage that shifts across its guideway when
/// its drive reverses), made in the test and not by the simulator: the Y error is
/// c·d·(1 − 2·e^(−s/w)), continuous through each reversal and settling to ±c over
/// w = 0.5 mm of travel. The candidate's clearance is taken up linearly over a travel
/// the data choose (`take_up_mm`): it is found by its signature, proven on held-out
/// runs, with the shift within 3σ of 2c and a take-up of the order of the settling
/// (between w and 4w: a linear ramp that follows an exponential over its first 2–3 w).
/// (Before the take-up, the sharp model's form did not hold near the reversals and the
/// finding was only possible.)
#[test]
fn a_sideways_shift_at_reversal_made_outside_the_simulator_is_found_by_signature() {
    let c = 0.5;
    let mut session = clean_session(51, RATE);
    add_error(&mut session, Axis::Y, |run, i| {
        let (d, s) = direction_and_travel(run, 0)[i];
        c * d * (1.0 - 2.0 * (-s / 0.5).exp())
    });
    let r = diagnose_session(&session, &DiagnoseOptions::default()).unwrap();
    let f = r
        .findings
        .iter()
        .find(|f| f.effect == "direction_coupling")
        .unwrap_or_else(|| panic!("{r:#?}"));
    assert_eq!(f.axis.as_deref(), Some("Y"), "{r:#?}");
    assert_eq!(f.depends_on.as_deref(), Some("X"), "{r:#?}");
    assert_eq!(
        f.signature.as_deref(),
        Some("a Y error that flips with the X direction of travel"),
        "{r:#?}"
    );
    let (shift, sd) = (param(f, "shift_um"), param(f, "std_shift_um"));
    assert!((shift.abs() - 2.0 * c).abs() <= 3.0 * sd, "{f:#?}");
    let take_up = param(f, "take_up_mm");
    assert!((0.5..=2.0).contains(&take_up), "{f:#?}");
    assert!(
        f.heldout_rms_um.after < 0.8 * f.heldout_rms_um.before,
        "{r:#?}"
    );
    assert!(
        r.possible.iter().all(|p| p.effect != "direction_coupling"),
        "{r:#?}"
    );
    assert_ne!(r.verdict, Verdict::Consistent, "{r:#?}");
    effects::conforms(f).unwrap();
}

/// Physics outside the signature space: a Y error proportional to the X acceleration (an
/// inertial deflection at the feed ramps; no source of the space is an acceleration),
/// 0.5 µm RMS, made in the test. Whatever the diagnosis says, it
/// does not absorb the effect into parameters that make no physical sense (the failure of
/// a 216 µm thermal offset and a 0.02 Hz "vibration" explaining a sub-micrometre misfit):
/// no time-bound effect is reported, no reported length exceeds 10 µm, the misfit is
/// located, and what is not explained is said, with where.
#[test]
fn an_effect_outside_the_signature_space_is_not_absorbed_into_absurd_parameters() {
    let accel = |run: &Run, i: usize| {
        let n = run.t_s.len();
        let v = |j: usize| {
            let (a, b) = (j.saturating_sub(1), (j + 1).min(n - 1));
            (run.pos_mm[b][0] - run.pos_mm[a][0]) / (run.t_s[b] - run.t_s[a]).max(1e-9)
        };
        let (a, b) = (i.saturating_sub(1), (i + 1).min(n - 1));
        (v(b) - v(a)) / (run.t_s[b] - run.t_s[a]).max(1e-9)
    };
    let mut session = clean_session(52, RATE);
    // Scaled to 0.5 µm RMS over the samples that read Y (it is nonzero on the ramps only).
    let (ss, n) = session
        .planes
        .iter()
        .filter(|p| [p.plane.axes().0, p.plane.axes().1].contains(&Axis::Y))
        .flat_map(|p| &p.runs)
        .flat_map(|run| (0..run.t_s.len()).map(move |i| accel(run, i)))
        .fold((0.0, 0usize), |(ss, n), a| (ss + a * a, n + 1));
    let k = 0.5 / (ss / n as f64).sqrt();
    add_error(&mut session, Axis::Y, |run, i| k * accel(run, i));
    let r = diagnose_session(&session, &DiagnoseOptions::default()).unwrap();
    assert_ne!(r.verdict, Verdict::Consistent, "{r:#?}");
    assert!(!r.mismatch.is_empty(), "the misfit is located: {r:#?}");
    for f in &r.findings {
        assert!(
            !matches!(f.effect.as_str(), "thermal_drift" | "vibration"),
            "a time-bound effect absorbed a position-bound one: {f:#?}"
        );
        for (name, v) in &f.parameters {
            if name.ends_with("_um") && !name.starts_with("std_") {
                assert!(v.abs() < 10.0, "{name} = {v} in {f:#?}");
            }
        }
    }
    if r.verdict != Verdict::Explained {
        assert!(
            r.unexplained
                .iter()
                .any(|u| u.contains("misfit concentrates in")),
            "{r:#?}"
        );
    }
}

/// The 0.8 µm vibration at 7 Hz (sampled at 20 Hz) that once raised the floor and was
/// called "consistent": the floor stays at the noise (0.15 µm within 10 %), the vibration
/// is found at 7 Hz along X with its amplitude, and the session is explained.
#[test]
fn a_7_hz_vibration_is_found_not_taken_for_noise() {
    let o = SimOptions {
        seed: 53,
        sample_rate_hz: 20.0,
        effects: vec![Effect::Vibration {
            direction: Axis::X,
            amplitude_um: 0.8,
            frequency_hz: 7.0,
            phase_rad: 0.0,
        }],
        ..SimOptions::default()
    };
    let out = simulate(&random_truth(53), &o).unwrap();
    let r = diagnose_session(&out.session, &DiagnoseOptions::default()).unwrap();
    assert!(
        close(r.baseline.noise_estimate_um, 0.15, 0.1, 0.0),
        "{:?}",
        r.baseline
    );
    let f = r
        .findings
        .iter()
        .find(|f| f.effect == "vibration")
        .unwrap_or_else(|| panic!("{r:#?}"));
    assert_eq!(f.axis.as_deref(), Some("X"));
    assert!(close(param(f, "frequency_hz"), 7.0, 0.002, 0.0), "{f:#?}");
    assert!(close(param(f, "amplitude_um"), 0.8, 0.05, 0.02), "{f:#?}");
    assert_eq!(r.verdict, Verdict::Explained, "{r:#?}");
}

/// Adds a lost motion b(q) of `axis` to the readings along it: −d·b(q)/2 with d the sign
/// of the axis's last travel carried through each file (the unrecorded approach moves
/// between runs included; before the file's first move, the opposite of it). Made in the
/// test, not by the simulator.
pub(crate) fn add_lost_motion(session: &mut Session, axis: Axis, b: impl Fn(f64) -> f64) {
    let a = axis.index();
    for p in &mut session.planes {
        let (u, v) = p.plane.axes();
        let travel = travel_through_file(p, a);
        for (run, dir) in p.runs.iter_mut().zip(travel) {
            for (i, (d, _)) in dir.into_iter().enumerate() {
                let e = -d * b(run.pos_mm[i][a]) / 2.0;
                if u == axis {
                    run.du_um[i] += e;
                } else if v == axis {
                    run.dv_um[i] += e;
                }
            }
        }
    }
}

/// Per run of `plane`, per sample: the sign d of axis `a`'s last travel and its travel s
/// since it last reversed (mm), from the set-points, carried through the file (the
/// unrecorded approach moves between runs included). Before the file's first move d is
/// the opposite of that move (the approach came from the other side) and s is infinite;
/// the first move is a reversal.
pub(crate) fn travel_through_file(plane: &PlaneRecord, a: usize) -> Vec<Vec<(f64, f64)>> {
    let all: Vec<f64> = plane
        .runs
        .iter()
        .flat_map(|r| r.pos_mm.iter().map(|q| q[a]))
        .collect();
    let first = all
        .windows(2)
        .map(|w| w[1] - w[0])
        .find(|d| d.abs() > 1e-9)
        .map_or(1.0, f64::signum);
    let (mut d, mut s) = (-first, f64::INFINITY);
    let mut last = all.first().copied().unwrap_or(0.0);
    plane
        .runs
        .iter()
        .map(|run| {
            run.pos_mm
                .iter()
                .map(|q| {
                    let step = q[a] - last;
                    if step.abs() > 1e-9 {
                        if step.signum() != d {
                            (d, s) = (step.signum(), 0.0);
                        }
                        s += step.abs();
                    }
                    last = q[a];
                    (d, s)
                })
                .collect()
        })
        .collect()
}

/// The misfit of a backlash of Y (4 µm) and of Z (3 µm), made in the test, is located at
/// the Y and the Z reversals: the largest places of the rigid model's misfit are circle
/// sectors where Y or Z reverses, or the Y or Z line passes after their reversals, and the
/// runs listed under them are circles or passes of those axes; no place is a fifth of
/// the session time (the misfit does not follow time).
#[test]
fn a_y_and_z_backlash_is_located_at_the_y_and_z_reversals() {
    let mut session = clean_session(62, RATE);
    add_lost_motion(&mut session, Axis::Y, |_| 4.0);
    add_lost_motion(&mut session, Axis::Z, |_| 3.0);
    let r = diagnose_session(&session, &DiagnoseOptions::default()).unwrap();
    // The places finer than a whole file's test (an angle, a stretch of travel, a time):
    // the largest is at Y or Z reversals.
    let fine: Vec<&str> = r
        .mismatch
        .iter()
        .map(|m| m.where_.as_str())
        .filter(|w| !w.ends_with(" runs"))
        .collect();
    assert!(
        fine.first()
            .is_some_and(|w| w.contains("(Y reverses)") || w.contains("(Z reverses)")),
        "{:#?}",
        r.mismatch
    );
    for m in &r.mismatch {
        assert!(!m.where_.contains("(X reverses)"), "{:#?}", r.mismatch);
    }
    assert!(
        r.mismatch.iter().any(|m| m.where_.contains("Y reverses")),
        "{:#?}",
        r.mismatch
    );
    assert!(
        r.mismatch.iter().any(|m| m.where_.contains("Z reverses")),
        "{:#?}",
        r.mismatch
    );
    assert!(
        !r.mismatch
            .iter()
            .any(|m| m.where_.starts_with("session time")),
        "{:#?}",
        r.mismatch
    );
    for name in ["Y", "Z"] {
        assert!(
            r.findings
                .iter()
                .any(|f| f.effect.contains("lost_motion") || f.effect == "backlash")
                && r.findings.iter().any(|f| f.axis.as_deref() == Some(name)),
            "{name}: {r:#?}"
        );
    }
}

/// A worn screw, made in the test (outside the simulator's catalogue): the X lost motion
/// is 2 µm at the ends of the travel and 8 µm in the middle, b(x) = 8 − 6·(x/50)², the
/// X reading offset by −d·b(x)/2 with d the sign of the last X travel carried through
/// each file (the unrecorded approach moves between runs included; before the file's
/// first move, the opposite of it). It is found as a position-dependent lost motion, not
/// as a servo lag or a reversal spike: its profile within 0.3 µm of b at five points of
/// the travel and within 3σ + 0.1 µm, its variation along the travel within 10 %, of
/// the order of b (2: the data choose it among 2 … 9, a higher order would not lower
/// both the BIC and the held-out sum), and the finding says how the constant and varying
/// parts share it.
#[test]
fn a_worn_screw_is_found_as_lost_motion_varying_along_the_travel() {
    let b = |x: f64| 8.0 - 6.0 * (x / 50.0).powi(2);
    let (r, f) = x_lost_motion_profile(61, &b, 0.1);
    let f = &f;
    assert_eq!(param(f, "order"), 2.0, "{f:#?}");
    assert!(
        !r.findings.iter().any(|f| matches!(
            f.effect.as_str(),
            "servo_lag" | "reversal_spike" | "backlash"
        )),
        "{r:#?}"
    );
    for n in 1..=5 {
        let (x, got) = (
            param(f, &format!("target_mm_{n}")),
            param(f, &format!("lost_motion_um_{n}")),
        );
        assert!(
            (got - b(x)).abs() <= 0.3,
            "x {x}: {got} vs {}: {f:#?}",
            b(x)
        );
    }
    // RMS of b about its mean over the five points 0, ±25, ±50 mm: b = 8, 6.5, 2.
    let pts = [2.0, 6.5, 8.0, 6.5, 2.0];
    let m = pts.iter().sum::<f64>() / 5.0;
    let var = (pts.iter().map(|v| (v - m) * (v - m)).sum::<f64>() / 5.0).sqrt();
    assert!(close(param(f, "variation_um"), var, 0.1, 0.0), "{f:#?}");
    assert!(
        f.evidence.contains("varying along the travel"),
        "{}",
        f.evidence
    );
    assert!(f.physics.contains("worn"), "{}", f.physics);
    effects::conforms(f).unwrap();
    assert_ne!(r.verdict, Verdict::Consistent);
}

/// A pitch error of the screw that changes the lost motion's sign along the travel,
/// made in the test as b(x) = −1 + 6·tanh(x/25) µm on the X travel [−50, 50] mm (no
/// polynomial: a profile of order 2 was off by tens of its σ at the five points). The
/// data choose a higher order (4 … 9) and the profile holds at the five points within 3σ
/// + 0.05 µm.
#[test]
fn a_lost_motion_changing_sign_along_the_travel_takes_the_order_the_data_choose() {
    let b = |x: f64| -1.0 + 6.0 * (x / 25.0).tanh();
    let (_, f) = x_lost_motion_profile(62, &b, 0.05);
    let order = param(&f, "order");
    assert!((4.0..=9.0).contains(&order), "{f:#?}");
    effects::conforms(&f).unwrap();
}

/// A lost motion b(x) of X made in the test (`add_lost_motion`) on the clean session of
/// `seed`, diagnosed: the result and its `lost_motion_profile` finding of X, whose
/// profile is within 3σ + `tol` µm of b at each of its five points.
fn x_lost_motion_profile(
    seed: u64,
    b: &dyn Fn(f64) -> f64,
    tol: f64,
) -> (DiagnosisResult, Finding) {
    let mut session = clean_session(seed, RATE);
    add_lost_motion(&mut session, Axis::X, b);
    let r = diagnose_session(&session, &DiagnoseOptions::default()).unwrap();
    let f = r
        .findings
        .iter()
        .find(|f| f.effect == "lost_motion_profile")
        .cloned()
        .unwrap_or_else(|| panic!("{r:#?}"));
    assert_eq!(f.axis.as_deref(), Some("X"), "{r:#?}");
    for n in 1..=5 {
        let x = param(&f, &format!("target_mm_{n}"));
        let (got, sd) = (
            param(&f, &format!("lost_motion_um_{n}")),
            param(&f, &format!("std_lost_motion_um_{n}")),
        );
        assert!(
            (got - b(x)).abs() <= 3.0 * sd + tol,
            "x {x}: {got} ± {sd} vs {}: {f:#?}",
            b(x)
        );
    }
    (r, f)
}

/// The commanded position of axis `a` in `run` at time `t` (s): the Catmull-Rom spline
/// through the run's set-points (a path with continuous velocity, as an interpolator
/// makes it), held at the first set-point before the run.
pub(crate) fn commanded_at(run: &Run, a: usize, t: f64) -> f64 {
    let (ts, n) = (&run.t_s, run.t_s.len());
    let p = |i: isize| run.pos_mm[i.clamp(0, n as isize - 1) as usize][a];
    if t <= ts[0] {
        return p(0);
    }
    let i = ts.partition_point(|&x| x <= t).min(n - 1).max(1) as isize - 1;
    let (t0, t1) = (ts[i as usize], ts[(i + 1) as usize]);
    let u = ((t - t0) / (t1 - t0)).clamp(0.0, 1.0);
    let (p0, p1, p2, p3) = (p(i - 1), p(i), p(i + 1), p(i + 2));
    0.5 * (2.0 * p1
        + (p2 - p0) * u
        + (2.0 * p0 - 5.0 * p1 + 4.0 * p2 - p3) * u * u
        + (3.0 * p1 - p0 - 3.0 * p2 + p3) * u * u * u)
}

/// The error (µm) along axis `a` of a servo that follows its commanded path with a delay
/// `tau` (s), at sample `i` of `run`: on a circle (a smooth path),
/// (x(t − τ) − x(t))·1000 with x the Catmull-Rom spline through the set-points; on a line,
/// whose set-points move at a constant feed and stop between two samples (a spline
/// overshoots there), −τ·v·1000 with v the feed at the sample (0 at rest on either side).
pub(crate) fn delayed(run: &Run, a: usize, i: usize, tau: f64) -> f64 {
    if is_circle(run) {
        let t = run.t_s[i];
        return (commanded_at(run, a, t - tau) - commanded_at(run, a, t)) * 1000.0;
    }
    let v = mtcal_solver::diagnosis::design::velocity(&run.t_s, &run.pos_mm, i)[a];
    -tau * v * 1000.0
}

/// Whether `run` is a circle test.
pub(crate) fn is_circle(run: &Run) -> bool {
    run.test.is_some_and(|t| t.is_circle())
}

/// A servo that follows its commanded path with a pure delay τ, made in the test (not by
/// the simulator's `servo_lag`, whose error is −τ·v alone): the X reading is offset on
/// the circles by (x(t − τ) − x(t))·1000 µm, x the commanded path through the set-points
/// (a Catmull-Rom spline), i.e. −τ·v + τ²·a/2 − …, whose second-order term during the
/// circles' acceleration is a transient after each X reversal, and on the lines by −τ
/// times their feed. At 3 ms and at 1 ms, over six seeds: no reversal spike (found or
/// possible) and no other finding, a servo lag of X within 5 % and 3σ of τ in every
/// seed and within 2σ in at least 5 of 6.
#[test]
fn a_servo_delay_made_outside_the_simulator_adds_no_reversal_spike() {
    for tau in [3e-3, 1e-3] {
        let out = par_map(&[71, 72, 73, 74, 75, 76], |seed| {
            let mut session = clean_session(seed, RATE);
            add_error(&mut session, Axis::X, |run, i| delayed(run, 0, i, tau));
            diagnose_session(&session, &DiagnoseOptions::default()).unwrap()
        });
        let mut within = 0;
        for r in &out {
            assert!(
                !r.findings
                    .iter()
                    .chain(&r.possible)
                    .any(|f| f.effect == "reversal_spike"),
                "{tau}: {r:#?}"
            );
            assert_eq!(r.findings.len(), 1, "{tau}: {r:#?}");
            let f = r
                .findings
                .iter()
                .find(|f| f.effect == "servo_lag")
                .unwrap_or_else(|| panic!("{tau}: {r:#?}"));
            assert_eq!(f.axis.as_deref(), Some("X"));
            let (got, sd) = (param(f, "lag_s"), param(f, "std_lag_s"));
            assert!(close(got, tau, 0.05, 0.0), "{tau}: {got} ± {sd}");
            assert!((got - tau).abs() <= 3.0 * sd, "{tau}: {got} ± {sd}");
            within += usize::from((got - tau).abs() <= 2.0 * sd);
            effects::conforms(f).unwrap();
        }
        // The starts and stops of the motion, where the delay made here and the model's
        // velocity differ, are the lag's nuisance (docs/diagnosis-catalogue.md, "Servo lag:
        // what holds"); before, the lag read up to 2.7σ low, within 2σ in 4 of 6 seeds.
        assert!(within >= 5, "{tau}: {within} of 6 within 2σ");
    }
}

/// z = (estimate − truth)/σ of a parameter `name` a finding reports with its σ (`None`:
/// not reported with one). Where the finding reports the parameter's 2σ interval
/// (`{name}_low`, `{name}_high`: a thermal drift's time constant, from its profile,
/// often asymmetric), σ is half the distance to the bound on the truth's side, so that
/// |z| ≤ 2 exactly when the truth is within the interval (an absent upper bound: open).
pub(crate) fn z_of(f: &Finding, name: &str, want: f64) -> Option<f64> {
    let v = *f.parameters.get(name)?;
    let sd = *f.parameters.get(&format!("std_{name}"))?;
    let bound = |side: &str| f.parameters.get(&format!("{name}_{side}")).copied();
    let half = match (bound("low"), bound("high")) {
        (Some(lo), _) if want <= v => 0.5 * (v - lo),
        (Some(_), hi) if want > v => 0.5 * (hi.unwrap_or(f64::INFINITY) - v),
        _ => sd,
    };
    Some((v - want) / half)
}
