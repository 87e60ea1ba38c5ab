//! Phase timings of one identification (profiling aid):
//! `cargo run --release -p mtcal-solver --example time_identify`
use mtcal_solver::design::{ErrorModel, fit, measured_travel};
use mtcal_solver::identification::{IdentifyOptions, identify};
use mtcal_solver::simulate::benchmark_session;
use std::time::Instant;

fn main() {
    let out = benchmark_session().unwrap();
    let s = &out.session;
    let t = Instant::now();
    let model = ErrorModel::new(
        Default::default(),
        Default::default(),
        3,
        measured_travel(s),
    );
    let f = fit(s, &model, &|_, _| true, None);
    println!(
        "fit: {:?} ({} compressed runs)",
        t.elapsed(),
        f.compressed_runs
    );
    let t = Instant::now();
    let n = mtcal_solver::noise::session_floor(s);
    println!("noise: {:?} {n:?}", t.elapsed());
    let t = Instant::now();
    let _ = identify(s, &IdentifyOptions::default()).unwrap();
    println!("identify: {:?}", t.elapsed());
}
