//! A logged temperature added to a simulated session (`temp_c` in every run, a sensor
//! noise of 5 mK), with or without a growth of the machine that follows it: the sessions
//! the speed benchmarks of the diagnosis use (`crates/solver/examples/time_diagnose.rs`,
//! `crates/formats/examples/time_sessions.rs`, BENCHMARKS.md).

use crate::axis::Axis;
use crate::session::Session;
use rand::SeedableRng;
use rand_distr::Distribution;

/// The growth along Z per kelvin of the structure's temperature (µm/K), and the rise
/// and fall (K) of the sessions with a growth.
pub const GROWTH_UM_PER_K: f64 = 4.0;
pub const SWING_K: f64 = 2.0;

/// The logged temperature of a session's variant.
#[derive(Clone, Copy)]
pub enum Logged {
    /// A rise and fall of 0.5 K over the session (its duration: the last sample time);
    /// nothing follows it.
    Still,
    /// A rise and fall of [`SWING_K`] over the session, below the start at its end; the
    /// machine grows [`GROWTH_UM_PER_K`] along Z through a
    /// first-order lag of `lag_s` (0: the structure at the sensor's temperature).
    Growth { lag_s: f64 },
}

/// The session `s` with `temp_c` in every run (the sensor's noise 5 mK) and, for
/// [`Logged::Growth`], the growth added to the readings along Z.
pub fn with_temperature(s: &Session, how: Logged) -> Session {
    let dur = s
        .planes
        .iter()
        .flat_map(|p| &p.runs)
        .flat_map(|r| r.t_s.last())
        .fold(1.0f64, |a, &t| a.max(t));
    let mut out = s.clone();
    let mut rng = rand::rngs::StdRng::seed_from_u64(1);
    let sensor = rand_distr::Normal::new(0.0, 0.005).expect("a positive sensor noise");
    let temp = |t: f64| match how {
        Logged::Still => 0.5 * (2.0 * std::f64::consts::PI * t / dur).sin(),
        Logged::Growth { .. } => SWING_K * (2.0 * std::f64::consts::PI * t / dur).sin(),
    };
    // The structure's temperature, integrated through the lag in steps of at most 0.05 s
    // (the clock runs on through the gaps between runs).
    let (mut structure, mut last) = (0.0, 0.0);
    for p in &mut out.planes {
        let (u, v) = p.plane.axes();
        for r in &mut p.runs {
            let mut log = Vec::with_capacity(r.len());
            for i in 0..r.len() {
                let t = r.t_s[i];
                log.push(20.0 + temp(t) + sensor.sample(&mut rng));
                let Logged::Growth { lag_s } = how else {
                    continue;
                };
                structure = if lag_s > 0.0 {
                    let h = (t - last).max(0.0);
                    let steps = (h / 0.05).ceil().max(1.0);
                    let a = (-(h / steps) / lag_s).exp();
                    (0..steps as usize).fold(structure, |y, k| {
                        a * y + (1.0 - a) * temp(last + (k as f64 + 0.5) * h / steps)
                    })
                } else {
                    temp(t)
                };
                last = t;
                let growth = GROWTH_UM_PER_K * structure;
                if u == Axis::Z {
                    r.du_um[i] += growth;
                }
                if v == Axis::Z {
                    r.dv_um[i] += growth;
                }
            }
            r.temp_c = Some(log);
        }
    }
    out
}
