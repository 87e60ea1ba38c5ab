//! Fuzzing of every reader (docs/datasets.md, "Fuzzing the readers"): a seeded mutation
//! campaign over the committed corpus in `tests/corpus/` (a session with two plane files,
//! positioning runs, a rotary point set with its sidecar, a drift log), run through every
//! entry point: the session upload and folder readers, `.tar` / `.tar.gz` archives, each
//! single-file reader, gzip-compressed files, both CSV dialects.
//!
//! Each case mutates one file of a valid upload (bit flips, byte insertions, deletions and
//! repeats, truncation, hostile tokens such as `NaN`, `1e308`, quotes, separators,
//! byte-order marks; whole lines repeated, dropped or swapped; cells replaced) and reads
//! it. Asserted for every case:
//!
//! * no panic;
//! * a rejection is a `FormatError` naming a file of the upload (or `upload`, or the
//!   archive), a line within that file (0 when not tied to a line), a column that is empty
//!   or a column/field of the file, and a non-empty rule; its text is
//!   `file:line:column: rule`;
//! * an accepted upload holds only finite values within the magnitude bounds of
//!   `Limits` (no absurd value can reach the solver).
//!
//! `MTCAL_FUZZ_ITERS` sets the cases per target (default 2000: the whole campaign takes a
//! few seconds in the debug profile), `MTCAL_FUZZ_SECONDS` the time a campaign may take
//! (default 20: on a slow or busy machine it stops there, after a whole round of every
//! target and entry point, having run at least one), `MTCAL_FUZZ_SEED` the seed (default
//! fixed, so a failure reproduces: the cases run in the same order whatever the time
//! allows); a failure prints the seed, the target and the mutated file. Longer
//! campaigns: `MTCAL_FUZZ_ITERS=200000 MTCAL_FUZZ_SECONDS=3600 cargo test -p
//! mtcal-formats --test fuzz`.

use mtcal_formats::upload::DatasetData;
use mtcal_formats::{CsvDialect, Dataset, FormatError, Limits, read_archive, read_upload};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use std::io::Write;

const CORPUS: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/corpus");

fn corpus(name: &str) -> Vec<u8> {
    std::fs::read(format!("{CORPUS}/{name}")).unwrap()
}

fn env_or(name: &str, default: u64) -> u64 {
    std::env::var(name)
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
}

/// When a campaign stops, even with iterations left (`MTCAL_FUZZ_SECONDS`, default 20).
fn deadline() -> std::time::Instant {
    std::time::Instant::now() + std::time::Duration::from_secs(env_or("MTCAL_FUZZ_SECONDS", 20))
}

fn gzip(bytes: &[u8]) -> Vec<u8> {
    let mut e = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
    e.write_all(bytes).unwrap();
    e.finish().unwrap()
}

fn gunzip(bytes: &[u8]) -> Option<Vec<u8>> {
    use std::io::Read;
    let mut out = Vec::new();
    flate2::read::MultiGzDecoder::new(bytes)
        .take(1 << 24)
        .read_to_end(&mut out)
        .ok()?;
    Some(out)
}

type Files = Vec<(String, Vec<u8>)>;

/// Tokens a careless export or an attacker puts in a file.
const TOKENS: &[&str] = &[
    "NaN",
    "inf",
    "-inf",
    "1e308",
    "-1e309",
    "1e-320",
    "",
    " ",
    ",",
    ";",
    "\"",
    "\"\"",
    "\n",
    "\r\n",
    "\r",
    "#",
    "\u{feff}",
    "\u{0}",
    "\u{00e9}",
    "\u{202e}",
    "-",
    "+",
    ".",
    "..",
    "e",
    "0x10",
    "1,5",
    "99999999999999999999",
    "-0",
    "x-",
    "run",
    "t_s",
    "du_um",
    "a_deg",
    "axis",
    "X",
    "line_X",
    "circle_cw",
    "{",
    "}",
    "[",
    "]",
    ":",
    "null",
    "\"planes\"",
    "\"file\"",
    "../",
    "/etc/passwd",
    "xy.csv",
    "session.json",
    "\u{fffd}",
];

