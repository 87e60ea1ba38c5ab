//! A whole session from disk to an identified model, side by side with the parse time:
//! the full plan (9 plane files) at about one million samples, written by the simulator
//! to a temporary folder. Three timings:
//! - `parse_sequential`: every plane file parsed one after the other on one core
//!   ([`read_plane_csv`], files already in memory): the parse time;
//! - `read_session_dir`: the session reader (files read, plane files parsed on all cores);
//! - `identify_simulated` / `identify_read`: `identify` alone on the simulator's session
//!   and on the same session read back from its files;
//! - `read_and_identify`: `read_session_dir` + `identify`, i.e. `mtcal identify` without
//!   the printing.
//!
//! Run: `cargo bench -p mtcal-formats --bench session` (figures in BENCHMARKS.md).

mod common;

use common::session_on_disk;
use criterion::{Criterion, criterion_group, criterion_main};
use mtcal_formats::session::read_plane_csv;
use mtcal_formats::{Limits, read_session_dir};
use mtcal_solver::identification::{IdentifyOptions, identify};
use std::hint::black_box;

fn bench(c: &mut Criterion) {
    let (session, dir) = session_on_disk();
    let files: Vec<(String, Vec<u8>)> = session
        .planes
        .iter()
        .map(|p| {
            let bytes = std::fs::read(dir.path().join(&p.file)).expect("plane file");
            (p.file.clone(), bytes)
        })
        .collect();
    let mb = files.iter().map(|(_, b)| b.len()).sum::<usize>() as f64 / 1e6;
    eprintln!(
        "session: {} samples in {} plane files, {mb:.1} MB",
        session.sample_count(),
        files.len()
    );
    let limits = Limits::default();
    let mut g = c.benchmark_group("session");
    g.sample_size(10);
    g.bench_function("parse_sequential", |b| {
        b.iter(|| {
            for (name, bytes) in &files {
                black_box(read_plane_csv(name, bytes, &limits).unwrap());
            }
        })
    });
    g.bench_function("read_session_dir", |b| {
        b.iter(|| black_box(read_session_dir(dir.path(), &limits).unwrap()))
    });
    let read = read_session_dir(dir.path(), &limits).unwrap();
    g.bench_function("identify_simulated", |b| {
        b.iter(|| black_box(identify(&session, &IdentifyOptions::default()).unwrap()))
    });
    g.bench_function("identify_read", |b| {
        b.iter(|| black_box(identify(&read, &IdentifyOptions::default()).unwrap()))
    });
    g.bench_function("read_and_identify", |b| {
        b.iter(|| {
            let s = read_session_dir(dir.path(), &limits).unwrap();
            black_box(identify(&s, &IdentifyOptions::default()).unwrap())
        })
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
