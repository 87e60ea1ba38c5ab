//! Shared by the benchmarks of this crate: the benchmark session and the process's CPU
//! time.
#![allow(dead_code)]

use mtcal_formats::write_session_dir;
use mtcal_solver::session::Session;
use mtcal_solver::simulate::benchmark_session;

/// The benchmark session: the full plan (three head offsets, 9 plane files) at 340 Hz,
/// 999 972 samples, as `mtcal simulate --plan full --rate-hz 340 --seed 1` writes it,
/// and a temporary folder holding its files.
pub fn session_on_disk() -> (Session, tempfile::TempDir) {
    let out = benchmark_session().expect("simulation");
    let dir = tempfile::tempdir().expect("temporary folder");
    write_session_dir(dir.path(), &out.session).expect("session written");
    (out.session, dir)
}

/// CPU time (user + system) of this process, s, from /proc/self/stat (clock ticks of
/// 1/100 s on Linux); `None` where /proc is unavailable.
pub fn cpu_s() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    let after = &stat[stat.rfind(')')? + 2..];
    let f: Vec<&str> = after.split_whitespace().collect();
    Some((f[11].parse::<f64>().ok()? + f[12].parse::<f64>().ok()?) / 100.0)
}
