//! Identification of a full-plan session of about one million samples (issue target:
//! ≤ 0.3 s median on the 2-core reference machine).
//!
//! `cargo bench -p mtcal-solver --bench identify`

use criterion::{Criterion, criterion_group, criterion_main};
use mtcal_solver::identification::{IdentifyOptions, identify};
use mtcal_solver::simulate::benchmark_session;
use std::hint::black_box;

fn bench(c: &mut Criterion) {
    // The full plan at 340 Hz gives ≈ 1.0 million samples (2.0 million readings).
    let out = benchmark_session().expect("simulation");
    let n = out.session.sample_count();
    eprintln!("session: {n} samples");
    let mut g = c.benchmark_group("identify");
    g.sample_size(10);
    g.bench_function(format!("full_plan_{n}_samples"), |b| {
        b.iter(|| identify(black_box(&out.session), &IdentifyOptions::default()).unwrap())
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
