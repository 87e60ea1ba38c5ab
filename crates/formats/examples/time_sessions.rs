//! The four sessions of the diagnosis's speed benchmark
//! (`crates/solver/examples/time_diagnose.rs`) written as session folders, for timing the
//! whole process (`mtcal identify --json` and `mtcal diagnose --json` reading the files;
//! BENCHMARKS.md):
//!
//! `cargo run --release -p mtcal-formats --example time_sessions -- DIR [SAMPLES]`
//!
//! writes DIR/no_temperature (the full plan at the sample rate that gives SAMPLES
//! samples, default 300 000), DIR/logged (a logged temperature nothing follows),
//! DIR/growth (a growth of 4 µm/K along Z following it) and DIR/growth_lag30 (the same
//! growth through a first-order lag of 30 s); and the same machine with effects of the
//! catalogue instead, one folder each: DIR/backlash, DIR/cyclic, DIR/servo_lag,
//! DIR/reversal_spike, DIR/thermal_drift and DIR/backlash+cyclic.
use mtcal_formats::write_session_dir;
use mtcal_solver::simulate::logged::{Logged, benchmark_session, with_temperature};
use std::path::Path;

fn main() {
    let mut args = std::env::args().skip(1);
    let dir = args.next().expect("usage: time_sessions DIR [SAMPLES]");
    let samples: f64 = args
        .next()
        .and_then(|a| a.parse().ok())
        .unwrap_or(300_000.0);
    let s = benchmark_session(samples, "").expect("simulate");
    let dir = Path::new(&dir);
    let cases = [
        ("logged", Logged::Still),
        ("growth", Logged::Growth { lag_s: 0.0 }),
        ("growth_lag30", Logged::Growth { lag_s: 30.0 }),
    ];
    write_session_dir(&dir.join("no_temperature"), &s).expect("write");
    for (name, how) in cases {
        write_session_dir(&dir.join(name), &with_temperature(&s, how)).expect("write");
    }
    // The same machine with effects of the catalogue instead (time_diagnose's
    // `TIME_DIAGNOSE_EFFECTS` sessions), one finding of each kind and two together.
    for spec in CATALOGUE_SESSIONS {
        let with = benchmark_session(samples, spec).expect("simulate");
        write_session_dir(&dir.join(spec), &with).expect("write");
    }
    println!("{}: {} samples each", dir.display(), s.sample_count());
}

/// The sessions with effects of the catalogue, as `mtcal simulate --effect` takes them.
const CATALOGUE_SESSIONS: [&str; 6] = [
    "backlash",
    "cyclic",
    "servo_lag",
    "reversal_spike",
    "thermal_drift",
    "backlash+cyclic",
];
