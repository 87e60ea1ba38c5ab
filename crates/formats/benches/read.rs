//! Reading throughput of a large plane CSV (1 million samples, in memory) and of the same
//! data as a drift log, plus the peak resident memory of one read (Linux: VmHWM after
//! resetting it through /proc/self/clear_refs), printed before the timings.
//!
//! Run: `cargo bench -p mtcal-formats --bench read` (see BENCHMARKS.md for the figures
//! and the exact command used).

mod common;

use common::cpu_s;
use criterion::{Criterion, Throughput, criterion_group};
use mtcal_formats::session::read_plane_csv;
use mtcal_formats::{Limits, read_drift_log};
use std::fmt::Write;
use std::hint::black_box;

const RUNS: usize = 100;
const PER_RUN: usize = 10_000;

/// A plane CSV as an encoder exports it: 100 runs × 10 000 samples at 1 kHz, positions
/// to 0.1 µm, deviations to 1 nm.
fn plane_csv() -> String {
    let mut s = String::with_capacity(RUNS * PER_RUN * 64);
    s.push_str("# generated for the reading benchmark\nrun,t_s,x_mm,y_mm,z_mm,du_um,dv_um\n");
    for r in 0..RUNS {
        for i in 0..PER_RUN {
            let t = (r * PER_RUN + i) as f64 * 1e-3;
            let x = -50.0 + 100.0 * i as f64 / PER_RUN as f64;
            let du = (0.37 * i as f64).sin() * 1.234;
            let dv = (0.11 * i as f64).cos() * 0.567;
            writeln!(
                s,
                "{},{t:.4},{x:.4},0.0000,-100.0000,{du:.3},{dv:.3}",
                r + 1
            )
            .unwrap();
        }
    }
    s
}

/// The same number of rows as a drift log with 6 channels.
fn drift_csv() -> String {
    let mut s = String::with_capacity(RUNS * PER_RUN * 64);
    s.push_str("t_s,ch1_um,ch2_um,ch3_um,t1_c,t2_c,spindle_rpm\n");
    for i in 0..RUNS * PER_RUN {
        let t = i as f64 * 15.0;
        let a = (1e-4 * i as f64).sin();
        writeln!(
            s,
            "{t},{:.4},{:.4},{:.4},{:.3},{:.3},{}",
            12.0 * a,
            -3.0 * a,
            0.5 * a,
            20.0 + a,
            24.0 - a,
            (i / 1000 % 6) * 1000
        )
        .unwrap();
    }
    s
}

fn status_kib(field: &str) -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with(field))?;
    line.split_whitespace().nth(1)?.parse().ok()
}

/// Peak resident memory added by `f`, KiB (None where /proc is unavailable).
fn peak_extra_kib(f: impl FnOnce()) -> Option<u64> {
    std::fs::write("/proc/self/clear_refs", "5").ok()?;
    let base = status_kib("VmRSS:")?;
    f();
    Some(status_kib("VmHWM:")?.saturating_sub(base))
}

fn memory_report() {
    let csv = plane_csv();
    let mb = csv.len() as f64 / 1e6;
    let mut samples = 0;
    let extra = peak_extra_kib(|| {
        let runs = read_plane_csv("bench.csv", csv.as_bytes(), &Limits::default()).unwrap();
        samples = runs.iter().map(|r| r.len()).sum::<usize>();
        black_box(runs);
    });
    // On a shared machine wall time includes waiting for a core: report CPU time too.
    let (wall, cpu0) = (std::time::Instant::now(), cpu_s());
    for _ in 0..5 {
        black_box(read_plane_csv("bench.csv", csv.as_bytes(), &Limits::default()).unwrap());
    }
    let wall = wall.elapsed().as_secs_f64() / 5.0;
    if let (Some(c0), Some(c1)) = (cpu0, cpu_s()) {
        let cpu = (c1 - c0) / 5.0;
        println!(
            "plane CSV read: wall {wall:.3} s ({:.0} MB/s), CPU {cpu:.3} s ({:.0} MB/s per CPU second)",
            mb / wall,
            mb / cpu
        );
    }
    if let Some(kib) = extra {
        let extra_mb = kib as f64 * 1024.0 / 1e6;
        println!(
            "plane CSV: {mb:.1} MB, {samples} samples; peak extra resident memory while reading {extra_mb:.1} MB; peak (input + columns) = {:.2} x the CSV size",
            (mb + extra_mb) / mb
        );
    }
}

fn bench_read(c: &mut Criterion) {
    let plane = plane_csv();
    let drift = drift_csv();
    let mut g = c.benchmark_group("read");
    g.sample_size(10);
    g.throughput(Throughput::Bytes(plane.len() as u64));
    g.bench_function("plane_csv_1M_samples", |b| {
        b.iter(|| {
            read_plane_csv("bench.csv", black_box(plane.as_bytes()), &Limits::default()).unwrap()
        })
    });
    g.throughput(Throughput::Bytes(drift.len() as u64));
    g.bench_function("drift_log_1M_rows_6_channels", |b| {
        b.iter(|| {
            read_drift_log("bench.csv", black_box(drift.as_bytes()), &Limits::default()).unwrap()
        })
    });
    g.finish();
}

criterion_group!(benches, bench_read);

fn main() {
    memory_report();
    benches();
    Criterion::default().configure_from_args().final_summary();
}