/// One random mutation of `b`.
fn mutate(rng: &mut StdRng, b: &mut Vec<u8>) {
    let pos = |rng: &mut StdRng, len: usize| rng.random_range(0..=len);
    match rng.random_range(0..10) {
        // Flip a bit.
        0 if !b.is_empty() => {
            let i = rng.random_range(0..b.len());
            b[i] ^= 1 << rng.random_range(0..8);
        }
        // Insert a token.
        1 | 2 => {
            let t = TOKENS[rng.random_range(0..TOKENS.len())].as_bytes();
            let i = pos(rng, b.len());
            b.splice(i..i, t.iter().copied());
        }
        // Delete a run of bytes.
        3 if !b.is_empty() => {
            let i = rng.random_range(0..b.len());
            let n = rng.random_range(1..=8).min(b.len() - i);
            b.drain(i..i + n);
        }
        // Repeat a run of bytes.
        4 if !b.is_empty() => {
            let i = rng.random_range(0..b.len());
            let n = rng.random_range(1..=16).min(b.len() - i);
            let run: Vec<u8> = b[i..i + n].to_vec();
            let j = pos(rng, b.len());
            b.splice(j..j, run);
        }
        // Truncate.
        5 => {
            let i = pos(rng, b.len());
            b.truncate(i);
        }
        // Replace a cell (between separators) by a token.
        6 => {
            let seps: Vec<usize> = (0..b.len())
                .filter(|&i| matches!(b[i], b',' | b'\n' | b';' | b':'))
                .collect();
            if seps.len() >= 2 {
                let k = rng.random_range(0..seps.len() - 1);
                let (s, e) = (seps[k] + 1, seps[k + 1]);
                let t = TOKENS[rng.random_range(0..TOKENS.len())].as_bytes();
                b.splice(s..e, t.iter().copied());
            }
        }
        // Whole lines: repeat, drop or swap.
        7..=9 => {
            let text = b.clone();
            let mut lines: Vec<&[u8]> = text.split(|&c| c == b'\n').collect();
            if lines.len() >= 2 {
                let i = rng.random_range(0..lines.len());
                let j = rng.random_range(0..lines.len());
                match rng.random_range(0..3) {
                    0 => lines.insert(j, lines[i]),
                    1 => {
                        lines.remove(i);
                    }
                    _ => lines.swap(i, j),
                }
                *b = lines.join(&b'\n');
            }
        }
        _ => {}
    }
}

/// Checks an error against the upload it came from (see the module documentation).
fn check_error(e: &FormatError, files: &Files, archive: Option<&str>) -> Result<(), String> {
    if e.rule.is_empty() {
        return Err("empty rule".into());
    }
    let place = match (e.line, e.column.is_empty()) {
        (0, true) => String::new(),
        (0, false) => format!(": {}", e.column),
        (l, true) => format!(":{l}"),
        (l, false) => format!(":{l}:{}", e.column),
    };
    if e.to_string() != format!("{}{place}: {}", e.file, e.rule) {
        return Err("display form".into());
    }
    if e.file == "upload" || Some(e.file.as_str()) == archive {
        return Ok(());
    }
    // The file named is one of the upload's (a session's plane file may be named as
    // session.json names it, without its `.gz`).
    let Some((_, bytes)) = files
        .iter()
        .find(|(n, _)| *n == e.file || n.strip_suffix(".gz") == Some(e.file.as_str()))
    else {
        // Names are cut in messages; a cut name starts like one of the upload's.
        if e.file.contains("… (") || e.rule.contains("file name") {
            return Ok(());
        }
        return Err(format!("file {:?} is not in the upload", e.file));
    };
    let plain = if bytes.starts_with(&[0x1f, 0x8b]) {
        gunzip(bytes).unwrap_or_default()
    } else {
        bytes.clone()
    };
    let lines = plain.iter().filter(|&&c| c == b'\n').count() as u64 + 1;
    if e.line > lines {
        return Err(format!("line {} beyond the file's {lines} lines", e.line));
    }
    if !e.column.is_empty() && !e.column.contains("… (") && !e.rule.contains("missing") {
        // A CSV column or JSON field path: its name (before any `[`/`.`) is in the file.
        let root = e
            .column
            .split(['[', '.'])
            .next()
            .unwrap_or_default()
            .to_string();
        // CSV quoting is undone in names: compare without quotes.
        let text = String::from_utf8_lossy(&plain).replace('"', "");
        let root = root.replace('"', "");
        if !root.is_empty() && !text.contains(&root) {
            return Err(format!("column {:?} does not occur in the file", e.column));
        }
    }
    Ok(())
}

