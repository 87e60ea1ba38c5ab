//! The sessions the speed benchmarks of the diagnosis use
//! (`crates/solver/examples/time_diagnose.rs`, `crates/formats/examples/time_sessions.rs`,
//! BENCHMARKS.md): one machine measured with the full plan ([`benchmark_session`]), with
//! effects of the catalogue, or with a logged temperature added (`temp_c` in every run, a
//! sensor noise of 5 mK) and a growth of the machine that follows it or not.

use super::{Effect, Plan, SimOptions, random_truth, simulate};
use crate::axis::Axis;
use crate::session::Session;
use rand::SeedableRng;
use rand_distr::Distribution;

/// About how many samples the full plan gives per hertz of sample rate.
pub const FULL_PLAN_SAMPLES_PER_HZ: f64 = 2941.0;

/// The benchmarks' machine (`random_truth(1)`) measured with the full plan at the sample
/// rate that gives about `samples` samples ([`FULL_PLAN_SAMPLES_PER_HZ`]), with the
/// effects `spec`: `+`-joined, each as `mtcal simulate --effect` takes it (empty: none).
pub fn benchmark_session(samples: f64, spec: &str) -> Result<Session, String> {
    let effects = spec
        .split('+')
        .map(str::trim)
        .filter(|e| !e.is_empty())
        .map(Effect::from_spec)
        .collect::<Result<Vec<_>, _>>()?;
    let o = SimOptions {
        plan: Plan::Full,
        sample_rate_hz: samples / FULL_PLAN_SAMPLES_PER_HZ,
        effects,
        ..Default::default()
    };
    simulate(&random_truth(1), &o)
        .map(|out| out.session)
        .map_err(|e| e.to_string())
}

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

/// A first-order lag's output `y` (time constant `tau`, s) carried from time `from` to
/// `to` under the input `input(t)`: dy/dt = (input − y)/τ integrated in sub-steps of at
/// most 0.05 s, each exact for the input held at the sub-step's middle
/// (y ← a·y + (1 − a)·input, a = e^(−h/τ)). The clock runs on through the gaps between
/// runs, so a structure slower than its sensor follows it across them.
pub fn first_order_lag(y: f64, from: f64, to: f64, tau: f64, input: impl Fn(f64) -> f64) -> f64 {
    let h = (to - from).max(0.0);
    let steps = (h / 0.05).ceil().max(1.0);
    let a = (-(h / steps) / tau).exp();
    (0..steps as usize).fold(y, |y, k| {
        a * y + (1.0 - a) * input(from + (k as f64 + 0.5) * h / steps)
    })
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
    // The structure's temperature, through the lag ([`first_order_lag`]).
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
                    first_order_lag(structure, last, t, lag_s, temp)
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

#[cfg(test)]
mod tests {
    use super::first_order_lag;

    /// A unit step held from 0 on: y(t) = 1 − e^(−t/τ) (the textbook response), carried
    /// over one long stretch or many short ones alike.
    #[test]
    fn a_step_input_gives_the_textbook_response() {
        let tau = 30.0;
        let one = first_order_lag(0.0, 0.0, 45.0, tau, |_| 1.0);
        let want = 1.0 - (-45.0f64 / tau).exp();
        assert!((one - want).abs() < 1e-12, "{one} against {want}");
        let many = (0..450).fold(0.0, |y, k| {
            first_order_lag(y, k as f64 * 0.1, (k + 1) as f64 * 0.1, tau, |_| 1.0)
        });
        assert!((many - want).abs() < 1e-12, "{many} against {want}");
        // A ramp input lags by τ once settled: y(t) ≈ t − τ for t ≫ τ.
        let ramp = first_order_lag(0.0, 0.0, 600.0, tau, |t| t);
        assert!((ramp - (600.0 - tau)).abs() < 1e-3, "{ramp}");
    }
}
