//! The result documents of a fixed set of simulated sessions, written to a directory, to
//! show that a change of the diagnosis's speed changes no result: run it before and after
//! the change and compare the two directories byte for byte
//! (`scripts/diagnose-identity` does both and the comparison).
//!
//! `cargo run --release -p mtcal-solver --example diagnose_identity -- DIR`
//!
//! The sessions (seed plan at 10 Hz, two seeds each): clean; every effect of the
//! simulator alone; three pairs of effects together; and four made outside the simulator
//! on a clean session: a lasting step of 3 µm in the X readings from the middle of one
//! run on (that file's later runs included), a burst (a 2 µm,
//! 3 Hz oscillation over 2 s of one run), a worn screw (an X lost motion of
//! 8 − 6·(x/50)² µm) and a growth of 4 µm/K along Z following a logged temperature
//! (a rise and fall of 2 K, sensor noise 5 mK).
use mtcal_solver::axis::Axis;
use mtcal_solver::diagnosis::{DiagnoseOptions, diagnose_session};
use mtcal_solver::session::Session;
use mtcal_solver::simulate::{Effect, Plan, SimOptions, random_truth, simulate};
use rand::SeedableRng;
use rand::rngs::StdRng;
use rand_distr::Distribution;

const RATE: f64 = 10.0;

fn session(effects: &[&str], seed: u64) -> Session {
    let mut rng = StdRng::seed_from_u64(seed ^ 0xeffec7);
    let effects: Vec<Effect> = effects
        .iter()
        .map(|n| Effect::random(n, &mut rng, RATE / 2.0).expect("effect"))
        .collect();
    let o = SimOptions {
        plan: Plan::Seed,
        seed,
        sample_rate_hz: RATE,
        effects,
        ..SimOptions::default()
    };
    simulate(&random_truth(seed), &o).expect("simulate").session
}

/// Adds `f(t, x, y, z)` (µm) to every reading along `axis`.
fn add_along(s: &mut Session, axis: Axis, f: impl Fn(usize, f64, [f64; 3]) -> f64) {
    for (pi, p) in s.planes.iter_mut().enumerate() {
        let (u, v) = p.plane.axes();
        for (ri, r) in p.runs.iter_mut().enumerate() {
            for i in 0..r.t_s.len() {
                let e = f(pi * 1000 + ri, r.t_s[i], r.pos_mm[i]);
                if u == axis {
                    r.du_um[i] += e;
                }
                if v == axis {
                    r.dv_um[i] += e;
                }
            }
        }
    }
}

/// The first run (plane index·1000 + run index) of the first plane reading `axis`, with
/// its middle time.
fn a_run(s: &Session, axis: Axis) -> (usize, f64) {
    for (pi, p) in s.planes.iter().enumerate() {
        let (u, v) = p.plane.axes();
        if u == axis || v == axis {
            let ri = p.runs.len() / 2;
            let t = &p.runs[ri].t_s;
            return (pi * 1000 + ri, 0.5 * (t[0] + t[t.len() - 1]));
        }
    }
    panic!("no run reads {axis}")
}

fn main() {
    let dir = std::env::args().nth(1).expect("output directory");
    std::fs::create_dir_all(&dir).expect("output directory");
    let mut cases: Vec<(String, Session)> = Vec::new();
    let singles = [
        "backlash",
        "servo_lag",
        "reversal_spike",
        "cyclic",
        "thermal_drift",
        "waviness",
        "vibration",
        "velocity_coupling",
    ];
    let pairs = [
        ["backlash", "cyclic"],
        ["thermal_drift", "vibration"],
        ["servo_lag", "reversal_spike"],
    ];
    for seed in [1u64, 2] {
        cases.push((format!("clean_{seed}"), session(&[], seed)));
        for e in singles {
            cases.push((format!("{e}_{seed}"), session(&[e], seed)));
        }
        for p in pairs {
            cases.push((format!("{}+{}_{seed}", p[0], p[1]), session(&p, seed)));
        }
        // A lasting step of 3 µm in the X readings from the middle of one run on.
        let mut s = session(&[], seed + 10);
        let (run, t0) = a_run(&s, Axis::X);
        add_along(&mut s, Axis::X, |g, t, _| {
            let later = g / 1000 == run / 1000 && (g > run || (g == run && t >= t0));
            if later { 3.0 } else { 0.0 }
        });
        cases.push((format!("step_outside_{seed}"), s));
        // A burst: 2 µm at 3 Hz over 2 s of one run's Y readings.
        let mut s = session(&[], seed + 20);
        let (run, t0) = a_run(&s, Axis::Y);
        add_along(&mut s, Axis::Y, |g, t, _| {
            if g == run && (t - t0).abs() < 1.0 {
                2.0 * (2.0 * std::f64::consts::PI * 3.0 * (t - t0)).sin()
            } else {
                0.0
            }
        });
        cases.push((format!("burst_outside_{seed}"), s));
        // A worn screw: X lost motion 8 − 6·(x/50)² µm, −d·b(x)/2 on the X readings, d
        // the sign of the last X travel within each file.
        let mut s = session(&[], seed + 30);
        for p in &mut s.planes {
            let (u, v) = p.plane.axes();
            let mut d = 1.0;
            let mut last = None;
            for r in &mut p.runs {
                for i in 0..r.t_s.len() {
                    let x = r.pos_mm[i][0];
                    if let Some(l) = last
                        && f64::abs(x - l) > 1e-9
                    {
                        d = f64::signum(x - l);
                    }
                    last = Some(x);
                    let e = -d * (8.0 - 6.0 * (x / 50.0).powi(2)) / 2.0;
                    if u == Axis::X {
                        r.du_um[i] += e;
                    }
                    if v == Axis::X {
                        r.dv_um[i] += e;
                    }
                }
            }
        }
        cases.push((format!("worn_screw_outside_{seed}"), s));
        // A growth of 4 µm/K along Z following a logged temperature.
        let mut s = session(&[], seed + 40);
        let span = s
            .planes
            .iter()
            .flat_map(|p| p.runs.iter().flat_map(|r| r.t_s.iter().copied()))
            .fold(0.0, f64::max);
        let temp = |t: f64| 2.0 * (std::f64::consts::PI * t / span).sin();
        add_along(&mut s, Axis::Z, |_, t, _| 4.0 * temp(t));
        let mut rng = StdRng::seed_from_u64(seed + 40);
        let sensor = rand_distr::Normal::new(0.0, 0.005).expect("sensor");
        for p in &mut s.planes {
            for r in &mut p.runs {
                r.temp_c = Some(
                    r.t_s
                        .iter()
                        .map(|&t| 20.0 + temp(t) + sensor.sample(&mut rng))
                        .collect(),
                );
            }
        }
        cases.push((format!("temperature_growth_{seed}"), s));
    }
    for (name, s) in &cases {
        let r = diagnose_session(s, &DiagnoseOptions::default()).expect("diagnosis");
        let json = serde_json::to_string_pretty(&r).expect("json");
        std::fs::write(format!("{dir}/{name}.json"), json).expect("write");
        eprintln!("{name}: {:?}, {} finding(s)", r.verdict, r.findings.len());
    }
}