/// Every value of an accepted dataset is finite and within the magnitude bounds.
fn check_accepted(d: &Dataset, l: &Limits) -> Result<(), String> {
    let within = |v: f64, max: f64| v.is_finite() && v.abs() <= max;
    let ok = match &d.data {
        DatasetData::Session(s) => s.planes.iter().flat_map(|p| &p.runs).all(|r| {
            r.t_s.iter().all(|&t| within(t, l.max_abs_time_s))
                && r.pos_mm
                    .iter()
                    .flatten()
                    .all(|&p| within(p, l.max_abs_position_mm))
                && r.du_um
                    .iter()
                    .chain(&r.dv_um)
                    .all(|&v| within(v, l.max_abs_deviation_um))
                && r.t_s.windows(2).all(|w| w[1] > w[0])
        }),
        DatasetData::Positioning(p) => p.records.iter().all(|r| {
            within(r.target_mm, l.max_abs_position_mm)
                && within(r.deviation_um, l.max_abs_deviation_um)
        }),
        DatasetData::RotaryPoints(p) => p.points.iter().all(|q| {
            [q.a_deg, q.c_deg]
                .iter()
                .all(|&a| within(a, l.max_abs_angle_deg))
                && [q.x_mm, q.y_mm, q.z_mm]
                    .iter()
                    .all(|&x| within(x, l.max_abs_position_mm))
        }),
        DatasetData::DriftLog(g) => {
            g.t_s.windows(2).all(|w| w[1] > w[0])
                && g.channels
                    .iter()
                    .flat_map(|c| &c.values)
                    .all(|&v| within(v, l.max_abs_value))
        }
    };
    if ok && d.samples() > 0 {
        Ok(())
    } else {
        Err("accepted data out of bounds or empty".into())
    }
}

/// A tar archive of `files` in a folder `s/`.
fn tar_of(files: &Files) -> Vec<u8> {
    let mut b = tar::Builder::new(Vec::new());
    for (name, bytes) in files {
        let mut h = tar::Header::new_gnu();
        h.set_size(bytes.len() as u64);
        h.set_mode(0o644);
        b.append_data(&mut h, format!("s/{name}"), bytes.as_slice())
            .unwrap();
    }
    b.into_inner().unwrap()
}

/// How a target reads an upload.
#[derive(Clone, Copy, Debug)]
enum Via {
    /// `read_upload` on the files.
    Files,
    /// The files gzip-compressed (`name.gz`), then mutated.
    Gzip,
    /// A `.tar.gz` of the files, the archive mutated as a whole.
    TarGz,
    /// A plain `.tar`, mutated as a whole.
    Tar,
}

/// Reads `files` via `via`: whether it was accepted, or `Err(why)` when the outcome
/// breaks a property.
fn run_case(files: &Files, via: Via, archive: Option<&[u8]>, l: &Limits) -> Result<bool, String> {
    let outcome = std::panic::catch_unwind(|| match (via, archive) {
        (Via::TarGz, Some(a)) | (Via::Tar, Some(a)) => {
            let name = if matches!(via, Via::TarGz) {
                "s.tar.gz"
            } else {
                "s.tar"
            };
            match read_archive(name, a, l) {
                Ok(inner) => (read_upload(&inner, l), inner, Some(name)),
                Err(e) => (Err(e), vec![], Some(name)),
            }
        }
        _ => (read_upload(files, l), files.clone(), None),
    });
    let (result, read_files, archive_name) = outcome.map_err(|p| {
        p.downcast_ref::<String>()
            .cloned()
            .or_else(|| p.downcast_ref::<&str>().map(|s| s.to_string()))
            .unwrap_or_else(|| "panic".into())
    })?;
    match result {
        Ok(d) => check_accepted(&d, l).map(|()| true),
        Err(e) => check_error(&e, &read_files, archive_name)
            .map(|()| false)
            .map_err(|w| format!("{w}: {e}")),
    }
}

/// The valid uploads the campaign starts from.
fn targets() -> Vec<(&'static str, Files)> {
    let f = |n: &str| (n.to_string(), corpus(n));
    vec![
        ("session", vec![f("session.json"), f("xy.csv"), f("xz.csv")]),
        ("positioning", vec![f("positioning.csv")]),
        ("rotary", vec![f("rotary.csv"), f("rotary.json")]),
        ("drift", vec![f("drift.csv")]),
    ]
}

/// The Excel form of a file (`;` separators, decimal commas, a byte-order mark).
fn to_excel(files: &Files) -> Files {
    files
        .iter()
        .map(|(n, b)| {
            if n.ends_with(".csv") {
                let t = String::from_utf8(b.clone()).unwrap();
                let t = format!("\u{feff}{}", t.replace(',', ";").replace('.', ","));
                (n.clone(), t.into_bytes())
            } else {
                (n.clone(), b.clone())
            }
        })
        .collect()
}

#[test]
fn the_corpus_is_valid_in_both_dialects() {
    let excel = Limits::default().with_dialect(CsvDialect::Excel);
    for (name, files) in targets() {
        let d = read_upload(&files, &Limits::default()).unwrap_or_else(|e| panic!("{name}: {e}"));
        check_accepted(&d, &Limits::default()).unwrap();
        let x = read_upload(&to_excel(&files), &excel).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(format!("{:?}", x.data), format!("{:?}", d.data), "{name}");
    }
}

