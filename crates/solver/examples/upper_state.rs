//! What an `exp` call costs before any faer routine, after a faer matrix product (which
//! leaves the vector registers' upper halves set on an AVX-512 processor) and after
//! [`mtcal_solver::upper_state::clear`] (BENCHMARKS.md, "Diagnosis against
//! identification"). Prints nanoseconds a call, over two million calls each.
//!
//!   cargo run --release -p mtcal-solver --example upper_state

use std::hint::black_box;
use std::time::Instant;

/// Nanoseconds of one `exp` call, over `n` calls.
fn per_call(n: usize) -> f64 {
    let start = Instant::now();
    let mut sum = 0.0;
    for i in 0..n {
        sum += black_box(-(i as f64) * 1e-6).exp();
    }
    black_box(sum);
    start.elapsed().as_nanos() as f64 / n as f64
}

fn main() {
    let n = 2_000_000;
    println!("before any faer routine: {:.1} ns a call", per_call(n));
    let a = faer::Mat::<f64>::from_fn(200, 200, |i, j| (i + j) as f64);
    black_box(&a * &a);
    println!("after a faer product: {:.1} ns a call", per_call(n));
    mtcal_solver::upper_state::clear();
    println!("after upper_state::clear: {:.1} ns a call", per_call(n));
}
