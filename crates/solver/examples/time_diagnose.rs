//! Diagnosis against identification on the same session, side by side: wall time and
//! CPU time and peak resident memory of each (Linux: `/proc/self/stat`; `VmHWM`, reset
//! through `/proc/self/clear_refs`).
//!
//! `cargo run -p mtcal-solver --example time_diagnose -- [SAMPLES]` (default 300 000:
//! the full plan, 198 runs, at the sample rate that gives that many samples). The same
//! session is then diagnosed again with a logged temperature in every run (`temp_c`,
//! a sensor noise of 5 mK): a rise and fall of 0.5 K over the session with no growth
//! following it; a rise and fall of 2 K
//! with a growth of 4 µm/K along Z following it; the
//! same growth through a first-order lag of 30 s (a structure slower than its sensor:
//! the worst case, where every round of the loop searches the forms of the growth until
//! the finding is added). So the cost of the temperature's smoother and of its three
//! forms of growth shows against the same diagnosis without it. With the environment
//! variable `TIME_DIAGNOSE_JSON` set to a directory, the four results are written there
//! (`diagnose0.json` … `diagnose3.json`) to compare the findings before and after a
//! change.
//!
//! With `TIME_DIAGNOSE_EFFECTS` set to sessions separated by `;`, each a `+`-joined list
//! of effects as `mtcal simulate --effect` takes them (`backlash;cyclic;backlash+cyclic`),
//! the same machine is simulated with those effects instead, and each session's
//! identification and diagnosis are measured side by side: the sessions above find
//! nothing or one growth; these show what a finding of the catalogue costs (every finding
//! adds an admission, a refit and a round of the search). With `TIME_DIAGNOSE_JSON` set
//! too, each session's result is written there as `SESSION.json` (`backlash+cyclic.json`).
use mtcal_solver::diagnosis::{DiagnoseOptions, diagnose_session};
use mtcal_solver::identification::{IdentifyOptions, identify};
use mtcal_solver::simulate::logged::{
    FULL_PLAN_SAMPLES_PER_HZ, Logged, benchmark_session, with_temperature,
};
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
    let rate = samples / FULL_PLAN_SAMPLES_PER_HZ;
    if let Ok(list) = std::env::var("TIME_DIAGNOSE_EFFECTS") {
        for spec in list.split(';').filter(|s| !s.trim().is_empty()) {
            let session = benchmark_session(samples, spec).unwrap();
            let s = &session;
            let (_, ti, ci, _) = measured(|| identify(s, &IdentifyOptions::default()).unwrap());
            let (d, td, cd, md) =
                measured(|| diagnose_session(s, &DiagnoseOptions::default()).unwrap());
            let found: Vec<&str> = d.findings.iter().map(|f| f.effect.as_str()).collect();
            println!(
                "{spec}: {} samples; identify {ti:.3} s (CPU {ci:.2} s); diagnose {td:.3} s (CPU {cd:.2} s), peak resident {md:.0} MB (verdict {:?}, findings {found:?}); {:.1} x identify (CPU {:.1} x)",
                s.sample_count(),
                d.verdict,
                td / ti,
                cd / ci
            );
            if let Some(dir) = std::env::var_os("TIME_DIAGNOSE_JSON") {
                let path = std::path::Path::new(&dir).join(format!("{}.json", spec.trim()));
                std::fs::write(&path, serde_json::to_string_pretty(&d).unwrap()).unwrap();
            }
        }
        return;
    }
    let session = benchmark_session(samples, "").unwrap();
    let s = &session;
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
    let dump = std::env::var_os("TIME_DIAGNOSE_JSON");
    let cases = [
        ("with a logged temperature", Logged::Still),
        (
            "with a growth that follows it",
            Logged::Growth { lag_s: 0.0 },
        ),
        (
            "with a growth lagging it by 30 s",
            Logged::Growth { lag_s: 30.0 },
        ),
    ];
    for (i, (label, how)) in cases.into_iter().enumerate() {
        let logged = with_temperature(s, how);
        let (dl, tl, cl, ml) =
            measured(|| diagnose_session(&logged, &DiagnoseOptions::default()).unwrap());
        let found: Vec<&str> = dl.findings.iter().map(|f| f.effect.as_str()).collect();
        println!(
            "diagnose {label}: {tl:.3} s (CPU {cl:.2} s), peak resident {ml:.0} MB (verdict {:?}, findings {found:?}); {:.1} x identify (CPU {:.1} x), {:.2} x diagnose without it (CPU {:.2} x)",
            dl.verdict,
            tl / ti,
            cl / ci,
            tl / td,
            cl / cd
        );
        if let Some(dir) = &dump {
            let path = std::path::Path::new(dir).join(format!("diagnose{}.json", i + 1));
            std::fs::write(&path, serde_json::to_string_pretty(&dl).unwrap()).unwrap();
        }
    }
    if let Some(dir) = &dump {
        let path = std::path::Path::new(dir).join("diagnose0.json");
        std::fs::write(&path, serde_json::to_string_pretty(&d).unwrap()).unwrap();
    }
}
