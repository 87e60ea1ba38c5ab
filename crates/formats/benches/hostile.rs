//! Time to reject a 1 MB pathological header (a header-only CSV of ~125 000 distinct
//! `x-` columns, the shape that cost minutes of CPU when the duplicate-column check was
//! quadratic): with the default limits (refused at once by the line-length cap) and with
//! the caps raised out of the way (the whole header checked: linear through a set).
//!
//! Run: `cargo bench -p mtcal-formats --bench hostile --profile dev` (BENCHMARKS.md,
//! "Rejecting hostile input").

use criterion::{Criterion, Throughput, criterion_group};
use mtcal_formats::{Limits, read_positioning};
use std::hint::black_box;

/// A header of distinct `x-` columns, at least `bytes` long, then a newline.
fn pathological_header(bytes: usize) -> String {
    let mut s = String::with_capacity(bytes + 16);
    let mut i = 0;
    while s.len() < bytes {
        if i > 0 {
            s.push(',');
        }
        s.push_str(&format!("x-{i}"));
        i += 1;
    }
    s.push('\n');
    s
}

fn bench_hostile(c: &mut Criterion) {
    let header = pathological_header(1 << 20);
    let columns = header.split(',').count();
    println!("header: {} bytes, {columns} columns", header.len());
    let mut g = c.benchmark_group("reject");
    g.sample_size(10);
    g.throughput(Throughput::Bytes(header.len() as u64));
    g.bench_function("1MB_header_default_limits", |b| {
        b.iter(|| {
            read_positioning("p.csv", black_box(header.as_bytes()), &Limits::default()).unwrap_err()
        })
    });
    let raised = Limits {
        max_columns: usize::MAX,
        max_line_bytes: usize::MAX,
        ..Limits::default()
    };
    g.bench_function("1MB_header_caps_raised", |b| {
        b.iter(|| read_positioning("p.csv", black_box(header.as_bytes()), &raised).unwrap_err())
    });
    g.finish();
}

criterion_group!(benches, bench_hostile);

fn main() {
    benches();
    Criterion::default().configure_from_args().final_summary();
}
