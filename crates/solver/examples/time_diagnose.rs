//! Diagnosis against identification on the same session, side by side: wall time and
//! CPU time and peak resident memory of each (Linux: `/proc/self/stat`; `VmHWM`, reset
//! through `/proc/self/clear_refs`).
//!
//! `cargo run -p mtcal-solver --example time_diagnose -- [SAMPLES]` (default 300 000:
//! the full plan, 198 runs, at the sample rate that gives that many samples). The same
//! session is then diagnosed again with a logged temperature in every run (`temp_c`: a
//! rise and fall of 0.5 K over the session and a sensor noise of 5 mK, no growth
//! following it), so the cost of the temperature's smoother and of its three forms of
//! growth shows against the same diagnosis without it.
use mtcal_solver::diagnosis::{DiagnoseOptions, diagnose_session};
use mtcal_solver::identification::{IdentifyOptions, identify};
use mtcal_solver::simulate::{Plan, SimOptions, random_truth, simulate};
use rand::SeedableRng;
use rand_distr::Distribution;
use std::time::Instant;

/// Peak resident set (MB) since the last reset, and a reset.
fn peak_mb() -> Option<f64> {
    let s = std::fs::read_to_string("/proc/self/status").ok()?;
    let kb: f64 = s
        .lines()
        .find(|l| l.starts_with("VmHWM:"))?
        .split_whitespace()
        .nth(1)?
        .parse()
        .ok()?;
    Some(kb / 1024.0)
}

/// CPU time (user + system, all threads) of the process so far, s (Linux, 100 ticks/s).
fn cpu_s() -> f64 {
    std::fs::read_to_string("/proc/self/stat")
        .ok()
        .and_then(|s| {
            let rest = &s[s.rfind(')')? + 2..];
            let f: Vec<f64> = rest
                .split_whitespace()
                .skip(11)
                .take(2)
                .filter_map(|v| v.parse().ok())
                .collect();
            (f.len() == 2).then(|| (f[0] + f[1]) / 100.0)
        })
        .unwrap_or(f64::NAN)
}

fn reset_peak() {
    let _ = std::fs::write("/proc/self/clear_refs", "5");
}

/// `f` run once: its value, wall time (s), CPU time (s) and peak resident memory (MB).
fn measured<T>(f: impl FnOnce() -> T) -> (T, f64, f64, f64) {
    reset_peak();
    let (t, c) = (Instant::now(), cpu_s());
    let v = f();
    let (wall, cpu) = (t.elapsed().as_secs_f64(), cpu_s() - c);
    (v, wall, cpu, peak_mb().unwrap_or(f64::NAN))
}

fn main() {
    let samples: f64 = std::env::args()
        .nth(1)
        .and_then(|a| a.parse().ok())
        .unwrap_or(300_000.0);
    // The full plan gives about 2 940 samples per Hz of sample rate.
    let rate = samples / 2941.0;
    let out = simulate(
        &random_truth(1),
        &SimOptions {
            plan: Plan::Full,
            sample_rate_hz: rate,
            ..Default::default()
        },
    )
    .unwrap();
    let s = &out.session;
    println!(
        "session: {} samples, {} runs, {rate:.1} Hz; resident {:.0} MB",
        s.sample_count(),
        s.planes.iter().map(|p| p.runs.len()).sum::<usize>(),
        peak_mb().unwrap_or(f64::NAN)
    );
    let (id, ti, ci, mi) = measured(|| identify(s, &IdentifyOptions::default()).unwrap());
    println!(
        "identify: {ti:.3} s (CPU {ci:.2} s), peak resident {mi:.0} MB (residual {:.3} um, floor {:?})",
        id.fit.residual_rms_um, id.fit.noise_estimate_um
    );
    let (d, td, cd, md) = measured(|| diagnose_session(s, &DiagnoseOptions::default()).unwrap());
    println!(
        "diagnose: {td:.3} s (CPU {cd:.2} s), peak resident {md:.0} MB (verdict {:?}, {} finding(s)); {:.1} x identify (CPU {:.1} x)",
        d.verdict,
        d.findings.len(),
        td / ti,
        cd / ci
    );
    let mut logged = s.clone();
    let dur = s
        .planes
        .iter()
        .flat_map(|p| &p.runs)
        .flat_map(|r| r.t_s.last())
        .fold(1.0f64, |a, &t| a.max(t));
    let mut rng = rand::rngs::StdRng::seed_from_u64(1);
    let sensor = rand_distr::Normal::new(0.0, 0.005).unwrap();
    for r in logged.planes.iter_mut().flat_map(|p| &mut p.runs) {
        r.temp_c = Some(
            r.t_s
                .iter()
                .map(|&t| {
                    20.0 + 0.5 * (2.0 * std::f64::consts::PI * t / dur).sin()
                        + sensor.sample(&mut rng)
                })
                .collect(),
        );
    }
    let (dl, tl, cl, ml) =
        measured(|| diagnose_session(&logged, &DiagnoseOptions::default()).unwrap());
    println!(
        "diagnose with a logged temperature: {tl:.3} s (CPU {cl:.2} s), peak resident {ml:.0} MB (verdict {:?}, {} finding(s)); {:.1} x identify (CPU {:.1} x), {:.2} x diagnose without it (CPU {:.2} x)",
        dl.verdict,
        dl.findings.len(),
        tl / ti,
        cl / ci,
        tl / td,
        cl / cd
    );
}
