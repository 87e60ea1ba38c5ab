//! The parse bound of a session's plane files, side by side with the strict reader, on
//! one core (the CPU time of every figure is the process's, from /proc/self/stat, over
//! several passes; the machine is shared, so wall time is not the measure).
//!
//! Data: the session benchmark's session (full plan, 999 972 samples, 9 plane files,
//! 94.5 MB), the same files as `mtcal simulate --plan full --rate-hz 340 --seed 1`.
//!
//! - `bound`: csv-core splits every record and every numeric cell is parsed by
//!   `str::parse::<f64>` — nothing else: no UTF-8 check per cell (cells are sliced from
//!   the file's text, checked once outside the timing), no limit, no bound, no column
//!   or time rule, no storage. What any reader of these bytes must at least do with
//!   these two libraries.
//! - `split`: csv-core alone; `floats`: `str::parse::<f64>` alone, over the cells split
//!   beforehand.
//! - `plain`: the plain way with the csv crate: records into a reused `ByteRecord`, each
//!   numeric cell checked as UTF-8 and parsed by `str::parse::<f64>`, nothing else.
//! - `reader`: [`read_plane_csv`] of every file, one after the other (every rule of
//!   `docs/datasets.md`, the columns stored).
//!
//! Run: `cargo bench -p mtcal-formats --bench bound` (figures in BENCHMARKS.md).

mod common;

use common::{cpu_s, session_on_disk};
use mtcal_formats::Limits;
use mtcal_formats::session::read_plane_csv;
use std::hint::black_box;

/// The byte ranges of every field of every record after the header, by csv-core, for
/// files without quotes, comments or blank lines (checked): a field's input range
/// follows from csv-core's output ends (one separator or terminator byte between fields).
fn split<'t>(text: &'t str, mut field: impl FnMut(usize, &'t str)) {
    let bytes = text.as_bytes();
    let mut rdr = csv_core::Reader::new();
    let mut out = vec![0u8; 4096];
    let mut ends = vec![0usize; 64];
    let mut at = 0;
    let mut record = 0usize;
    loop {
        let (res, nin, _, nend) = rdr.read_record(&bytes[at..], &mut out, &mut ends);
        match res {
            csv_core::ReadRecordResult::Record => {
                if record > 0 {
                    let mut from = 0;
                    for (i, &to) in ends[..nend].iter().enumerate() {
                        field(i, &text[at + from + i..at + to + i]);
                        from = to;
                    }
                }
                record += 1;
            }
            csv_core::ReadRecordResult::End => break,
            csv_core::ReadRecordResult::InputEmpty => {}
            r => panic!("unexpected {r:?}"),
        }
        at += nin;
    }
}

/// Runs `f` `passes` times; CPU seconds per pass.
fn cpu_per_pass(passes: usize, mut f: impl FnMut()) -> f64 {
    let c0 = cpu_s().expect("/proc/self/stat");
    for _ in 0..passes {
        f();
    }
    (cpu_s().expect("/proc/self/stat") - c0) / passes as f64
}

fn main() {
    let (session, dir) = session_on_disk();
    let files: Vec<(String, String)> = session
        .planes
        .iter()
        .map(|p| {
            let text = std::fs::read_to_string(dir.path().join(&p.file)).expect("plane file");
            (p.file.clone(), text)
        })
        .collect();
    drop(session);
    let mb = files.iter().map(|(_, t)| t.len()).sum::<usize>() as f64 / 1e6;
    let numeric = |i: usize| i < 7; // run, t_s, x, y, z, du, dv (not the test label)
    // The split agrees with the reader's cells (no quotes, comments or blank lines).
    let mut cells: Vec<&str> = Vec::new();
    for (_, text) in &files {
        assert!(!text.contains(['"', '#', '\r']) && !text.contains("\n\n"));
        split(text, |i, s| {
            if numeric(i) {
                cells.push(s)
            }
        });
    }
    let samples: usize = files
        .iter()
        .map(|(name, text)| {
            let runs = read_plane_csv(name, text.as_bytes(), &Limits::default()).unwrap();
            runs.iter().map(|r| r.len()).sum::<usize>()
        })
        .sum();
    assert_eq!(cells.len(), 7 * samples);
    println!(
        "{} files, {mb:.1} MB, {samples} samples, {} numeric cells",
        files.len(),
        cells.len()
    );
    let passes: usize = std::env::var("MTCAL_BOUND_PASSES")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(10);
    let report = |name: &str, cpu: f64| {
        println!(
            "{name:<8} {:>7.1} ms CPU per pass, {:>6.0} MB/s per core",
            cpu * 1e3,
            mb / cpu
        );
    };
    if std::env::var_os("MTCAL_BOUND_READER_ONLY").is_some() {
        // For a profiler: the reader alone.
        report(
            "reader",
            cpu_per_pass(passes, || {
                for (name, text) in &files {
                    black_box(read_plane_csv(name, text.as_bytes(), &Limits::default()).unwrap());
                }
            }),
        );
        return;
    }
    let bound = cpu_per_pass(passes, || {
        let mut sum = 0.0;
        for (_, text) in &files {
            split(text, |i, s| {
                if numeric(i) {
                    sum += s.parse::<f64>().unwrap_or(0.0);
                }
            });
        }
        black_box(sum);
    });
    let split_only = cpu_per_pass(passes, || {
        let mut n = 0usize;
        for (_, text) in &files {
            split(text, |_, s| n += s.len());
        }
        black_box(n);
    });
    let floats = cpu_per_pass(passes, || {
        let mut sum = 0.0;
        for s in &cells {
            sum += s.parse::<f64>().unwrap_or(0.0);
        }
        black_box(sum);
    });
    let plain = cpu_per_pass(passes, || {
        let mut sum = 0.0;
        for (_, text) in &files {
            let mut rdr = csv::ReaderBuilder::new()
                .has_headers(true)
                .from_reader(text.as_bytes());
            let mut rec = csv::ByteRecord::new();
            while rdr.read_byte_record(&mut rec).unwrap() {
                for (i, f) in rec.iter().enumerate() {
                    if numeric(i) {
                        sum += std::str::from_utf8(f)
                            .ok()
                            .and_then(|s| s.parse::<f64>().ok())
                            .unwrap_or(0.0);
                    }
                }
            }
        }
        black_box(sum);
    });
    let reader = cpu_per_pass(passes, || {
        for (name, text) in &files {
            black_box(read_plane_csv(name, text.as_bytes(), &Limits::default()).unwrap());
        }
    });
    report("bound", bound);
    report("split", split_only);
    report("floats", floats);
    report("plain", plain);
    report("reader", reader);
    println!("reader / bound = {:.2}", reader / bound);
}