#[test]
fn mutated_uploads_never_panic_and_every_rejection_is_located() {
    let iters = env_or("MTCAL_FUZZ_ITERS", 2000);
    let seed = env_or("MTCAL_FUZZ_SEED", 0x006d_7463_616c);
    let mut rng = StdRng::seed_from_u64(seed);
    // Tight limits too, so that limit paths are exercised with small inputs.
    let tight = Limits {
        max_samples_per_file: 5,
        max_bytes: 2000,
        max_files: 4,
        max_columns: 8,
        max_line_bytes: 80,
        ..Limits::default()
    };
    let excel = Limits::default().with_dialect(CsvDialect::Excel);
    let mut cases = 0u64;
    let mut accepted = 0u64;
    // Quiet the default panic message: a panic is reported below with its input.
    let hook = std::panic::take_hook();
    std::panic::set_hook(Box::new(|_| {}));
    let mut failures = Vec::new();
    // Round k mutates every target through every entry point, so that a campaign cut
    // short by time has covered them all alike.
    let (targets, stop) = (targets(), deadline());
    let mut done = 0;
    for k in 0..iters {
        for (name, base) in &targets {
            for via in [Via::Files, Via::Gzip, Via::TarGz, Via::Tar] {
                let (limits, mut files) = match k % 4 {
                    0 => (&tight, base.clone()),
                    1 => (&excel, to_excel(base)),
                    _ => (&Limits::default(), base.clone()),
                };
                if matches!(via, Via::Gzip) {
                    files = files
                        .into_iter()
                        .map(|(n, b)| (format!("{n}.gz"), gzip(&b)))
                        .collect();
                }
                let mut archive = match via {
                    Via::TarGz => Some(gzip(&tar_of(&files))),
                    Via::Tar => Some(tar_of(&files)),
                    _ => None,
                };
                let rounds = rng.random_range(1..=3);
                for _ in 0..rounds {
                    match archive.as_mut() {
                        Some(a) => mutate(&mut rng, a),
                        None => {
                            let i = rng.random_range(0..files.len());
                            mutate(&mut rng, &mut files[i].1);
                        }
                    }
                }
                cases += 1;
                let r = run_case(&files, via, archive.as_deref(), limits);
                if r == Ok(true) {
                    accepted += 1;
                }
                if let Err(why) = r {
                    failures.push(format!(
                        "{name} via {via:?} case {k} (seed {seed}): {why}\nfiles: {:?}\narchive: {:?}",
                        files
                            .iter()
                            .map(|(n, b)| (n, String::from_utf8_lossy(b)))
                            .collect::<Vec<_>>(),
                        archive.as_ref().map(|a| a.len())
                    ));
                }
            }
        }
        done += 1;
        if failures.len() >= 5 || std::time::Instant::now() >= stop {
            break;
        }
    }
    std::panic::set_hook(hook);
    assert!(failures.is_empty(), "{}", failures.join("\n\n"));
    // The mutations must leave some inputs valid and refuse most: a campaign that only
    // ever saw rejections (or only acceptances) would test little.
    assert!(
        accepted > 0 && accepted < cases,
        "{accepted} of {cases} accepted"
    );
    eprintln!("{cases} cases ({done} of {iters} rounds), {accepted} accepted, seed {seed}");
}

/// The path-based readers (a session folder on disk, one file with its sidecar) see the
/// same mutated inputs as the in-memory ones, and give the same outcome.
#[test]
fn folders_on_disk_read_like_uploads() {
    let iters = env_or("MTCAL_FUZZ_ITERS", 2000) / 8;
    let seed = env_or("MTCAL_FUZZ_SEED", 0x006d_7463_616c) ^ 1;
    let mut rng = StdRng::seed_from_u64(seed);
    let l = Limits::default();
    let (targets, stop) = (targets(), deadline());
    for k in 0..iters {
        if k > 0 && std::time::Instant::now() >= stop {
            break;
        }
        for (name, base) in &targets {
            let mut files = base.clone();
            let i = rng.random_range(0..files.len());
            mutate(&mut rng, &mut files[i].1);
            let dir = tempfile::tempdir().unwrap();
            for (n, b) in &files {
                std::fs::write(dir.path().join(n), b).unwrap();
            }
            let from_disk = mtcal_formats::read_path(dir.path(), &l).map(|d| d.samples());
            let in_memory = read_upload(&files, &l).map(|d| d.samples());
            assert_eq!(
                from_disk, in_memory,
                "{name} case {k} (seed {seed}): {files:?}"
            );
        }
    }
}
